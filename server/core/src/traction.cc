#include "mdr/core/traction.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <string>

#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::ForEachAbelInterval;
using internal::kEps;
using internal::kInf;
using internal::kPi;
using internal::Quadrature;
constexpr std::size_t kQuadratureLimit = 512;

// One route's value at one radius, per unit modulus (G* for tau, E* for p).
struct RouteValue {
  double value = 0;
  double error = 0;
  bool defined = true;
};

// Spring displacements v(z) as a polyline in depth: the tangential memory u, or the normal
// springs w = delta - z. Both routes act on this form alone. rounded: the interior vertices are
// placed by the engine's rounding (the memory's crossings), not given exactly.
struct DepthPolyline {
  std::span<const double> z, v;
  bool rounded = false;
};

// Rounding of the polyline's vertices (docs/engine.md, "Error estimates"). A memory vertex's
// depth is known to kVertexDepthUlps * eps * delta (the crossing parameter, za + t (zb - za)
// and the nudges of memory.cc), its u to kVertexValueUlps * eps of the largest |u| of its
// segments (the interpolation, and a crossing nearly parallel to its bound line, where the
// rounding moves the vertex along the bound instead). Every radius x = g^-1(z) that the
// pressures use is rounded by the profile to kRadiusUlps * eps * x (sqrt, pow).
constexpr double kVertexDepthUlps = 8;
constexpr double kVertexValueUlps = 8;
constexpr double kRadiusUlps = 4;

// Bound on the change of p(r; x) per modulus, (1/pi) integral_r^x g'(s)/sqrt(s^2 - r^2) ds, when
// its edge x moves anywhere within dx = g_dx / g' (g_dx: the error as a depth). The integrand
// over [x - dx, x + dx] gives (1/pi) min(g_dx / sqrt((x - dx)^2 - r^2), 3 sqrt(g_dx g' / x)), the
// second form where the edge may come near r (p rises like sqrt(x - r) there). A jump of g (flat
// punch) stays at its radius; its height moves: g_dx / (pi sqrt(x^2 - r^2)).
double EdgeShift(double x, double g_slope, double g_dx, double r) {
  if (std::isinf(g_slope)) return x > r ? g_dx / (kPi * std::sqrt((x - r) * (x + r))) : 0.0;
  const double dx = g_dx / g_slope;
  if (!(x + dx > r) || !(x > 0)) return 0;
  const double inner = x - dx;
  const double far = inner > r ? g_dx / std::sqrt((inner - r) * (inner + r)) : kInf;
  const double shift = std::min(far, 3 * std::sqrt(g_dx * g_slope / x));
  return std::isfinite(shift) ? shift / kPi : 0;
}

// Bound on |value(r)| / modulus from that rounding, for both routes alike (they act on the same
// rounded polyline, so their difference cannot see it): each vertex is a kink of v whose slope
// jumps by [s]_k (to 0 beyond the edge), and moving it moves an edge of p by the rounding of
// its depth and its radius (EdgeShift, times |[s]_k|); an error du of u at the ends of segment k
// changes its slope by 2 du / (z_{k+1} - z_k), times |P(r; z_{k+1}) - P(r; z_k)|.
double VertexRounding(const DepthPolyline& springs, const Profile& profile, double r) {
  const std::size_t n = springs.z.size();
  // Radii from the reported contact radius on carry no load by definition (traction.h).
  if (n < 2 || !(r < profile.RadiusAtDepth(springs.z.back()))) return 0;
  const double dz = springs.rounded ? kVertexDepthUlps * kEps * springs.z.back() : 0;
  auto slope = [&](std::size_t k) {
    if (k + 1 >= n) return 0.0;
    return (springs.v[k + 1] - springs.v[k]) / (springs.z[k + 1] - springs.z[k]);
  };
  double bound = 0;
  for (std::size_t k = 1; k < n; ++k) {
    if (springs.rounded) {
      const double dp = std::abs(profile.PressurePerModulus(r, springs.z[k]) -
                                 profile.PressurePerModulus(r, springs.z[k - 1]));
      const double du =
          kVertexValueUlps * kEps * std::max(std::abs(springs.v[k - 1]), std::abs(springs.v[k]));
      if (std::isfinite(dp)) bound += 2 * du / (springs.z[k] - springs.z[k - 1]) * dp;
    }
    const double jump = std::abs(slope(k) - slope(k - 1));
    if (jump == 0) continue;
    const double x = profile.RadiusAtDepth(springs.z[k]);
    const double g_slope = profile.Slope(x);
    // The last vertex is the contact edge, z = delta: given, not rounded.
    const double depth_error = k + 1 < n ? dz : 0;
    // A jump of g (flat punch) sits at the profile's own radius, exactly.
    const double g_dx =
        std::isinf(g_slope) ? depth_error : depth_error + g_slope * kRadiusUlps * kEps * x;
    if (g_dx == 0) continue;
    bound += jump * EdgeShift(x, g_slope, g_dx, r);
  }
  return bound;
}

// Route (1): -(1/pi) integral_r^a v'(x)/sqrt(x^2 - r^2) dx with v'(x) = (dv/dz) g'(x) on each
// segment; x = sqrt(r^2 + s^2) turns it into -(1/pi) (dv/dz) integral g'(x)/x ds, smooth for
// r > 0. A segment with no radial extent is a jump of v at a radius where g jumps (flat punch
// edge): v' is a delta there and contributes -[v]/(pi sqrt(x*^2 - r^2)) in closed form.
RouteValue AbelRoute(const DepthPolyline& springs, const Profile& profile, double r,
                     double rel_tolerance, Quadrature& quadrature) {
  RouteValue out;
  for (std::size_t k = 0; k + 1 < springs.z.size(); ++k) {
    const double dv = springs.v[k + 1] - springs.v[k];
    if (dv == 0) continue;
    const double xa = profile.RadiusAtDepth(springs.z[k]);
    const double xb = profile.RadiusAtDepth(springs.z[k + 1]);
    if (!(xb > r)) continue;
    if (!(xb > xa)) {
      out.value -= dv / (kPi * std::sqrt((xa - r) * (xa + r)));
      continue;
    }
    const double slope = dv / (springs.z[k + 1] - springs.z[k]);
    // At the centre g'(x)/x is integrable exactly when the pressure there is finite (cone and
    // n <= 1 power laws: it is not), and then the traction is that of the first segment: infinite.
    if (r == 0 && xa == 0 && std::isinf(profile.PressurePerModulus(0, springs.z[k + 1]))) {
      return {slope > 0 ? -kInf : kInf, 0, true};
    }
    auto integrand = [&](double s) {
      const double x = std::sqrt(r * r + s * s);
      return profile.Slope(x) / x;
    };
    const double lo = std::max(xa, r);
    const double s_lo = std::sqrt((lo - r) * (lo + r)), s_hi = std::sqrt((xb - r) * (xb + r));
    // For n < 2, g'(x)/x peaks in a layer of width r at s = 0: integrate that layer separately.
    double integral = 0, error = 0;
    ForEachAbelInterval(r, s_lo, s_hi, [&](double lo_s, double hi_s) {
      quadrature.AddWithExtrapolation(integrand, lo_s, hi_s, 0, rel_tolerance, &integral, &error);
    });
    out.value -= slope * integral / kPi;
    out.error += std::abs(slope) * error / kPi;
  }
  return out;
}

// Route (2): -sum_k (dv/dz)_k [P(r; z_{k+1}) - P(r; z_k)] with P the pressure per modulus at
// depth z. For the tangential springs -(du/dz) G* = mu F_k E*, Jäger's weights times mu p.
// A term whose two pressures are infinite (r = 0 on a cone) is a finite difference this route
// cannot evaluate: the route is then undefined, unless an infinite term decides the sum.
RouteValue JagerRoute(const DepthPolyline& springs, const Profile& profile, double r) {
  double sum = 0, magnitude = 0;
  int infinite_sign = 0;
  bool indeterminate = false, conflicting = false;
  for (std::size_t k = 0; k + 1 < springs.z.size(); ++k) {
    const double dv = springs.v[k + 1] - springs.v[k];
    if (dv == 0) continue;
    const double p_outer = profile.PressurePerModulus(r, springs.z[k + 1]);
    if (p_outer == 0) continue;  // r beyond the contact radius at depth z_{k+1}
    const double p_inner = profile.PressurePerModulus(r, springs.z[k]);
    const double slope = dv / (springs.z[k + 1] - springs.z[k]);
    if (std::isinf(p_inner)) {
      indeterminate = true;
    } else if (std::isinf(p_outer)) {
      const int sign = slope > 0 ? -1 : 1;
      conflicting |= infinite_sign != 0 && infinite_sign != sign;
      infinite_sign = sign;
    } else {
      const double term = -slope * (p_outer - p_inner);
      sum += term;
      magnitude += std::abs(term);
    }
  }
  if (infinite_sign != 0) return {infinite_sign * kInf, 0, !conflicting};
  if (indeterminate) return {0, 0, false};
  return {sum, 4 * kEps * magnitude, true};
}

// |a - b|, with 0 for the same infinity.
double Discrepancy(double a, double b) { return a == b ? 0.0 : std::abs(a - b); }

// Where g jumps at r (a flat punch edge: Slope(r) = +inf), the springs of a range of depths all
// sit at r and both routes have their inverse square root singularity there: the value is
// -sign([v]) * inf for the net jump [v] of v at r, or 0 if v does not jump. Empty elsewhere.
std::optional<double> JumpSingularity(const DepthPolyline& springs, const Profile& profile,
                                      double r) {
  if (!(r > 0) || !std::isinf(profile.Slope(r))) return std::nullopt;
  double jump = 0;
  bool at_jump = false;
  for (std::size_t k = 0; k + 1 < springs.z.size(); ++k) {
    if (profile.RadiusAtDepth(springs.z[k]) != r || profile.RadiusAtDepth(springs.z[k + 1]) != r) {
      continue;
    }
    at_jump = true;
    jump += springs.v[k + 1] - springs.v[k];
  }
  if (!at_jump) return std::nullopt;
  return jump == 0 ? 0.0 : (jump < 0 ? kInf : -kInf);
}

// Picks the reported value (traction.h, RadialValue): Jäger's when both routes are defined. The
// estimate adds the rounding of the vertices both routes share (VertexRounding) and, for a
// chosen Jäger value, the round-off of its own sum.
void ChooseValue(double abel_error, double jager_error, double rounding, RadialValue* out) {
  if (out->abel && out->jager) {
    out->chosen = TractionRoute::kBoth;
    out->value = *out->jager;
    out->error_estimate = Discrepancy(*out->abel, *out->jager) + jager_error + rounding;
  } else if (out->abel) {
    out->chosen = TractionRoute::kAbel;
    out->value = *out->abel;
    out->error_estimate = abel_error + rounding;
  } else {
    out->chosen = TractionRoute::kJager;
    out->value = *out->jager;
    out->error_estimate = jager_error + rounding;
  }
  if (std::isinf(out->value)) out->error_estimate = 0;  // an exact infinity
}

// Both routes at one radius as requested, and the choice between them (traction.h).
RadialValue Evaluate(const DepthPolyline& springs, const Profile& profile, double modulus, double r,
                     const TractionOptions& options, Quadrature& quadrature) {
  RadialValue out;
  out.radius = r;
  if (const std::optional<double> singular = JumpSingularity(springs, profile, r)) {
    out.value = *singular;
    if (options.routes != TractionRoute::kJager) out.abel = out.value;
    if (options.routes != TractionRoute::kAbel) out.jager = out.value;
    out.chosen = options.routes;
    return out;
  }
  double abel_error = 0, jager_error = 0;
  auto run_abel = [&] {
    const RouteValue abel =
        AbelRoute(springs, profile, r, options.abel_relative_tolerance, quadrature);
    out.abel = modulus * abel.value;
    abel_error = modulus * abel.error;
  };
  if (options.routes != TractionRoute::kJager) run_abel();
  if (options.routes != TractionRoute::kAbel) {
    const RouteValue jager = JagerRoute(springs, profile, r);
    if (jager.defined) {
      out.jager = modulus * jager.value;
      jager_error = modulus * jager.error;
    } else if (!out.abel) {
      run_abel();  // the only route that gives a value here
    }
  }
  ChooseValue(abel_error, jager_error, modulus * VertexRounding(springs, profile, r), &out);
  return out;
}

Status ValidateOptions(const TractionOptions& options) {
  return RequireInRange("options.abel_relative_tolerance", options.abel_relative_tolerance, 0, 1e-3,
                        /*lo_open=*/true);
}

Result<std::vector<RadialValue>> EvaluateAtRadii(const DepthPolyline& springs,
                                                 const Profile& profile, double modulus,
                                                 const std::vector<double>& radii,
                                                 const TractionOptions& options) {
  if (Status s = ValidateOptions(options); !s.ok()) return s;
  for (std::size_t i = 0; i < radii.size(); ++i) {
    if (Status s = RequireNonNegative("radii[" + std::to_string(i) + "]", radii[i]); !s.ok()) {
      return s;
    }
  }
  Quadrature quadrature(kQuadratureLimit);
  std::vector<RadialValue> values;
  values.reserve(radii.size());
  for (double r : radii) {
    if (Status s = options.interrupt.Check(); !s.ok()) return s;
    values.push_back(Evaluate(springs, profile, modulus, r, options, quadrature));
  }
  return values;
}

// The normal springs w = delta - z as a polyline (empty out of contact).
struct NormalSprings {
  explicit NormalSprings(double depth) {
    if (depth > 0) {
      z = {0, depth};
      v = {depth, 0};
    }
  }
  DepthPolyline polyline() const { return {z, v}; }
  std::vector<double> z, v;
};

// 2 pi integral_0^a value(r) r dr, split at the radii of the polyline's vertices (where the
// traction has kinks or infinite slopes). The absolute tolerance is relative_tolerance times
// 2 modulus max|v| a, the scale of the force (F_x = 2 G* integral u dx), so that loads whose
// traction changes sign converge too.
Result<IntegratedForce> IntegrateRadially(const DepthPolyline& springs, const Profile& profile,
                                          double modulus, double relative_tolerance,
                                          TractionRoute route) {
  if (Status s = RequireInRange("relative_tolerance", relative_tolerance, 0, 1e-3,
                                /*lo_open=*/true);
      !s.ok()) {
    return s;
  }
  IntegratedForce out;
  if (springs.z.empty()) return out;
  const double a = profile.RadiusAtDepth(springs.z.back());
  std::vector<double> breaks = {0.0, a};
  for (double z : springs.z) {
    const double x = profile.RadiusAtDepth(z);
    if (x > 0 && x < a) breaks.push_back(x);
  }
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
  double v_max = 0;
  for (double v : springs.v) v_max = std::max(v_max, std::abs(v));
  const double abs_tolerance = relative_tolerance * 2 * modulus * v_max * a;

  TractionOptions options;
  options.routes = route;
  Quadrature outer(kQuadratureLimit), inner(kQuadratureLimit);
  auto integrand = [&](double r) {
    return 2 * kPi * r * Evaluate(springs, profile, modulus, r, options, inner).value;
  };
  for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
    outer.AddWithExtrapolation(integrand, breaks[i], breaks[i + 1], abs_tolerance,
                               relative_tolerance, &out.value, &out.error_estimate);
  }
  return out;
}

DepthPolyline TangentialSprings(const PiecewiseLinearMemory& memory) {
  return {memory.z(), memory.u(), /*rounded=*/true};
}

}  // namespace

Result<std::vector<RadialValue>> ComputeTangentialTraction(const PiecewiseLinearMemory& memory,
                                                           const Profile& profile,
                                                           const EffectiveMaterial& material,
                                                           const std::vector<double>& radii,
                                                           const TractionOptions& options) {
  return EvaluateAtRadii(TangentialSprings(memory), profile, material.g_star, radii, options);
}

Result<std::vector<RadialValue>> ComputeTangentialTraction(const Contact& contact,
                                                           const std::vector<double>& radii,
                                                           const TractionOptions& options) {
  if (Status s = RequireExactMethod(contact, "method"); !s.ok()) return s;
  return ComputeTangentialTraction(contact.memory(), *contact.config().profile,
                                   contact.config().material, radii, options);
}

Result<std::vector<RadialValue>> ComputeNormalPressure(const Profile& profile,
                                                       const EffectiveMaterial& material,
                                                       double depth,
                                                       const std::vector<double>& radii,
                                                       const TractionOptions& options) {
  if (Status s = RequireFinite("depth", depth); !s.ok()) return s;
  const NormalSprings springs(depth);
  return EvaluateAtRadii(springs.polyline(), profile, material.e_star, radii, options);
}

Result<std::vector<RadialValue>> ComputeNormalPressure(const Contact& contact,
                                                       const std::vector<double>& radii,
                                                       const TractionOptions& options) {
  return ComputeNormalPressure(*contact.config().profile, contact.config().material,
                               contact.depth(), radii, options);
}

Result<IntegratedForce> IntegrateTangentialTraction(const Contact& contact,
                                                    double relative_tolerance,
                                                    TractionRoute route) {
  if (Status s = RequireExactMethod(contact, "method"); !s.ok()) return s;
  return IntegrateRadially(TangentialSprings(contact.memory()), *contact.config().profile,
                           contact.config().material.g_star, relative_tolerance, route);
}

Result<IntegratedForce> IntegrateNormalPressure(const Contact& contact, double relative_tolerance,
                                                TractionRoute route) {
  const NormalSprings springs(contact.depth());
  return IntegrateRadially(springs.polyline(), *contact.config().profile,
                           contact.config().material.e_star, relative_tolerance, route);
}

}  // namespace mdr
