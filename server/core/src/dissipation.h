// The energy one spring dissipates along a step linear in (delta, ux), per G* and unit radius
// (docs/engine.md, "Dissipated energy, exactly per spring"), written once for both memories: the
// grid evaluates it spring by spring on numbers, the exact memory on a segment where the clamped
// amount e, the bound b1 and the onset bound b* are linear in z, which makes it a quadratic in z
// that Profile::IntegratePiece integrates exactly. Internal to mdr_core.
#pragma once

#include <algorithm>

#include "mdr/core/memory.h"

namespace mdr::internal {

// One step linear in (delta, ux): depth0 -> depth1, ux -> ux + dux.
struct LinearStep {
  double depth0, depth1, dux, mu_kappa;

  double ddelta() const { return depth1 - depth0; }
  double BoundAtEnd(double z) const { return CoulombBound(mu_kappa, depth1, z); }
  // r = sigma dux - mu_kappa ddelta: how fast a spring on the bound sigma (+-1) slides along it;
  // a spring with r <= 0 never reaches that bound during the step.
  double SlidingRate(int sigma) const { return sigma * dux - mu_kappa * ddelta(); }
  // b* = b0 + mu_kappa ddelta s*, the bound at the moment s* = (b0 - sigma u0) / r at which a
  // spring at z with start value u0 starts to slide on the bound sigma (for r > 0).
  double SlideOnsetBound(double z, double u0, int sigma) const {
    const double b0 = CoulombBound(mu_kappa, depth0, z);
    return std::clamp(b0 + mu_kappa * ddelta() * (b0 - sigma * u0) / SlidingRate(sigma), 0.0, b0);
  }
};

// A linear and a quadratic function on a segment [z_a, z_b], of t = (z - z_a) / (z_b - z_a)
// (the variable of Profile::IntegratePiece).
struct Linear {
  double at_a, slope;
};
struct Quadratic {
  double c0, c1, c2;
};
inline Quadratic operator*(Linear p, Linear q) {
  return {p.at_a * q.at_a, p.slope * q.at_a + p.at_a * q.slope, p.slope * q.slope};
}
inline Linear operator*(double k, Linear p) { return {k * p.at_a, k * p.slope}; }
inline Quadratic operator*(double k, Quadratic q) { return {k * q.c0, k * q.c1, k * q.c2}; }
inline Quadratic operator-(Quadratic p, Quadratic q) {
  return {p.c0 - q.c0, p.c1 - q.c1, p.c2 - q.c2};
}

// A spring that stays in or enters contact and that the clamp moves by e >= 0 onto its bound
// sigma (b1 at the step's end): 2 [e b1 - (mu_kappa ddelta / (2 r)) e^2]. Value: double or Linear.
// (k e) e, not k (e e): e may be near the largest double after a huge increment, where k is tiny.
template <class Value>
auto ClampedSpringDissipation(const LinearStep& step, int sigma, const Value& e, const Value& b1) {
  const double r = step.SlidingRate(sigma);
  const double k = r > 0 ? step.mu_kappa * step.ddelta() / (2 * r) : 0.0;
  return 2.0 * (e * b1 - (k * e) * e);
}

// A spring that leaves contact during an unloading step while on the side sigma: it slides from
// the bound b* = SlideOnsetBound on and dissipates r b*^2 / (-mu_kappa ddelta); nothing if r <= 0
// (it moves away from that bound no slower than the bound shrinks). Value: double or Linear.
template <class Value>
auto LeavingSpringDissipation(const LinearStep& step, int sigma, const Value& b_star) {
  const double r = step.SlidingRate(sigma);
  const double k = r > 0 ? r / (-step.mu_kappa * step.ddelta()) : 0.0;
  return (k * b_star) * b_star;
}

}  // namespace mdr::internal
