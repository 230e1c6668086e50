// Force control: the tangential increment for a force target, and curved force paths followed by
// adaptive bisection into exact linear sub-steps (docs/engine.md, "Force-controlled steps").
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <variant>
#include <vector>

#include "mdr/base/validate.h"
#include "mdr/core/contact.h"
#include "monotone_solve.h"

namespace mdr {
namespace {

// Curved force paths: bisection depth cap (at most 2^13 intervals, 3 exact sub-steps each), so
// a pathological request ends; a depth cap rather than a sub-step budget keeps the resolution
// uniform along the path when it is reached.
constexpr int kMaxBisections = 13;

// Largest |u_a(z) - u_b(z)| over the vertices of both memories (both are polylines), in one
// merge-like pass over the two sorted vertex lists.
double MaxDifference(const PiecewiseLinearMemory& a, const PiecewiseLinearMemory& b) {
  double diff = 0;
  for (const auto& [from, other] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    std::size_t own = 0, there = 0;
    for (double z : from->z()) {
      diff = std::max(
          diff, std::abs(from->UAtIncreasingDepth(z, own) - other->UAtIncreasingDepth(z, there)));
    }
  }
  return diff;
}

// The leading springs of an exact memory that stick, held apart from the sub-steps of a curved
// path (MoveLeadingVertices) and put back at its end moved by what u_x moved meanwhile. Sticking
// springs only move with u_x, so that is the same state to round-off, and it keeps every
// sub-step, copy and comparison to the springs the path can still change: without it a path
// that builds a long polyline (loading from near zero, each sub-step adding a vertex) costs
// sub-steps x vertices.
// Where u_x moves linearly in s (ux1 given), springs that stick to the path's end are taken: the
// depth is concave in s (F_N, or an actuator's depth delta + C_n F_N, linear in s, both convex in
// delta; or the depth itself linear), so on [s, 1] it is above its chord, and a spring's distance
// to either bound, mu kappa (delta - z) -+ u, is at least its value now plus the chord's change to
// the path's end when that is negative. Where u_x is solved along the way (a tangential force
// target or rig), springs that stick now, and would at the path's end depth with their u now, are
// taken (the sub-steps never uncover them: they keep the vertex the step cuts at), and every trial
// sub-step is checked (StillStick); the caller puts them back and sub-steps every spring once a
// check fails.
class StickingSprings {
 public:
  StickingSprings(double mu_kappa, double depth1, std::optional<double> ux1, double margin,
                  const Profile& profile)
      : mu_kappa_(mu_kappa), depth1_(depth1), ux1_(ux1), margin_(margin), profile_(profile) {}
  // Holds apart the leading vertices that stick, all but the last of them: that one stays as
  // the first of the polyline the sub-steps move.
  void TakeFrom(PiecewiseLinearMemory& memory, double ux) {
    const std::vector<double>& z = memory.z();
    const std::vector<double>& u = memory.u();
    const std::vector<std::uint8_t>& tags = memory.tags();
    std::size_t sticking = 0;
    while (sticking < z.size() && tags[sticking] == kInside &&
           Sticks(z[sticking], u[sticking], memory.depth(), ux)) {
      ++sticking;
    }
    if (sticking < 2) return;
    const std::size_t count = sticking - 1;
    // The first vertex kept stands for the disc inside it at its own u in the force solve
    // (memory_force.cc, the atom of IntegralAfterStep); the rest of the held integral is fixed
    // while everything in it moves together.
    double x = profile_.RadiusAtDepth(z[0]);
    held_integral_ += x * u[0];
    for (std::size_t i = 0; i < count; ++i) {
      const double x_next = profile_.RadiusAtDepth(z[i + 1]);
      const PieceIntegrals piece = profile_.IntegratePiece(z[i], z[i + 1], x, x_next, false);
      held_integral_ += u[i] * piece.j0 + (u[i + 1] - u[i]) * piece.j1;
      x = x_next;
      least_upper_ = std::min(least_upper_, ux - mu_kappa_ * z[i] - u[i]);
      least_lower_ = std::min(least_lower_, u[i] - ux - mu_kappa_ * z[i]);
    }
    held_integral_ -= x * u[count];
    memory.MoveLeadingVertices(count, run_);
    taken_.push_back({run_.z.size(), ux});
  }
  // Whether the springs held apart still stick (by half the margin) with `memory` at u_x = ux,
  // and its first vertex, which stands for them in the force solve, too.
  bool StillStick(const PiecewiseLinearMemory& memory, double ux) const {
    const double bound = mu_kappa_ * memory.depth();
    return (memory.tags().empty() || memory.tags()[0] == kInside) &&
           bound - ux + least_upper_ > 0.5 * margin_ && bound + ux + least_lower_ > 0.5 * margin_;
  }
  // integral u dx over the springs held apart, less what the first vertex kept stands for.
  double held_integral() const { return held_integral_; }
  // Puts the vertices back, each moved by u_x's change since it was taken.
  void ReturnTo(PiecewiseLinearMemory& memory, double ux) {
    std::size_t i = 0;
    for (const auto& [end, ux_then] : taken_) {
      const double moved = ux - ux_then;
      for (; i < end; ++i) run_.u[i] += moved;
    }
    taken_.clear();
    memory.RestoreLeadingVertices(run_);
  }

 private:
  bool Sticks(double z, double u, double depth, double ux) const {
    if (!ux1_) {  // and stay in contact: the depth is monotone along the path
      const double bound = mu_kappa_ * (std::min(depth, depth1_) - z);
      return bound - u > margin_ && bound + u > margin_;
    }
    const double bound = mu_kappa_ * (depth - z);
    const double chord = mu_kappa_ * (depth1_ - depth), dux = *ux1_ - ux;
    return bound - u + std::min(0.0, chord - dux) > margin_ &&
           bound + u + std::min(0.0, chord + dux) > margin_;
  }

  double mu_kappa_, depth1_;
  std::optional<double> ux1_;
  double margin_;
  const Profile& profile_;
  PiecewiseLinearMemory::VertexRun run_;
  std::vector<std::pair<std::size_t, double>> taken_;  // (end in run_, u_x when taken)
  double held_integral_ = 0;
  // The least of ux_taken - mu kappa z - u and of u - ux_taken - mu kappa z over the springs held
  // apart: adding mu kappa delta -+ ux gives their least distance to the upper and lower bound.
  double least_upper_ = std::numeric_limits<double>::infinity();
  double least_lower_ = std::numeric_limits<double>::infinity();
};

}  // namespace

double Contact::MemoryDifference(const Contact& a, const Contact& b) {
  if (const GridMemory* grid = a.grid_memory()) return grid->MaxDifference(*b.grid_memory());
  return MaxDifference(a.memory(), b.memory());
}

Result<double> Contact::SolveTangentialIncrement(double depth1, double fx,
                                                 double held_integral) const {
  const double limit = config_.friction * NormalForceAtDepth(depth1);
  if (!(std::abs(fx) <= limit * (1 + 1e-12))) {
    return FailedPrecondition("tangential_force",
                              "|F_x| = " + FormatNumber(std::abs(fx)) +
                                  " N exceeds the friction limit mu F_N = " + FormatNumber(limit) +
                                  " N at the step's end (no tangential force without contact)");
  }
  if (limit == 0) return 0.0;  // F_x = 0 holds for any ux: keep it
  // The unknown is the increment, not ux itself: after long sliding |ux| can exceed the memory's
  // scale mu kappa delta by many orders, and a root in ux would carry eps |ux| of noise.
  const double m = mu_kappa();
  const GridMemory* grid = grid_memory();
  if (std::abs(fx) >= limit) {  // onset of gross slip
    const int direction = fx > 0 ? +1 : -1;
    return grid ? grid->GrossSlipIncrement(depth1, m, direction)
                : memory().GrossSlipIncrement(depth1, m, direction);
  }
  const double target = fx / (2 * config_.material.g_star) - held_integral;  // integral u dx
  return grid ? grid->IncrementForIntegralU(depth1, m, target)
              : memory().IncrementForIntegralU(depth1, m, *config_.profile, target, solve_buffers_);
}

double Contact::SolveActuatorIncrement(double depth1, double u_act, double held_integral) const {
  // ux + dux + C_t 2 G* I(dux) = u_act, with I the integral of u after the step (F_x = 2 G* I):
  // I + spring dux = target, spring = 1 / (2 G* C_t).
  const double compliance = 2 * config_.material.g_star * config_.rig.tangential;
  const double spring = 1 / compliance, target = (u_act - ux_) / compliance - held_integral;
  const GridMemory* grid = grid_memory();
  return grid ? grid->IncrementForIntegralU(depth1, mu_kappa(), target, spring)
              : memory().IncrementForIntegralU(depth1, mu_kappa(), *config_.profile, target,
                                               solve_buffers_, spring);
}

double Contact::DepthAtActuatorDepth(double actuator) const {
  // delta + C_n F_N(delta) increases with delta (dF_N/d delta = 2 E* a) and equals delta out of
  // contact: the root lies in [0, actuator].
  if (!(actuator > 0)) return actuator;
  auto f = [&](double depth) {
    return internal::ValueAndSlope{depth + config_.rig.normal * NormalForceAtDepth(depth),
                                   1 + config_.rig.normal * 2 * config_.material.e_star *
                                           config_.profile->RadiusAtDepth(depth)};
  };
  std::vector<double> none;
  return internal::SolveNondecreasing(f, none, 0.0, actuator, actuator);
}

Status Contact::ApplyCurvedPath(const Step& step, const StepTargets& targets, StepReport* report,
                                const Interrupt& interrupt) {
  const double depth0 = depth(), ux0 = ux_;
  const double fn0 = normal_force(), fx0 = tangential_force();
  const double actuator_depth0 = actuator_depth(), actuator_displacement0 = actuator_displacement();
  const RigCompliance& rig = config_.rig;
  const bool tangential_force = step.tangential == TangentialControl::kForce;
  const bool through_rig = rig.tangential > 0 && !tangential_force;
  auto along = [](double from, double to, double s) { return from + s * (to - from); };
  auto depth_at = [&](double s) {
    if (s == 1) return targets.depth;
    if (step.normal == NormalControl::kForce) {
      return DepthAtNormalForce(along(fn0, step.normal_value, s));
    }
    if (rig.normal > 0) {
      return DepthAtActuatorDepth(along(actuator_depth0, targets.actuator_depth, s));
    }
    return along(depth0, targets.depth, s);
  };
  // Where an interval [s0, s1] is split: at the middle of its depth range where the depth is not
  // linear in s. Loaded by force from F_N = 0 the depth grows like F^(2/3), infinitely steep in
  // s at the start, while the path is smooth in the depth (Hertz: u_x - u_x0 grows like
  // delta^(3/2)): halving s there stalls at the bisection cap (path_error 6.4e-6 instead of
  // 1e-8 on the example of docs/engine.md), halving the depth converges.
  const bool depth_curved = step.normal == NormalControl::kForce || rig.normal > 0;
  auto split = [&](double s0, double s1) {
    const double half = 0.5 * (s0 + s1);
    if (!depth_curved) return half;
    const double depth = 0.5 * (depth_at(s0) + depth_at(s1));
    const double s = step.normal == NormalControl::kForce
                         ? (NormalForceAtDepth(depth) - fn0) / (step.normal_value - fn0)
                         : (depth + rig.normal * NormalForceAtDepth(depth) - actuator_depth0) /
                               (targets.actuator_depth - actuator_depth0);
    return s > s0 && s < s1 ? s : half;  // not NaN, and inside the interval despite round-off
  };
  // Springs that stick are held apart on an exact memory (StickingSprings); u_x moves linearly
  // unless a tangential force target or rig solves it. The margin covers round-off in the depth
  // solve and in u and u_x.
  std::optional<StickingSprings> sticking;
  auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_);
  if (exact != nullptr && mu_kappa() > 0 && hold_sticking_springs_apart_) {
    const bool ux_linear = !tangential_force && !through_rig;
    const double ux1 = targets.actuator_displacement;
    const double margin = 1e-9 * mu_kappa() * std::max(depth0, targets.depth) +
                          1e-12 * (std::abs(ux0) + std::abs(ux1));
    sticking.emplace(mu_kappa(), targets.depth, ux_linear ? std::optional(ux1) : std::nullopt,
                     margin, *config_.profile);
    sticking->TakeFrom(*exact, ux_);
  }
  // One exact linear sub-step of `contact` to the path point at s.
  auto advance = [&](Contact& contact, double s, double* dissipated) -> Status {
    const double d = depth_at(s);
    double ux = along(ux0, targets.actuator_displacement, s);
    double dux = ux - contact.ux_;
    const double held = sticking ? sticking->held_integral() : 0.0;
    if (tangential_force) {
      Result<double> solved =
          contact.SolveTangentialIncrement(d, along(fx0, step.tangential_value, s), held);
      if (!solved.ok()) return solved.status();
      dux = *solved;
      ux = contact.ux_ + dux;
    } else if (through_rig) {
      dux = contact.SolveActuatorIncrement(
          d, along(actuator_displacement0, targets.actuator_displacement, s), held);
      ux = contact.ux_ + dux;
    }
    *dissipated += contact.LinearStep(d, ux, dux);
    return OkStatus();
  };
  const double scale = std::max(mu_kappa() * std::max(depth0, targets.depth), 1e-300);
  // The dissipated energy in units of sliding at the friction limit (at the path's deeper end) by
  // the slip distance mu kappa delta or the actuator's travel, the larger: the most the step
  // can dissipate, up to its elastic part (0 without friction: nothing dissipates).
  const double energy_scale =
      config_.friction * NormalForceAtDepth(std::max(depth0, targets.depth)) *
      std::max(scale, std::abs(targets.actuator_displacement - actuator_displacement0));

  // Adaptive bisection: accept [s0, s1] when one sub-step and two half sub-steps agree to the
  // tolerance, in the memory and in the energy they dissipate. A chord's error in the memory sits
  // in the springs that enter or slide during that interval and is not accumulated afterwards
  // (sticking springs move rigidly with exact sub-step ends, the clamp is non-expansive), so the
  // memory's estimate is the largest local one. Each chord dissipates exactly what it does, not
  // what the curve would, and those errors add up: an interval may take its share (s1 - s0) of
  // the tolerance, and the estimate is their sum. Both converge at second order.
  StepReport total;
  double memory_error = 0, energy_error = 0;
  // Up to 2^kMaxBisections intervals, depth first from s = 0, the interrupt checked at each. A
  // loop over a stack of intervals rather than recursion, and trial contacts whose buffers are
  // reused rather than fresh copies per interval: the path allocates little, and always from the
  // same place (a sanitizer records a stack trace per distinct allocation site and depth).
  struct Interval {
    double s0, s1;
    int level;
  };
  std::vector<Interval> pending = {{0.0, 1.0, 0}};
  // `half`: the state at an interval's middle, which is the one-sub-step trial of its left half
  // (processed next) if the interval is split: that sub-step is not taken twice.
  Contact one = *this, two = *this, half = *this;
  double d_half = 0;
  bool half_is_next = false;
  auto follow = [&]() -> Status {
    while (!pending.empty()) {
      const auto [s0, s1, level] = pending.back();
      pending.pop_back();
      if (Status s = interrupt.Check(); !s.ok()) return s;
      double d_one = 0, d_two = 0;
      const double mid = split(s0, s1);
      bool held_stick = true;
      auto still_stick = [&](const Contact& trial) {
        held_stick = held_stick &&
                     (!sticking || sticking->StillStick(
                                       std::get<PiecewiseLinearMemory>(trial.memory_), trial.ux_));
      };
      if (half_is_next) {  // checked as the split interval's middle
        std::swap(one, half);
        d_one = d_half;
      } else {
        one = *this;
        if (Status s = advance(one, s1, &d_one); !s.ok()) return s;
        still_stick(one);
      }
      half_is_next = false;
      two = *this;
      if (Status s = advance(two, mid, &d_two); !s.ok()) return s;
      still_stick(two);
      half = two;
      d_half = d_two;
      if (Status s = advance(two, s1, &d_two); !s.ok()) return s;
      still_stick(two);
      if (!held_stick) {  // put them back, and sub-step every spring from here on
        sticking->ReturnTo(std::get<PiecewiseLinearMemory>(memory_), ux_);
        sticking.reset();
        pending.push_back({s0, s1, level});
        continue;
      }
      const double error = MemoryDifference(one, two) / scale;
      const double energy = energy_scale > 0 ? std::abs(d_one - d_two) / energy_scale : 0.0;
      const double tolerance = config_.force_path_tolerance;
      if ((error <= tolerance && energy <= tolerance * (s1 - s0)) || level >= kMaxBisections) {
        std::swap(*this, two);
        total.substeps += 2;
        memory_error = std::max(memory_error, error);
        energy_error += energy;
        total.dissipated += d_two;
        if (sticking) sticking->TakeFrom(std::get<PiecewiseLinearMemory>(memory_), ux_);
        continue;
      }
      pending.push_back({mid, s1, level + 1});
      pending.push_back({s0, mid, level + 1});
      half_is_next = true;
    }
    return OkStatus();
  };
  const Status refined = follow();
  if (sticking) sticking->ReturnTo(std::get<PiecewiseLinearMemory>(memory_), ux_);
  if (!refined.ok()) return refined;
  // Each estimate bounds its chords' error by itself: the accepted two half sub-steps err by
  // about a third of the difference (second order; measured against much finer references, which
  // contact_test.cc checks). path_error is the larger of the two. Each exact sub-step adds its own
  // rounding, a few eps of mu kappa delta per spring (u += dux, the clamp), which the difference
  // of two runs does not show.
  constexpr double kSubstepRounding = 4 * std::numeric_limits<double>::epsilon();
  total.path_error = std::max(memory_error, energy_error) + total.substeps * kSubstepRounding;
  *report = total;
  return OkStatus();
}

}  // namespace mdr
