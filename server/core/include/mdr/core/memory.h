// The exact MDR tangential memory (docs/physics.md, "MDR" and "Exactness for linear steps").
//
// Springs are indexed by z = g(x) instead of x. In z the Coulomb bound mu*kappa*(delta - z) is a
// straight line, so after any piecewise-linear loading history u is a continuous polyline in z:
// vertices (z_i, u_i) with z_0 = 0 < z_1 < ... < z_N = delta and u_N = 0. A step linear in
// (delta, ux) maps this polyline to another one exactly (cut or extend at the new depth, shift by
// dux, clamp against the two bound lines, inserting vertices where they cross). No profile call is
// needed per increment; x = g^-1(z) is evaluated only when forces or profiles are asked for.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/profile.h"

namespace mdr {

// Whether a vertex lies on the upper bound +mu*kappa*(delta - z), the lower one, or both
// (the contact edge z = delta, and everything when mu = 0).
enum BoundTag : std::uint8_t { kInside = 0, kOnUpper = 1, kOnLower = 2, kOnBoth = 3 };

// The Coulomb bound mu_kappa * (depth - z) in the one expression that the step clamps against
// and that restoring a snapshot checks, so that every state the engine makes passes the check
// exactly, with no tolerance (docs/engine.md, "Restorable states").
inline double CoulombBound(double mu_kappa, double depth, double z) {
  return mu_kappa * (depth - z);
}

// No friction band: mu = 0, or a depth of a few subnormals where mu kappa delta rounds to 0. Every
// spring then lies on both bounds (kOnBoth), slip has no direction and Jäger's weights are 0/0.
inline bool FrictionBandVanishes(double mu_kappa, double depth) {
  return CoulombBound(mu_kappa, depth, 0) == 0;
}

// The friction cone: no part of the memory is steeper than the bound lines, |du/dz| <= mu_kappa,
// so that every Jäger weight lies in [-1, 1] (docs/engine.md, "Restorable states"). The steps keep
// this exactly but for round-off: a sticking segment is an earlier one moved by dux, which rounds
// its ends apart by about eps * mu_kappa * depth per step, a random walk. The slack, 2^20 eps of
// mu_kappa * depth (2.3e-10), is far above that walk over any realistic history (10^9 steps walk
// about 3 * 10^4 eps) and far below what shows in a force, a traction or a weight.
inline constexpr double kFrictionConeSlack = 0x1p20 * std::numeric_limits<double>::epsilon();

// Whether the springs at (za, ua) and (zb, ub), both in contact at `depth`, lie within the cone.
inline bool WithinFrictionCone(double za, double ua, double zb, double ub, double mu_kappa,
                               double depth) {
  return std::abs(ub - ua) <= mu_kappa * std::abs(zb - za) + kFrictionConeSlack * mu_kappa * depth;
}

// The Coulomb bound a memory segment last lay on, and the contact's depth and tangential
// displacement at that moment (docs/engine.md, "Slip state, decided structurally"). A segment
// that sticks moves rigidly with ux and its bound moves with the depth, so its excess over that
// bound is AnchorExcess, computed from the anchor and the contact's state alone: exactly 0 when
// the contact is back at the anchor, whatever the rounding of the spring values in between.
// Segments on a bound are anchored at the current state.
struct SegmentAnchor {
  // kInside: not on a bound since the segment entered contact. (kOnBoth marks, during a step
  // only, the segment entering contact: its outer end was on both bounds at the old edge.)
  BoundTag bound = kInside;
  double tangential_displacement = 0;  // m
  double depth = 0;                    // m
  bool operator==(const SegmentAnchor&) const = default;
};

// sigma (ux - ux_a) - mu_kappa (depth - depth_a) for the anchor's bound sigma = +-1: > 0 beyond
// the bound, 0 on it, < 0 inside it. The one expression the step and the restore check use.
inline double AnchorExcess(const SegmentAnchor& anchor, double mu_kappa, double depth, double ux) {
  const double sigma = anchor.bound == kOnUpper ? 1.0 : -1.0;
  return sigma * (ux - anchor.tangential_displacement) - mu_kappa * (depth - anchor.depth);
}

// What the step leaves in an anchor, checked when a snapshot is restored (error naming field):
// finite; springs on a bound (on = kOnUpper or kOnLower) anchored on it at the current depth and
// tangential displacement; springs that stick (on = kInside) unanchored or strictly inside the
// bound of their anchor (AnchorExcess < 0); none where the bound is 0 (on = kOnBoth).
Status CheckAnchor(const SegmentAnchor& anchor, BoundTag on, double mu_kappa, double depth,
                   double tangential_displacement, const std::string& field);

// The tangential displacement, within `tolerance` of ux, at which a segment anchored at `depth`
// is back on its bound (its anchor's ux), nearest to ux; nothing if there is none. A force-
// controlled step whose solved displacement lies that close to a turning point lands on it, so
// that the return puts the segment back on its bound exactly (Contact::Apply).
std::optional<double> NearestReturn(const std::vector<SegmentAnchor>& anchors, double depth,
                                    double ux, double tolerance);

// One step linear in (delta, ux) as the memory takes it: the springs move by dux (given, not
// derived from ux1 - ux0, so that an increment survives a large |ux| exactly); ux0 and ux1 are
// the contact's tangential displacement before and after, which the anchors refer to.
struct LinearMove {
  double depth1;
  double dux;
  double ux0, ux1;
};

// One memory piece, u = intercept + slope * g(x) for x in [x_begin, x_end] (docs/physics.md:
// u = A_k + B_k g(x)); bound is the tag shared by both ends (kInside: sticking piece).
struct MemoryPiece {
  double x_begin, x_end;  // radii
  double z_begin, z_end;  // g at the ends
  double intercept, slope;
  BoundTag bound;
};

// The work arrays of a force-controlled step's solve (IncrementForIntegralU), kept by their owner
// (a Contact) across steps: once grown, a solve allocates nothing, on whichever thread it runs.
// Not part of any state: a copy starts empty.
struct ForceSolveBuffers {
  // A vertex of the polyline before the step, with what the integral after the step needs.
  struct Vertex {
    double z, u, x;
    double bound;          // b1 = CoulombBound(mu_kappa, depth1, z)
    double up, lo;         // the dux at which it reaches the upper / lower bound: +-b1 - u
    PieceIntegrals piece;  // J_0, J_1 of the segment to the next vertex
  };
  ForceSolveBuffers() = default;
  ForceSolveBuffers(const ForceSolveBuffers&) {}
  ForceSolveBuffers& operator=(const ForceSolveBuffers&) { return *this; }
  std::vector<Vertex> vertices;
  std::vector<double> breakpoints;
};

// Slip state (docs/engine.md, "Slip state, decided structurally"): every segment of the polyline
// is on the upper bound, on the lower one or sticking, and the vertex tags say which (a segment is
// on a bound iff both its ends are tagged with it). The step decides this per segment from what
// the update rule does to it, never by comparing a rounded spring value with its bound: a
// segment anchored on a bound stays on it while AnchorExcess >= 0; any other segment goes onto a
// bound when the clamp moves it there (the excess positive inside it, or zero at both ends).
class PiecewiseLinearMemory {
 public:
  // Bytes of state per vertex (z, u, tag and the anchor of the segment it starts), for the
  // memory accounting of sessions and interfaces.
  static constexpr std::size_t kBytesPerVertex =
      2 * sizeof(double) + sizeof(std::uint8_t) + sizeof(SegmentAnchor);

  // Applies one step linear in (delta, ux) from the current depth to move.depth1, exactly.
  // mu_kappa = mu * kappa >= 0. If profile is non-null, returns the energy dissipated along the
  // step divided by G* (J / Pa); otherwise returns 0.
  double ApplyLinearStep(const LinearMove& move, double mu_kappa, const Profile* profile);

  double depth() const { return depth_; }
  bool in_contact() const { return depth_ > 0; }
  std::size_t vertex_count() const { return z_.size(); }
  const std::vector<double>& z() const { return z_; }
  const std::vector<double>& u() const { return u_; }
  const std::vector<std::uint8_t>& tags() const { return tag_; }
  // anchors()[i] belongs to the segment from vertex i to i + 1; the last one is always empty.
  const std::vector<SegmentAnchor>& anchors() const { return anchor_; }
  // u at depth coordinate z (0 outside [0, depth]).
  double UAtDepth(double z) const;
  // The same for depths asked in increasing order, walking the vertices from `next` (start at 0)
  // instead of searching: one pass over a list of depths.
  double UAtIncreasingDepth(double z, std::size_t& next) const;
  // integral_0^a u(x) dx; F_x = 2 G* times this.
  double IntegralU(const Profile& profile) const;
  // Radius measure of the springs that stick in a further move toward the given bound (upper:
  // +x), i.e. that are not on it, including the z = 0 atom of a flat punch; 2 G* times this is
  // the incremental tangential stiffness. Measured where they are (the stick disc as its radius),
  // not as the contact minus the slip annulus, which would cancel when the disc is small.
  double MeasureSticking(const Profile& profile, BoundTag bound) const;
  // Largest increment dux for which some spring still sticks when moving to depth1 (the onset
  // of gross slip in +x, or in -x for direction < 0, as a positive number for +x and negative
  // for -x). Brackets force-controlled steps.
  double GrossSlipIncrement(double depth1, double mu_kappa, int direction) const;
  // The increment dux in [GrossSlipIncrement(-1), GrossSlipIncrement(+1)] after which a linear
  // step to depth1 leaves integral_0^a u dx = target (F_x = 2 G* target), the state unchanged.
  // That integral is continuous and nondecreasing in dux, smooth between the dux at which a
  // vertex reaches a bound, with slope the radius measure of the springs that stick: the
  // breakpoints are walked to the bracket of the root, which Newton's method then finds
  // (memory_force.cc). Targets beyond the range give its ends. With spring > 0 the solve is
  // of integral + spring * dux = target instead (a rig in series, Contact), which has one root
  // for every target: beyond gross slip the integral is constant.
  // buffers: the solve's work arrays, kept by the caller across steps.
  double IncrementForIntegralU(double depth1, double mu_kappa, const Profile& profile,
                               double target, ForceSolveBuffers& buffers, double spring = 0) const;
  // The pieces in x (one per polyline segment, plus the z = 0 atom of a flat punch when present).
  std::vector<MemoryPiece> Pieces(const Profile& profile) const;

  // Rebuilds a memory from its exact state (session export/import), validating the polyline:
  // no vertices when depth <= 0; otherwise z_0 = 0 < z_1 < ... < z_N = depth, u_N = 0, tags <= 3,
  // all finite. anchors: one per vertex, or none (snapshots written before anchors existed); a
  // segment on a bound whose anchor is missing is anchored at the current state (depth,
  // tangential_displacement). The Coulomb bound and the anchors are checked by CheckCoulomb and
  // CheckAnchors, which need mu*kappa.
  static Result<PiecewiseLinearMemory> Restore(double depth, std::vector<double> z,
                                               std::vector<double> u,
                                               std::vector<std::uint8_t> tags,
                                               std::vector<SegmentAnchor> anchors = {},
                                               double tangential_displacement = 0);
  // What every state Step produces satisfies, checked when a snapshot is restored (field
  // "memory[i]"): |u_i| <= CoulombBound(mu_kappa, depth, z_i) exactly; kOnBoth only where that
  // bound is 0; a vertex tagged on the upper (lower) bound within BoundTagTolerance of it.
  Status CheckCoulomb(double mu_kappa) const;
  // The anchors as the step leaves them (field "memory[i].anchor"): finite; the last vertex's
  // empty; a segment on a bound anchored on it at the current state (depth,
  // tangential_displacement); a sticking segment either unanchored or strictly inside the bound
  // of its anchor (AnchorExcess < 0), so that a restored memory takes the next step exactly as
  // the original.
  Status CheckAnchors(double mu_kappa, double tangential_displacement) const;
  // Every segment within the friction cone (WithinFrictionCone), field "memory[i]" naming the
  // segment's inner vertex: a memory whose weights would leave [-1, 1] (a zigzag inside the
  // Coulomb bound) is no state the engine reaches.
  Status CheckFrictionCone(double mu_kappa) const;
  // The three checks above: what a restored snapshot must satisfy. Every step's result is held to
  // the cone's (Contact::CheckStepResult), the one check with a rounding slack.
  Status CheckReachable(double mu_kappa, double tangential_displacement) const;
  // How far below the bound line a vertex tagged on it may lie: a crossing vertex takes u from
  // the segment it was placed on at a z rounded to a few ulps of depth, so it sits up to
  // ~(mu_kappa + |du/dz|) * c * eps * depth inside the bound (memory.cc, PlaceCrossing).
  double BoundTagTolerance(std::size_t i, double mu_kappa) const;

  // The leading vertices of a polyline, held apart while a curved force path sub-steps the rest
  // (force_control.cc): springs that stick only move with u_x.
  struct VertexRun {
    std::vector<double> z, u;
    std::vector<std::uint8_t> tag;
    std::vector<SegmentAnchor> anchor;
  };
  // Appends vertices [0, count) to `run` and removes them; vertex `count` becomes the first, so
  // count < vertex_count(). Steps then treat the rest as a polyline starting there; that is
  // exact for the vertices kept as long as those set apart stick (they take no part in a step's
  // crossings, slip state or dissipation then, and the first vertex kept is never merged).
  void MoveLeadingVertices(std::size_t count, VertexRun& run);
  // Puts `run` back in front of the vertices (emptying it) and merges the redundant ones, as a
  // step would.
  void RestoreLeadingVertices(VertexRun& run);

  // Same state (depth, polyline and anchors), bit for bit.
  bool operator==(const PiecewiseLinearMemory& other) const {
    return depth_ == other.depth_ && z_ == other.z_ && u_ == other.u_ && tag_ == other.tag_ &&
           anchor_ == other.anchor_;
  }

 private:
  // u at z from j, the first vertex beyond z (UAtDepth and UAtIncreasingDepth).
  double UBeforeVertex(std::size_t j, double z) const;
  // Builds the unclamped polyline v = u + dux on [0, depth1] (cut or extended).
  void ShiftAndResize(double depth0, double depth1, double dux);
  // Clamps v into the bounds +-mu_kappa*(depth1 - z), inserting the crossing vertices; returns
  // the energy dissipated by springs that stay in or enter contact (per G*) if profile != null.
  // Three phases on the refined polyline in next_:
  double ClampToBounds(double depth0, double dux, double mu_kappa, double ux1,
                       const Profile* profile);
  // 1. v with a vertex inserted wherever it crosses a bound line (marked with that bound), each
  // refined segment classified (on a bound or sticking) and anchored as it is built;
  void InsertCrossings(double depth0, double dux, double mu_kappa, double ux1);
  // 2. the energy (per G*) that the clamp of phase 3 dissipates, spring by spring, exactly;
  double SlidingDissipation(double depth0, double dux, double mu_kappa,
                            const Profile& profile) const;
  // 3. the vertices tagged and clamped as their segments say; the refined polyline becomes the
  // state.
  void TagAndClampVertices(double mu_kappa, double ux1);
  void MergeRedundantVertices();
  // Energy dissipated (per G*) by springs in (max(depth1, 0), depth0] that leave contact.
  double LeavingDissipation(double depth1, double dux, double mu_kappa,
                            const Profile& profile) const;

  friend class PackedContacts;  // encodes and decodes the state (packed_contacts.h)

  double depth_ = 0;  // may be negative (indenter lifted): then there are no vertices
  std::vector<double> z_, u_;
  std::vector<std::uint8_t> tag_;
  std::vector<SegmentAnchor> anchor_;
  // Buffers reused across steps so the hot path does not allocate; not part of the state, so
  // copies start with empty ones.
  struct Scratch {
    Scratch() = default;
    Scratch(const Scratch&) {}
    Scratch& operator=(const Scratch&) { return *this; }
    std::vector<double> z, u;
    std::vector<std::uint8_t> crossing;  // the bound a refined vertex crosses (0: not a crossing)
    std::vector<std::uint8_t> tag;       // each refined vertex's tag after the clamp
    BoundTag slip = kInside;             // the slip annulus' bound after the step (kInside:
    std::size_t first_slipping = 0;      // none), from this refined segment to the edge
    std::vector<SegmentAnchor> anchor;   // each refined segment's anchor after the step
  };
  Scratch next_;
};

}  // namespace mdr
