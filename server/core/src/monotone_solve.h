// Root of a continuous, nondecreasing function that is smooth between known breakpoints and whose
// derivative is known exactly: the tangential force after a linear step as a function of the
// increment (force-controlled steps). Internal to mdr_core.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace mdr::internal {

struct ValueAndSlope {
  double value, slope;
};

// The s in [lo, hi] with f(s) = target (lo or hi if target is beyond f's range there).
// breakpoints (any order, may lie outside [lo, hi]) are where f may not be smooth: they are walked
// by bisection to the bracket that holds the root, inside which Newton's method with the exact
// slope converges quadratically; a Newton step that leaves the bracket or does not halve the
// residual bisects instead, so the iteration also ends without breakpoints (piecewise-linear f).
// Ends when the step is below 1e-15 of the initial bracket's scale (the round-off of f), or when
// the quadratic convergence of the last two Newton steps d1, d2 puts the next one, ~d2^3/d1^2,
// below that.
template <class Function>  // ValueAndSlope f(double s)
double SolveNondecreasing(const Function& f, std::vector<double>& breakpoints, double lo, double hi,
                          double target) {
  const double tolerance = 1e-15 * std::max({std::abs(lo), std::abs(hi), hi - lo});
  std::sort(breakpoints.begin(), breakpoints.end());
  auto first = std::upper_bound(breakpoints.begin(), breakpoints.end(), lo);
  auto last = std::lower_bound(first, breakpoints.end(), hi);
  bool lo_known = false, hi_known = false;  // f at the bracket's ends, once evaluated
  double f_lo = 0, f_hi = 0;
  while (last - first > 0) {  // halve the breakpoints inside the bracket
    const auto mid = first + (last - first) / 2;
    const double value = f(*mid).value;
    if (value == target) return *mid;
    if (value < target) {
      lo = *mid, f_lo = value, lo_known = true, first = mid + 1;
    } else {
      hi = *mid, f_hi = value, hi_known = true, last = mid;
    }
  }
  if (!lo_known) f_lo = f(lo).value;
  if (f_lo >= target) return lo;
  if (!hi_known) f_hi = f(hi).value;
  if (f_hi <= target) return hi;
  // Smooth on [lo, hi]: start at the chord's root.
  double s = f_hi > f_lo ? lo + (hi - lo) * ((target - f_lo) / (f_hi - f_lo)) : lo;
  double last_residual = f_hi - f_lo, last_step = 0;
  for (int iteration = 0; iteration < 100; ++iteration) {
    const ValueAndSlope at = f(s);
    const double residual = at.value - target;
    if (residual == 0) return s;
    (residual < 0 ? lo : hi) = s;
    const double newton = s - residual / at.slope, step = std::abs(newton - s);
    const bool inside = newton >= lo && newton <= hi;  // may land on an end that is the root
    const bool converging = inside && 2 * std::abs(residual) <= last_residual;
    if (inside &&
        (step <= tolerance || (converging && step < 0.5 * last_step &&
                               step * step * step <= tolerance * last_step * last_step))) {
      return newton;
    }
    last_residual = std::abs(residual);
    last_step = converging ? step : 0;
    s = converging ? newton : 0.5 * (lo + hi);
    if (hi - lo <= tolerance) return s;
  }
  return s;
}

// The s with f(s) + spring * s = target, spring >= 0, for f nondecreasing on [lo, hi] and constant
// beyond (the tangential force saturates at gross slip): SolveNondecreasing inside, the linear
// tails outside. spring = 0 is SolveNondecreasing itself (ends clamped to [lo, hi]).
template <class Function>
double SolveWithSpring(const Function& f, std::vector<double>& breakpoints, double lo, double hi,
                       double target, double spring) {
  if (!(spring > 0)) return SolveNondecreasing(f, breakpoints, lo, hi, target);
  const double f_lo = f(lo).value + spring * lo, f_hi = f(hi).value + spring * hi;
  if (target <= f_lo) return lo + (target - f_lo) / spring;
  if (target >= f_hi) return hi + (target - f_hi) / spring;
  auto with_spring = [&](double s) {
    ValueAndSlope at = f(s);
    return ValueAndSlope{at.value + spring * s, at.slope + spring};
  };
  return SolveNondecreasing(with_spring, breakpoints, lo, hi, target);
}

}  // namespace mdr::internal
