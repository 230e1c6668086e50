#include "mdr/core/grid_memory.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dissipation.h"
#include "mdr/base/validate.h"
#include "monotone_solve.h"

namespace mdr {
namespace {

using internal::LinearStep;

// Unclamped end value of a spring at z with start value u that is in contact at the end
// (z < depth1), by the given rule (see GridStepRule).
double UnclampedEnd(const LinearStep& step, GridStepRule rule, double z, double u) {
  if (z < step.depth0) return u + step.dux;  // in contact throughout
  if (rule == GridStepRule::kNaive) return step.dux;
  return step.dux * ((step.depth1 - z) / step.ddelta());  // (1 - s_e) dux, entering at s_e
}

// d UnclampedEnd / d dux.
double UnclampedEndSlope(const LinearStep& step, GridStepRule rule, double z) {
  if (z < step.depth0 || rule == GridStepRule::kNaive) return 1;
  return (step.depth1 - z) / step.ddelta();
}

// Energy per G* and unit radius of a spring that stays or enters and ends clamped from v to
// the bound b1.
double ClampedSpringDissipation(const LinearStep& step, double v, double b1) {
  const int sigma = v > 0 ? +1 : -1;
  return internal::ClampedSpringDissipation(step, sigma, sigma * v - b1, b1);
}

// Energy per G* and unit radius of a spring at z with start value u0 that leaves contact
// during an unloading step, on the side of its value when it leaves.
double LeavingSpringDissipation(const LinearStep& step, double z, double u0) {
  const double at_leaving = u0 + (step.depth0 - z) / -step.ddelta() * step.dux;
  if (at_leaving == 0) return 0;
  const int sigma = at_leaving > 0 ? +1 : -1;
  return internal::LeavingSpringDissipation(step, sigma, step.SlideOnsetBound(z, u0, sigma));
}

}  // namespace

GridMemory::GridMemory(const Profile& profile, std::size_t size, double max_radius,
                       GridStepRule rule)
    : spacing_(max_radius / static_cast<double>(size)),
      rule_(rule),
      z_(static_cast<Eigen::Index>(size)),
      u_(Eigen::ArrayXd::Zero(static_cast<Eigen::Index>(size))),
      tag_(size, kInside),
      anchor_(size) {
  for (Eigen::Index j = 0; j < z_.size(); ++j) {
    z_[j] = profile.G((static_cast<double>(j) + 0.5) * spacing_);
  }
}

namespace {

// The bound a spring in contact at the end of the step is on after it (kInside: it sticks),
// decided as the exact memory decides a segment (memory.h, "Slip state").
BoundTag SpringBound(const LinearStep& step, GridStepRule rule, const SegmentAnchor& anchor,
                     double z, double v, double b1, double ux1) {
  if (z < step.depth0) {  // in contact throughout: its anchor, else its end value
    if (anchor.bound != kInside && AnchorExcess(anchor, step.mu_kappa, step.depth1, ux1) >= 0) {
      return anchor.bound;
    }
    if (anchor.bound != kOnUpper && v >= b1) return kOnUpper;
    if (anchor.bound != kOnLower && v <= -b1) return kOnLower;
    return kInside;
  }
  if (rule == GridStepRule::kExact) {  // entering: the excess is the step's rate times (1 - s_e)
    if (step.SlidingRate(+1) >= 0) return kOnUpper;
    if (step.SlidingRate(-1) >= 0) return kOnLower;
    return kInside;
  }
  return v >= b1 ? kOnUpper : v <= -b1 ? kOnLower : kInside;
}

}  // namespace

double GridMemory::ApplyLinearStep(const LinearMove& move, double mu_kappa, bool track_energy) {
  const LinearStep step{depth_, move.depth1, move.dux, mu_kappa};
  const bool energy = track_energy && mu_kappa > 0;
  double dissipated = 0;
  for (Eigen::Index j = 0; j < z_.size(); ++j) {
    const auto spring = static_cast<std::size_t>(j);
    const double z = z_[j];
    if (!(z < step.depth1)) {  // out of contact at the end: forgets
      if (energy && z < step.depth0) dissipated += LeavingSpringDissipation(step, z, u_[j]);
      u_[j] = 0;
      tag_[spring] = kInside;
      anchor_[spring] = SegmentAnchor{};
      continue;
    }
    const double v = UnclampedEnd(step, rule_, z, u_[j]);
    const double b1 = step.BoundAtEnd(z);
    if (energy && std::abs(v) > b1) dissipated += ClampedSpringDissipation(step, v, b1);
    if (!(b1 > 0)) {  // mu = 0
      u_[j] = 0;
      tag_[spring] = kOnBoth;
      anchor_[spring] = SegmentAnchor{};
      continue;
    }
    const BoundTag on = SpringBound(step, rule_, anchor_[spring], z, v, b1, move.ux1);
    tag_[spring] = on;
    if (on != kInside) {
      u_[j] = on == kOnUpper ? b1 : -b1;
      anchor_[spring] = {on, move.ux1, step.depth1};
    } else {
      u_[j] = std::clamp(v, -b1, b1);
      if (!(z < step.depth0)) anchor_[spring] = SegmentAnchor{};
    }
  }
  depth_ = step.depth1;
  KeepSlipZoneAnnular(mu_kappa, move.ux1);
  return dissipated * spacing_;
}

void GridMemory::KeepSlipZoneAnnular(double mu_kappa, double ux1) {
  // As the exact memory (memory.cc): the innermost spring on a bound decides for every spring
  // beyond it, which only a tie at the limiting ratio dux / ddelta = mu kappa can set apart.
  std::size_t j = 0;
  while (j < size() && z_[static_cast<Eigen::Index>(j)] < depth_ && tag_[j] == kInside) ++j;
  if (j == size() || tag_[j] == kOnBoth) return;
  const auto on = static_cast<BoundTag>(tag_[j]);
  for (; j < size() && z_[static_cast<Eigen::Index>(j)] < depth_; ++j) {
    if (tag_[j] == on) continue;
    const auto i = static_cast<Eigen::Index>(j);
    const double b = CoulombBound(mu_kappa, depth_, z_[i]);
    u_[i] = on == kOnUpper ? b : -b;
    tag_[j] = on;
    anchor_[j] = {on, ux1, depth_};
  }
}

double GridMemory::IncrementForIntegralU(double depth1, double mu_kappa, double target,
                                         double spring) const {
  const LinearStep step{depth_, depth1, 0, mu_kappa};
  // IntegralU after the step with increment dux, and its slope in dux.
  auto integral = [&](double dux) {
    LinearStep moved = step;
    moved.dux = dux;
    internal::ValueAndSlope sum{0, 0};
    for (Eigen::Index j = 0; j < z_.size(); ++j) {
      const double z = z_[j];
      if (!(z < depth1)) continue;
      const double b1 = moved.BoundAtEnd(z);
      const double v = UnclampedEnd(moved, rule_, z, u_[j]);
      sum.value += std::clamp(v, -b1, b1);
      if (std::abs(v) < b1) sum.slope += UnclampedEndSlope(moved, rule_, z);
    }
    return internal::ValueAndSlope{sum.value * spacing_, sum.slope * spacing_};
  };
  const double lo = GrossSlipIncrement(depth1, mu_kappa, -1);
  const double hi = GrossSlipIncrement(depth1, mu_kappa, +1);
  // No breakpoints: one per spring would cost a sort of the grid, and Newton steps land exactly
  // on the root of each linear piece.
  std::vector<double> breakpoints;
  return internal::SolveWithSpring(integral, breakpoints, lo, hi, target, spring);
}

double GridMemory::MeasureInContact() const {
  return spacing_ * static_cast<double>((z_ < depth_).count());
}

std::size_t GridMemory::AnchoredSprings() const {
  return static_cast<std::size_t>(std::count_if(anchor_.begin(), anchor_.end(),
                                                [](const auto& a) { return a.bound != kInside; }));
}

double GridMemory::MeasureOnBound(BoundTag bound) const {
  std::size_t count = 0;
  for (std::uint8_t tag : tag_) count += (tag & bound) != 0;
  return spacing_ * static_cast<double>(count);
}

double GridMemory::GrossSlipIncrement(double depth1, double mu_kappa, int direction) const {
  // Every spring in contact at the end must reach the bound: springs in contact throughout
  // once sigma (u + dux) >= b1; entering ones once |dux| >= mu_kappa (depth1 - depth0) with the
  // exact rule, or |dux| >= b1 with the naive one.
  const double sigma = direction >= 0 ? 1.0 : -1.0;
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  double needed = kNone;
  for (Eigen::Index j = 0; j < z_.size(); ++j) {
    const double z = z_[j];
    if (!(z < depth1)) continue;
    const double b1 = CoulombBound(mu_kappa, depth1, z);
    if (z < depth_) {
      needed = std::max(needed, b1 - sigma * u_[j]);
    } else {
      needed = std::max(needed, rule_ == GridStepRule::kExact ? mu_kappa * (depth1 - depth_) : b1);
    }
  }
  return needed == kNone ? 0.0 : sigma * needed;
}

double GridMemory::UAtRadius(double x) const {
  const double cell = std::floor(std::abs(x) / spacing_);
  if (!(cell < static_cast<double>(size()))) return 0;
  const auto j = static_cast<Eigen::Index>(cell);
  return z_[j] < depth_ ? u_[j] : 0.0;
}

double GridMemory::MaxDifference(const GridMemory& other) const {
  return (u_ - other.u_).abs().maxCoeff();
}

Status GridMemory::Restore(double depth, const std::vector<double>& u, double mu_kappa,
                           const std::vector<SegmentAnchor>& anchors,
                           double tangential_displacement) {
  if (!std::isfinite(depth)) return InvalidArgument("depth", "must be finite");
  if (u.size() != size()) {
    return InvalidArgument("grid_u", "needs one value per spring: " + std::to_string(u.size()) +
                                         " values for grid_size " + std::to_string(size()));
  }
  if (!anchors.empty() && anchors.size() != size()) {
    return InvalidArgument(
        "grid_anchors", "needs one anchor per spring or none: " + std::to_string(anchors.size()) +
                            " anchors for grid_size " + std::to_string(size()));
  }
  std::vector<std::uint8_t> tags(size(), kInside);
  std::vector<SegmentAnchor> restored = anchors;
  restored.resize(size());
  for (std::size_t j = 0; j < u.size(); ++j) {
    const double z = z_[static_cast<Eigen::Index>(j)];
    // Step clamps to exactly this expression and zeroes springs out of contact: no tolerance.
    const double bound = z < depth ? CoulombBound(mu_kappa, depth, z) : 0.0;
    if (!std::isfinite(u[j]) || !(std::abs(u[j]) <= bound)) {
      return InvalidArgument(Indexed("grid_u", j),
                             "must be finite, 0 out of contact and within the Coulomb "
                             "bound mu kappa (depth - g(x_j))");
    }
    if (!(z < depth)) continue;
    if (!(bound > 0)) {
      tags[j] = kOnBoth;
      continue;
    }
    SegmentAnchor& anchor = restored[j];
    const BoundTag at_bound = u[j] == bound ? kOnUpper : u[j] == -bound ? kOnLower : kInside;
    if (anchors.empty() && at_bound != kInside) anchor = {at_bound, tangential_displacement, depth};
    // A spring is on a bound iff it is anchored there now (at its bound's value, as the clamp
    // leaves it); CheckAnchor then accepts only what a step leaves.
    const bool anchored_now = anchor.bound != kInside &&
                              anchor == SegmentAnchor{anchor.bound, tangential_displacement, depth};
    const BoundTag on = anchored_now ? anchor.bound : kInside;
    const auto field = [j] { return Indexed("grid_anchors", j); };  // only for an error
    if (!CheckAnchor(anchor, on, mu_kappa, depth, tangential_displacement, "").ok()) {
      return CheckAnchor(anchor, on, mu_kappa, depth, tangential_displacement, field());
    }
    if (on != kInside && at_bound != on) {
      return InvalidArgument(field(), "anchors the spring on its bound now, but u is not at it");
    }
    tags[j] = on;
  }
  for (std::size_t j = 0; j < size(); ++j) {
    if (!(z_[static_cast<Eigen::Index>(j)] < depth) && restored[j] != SegmentAnchor{}) {
      return InvalidArgument(Indexed("grid_anchors", j), "must be empty out of contact");
    }
  }
  // Neighbours in contact within the friction cone (memory.h); the last one in contact is, by
  // its Coulomb bound, within it of the first spring out (u = 0).
  for (std::size_t j = 0; j + 1 < size(); ++j) {
    const double za = z_[static_cast<Eigen::Index>(j)], zb = z_[static_cast<Eigen::Index>(j + 1)];
    if (!(zb < depth)) break;
    if (!WithinFrictionCone(za, u[j], zb, u[j + 1], mu_kappa, depth)) {
      return InvalidArgument(Indexed("grid_u", j + 1),
                             "differs from grid_u[" + std::to_string(j) +
                                 "] by more than mu kappa (g(x_j+1) - g(x_j)): steeper than the "
                                 "friction cone, which no loading history makes");
    }
  }
  depth_ = depth;
  u_ = Eigen::Map<const Eigen::ArrayXd>(u.data(), static_cast<Eigen::Index>(u.size()));
  tag_ = std::move(tags);
  anchor_ = std::move(restored);
  return OkStatus();
}

}  // namespace mdr
