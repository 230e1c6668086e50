// The exact MDR tangential memory (docs/physics.md, "MDR" and "Exactness for linear steps").
//
// Springs are indexed by z = g(x) instead of x. In z the Coulomb bound mu*kappa*(delta - z) is a
// straight line, so after any piecewise-linear loading history u is a continuous polyline in z:
// vertices (z_i, u_i) with z_0 = 0 < z_1 < ... < z_N = delta and u_N = 0. A step linear in
// (delta, ux) maps this polyline to another one exactly (cut or extend at the new depth, shift by
// dux, clamp against the two bound lines, inserting vertices where they cross). No profile call is
// needed per increment; x = g^-1(z) is evaluated only when forces or profiles are asked for.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mdr/core/profile.h"
#include "mdr/base/status.h"

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

// One memory piece, u = intercept + slope * g(x) for x in [x_begin, x_end] (docs/physics.md:
// u = A_k + B_k g(x)); bound is the tag shared by both ends (kInside: sticking piece).
struct MemoryPiece {
  double x_begin, x_end;  // radii
  double z_begin, z_end;  // g at the ends
  double intercept, slope;
  BoundTag bound;
};

class PiecewiseLinearMemory {
 public:
  // Applies one step linear in (delta, ux) from the current depth to depth1 with tangential
  // increment dux, exactly. mu_kappa = mu * kappa >= 0. If profile is non-null, returns the
  // energy dissipated along the step divided by G* (J / Pa); otherwise returns 0.
  double ApplyLinearStep(double depth1, double dux, double mu_kappa, const Profile* profile);

  double depth() const { return depth_; }
  bool in_contact() const { return depth_ > 0; }
  std::size_t vertex_count() const { return z_.size(); }
  const std::vector<double>& z() const { return z_; }
  const std::vector<double>& u() const { return u_; }
  const std::vector<std::uint8_t>& tags() const { return tag_; }

  // u at depth coordinate z (0 outside [0, depth]).
  double UAtDepth(double z) const;
  // integral_0^a u(x) dx; F_x = 2 G* times this.
  double IntegralU(const Profile& profile) const;
  // Radius measure of the springs on the given bound (upper or lower), including the
  // z = 0 atom of a flat punch; used for the incremental stiffness and slip zones.
  double MeasureOnBound(const Profile& profile, BoundTag bound) const;
  // Largest increment dux for which some spring still sticks when moving to depth1 (the onset
  // of gross slip in +x, or in -x for direction < 0, as a positive number for +x and negative
  // for -x). Brackets force-controlled steps.
  double GrossSlipIncrement(double depth1, double mu_kappa, int direction) const;
  // The increment dux in [GrossSlipIncrement(-1), GrossSlipIncrement(+1)] after which a linear
  // step to depth1 leaves integral_0^a u dx = target (F_x = 2 G* target), the state unchanged.
  // That integral is continuous and nondecreasing in dux, smooth between the dux at which a
  // vertex reaches a bound, with slope the radius measure of the springs that stick: the
  // breakpoints are walked to the bracket of the root, which Newton's method then finds
  // (memory_force.cc). Targets beyond the range give its ends.
  double IncrementForIntegralU(double depth1, double mu_kappa, const Profile& profile,
                               double target) const;
  // The pieces in x (one per polyline segment, plus the z = 0 atom of a flat punch when present).
  std::vector<MemoryPiece> Pieces(const Profile& profile) const;

  // Rebuilds a memory from its exact state (session export/import), validating the polyline:
  // no vertices when depth <= 0; otherwise z_0 = 0 < z_1 < ... < z_N = depth, u_N = 0, tags <= 3,
  // all finite. The Coulomb bound is checked by CheckCoulomb, which needs mu*kappa.
  static Result<PiecewiseLinearMemory> Restore(double depth, std::vector<double> z,
                                               std::vector<double> u,
                                               std::vector<std::uint8_t> tags);
  // What every state Step produces satisfies, checked when a snapshot is restored (field
  // "memory[i]"): |u_i| <= CoulombBound(mu_kappa, depth, z_i) exactly; kOnBoth only where that
  // bound is 0; a vertex tagged on the upper (lower) bound within BoundTagTolerance of it.
  Status CheckCoulomb(double mu_kappa) const;
  // How far below the bound line a vertex tagged on it may lie: a crossing vertex takes u from
  // the segment it was placed on at a z rounded to a few ulps of depth, so it sits up to
  // ~(mu_kappa + |du/dz|) * c * eps * depth inside the bound (memory.cc, PlaceCrossing).
  double BoundTagTolerance(std::size_t i, double mu_kappa) const;

  // Same state (depth and polyline), bit for bit.
  bool operator==(const PiecewiseLinearMemory& other) const {
    return depth_ == other.depth_ && z_ == other.z_ && u_ == other.u_ && tag_ == other.tag_;
  }

 private:
  // Builds the unclamped polyline v = u + dux on [0, depth1] (cut or extended).
  void ShiftAndResize(double depth0, double depth1, double dux);
  // Clamps v into the bounds +-mu_kappa*(depth1 - z), inserting the crossing vertices; returns
  // the energy dissipated by springs that stay in or enter contact (per G*) if profile != null.
  // Three phases on the refined polyline in next_:
  double ClampToBounds(double depth0, double dux, double mu_kappa, const Profile* profile);
  // 1. v with a vertex inserted wherever it crosses a bound line (tagged with that bound);
  void InsertCrossings(double mu_kappa);
  // 2. the energy (per G*) that the clamp of phase 3 dissipates, spring by spring, exactly;
  double SlidingDissipation(double depth0, double dux, double mu_kappa,
                            const Profile& profile) const;
  // 3. every vertex clamped to the bounds and tagged; the refined polyline becomes the state.
  void ClampRefinedVertices(double mu_kappa);
  void MergeRedundantVertices();
  // Energy dissipated (per G*) by springs in (max(depth1, 0), depth0] that leave contact.
  double LeavingDissipation(double depth1, double dux, double mu_kappa,
                            const Profile& profile) const;

  double depth_ = 0;  // may be negative (indenter lifted): then there are no vertices
  std::vector<double> z_, u_;
  std::vector<std::uint8_t> tag_;
  // Buffers reused across steps so the hot path does not allocate; not part of the state, so
  // copies start with empty ones.
  struct Scratch {
    Scratch() = default;
    Scratch(const Scratch&) {}
    Scratch& operator=(const Scratch&) { return *this; }
    std::vector<double> z, u;
    std::vector<std::uint8_t> tag;
    std::vector<std::uint8_t> was;  // each refined vertex's tag before the step (crossings: 0)
  };
  Scratch next_;
};

}  // namespace mdr
