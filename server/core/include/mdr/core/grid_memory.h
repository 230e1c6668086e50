// The classical MDR tangential memory: one spring per cell of a uniform grid in x
// (docs/physics.md, "MDR"), kept next to the exact PiecewiseLinearMemory for comparison and for
// users who want the textbook method.
//
// Springs sit at the cell midpoints x_j = (j + 1/2) h, h = max_radius / size, with z_j = g(x_j)
// fixed at creation; the contact may not grow beyond max_radius (Contact reports an error
// naming grid_max_radius). Integrals over the contact are midpoint sums, h sum_j u_j: the
// integrands have kinks (slip boundary, contact edge), so the grid method converges like h^2
// with the exact step rule and no better; the exact engine has no such error.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/memory.h"
#include "mdr/core/profile.h"

namespace mdr {

// How a spring's end value is found along a step linear in (delta, ux).
enum class GridStepRule {
  // docs/physics.md "Exactness for linear steps": clamp(u + dux) for springs in contact throughout,
  // clamp((1 - s_e) dux) for springs entering at s_e; independent of how a step is split.
  kExact,
  // "Add dux, then clamp" for every spring in contact at the end, entering ones included: the
  // textbook rule, wrong by O(step) when normal and tangential motion are simultaneous.
  kNaive,
};

// Slip state as in the exact memory (memory.h, "Slip state"): each spring carries its tag and
// the anchor of the bound it last lay on; a spring anchored on a bound stays on it while
// AnchorExcess >= 0, an entering one (exact rule) is on a bound iff the step's
// sigma dux - mu_kappa (depth1 - depth0) >= 0, and any other goes onto a bound when its end value
// reaches it.
class GridMemory {
 public:
  // Bytes of state per spring: z, u, tag and anchor.
  static constexpr std::size_t kBytesPerSpring =
      2 * sizeof(double) + sizeof(std::uint8_t) + sizeof(SegmentAnchor);

  GridMemory(const Profile& profile, std::size_t size, double max_radius, GridStepRule rule);

  // Same contract as PiecewiseLinearMemory::ApplyLinearStep: applies a step linear in
  // (delta, ux) and returns the dissipated energy per G* (J/Pa), summed spring by spring with
  // the exact per-spring formulas, if track_energy (else 0).
  double ApplyLinearStep(const LinearMove& move, double mu_kappa, bool track_energy);

  double depth() const { return depth_; }
  bool in_contact() const { return depth_ > 0; }
  std::size_t size() const { return static_cast<std::size_t>(z_.size()); }
  double spacing() const { return spacing_; }
  double max_radius() const { return spacing_ * static_cast<double>(size()); }
  GridStepRule rule() const { return rule_; }
  const Eigen::ArrayXd& z() const { return z_; }
  const Eigen::ArrayXd& u() const { return u_; }
  const std::vector<SegmentAnchor>& anchors() const { return anchor_; }
  // Springs with an anchor (what a snapshot carries values for).
  std::size_t AnchoredSprings() const;

  // h sum_j u_j, the midpoint rule for integral_0^a u dx (F_x = 2 G* times this).
  double IntegralU() const { return spacing_ * u_.sum(); }
  // The increment dux in [GrossSlipIncrement(-1), GrossSlipIncrement(+1)] after which a step to
  // depth1 leaves IntegralU() = target, the state unchanged (force-controlled steps). IntegralU
  // is piecewise linear in dux with slope h times the springs that stick (entering ones weighted
  // by their share of dux): Newton's method on it, safeguarded by bisection. Targets beyond the
  // range give its ends. spring > 0: integral + spring * dux = target (PiecewiseLinearMemory).
  double IncrementForIntegralU(double depth1, double mu_kappa, double target,
                               double spring = 0) const;
  // Radius measure h * count of the springs in contact, and of those on the given bound.
  double MeasureInContact() const;
  double MeasureOnBound(BoundTag bound) const;
  // Which bound spring j is on (kInside also out of contact); kOnBoth where the bound is 0.
  BoundTag Tag(std::size_t j) const { return static_cast<BoundTag>(tag_[j]); }
  // As PiecewiseLinearMemory::GrossSlipIncrement, for this rule.
  double GrossSlipIncrement(double depth1, double mu_kappa, int direction) const;
  // u of the spring whose cell holds radius x (0 outside the contact).
  double UAtRadius(double x) const;
  // max_j |u_j - other.u_j| (same grid).
  double MaxDifference(const GridMemory& other) const;

  // Rebuilds the state from spring values (session import): u has one value per spring, finite,
  // 0 out of contact and within mu_kappa (depth - z_j); anchors one per spring (CheckAnchor, field
  // "grid_anchors[j]"), or none for snapshots written before anchors existed: then a spring at
  // its bound (u_j = +-CoulombBound exactly, what the clamp leaves) is anchored at the current
  // state.
  Status Restore(double depth, const std::vector<double>& u, double mu_kappa,
                 const std::vector<SegmentAnchor>& anchors, double tangential_displacement);

  bool operator==(const GridMemory& other) const {
    return depth_ == other.depth_ && spacing_ == other.spacing_ && rule_ == other.rule_ &&
           z_.size() == other.z_.size() && (u_ == other.u_).all() && tag_ == other.tag_ &&
           anchor_ == other.anchor_;
  }

 private:
  friend class PackedContacts;  // encodes and decodes the state (packed_contacts.h)

  // The springs beyond the innermost one on a bound are on it too (memory.cc, the same rule).
  void KeepSlipZoneAnnular(double mu_kappa, double ux1);

  double spacing_;
  GridStepRule rule_;
  double depth_ = 0;
  Eigen::ArrayXd z_, u_;
  std::vector<std::uint8_t> tag_;
  std::vector<SegmentAnchor> anchor_;
};

}  // namespace mdr
