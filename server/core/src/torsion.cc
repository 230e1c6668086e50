#include "mdr/core/torsion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>

#include "carlson.h"
#include "hertz_torsion_table.h"
#include "mdr/base/validate.h"
#include "mdr/core/tabulated_profile.h"
#include "monotone_solve.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::kInf;
using internal::kPi;

// R_F(0, y, 1) and R_D(0, y, 1): K(m) = R_F and K(m) - E(m) = (m/3) R_D with y = 1 - m, which
// keeps K - E exact near the edge (m -> 0) and K exact near the centre (y -> 0).
double CarlsonF(double y) { return internal::CarlsonRF<double>(0, y, 1); }
double CarlsonD(double y) { return internal::CarlsonRD<double>(0, y, 1); }

// Two integrals taken together (the tails of x^2 B and x^2 B^2 share their bound's values); the
// quadratures below integrate a double or a Pair.
struct Pair {
  double first = 0, second = 0;
  Pair& operator+=(const Pair& other) {
    first += other.first, second += other.second;
    return *this;
  }
  friend Pair operator+(Pair a, const Pair& b) { return a += b; }
  friend Pair operator*(double s, const Pair& a) { return {s * a.first, s * a.second}; }
  friend Pair operator*(const Pair& a, double s) { return s * a; }
};
template <typename F>
using ValueOf = std::invoke_result_t<const F&, double>;

// integral_lo^hi f by 16-point Gauss-Legendre.
template <typename F>
ValueOf<F> Gauss16(const F& f, double lo, double hi) {
  static const internal::GaussLegendreRule rule(16);
  const double half = (hi - lo) / 2, mid = (lo + hi) / 2;
  ValueOf<F> part{};
  for (std::size_t i = 0; i < rule.size; ++i)
    part += rule.weights[i] * f(mid + half * rule.nodes[i]);
  return half * part;
}

// integral_0^top f over ceil(top) equal panels no wider than 1, 16-point Gauss-Legendre on each:
// for integrands analytic in a strip about [0, top] of half-width of order 1.
template <typename F>
double OverUnitPanels(const F& f, double top) {
  const int panels = std::max(1, static_cast<int>(std::ceil(top)));
  double sum = 0;
  for (int j = 0; j < panels; ++j) sum += Gauss16(f, top * j / panels, top * (j + 1) / panels);
  return sum;
}

// integral_lo^hi f in x = lo + (hi - lo) (1 - cos t) / 2, t in [0, pi], 16-point Gauss-Legendre
// on each half: a term like sqrt(x - lo) or sqrt(hi - x) at an end (a sample radius of a
// tabulated profile, where g' has one) is smooth in t, so the rule keeps its order.
template <typename F>
ValueOf<F> GaussCos(const F& f, double lo, double hi) {
  const double half = (hi - lo) / 2, mid = (lo + hi) / 2;
  auto in_t = [&](double t) { return f(mid - half * std::cos(t)) * half * std::sin(t); };
  return Gauss16(in_t, 0, kPi / 2) + Gauss16(in_t, kPi / 2, kPi);
}

// A contact that holds at most this many sample radii of a tabulated profile (a coarse one) has
// its integrals split at them. With more, the samples are dense: the square-root terms of g' at
// them are small (the jumps of f'' between neighbouring pieces are), the plain rules keep their
// measured accuracy (docs/physics.md, "Torsion") and splitting would cost an order of magnitude.
constexpr std::ptrdiff_t kMaxSplits = 16;

// integral_lo^hi f split at the points inside (lo, hi) (increasing), each part in equal panels no
// wider than `panel`, each panel by GaussCos: for f smooth but for square-root terms at the
// points.
template <typename F, typename Points>
double PanelsAcross(const F& f, double lo, double hi, double panel, const Points& points) {
  const auto first = std::upper_bound(points.begin(), points.end(), lo);
  const auto last = std::lower_bound(first, points.end(), hi);
  auto part = [&](double a, double b, bool cos_rule) {
    const int panels = std::max(1, static_cast<int>(std::ceil((b - a) / panel)));
    double sum = 0;
    for (int j = 0; j < panels; ++j) {
      const double pa = a + (b - a) * j / panels, pb = a + (b - a) * (j + 1) / panels;
      sum += cos_rule ? GaussCos(f, pa, pb) : Gauss16(f, pa, pb);
    }
    return sum;
  };
  if (first == last) return part(lo, hi, false);
  double sum = 0, a = lo;
  for (auto it = first; it != last; ++it) {
    sum += part(a, *it, true);
    a = *it;
  }
  return sum + part(a, hi, true);
}

// B = scale a h(x / a), h(t) = K(1 - t^2) - E(1 - t^2) read off the universal function's tables
// (hertz_torsion_table.h: Chebyshev series on dyadic panels, built from Carlson's integrals, to a
// few ulps), with its inverse and the integrals of x^2 B and x^2 B^2 in closed form per piece.
class HertzTorsionBound final : public TorsionBound {
 public:
  // scale = mu E* / (pi R G_t): B = scale * a * h.
  explicit HertzTorsionBound(double scale)
      : scale_(scale), table_(internal::HertzTorsionTable::Get()) {}

  double Bound(double x, double a) const override {
    if (x >= a) return 0;
    if (x <= 0) return kInf;
    // Where x / a would underflow: h = ln(4 a / x) - 1 to far below round-off (a / x itself may
    // overflow, its logarithm not).
    if (x < kTinyRatio * a) return scale_ * a * (std::log(4 * a) - std::log(x) - 1);
    return scale_ * a * table_.H(x / a, (a - x) / a);
  }
  double Slope(double x, double a) const override {
    if (x >= a || x <= 0) return x <= 0 ? -kInf : 0;
    if (x < kTinyRatio * a) return -scale_ * a / x;  // E = 1 there
    return -scale_ * a * table_.E(x / a, (a - x) / a) / x;
  }
  // mu p0 / G_t = 2 scale a, p = p0 sqrt(1 - r^2/a^2).
  double SlidingTractionPerModulus(double r, double a) const override {
    if (!(r < a)) return 0;
    return 2 * scale_ * std::sqrt((a - r) * (a + r));
  }
  // 16 scale a^4 integral_0^1 u^2 h du = 16 scale a^4 pi^2 / 64.
  double FullSlipMomentPerModulus(double a) const override {
    return 16 * scale_ * a * (a * a * a) * table_.WholeIntegrals().first;
  }
  // scale a^4 I1(x / a) and (scale a)^2 a^3 I2(x / a), I_k(t) = integral_t^1 u^2 h^k du.
  Integrals TailIntegrals(double x, double a) const override {
    if (x >= a) return {};
    const internal::HertzTorsionTable::Tails tails =
        // Below x = 1e-150 a what is left out is below x^3.
        x <= kTinyRatio * a ? table_.WholeIntegrals() : table_.Integrals(x / a, (a - x) / a);
    const double scaled = scale_ * a, cube = a * a * a;
    return {.first = scaled * cube * tails.first, .second = scaled * scaled * cube * tails.second};
  }
  double RadiusAtBound(double value, double a) const override {
    const internal::HertzTorsionTable::Point p = table_.Inverse(value / (scale_ * a));
    // Near the edge from w = 1 - t, which carries the digits there.
    return p.t > 0.5 ? a - a * p.w : a * p.t;
  }

 private:
  static constexpr double kTinyRatio = 1e-150;
  double scale_;
  const internal::HertzTorsionTable& table_;
};

// A power law g = k x^n: B(x; a) = scale a^(n-1) b_n(x/a), scale = mu E* n k / (2 pi G_t),
// b_n(t) = integral_t^1 u^(n-2) K(1 - t^2/u^2) du. With u = t^(1-s) the integrand is smooth in s
// on [0, 1] (du = u ln(1/t) ds, and K's logarithm becomes linear in s), so one 64-point
// Gauss-Legendre rule gives b_n and its slope to round-off.
class PowerLawTorsionBound final : public TorsionBound {
 public:
  PowerLawTorsionBound(double scale, double exponent) : scale_(scale), exponent_(exponent) {}

  double Bound(double x, double a) const override {
    if (x >= a) return 0;
    if (x <= 0) return kInf;
    return scale_ * std::pow(a, exponent_ - 1) * Scaled(x, a, false);
  }
  double Slope(double x, double a) const override {
    if (x >= a || x <= 0) return x <= 0 ? -kInf : 0;
    return scale_ * std::pow(a, exponent_ - 2) * Scaled(x, a, true);
  }
  // mu p / G_t = 2 scale a^(n-1) integral_rho^1 t^(n-1) / sqrt(t^2 - rho^2) dt, rho = r/a; with
  // t = rho cosh(w) the integrand (rho cosh w)^(n-1) is smooth on [0, acosh(1/rho)], integrated
  // in unit steps of w. Infinite at the centre of a profile with n <= 1 (the cone's tip).
  double SlidingTractionPerModulus(double r, double a) const override {
    if (!(r < a)) return 0;
    if (r <= 0)
      return exponent_ <= 1 ? kInf : 2 * scale_ * std::pow(a, exponent_ - 1) / (exponent_ - 1);
    const double rho = r / a;
    const double sum = OverUnitPanels(
        [&](double w) { return std::pow(rho * std::cosh(w), exponent_ - 1); }, std::acosh(1 / rho));
    return 2 * scale_ * std::pow(a, exponent_ - 1) * sum;
  }

 private:
  // b_n(t), or its derivative b_n'(t) = -(pi/2) t^(n-2) - (1/t) integral_t^1 u^(n-2)
  // (R_F - R_D/3)(0, t^2/u^2, 1) du (dK/dt at fixed u, without the cancellation of E - (1-m) K).
  // t = x/a; ln(1/t) from a - x (exact), not from the rounded t, which near the edge would
  // lose the digits of 1 - t.
  double Scaled(double x, double a, bool derivative) const {
    static const internal::GaussLegendreRule rule(64);
    const double t = x / a;
    const double log_inverse = std::log1p((a - x) / x);
    double sum = 0;
    for (std::size_t i = 0; i < rule.size; ++i) {
      const double s = (rule.nodes[i] + 1) / 2;
      const double ratio_squared = std::exp(-2 * s * log_inverse);  // (t/u)^2 = t^(2s)
      const double u = t / std::sqrt(ratio_squared);
      const double kernel = derivative ? CarlsonF(ratio_squared) - CarlsonD(ratio_squared) / 3
                                       : CarlsonF(ratio_squared);
      sum += rule.weights[i] * std::pow(u, exponent_ - 1) * kernel;
    }
    const double integral = sum * log_inverse / 2;
    if (!derivative) return integral;
    return -(kPi / 2) * std::pow(t, exponent_ - 2) - integral / t;
  }

  double scale_, exponent_;
};

// Any profile with a continuous g' (tabulated ones): B(x; a) = scale integral_x^a g'(s)
// K(1 - x^2/s^2) ds / s, scale = mu E* / (2 pi G_t), the power law's integral with the profile's
// own slope. With s = x e^y the integrand g'(x e^y) K(1 - e^(-2y)) is smooth in y (K's branch
// point lies pi/2 off the real axis, its logarithm becomes linear in y), so 16-point
// Gauss-Legendre on unit panels of [0, ln(a/x)] gives the bound to round-off for a smooth g';
// a tabulated g' is a C0 piecewise quadratic, and its kinks add what tests/core measure
// (docs/physics.md). The slope differentiates under the integral:
// dB/dx = -(scale/x) [(pi/2) g'(x) + integral_0^ln(a/x) g'(x e^y) (R_F - R_D/3)(0, e^(-2y), 1) dy].
// A tabulated profile's sample radii beyond the axis, where its g' is not smooth.
std::vector<double> SampleRadii(const Profile& profile) {
  const auto* tabulated = dynamic_cast<const TabulatedProfile*>(&profile);
  if (tabulated == nullptr || tabulated->sample_radii().empty()) return {};
  return {tabulated->sample_radii().begin() + 1, tabulated->sample_radii().end()};
}

class QuadratureTorsionBound final : public TorsionBound {
 public:
  QuadratureTorsionBound(ProfilePtr profile, double scale, double traction_scale)
      : profile_(std::move(profile)), scale_(scale), traction_scale_(traction_scale) {}

  double Bound(double x, double a) const override {
    if (x >= a) return 0;
    if (x <= 0) return kInf;
    return scale_ * Sum(x, a, false);
  }
  double Slope(double x, double a) const override {
    if (x >= a || x <= 0) return x <= 0 ? -kInf : 0;
    return -(scale_ / x) * ((kPi / 2) * profile_->Slope(x) + Sum(x, a, true));
  }
  double SlidingTractionPerModulus(double r, double a) const override {
    if (!(r < a)) return 0;
    return traction_scale_ * profile_->PressurePerModulus(r, profile_->G(a));
  }
  double FullSlipMomentPerModulus(double a) const override;
  const std::vector<double>& Breakpoints() const override { return breakpoints_; }

 private:
  double Sum(double x, double a, bool derivative) const {
    auto integrand = [&](double y) {
      const double e2 = std::exp(-2 * y);
      const double kernel = derivative ? CarlsonF(e2) - CarlsonD(e2) / 3 : CarlsonF(e2);
      return profile_->Slope(x * std::exp(y)) * kernel;
    };
    const double top = std::log1p((a - x) / x);  // ln(a/x), exact near the edge
    if (breakpoints_.empty()) return OverUnitPanels(integrand, top);
    // The sample radii inside (x, a), at y = ln(r_k / x): g' has a square-root term there.
    const auto first = std::upper_bound(breakpoints_.begin(), breakpoints_.end(), x);
    const auto last = std::lower_bound(first, breakpoints_.end(), a);
    if (first == last || last - breakpoints_.begin() > kMaxSplits) {
      return OverUnitPanels(integrand, top);
    }
    std::vector<double> at;  // small: at most kMaxSplits
    at.reserve(static_cast<std::size_t>(last - first));
    for (auto it = first; it != last; ++it) at.push_back(std::log1p((*it - x) / x));
    return PanelsAcross(integrand, 0, top, 1.0, at);
  }
  ProfilePtr profile_;
  double scale_, traction_scale_;
  std::vector<double> breakpoints_ = SampleRadii(*profile_);
};

// integral_lo^hi f over intervals at most a factor 2 apart in x (16-point Gauss-Legendre on each):
// the bound varies like log x near the centre, smoothly on each such interval. From lo = 0 the
// first interval is [0, hi 2^-60], where every integrand here (a factor x^2) is below round-off.
// The same with `rule` (rule(f, a, b)) on each panel but the one at 0.
template <typename F, typename Rule>
ValueOf<F> Integrate(const F& f, double lo, double hi, const Rule& rule) {
  ValueOf<F> sum{};
  if (!(hi > lo)) return sum;
  double a = lo;
  if (a == 0) {
    a = std::ldexp(hi, -60);
    // An interval so short that 2^-60 of it underflows (a root at the doubles' resolution of the
    // centre) is one panel: doubling from 0 would never reach hi (the engine fuzzer's find).
    if (!(a > 0)) return Gauss16(f, 0, hi);
    sum += Gauss16(f, 0, a);
  }
  while (a < hi) {
    const double b = std::min(2 * a, hi);
    sum += rule(f, a, b);
    a = b;
  }
  return sum;
}

template <typename F>
ValueOf<F> Integrate(const F& f, double lo, double hi) {
  return Integrate(f, lo, hi, [](const F& g, double a, double b) { return Gauss16(g, a, b); });
}

// Integrate, split at the breakpoints inside (lo, hi) (TorsionBound::Breakpoints, increasing),
// where the integrand's slope is not smooth: each part is then smooth for the Gauss rule.
template <typename F>
ValueOf<F> IntegrateAcross(const F& f, double lo, double hi,
                           const std::vector<double>& breakpoints) {
  const auto first = std::upper_bound(breakpoints.begin(), breakpoints.end(), lo);
  const auto last = std::lower_bound(first, breakpoints.end(), hi);
  if (!(hi > lo) || first == last || last - breakpoints.begin() > kMaxSplits) {
    return Integrate(f, lo, hi);
  }
  // Part by part between the points, each in Integrate's panels but by GaussCos.
  auto cos_rule = [](const F& g, double a, double b) { return GaussCos(g, a, b); };
  ValueOf<F> sum{};
  double a = lo;
  for (auto it = first; it != last; ++it) {
    sum += Integrate(f, a, *it, cos_rule);
    a = *it;
  }
  return sum + Integrate(f, a, hi, cos_rule);
}

// The first `count` values sorted, repeats removed; their new count. Insertion: at most six.
std::size_t SortedUnique(std::array<double, 6>& values, std::size_t count) {
  for (std::size_t i = 1; i < count; ++i) {
    for (std::size_t j = i; j > 0 && values[j] < values[j - 1]; --j) {
      std::swap(values[j], values[j - 1]);
    }
  }
  std::size_t kept = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (kept == 0 || values[i] != values[kept - 1]) values[kept++] = values[i];
  }
  return kept;
}

double CubeDifference(double lo, double hi) { return (hi * hi * hi - lo * lo * lo) / 3; }

// Every bound's inputs: mu, E* and G_t positive.
Status CheckBoundInputs(double friction, double effective_modulus, double torsional_modulus) {
  if (Status s = RequirePositive("friction", friction); !s.ok()) return s;
  if (Status s = RequirePositive("effective_modulus", effective_modulus); !s.ok()) return s;
  return RequirePositive("torsional_modulus", torsional_modulus);
}

// pi^2 scale = pi mu E* / (2 G_t).
double QuadratureTorsionBound::FullSlipMomentPerModulus(double a) const {
  return kPi * kPi * scale_ *
         IntegrateAcross([&](double x) { return x * x * profile_->Slope(x); }, 0, a, breakpoints_);
}

}  // namespace

double TorsionBound::FullSlipMomentPerModulus(double a) const {
  return 16 * IntegrateAcross([&](double x) { return x * x * Bound(x, a); }, 0, a, Breakpoints());
}

TorsionBound::Integrals TorsionBound::TailIntegrals(double x, double a) const {
  if (!(a > x)) return {};
  const Pair tails = IntegrateAcross(
      [&](double u) {
        const double b = Bound(u, a);
        return Pair{u * u * b, u * u * b * b};
      },
      x, a, Breakpoints());
  return {.first = tails.first, .second = tails.second};
}

double TorsionBound::RadiusAtBound(double, double) const {
  return std::numeric_limits<double>::quiet_NaN();
}

Result<std::shared_ptr<const TorsionBound>> MakeHertzTorsionBound(double friction,
                                                                  double effective_modulus,
                                                                  double torsional_modulus,
                                                                  double radius) {
  if (Status s = CheckBoundInputs(friction, effective_modulus, torsional_modulus); !s.ok()) {
    return s;
  }
  if (Status s = RequirePositive("radius", radius); !s.ok()) return s;
  const double scale = friction * effective_modulus / (kPi * radius * torsional_modulus);
  if (!std::isfinite(scale) || scale <= 0) {
    return InvalidArgument("friction", "mu E* / (pi R G_t) must be a positive finite number");
  }
  return std::shared_ptr<const TorsionBound>(std::make_shared<HertzTorsionBound>(scale));
}

Result<std::shared_ptr<const TorsionBound>> MakePowerLawTorsionBound(double friction,
                                                                     double effective_modulus,
                                                                     double torsional_modulus,
                                                                     double coefficient,
                                                                     double exponent) {
  if (Status s = CheckBoundInputs(friction, effective_modulus, torsional_modulus); !s.ok()) {
    return s;
  }
  if (Status s = RequirePositive("coefficient", coefficient); !s.ok()) return s;
  if (!(exponent >= 0.3 && exponent <= 10)) {
    return InvalidArgument("exponent", "must be in [0.3, 10], got " + std::to_string(exponent));
  }
  const double scale =
      friction * effective_modulus * exponent * coefficient / (2 * kPi * torsional_modulus);
  if (!std::isfinite(scale) || scale <= 0) {
    return InvalidArgument("friction", "mu E* n k / (2 pi G_t) must be a positive finite number");
  }
  return std::shared_ptr<const TorsionBound>(
      std::make_shared<PowerLawTorsionBound>(scale, exponent));
}

Result<std::shared_ptr<const TorsionBound>> MakeTorsionBound(const ProfilePtr& profile,
                                                             double friction,
                                                             double effective_modulus,
                                                             double torsional_modulus) {
  if (profile == nullptr) return InvalidArgument("profile", "required");
  const std::optional<PowerLawForm> form = profile->AsPowerLaw();
  if (form && form->exponent == 2) {
    return MakeHertzTorsionBound(friction, effective_modulus, torsional_modulus,
                                 1 / form->coefficient);
  }
  if (form) {
    return MakePowerLawTorsionBound(friction, effective_modulus, torsional_modulus,
                                    form->coefficient, form->exponent);
  }
  if (dynamic_cast<const TabulatedProfile*>(profile.get()) == nullptr) {
    // The flat punch: its bound scales with the depth at a fixed radius, which a memory keyed by
    // the contact radius cannot follow.
    return InvalidArgument("profile",
                           "torsion needs a sphere, a cone, a power law or a "
                           "tabulated profile; " +
                               profile->Describe() + " is not supported yet");
  }
  if (Status s = CheckBoundInputs(friction, effective_modulus, torsional_modulus); !s.ok()) {
    return s;
  }
  const double traction_scale = friction * effective_modulus / torsional_modulus;
  const double scale = traction_scale / (2 * kPi);
  if (!std::isfinite(traction_scale) || scale <= 0) {
    return InvalidArgument("friction", "mu E* / G_t must be a positive finite number");
  }
  return std::shared_ptr<const TorsionBound>(
      std::make_shared<QuadratureTorsionBound>(profile, scale, traction_scale));
}

TorsionalMemory::TorsionalMemory(std::shared_ptr<const TorsionBound> bound,
                                 double torsional_modulus, double contact_radius)
    : bound_(std::move(bound)), modulus_(torsional_modulus), radius_(contact_radius) {
  if (radius_ > 0) pieces_.push_back({.end = radius_}), tails_.push_back({});
}

Result<TorsionalMemory> TorsionalMemory::Create(std::shared_ptr<const TorsionBound> bound,
                                                double torsional_modulus, double contact_radius) {
  if (bound == nullptr) return InvalidArgument("bound", "required");
  if (Status s = RequirePositive("torsional_modulus", torsional_modulus); !s.ok()) return s;
  if (Status s = RequireNonNegative("contact_radius", contact_radius); !s.ok()) return s;
  return TorsionalMemory(std::move(bound), torsional_modulus, contact_radius);
}

TorsionSnapshot TorsionalMemory::Snapshot() const {
  return {.contact_radius = radius_,
          .twist = twist_,
          .dissipated_energy = dissipated_,
          .last_step_dissipation = last_dissipation_,
          .pieces = pieces_};
}

Result<TorsionalMemory> TorsionalMemory::Restore(std::shared_ptr<const TorsionBound> bound,
                                                 double torsional_modulus,
                                                 const TorsionSnapshot& snapshot) {
  Result<TorsionalMemory> created =
      Create(std::move(bound), torsional_modulus, snapshot.contact_radius);
  if (!created.ok()) return created.status();
  if (Status s = RequireFinite("contact_radius", snapshot.contact_radius); !s.ok()) return s;
  if (Status s = created->CheckRepresentable(snapshot.contact_radius); !s.ok()) return s;
  if (Status s = RequireFinite("twist", snapshot.twist); !s.ok()) return s;
  if (Status s = RequireNonNegative("dissipated_energy", snapshot.dissipated_energy); !s.ok()) {
    return s;
  }
  if (Status s = RequireNonNegative("last_step_dissipation", snapshot.last_step_dissipation);
      !s.ok()) {
    return s;
  }
  TorsionalMemory memory = std::move(created).value();
  const double radius = snapshot.contact_radius;
  if (snapshot.pieces.empty() != (radius == 0)) {
    return InvalidArgument("pieces",
                           "must cover [0, contact_radius): none exactly when the "
                           "contact radius is 0");
  }
  double start = 0;
  for (std::size_t i = 0; i < snapshot.pieces.size(); ++i) {
    const TorsionPiece& piece = snapshot.pieces[i];
    const std::string field = "pieces[" + std::to_string(i) + "]";
    const bool last = i + 1 == snapshot.pieces.size();
    if (!(piece.end > start) || !(piece.end <= radius) || (last && piece.end != radius)) {
      return InvalidArgument(field + ".end",
                             "must increase from 0 to contact_radius, the last "
                             "equal to it");
    }
    if (piece.sign < -1 || piece.sign > 1) {
      return InvalidArgument(field + ".sign", "must be -1, 0 or +1");
    }
    if (Status s = RequireFinite(field + ".offset", piece.offset); !s.ok()) return s;
    if (piece.sign != 0 && !(piece.radius > 0 && piece.radius <= radius)) {
      return InvalidArgument(field + ".radius",
                             "must be in (0, contact_radius] for a piece on a bound (an exact "
                             "state)");
    }
    if (piece.sign == 0 && piece.radius != 0) {
      return InvalidArgument(field + ".radius", "must be 0 for a constant piece");
    }
    for (double x : {start, piece.end}) {
      if (x == 0) continue;  // the centre's bound is infinite
      // To 1e-9 of the terms of v, plus what a root exact to 1e-15 of the radius moves v - B by
      // (near the edge B is small and steep: more than its round-off).
      const double b = memory.bound_->Bound(x, radius);
      const bool bound_piece = piece.sign != 0;
      const double own = bound_piece ? memory.bound_->Bound(x, piece.radius) : 0;
      // The slopes just inside their contacts (at an edge Slope is that of the outside, 0).
      auto slope_inside = [&](double at) {
        return std::abs(memory.bound_->Slope(std::min(x, std::nextafter(at, 0.0)), at));
      };
      const double steepness =
          slope_inside(radius) + (bound_piece ? slope_inside(piece.radius) : 0);
      const double allowed =
          1e-9 * std::max({b, own, std::abs(piece.offset)}) + 1e-13 * radius * steepness;
      if (!(std::abs(memory.Value(piece, x)) <= b + allowed)) {
        return InvalidArgument(field, "exceeds the bound |v| <= B(x; contact_radius)");
      }
    }
    start = piece.end;
  }
  memory.pieces_ = snapshot.pieces;
  memory.ComputeTails();
  memory.twist_ = snapshot.twist;
  memory.dissipated_ = snapshot.dissipated_energy;
  memory.last_dissipation_ = snapshot.last_step_dissipation;
  return memory;
}

double TorsionalMemory::Value(const TorsionPiece& piece, double x) const {
  return piece.sign == 0 ? piece.offset
                         : piece.sign * bound_->Bound(x, piece.radius) + piece.offset;
}

double TorsionalMemory::Slope(const TorsionPiece& piece, double x) const {
  return piece.sign == 0 ? 0 : piece.sign * bound_->Slope(x, piece.radius);
}

double TorsionalMemory::RadiusAtBound(double value, double radius, double lo, double hi) const {
  const double known = bound_->RadiusAtBound(value, radius);
  // A root below 2^-200 of the piece is the centre's (where the search below starts): the whole
  // piece is beyond the bound (a stick disk below 1e-60 of it is no state: its ends would be
  // subnormal, its moment x^3 below any round-off).
  if (!std::isnan(known)) {
    return lo == 0 && known < std::ldexp(hi, -200) ? lo : std::clamp(known, lo, hi);
  }
  // value - B(x) is nondecreasing in x with slope -B'(x); the centre never slips (B = +inf), so
  // the search starts just above it (never at 0, where hi is at the doubles' resolution).
  const double from =
      lo > 0 ? lo : std::max(std::ldexp(hi, -200), std::numeric_limits<double>::denorm_min());
  auto g = [&](double x) {
    return internal::ValueAndSlope{value - bound_->Bound(x, radius), -bound_->Slope(x, radius)};
  };
  std::vector<double> no_breakpoints;
  const double root = internal::SolveNondecreasing(g, no_breakpoints, from, hi, 0);
  return root == from ? lo : root;
}

// The tails of a step's new points, each computed once: where a clip ends one piece and starts
// the next, both need them. Pure values of (x, a), so a cache changes no bit.
class TailMemo {
 public:
  explicit TailMemo(const TorsionBound& bound) : bound_(bound) {}
  void Add(double x, double a, const TorsionBound::Integrals& tails) {
    entries_[next_] = {x, a, tails};
    next_ = (next_ + 1) % entries_.size();
  }
  TorsionBound::Integrals At(double x, double a) {
    if (x >= a) return {};
    for (const Entry& entry : entries_) {
      if (entry.x == x && entry.a == a) return entry.tails;
    }
    const TorsionBound::Integrals tails = bound_.TailIntegrals(x, a);
    Add(x, a, tails);
    return tails;
  }

 private:
  struct Entry {
    double x = -1, a = -1;
    TorsionBound::Integrals tails;
  };
  const TorsionBound& bound_;
  std::array<Entry, 6> entries_{};
  std::size_t next_ = 0;
};

void TorsionalMemory::Clip(double shift, double radius, bool shrinking,
                           std::vector<TorsionPiece>* out,
                           std::vector<TorsionBound::Integrals>* out_tails,
                           double* dissipation) const {
  out->clear();
  out_tails->clear();
  TailMemo memo(*bound_);
  double integral = 0;  // of x^2 B |slide| (twist) or x^2 (v^2 - B^2) / 2 (shrink)
  double start = 0;
  for (std::size_t index = 0; index < pieces_.size(); ++index) {
    const TorsionPiece& piece = pieces_[index];
    const double end = std::min(piece.end, radius);
    if (end <= start) break;
    if (piece.sign != 0) memo.Add(start, piece.radius, tails_[index]);
    if (index + 1 < pieces_.size() && pieces_[index + 1].sign != 0) {
      memo.Add(piece.end, pieces_[index + 1].radius, tails_[index + 1]);
    }
    TorsionPiece shifted = piece;
    shifted.offset += shift;
    const double c = shifted.offset;
    auto w = [&](double x) { return Value(shifted, x); };
    // Clipped to +B where up(x) = w - B > 0, to -B where down(x) = w + B < 0. Each is monotone
    // on a piece (physics.md), so each region is an end of [start, end).
    double up_lo = 0, up_hi = 0, down_lo = 0, down_hi = 0;
    bool clipped_up = false, clipped_down = false;
    // The outer part of [start, end) where B(x; radius) < value: where a spring at w = value
    // (or -value) is beyond the bound.
    auto outer = [&](double value, double* lo, double* hi) {
      *lo = RadiusAtBound(value, radius, start, end), *hi = end;
      return *hi > *lo;
    };
    // A constant, or a piece on the current bound (w = sign B + c), meets the bound where B is
    // c, c / 2, -c or -c / 2: decided structurally, the radius from the bound's inverse.
    const bool own_bound = piece.sign != 0 && piece.radius == radius;
    if (piece.sign == 0) {
      if (c > 0) clipped_up = outer(c, &up_lo, &up_hi);
      if (c < 0) clipped_down = outer(-c, &down_lo, &down_hi);
    } else if (own_bound) {
      if (piece.sign > 0 && c >= 0) clipped_up = true, up_lo = start, up_hi = end;
      if (piece.sign < 0 && c <= 0) clipped_down = true, down_lo = start, down_hi = end;
      // A piece on the other bound moved back towards this one: only its far side can cross.
      if (piece.sign > 0 && c < 0) clipped_down = outer(-c / 2, &down_lo, &down_hi);
      if (piece.sign < 0 && c > 0) clipped_up = outer(c / 2, &up_lo, &up_hi);
    } else {
      // A piece of an older radius: its difference to the bound is monotone, its root found by
      // a bracketed Newton iteration with the exact slopes.
      auto up = [&](double x) { return w(x) - bound_->Bound(x, radius); };
      auto down = [&](double x) { return w(x) + bound_->Bound(x, radius); };
      auto up_slope = [&](double x) { return Slope(shifted, x) - bound_->Slope(x, radius); };
      auto down_slope = [&](double x) { return Slope(shifted, x) + bound_->Slope(x, radius); };
      // The region [lo, hi) of [start, end) where sign * f > 0, as a root of the monotone f.
      auto region = [&](const auto& f, const auto& slope, int sign, double* lo, double* hi) {
        // Above the centre, where B is infinite: 2^-200 of the piece, and never 0 itself (a
        // piece at the doubles' resolution of the centre underflows it).
        const double from =
            start > 0 ? start
                      : std::max(std::ldexp(end, -200), std::numeric_limits<double>::denorm_min());
        const double f_start = sign * f(from), f_end = sign * f(end);
        if (!(f_start > 0) && !(f_end > 0)) return false;
        if (f_start > 0 && f_end > 0) {
          *lo = start, *hi = end;
          return true;
        }
        const bool rising = f_end > f_start;
        auto g = [&](double x) {
          const double s = rising ? sign : -sign;
          return internal::ValueAndSlope{s * f(x), s * slope(x)};
        };
        std::vector<double> no_breakpoints;
        const double root = internal::SolveNondecreasing(g, no_breakpoints, from, end, 0);
        if (rising) {
          *lo = root, *hi = end;
        } else {
          *lo = start, *hi = root;
        }
        return *hi > *lo;
      };
      clipped_up = region(up, up_slope, +1, &up_lo, &up_hi);
      clipped_down = region(down, down_slope, -1, &down_lo, &down_hi);
    }
    std::array<double, 6> cuts{start, end};
    std::size_t count = 2;
    if (clipped_up) cuts[count++] = up_lo, cuts[count++] = up_hi;
    if (clipped_down) cuts[count++] = down_lo, cuts[count++] = down_hi;
    count = SortedUnique(cuts, count);
    for (std::size_t i = 0; i + 1 < count; ++i) {
      const double lo = cuts[i], hi = cuts[i + 1];
      const bool is_up = clipped_up && lo >= up_lo && hi <= up_hi;
      const bool is_down = clipped_down && lo >= down_lo && hi <= down_hi;
      if (!is_up && !is_down) {
        out->push_back(shifted), out->back().end = hi;
        out_tails->push_back(piece.sign == 0 ? TorsionBound::Integrals{}
                                             : memo.At(lo, piece.radius));
        continue;
      }
      const int sign = is_up ? 1 : -1;
      out->push_back({.end = hi, .sign = static_cast<std::int8_t>(sign), .radius = radius});
      const TorsionBound::Integrals tails = memo.At(lo, radius);
      out_tails->push_back(tails);
      if (shrinking) {
        integral += IntegrateAcross(
            [&](double x) {
              // |v| >= b on a clipped region; the max keeps a root's round-off from making
              // the loss negative.
              const double v = w(x), b = bound_->Bound(x, radius);
              return x * x * std::max(0.0, v * v - b * b) / 2;
            },
            lo, hi, bound_->Breakpoints());
      } else if (piece.sign == 0 || own_bound) {
        // The slide w - sign B = (piece.sign - sign) B + c keeps its sign on the region:
        // integral x^2 B |slide| from the bound's integrals of x^2 B and x^2 B^2.
        const TorsionBound::Integrals beyond = memo.At(hi, radius);
        const double first = tails.first - beyond.first, second = tails.second - beyond.second;
        integral += std::max(0.0, sign * ((piece.sign - sign) * second + c * first));
      } else {
        integral += IntegrateAcross(
            [&](double x) {
              const double b = bound_->Bound(x, radius);
              return x * x * b * std::abs(w(x) - sign * b);
            },
            lo, hi, bound_->Breakpoints());
      }
    }
    start = piece.end;
  }
  *dissipation = 16 * modulus_ * integral;
}

void TorsionalMemory::Merge(std::vector<TorsionPiece>& pieces,
                            std::vector<TorsionBound::Integrals>& tails) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    TorsionPiece piece = pieces[i];
    if (piece.sign == 0) piece.radius = 0;  // a constant has no radius: one spelling per state
    if (kept > 0) {
      TorsionPiece& last = pieces[kept - 1];
      if (last.sign == piece.sign && last.offset == piece.offset && last.radius == piece.radius) {
        last.end = piece.end;
        continue;
      }
    }
    tails[kept] = tails[i];
    pieces[kept++] = piece;
  }
  pieces.resize(kept);
  tails.resize(kept);
}

void TorsionalMemory::ComputeTails() {
  tails_.assign(pieces_.size(), {});
  double start = 0;
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    if (pieces_[i].sign != 0) tails_[i] = bound_->TailIntegrals(start, pieces_[i].radius);
    start = pieces_[i].end;
  }
}

TorsionBound::Integrals TorsionalMemory::PieceIntegrals(std::size_t i) const {
  const TorsionPiece& piece = pieces_[i];
  if (piece.sign == 0) return {};
  // The tails at the end: the next piece's own where it is of the same bound.
  const bool shared =
      i + 1 < pieces_.size() && pieces_[i + 1].sign != 0 && pieces_[i + 1].radius == piece.radius;
  const TorsionBound::Integrals end =
      shared ? tails_[i + 1] : bound_->TailIntegrals(piece.end, piece.radius);
  return {.first = tails_[i].first - end.first, .second = tails_[i].second - end.second};
}

Status TorsionalMemory::Twist(double increment) {
  if (Status s = RequireFinite("twist_increment", increment); !s.ok()) return s;
  const double twist = twist_ + increment;
  if (!std::isfinite(twist)) {
    return InvalidArgument("twist_increment", "takes the twist beyond the finite doubles");
  }
  return ApplyTwist(increment, twist, "twist_increment");
}

Status TorsionalMemory::TwistTo(double angle) {
  if (Status s = RequireFinite("twist", angle); !s.ok()) return s;
  const double increment = angle - twist_;
  if (!std::isfinite(increment)) {
    return InvalidArgument("twist", "is too far from the current twist for a double increment");
  }
  return ApplyTwist(increment, angle, "twist");
}

Status TorsionalMemory::ApplyTwist(double increment, double twist, const char* field) {
  double dissipation = 0;
  Clip(increment, radius_, false, &scratch_, &scratch_tails_, &dissipation);
  if (Status s = CheckDissipation(dissipation, field); !s.ok()) return s;
  Merge(scratch_, scratch_tails_);
  pieces_.swap(scratch_);
  tails_.swap(scratch_tails_);
  twist_ = twist;
  last_dissipation_ = dissipation;
  dissipated_ += dissipation;
  return OkStatus();
}

// A state whose energy is not finite could not be restored from its snapshot (the C fuzzer's
// find: a twist of 1.5e308 rad on a sphere 18 m deep slides its springs through an infinite work).
Status TorsionalMemory::CheckDissipation(double dissipation, const char* field) const {
  if (std::isfinite(dissipated_ + dissipation)) return OkStatus();
  return InvalidArgument(field, "dissipates more energy than the finite doubles hold (" +
                                    FormatNumber(dissipation) + " J after " +
                                    FormatNumber(dissipated_) + " J); take a smaller step");
}

Status TorsionalMemory::TwistToMoment(double target) {
  if (Status s = RequireFinite("moment", target); !s.ok()) return s;
  const double start = Moment();
  if (target == start) return Twist(0);
  const double limit = FullSlipMoment();
  if (!(std::abs(target) < limit)) {
    return FailedPrecondition("moment", "|moment| must be below the full-slip moment " +
                                            std::to_string(limit) + " N m of the contact, got " +
                                            std::to_string(target));
  }
  // g(s) = direction (M(direction s) - target) is nondecreasing in s >= 0, with slope the
  // stiffness of the twisted state in that direction.
  const int direction = target > start ? 1 : -1;
  auto after = [&](double s) {
    TorsionalMemory trial = *this;
    (void)trial.Twist(direction * s);
    return trial;
  };
  auto g = [&](double s) {
    const TorsionalMemory trial = after(s);
    return internal::ValueAndSlope{direction * (trial.Moment() - target),
                                   trial.Stiffness(direction)};
  };
  // Bracket: from the elastic estimate, doubled until the moment passes the target (the twist
  // grows without bound as the target nears the full-slip moment).
  double hi = std::abs(target - start) / Stiffness(direction);
  for (int doubling = 0; g(hi).value < 0; ++doubling) {
    if (doubling == 2000 || !std::isfinite(2 * hi)) {
      return FailedPrecondition("moment",
                                "is too close to the full-slip moment to be reached by "
                                "a finite twist");
    }
    hi *= 2;
  }
  std::vector<double> no_breakpoints;
  const double s = internal::SolveNondecreasing(g, no_breakpoints, 0, hi, 0);
  return Twist(direction * s);
}

Status TorsionalMemory::TwistThroughCompliance(double actuator, double compliance) {
  if (Status s = RequireFinite("actuator", actuator); !s.ok()) return s;
  if (Status s = RequireFinite("compliance", compliance); !s.ok()) return s;
  if (Status s = RequireNonNegative("compliance", compliance); !s.ok()) return s;
  if (compliance == 0) return TwistTo(actuator);
  const double gap = actuator - (twist_ + compliance * Moment());
  if (!std::isfinite(gap)) {
    return InvalidArgument("actuator", "is too far from the current twist for a double increment");
  }
  if (gap == 0) return Twist(0);
  // g(s) = direction (twist + C M - actuator) after a twist of direction s: nondecreasing, with
  // slope 1 + C k >= 1, so the root lies in [0, |gap|].
  const int direction = gap > 0 ? 1 : -1;
  auto g = [&](double s) {
    TorsionalMemory trial = *this;
    (void)trial.Twist(direction * s);
    return internal::ValueAndSlope{
        direction * (trial.twist() + compliance * trial.Moment() - actuator),
        1 + compliance * trial.Stiffness(direction)};
  };
  std::vector<double> no_breakpoints;
  const double s = internal::SolveNondecreasing(g, no_breakpoints, 0, std::abs(gap), 0);
  return Twist(direction * s);
}

Status TorsionalMemory::CheckRepresentable(double contact_radius) const {
  if (contact_radius == 0) return OkStatus();  // unloaded: always allowed
  // A contact so small that its full-slip moment or full-stick stiffness per modulus falls near
  // the subnormal doubles loses the relative precision that |M| <= M_slip needs (the request
  // fuzzer's find: 8.4e-227 N on a steel sphere answered |M| = 1.0000015 M_slip); a physical
  // load is some 10^200 above this floor.
  constexpr double kSmallestFullPrecision =
      std::numeric_limits<double>::min() / std::numeric_limits<double>::epsilon();
  const double cube = contact_radius * contact_radius * contact_radius;
  const double slip_per_modulus = bound_->FullSlipMomentPerModulus(contact_radius);
  if (slip_per_modulus < kSmallestFullPrecision || cube < kSmallestFullPrecision) {
    return InvalidArgument("contact_radius",
                           "the full-slip moment of a contact of radius " +
                               FormatNumber(contact_radius) +
                               " m is too small for the doubles to carry it to full precision; "
                               "take a larger normal load, or unload to 0");
  }
  // A contact so large that its full-stick stiffness 16 G_t a^3 / 3 or its full-slip moment
  // overflows the doubles would answer infinite moments (the request fuzzer's find, a normal
  // force of 2.7e277 N on a steel sphere).
  if (!std::isfinite(16 * modulus_ * cube / 3) || !std::isfinite(modulus_ * slip_per_modulus)) {
    return InvalidArgument("contact_radius",
                           "the stiffness or the full-slip moment of a contact of radius " +
                               FormatNumber(contact_radius) +
                               " m exceeds the finite doubles; take a smaller normal load");
  }
  return OkStatus();
}

Status TorsionalMemory::SetContactRadius(double contact_radius) {
  if (Status s = RequireFinite("contact_radius", contact_radius); !s.ok()) return s;
  if (Status s = RequireNonNegative("contact_radius", contact_radius); !s.ok()) return s;
  if (contact_radius == radius_) {
    last_dissipation_ = 0;
    return OkStatus();
  }
  if (Status s = CheckRepresentable(contact_radius); !s.ok()) return s;
  std::vector<TorsionPiece> next;
  std::vector<TorsionBound::Integrals> next_tails;
  double dissipation = 0;
  if (contact_radius > radius_) {
    next = pieces_;
    next.push_back({.end = contact_radius});
    next_tails = tails_;
    next_tails.push_back({});
  } else {
    Clip(0, contact_radius, true, &next, &next_tails, &dissipation);
    // The springs outside the new radius slide to 0 as their bound vanishes.
    double start = 0;
    double forgotten = 0;
    for (const TorsionPiece& piece : pieces_) {
      const double lo = std::max(start, contact_radius);
      if (piece.end > lo) {
        forgotten += IntegrateAcross(
            [&](double x) {
              const double v = Value(piece, x);
              return x * x * v * v / 2;
            },
            lo, piece.end, bound_->Breakpoints());
      }
      start = piece.end;
    }
    dissipation += 16 * modulus_ * forgotten;
    if (Status s = CheckDissipation(dissipation, "contact_radius"); !s.ok()) return s;
  }
  Merge(next, next_tails);
  for (const TorsionPiece& piece : next) {
    if (piece.sign != 0 && piece.radius > contact_radius) {
      return FailedPrecondition(
          "contact_radius",
          "this normal-load decrease would leave springs on the bound of the larger contact "
          "(Jager's |F| > 1), where the spring model is not guaranteed to be the exact state (a "
          "ring model of the half-space is needed there): lower the load before a twist "
          "reversal, or by enough to wipe the reversal out");
    }
  }
  pieces_ = std::move(next);
  tails_ = std::move(next_tails);
  radius_ = contact_radius;
  last_dissipation_ = dissipation;
  dissipated_ += dissipation;
  return OkStatus();
}

double TorsionalMemory::Moment() const {
  double sum = 0, start = 0;
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    const TorsionPiece& piece = pieces_[i];
    sum += piece.offset * CubeDifference(start, piece.end);
    if (piece.sign != 0) sum += piece.sign * PieceIntegrals(i).first;
    start = piece.end;
  }
  return 16 * modulus_ * sum;
}

double TorsionalMemory::FullSlipMoment() const {
  return modulus_ * bound_->FullSlipMomentPerModulus(radius_);
}

double TorsionalMemory::StoredEnergy() const {
  double sum = 0, start = 0;
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    const TorsionPiece& piece = pieces_[i];
    // integral x^2 (sign B + c)^2 = integral x^2 B^2 + 2 sign c integral x^2 B + c^2 integral x^2
    const double c = piece.offset;
    sum += c * c * CubeDifference(start, piece.end);
    if (piece.sign != 0) {
      const TorsionBound::Integrals parts = PieceIntegrals(i);
      sum += parts.second + 2 * piece.sign * c * parts.first;
    }
    start = piece.end;
  }
  return 8 * modulus_ * std::max(0.0, sum);  // each part exact; a sum below 0 is round-off
}

double TorsionalMemory::Stiffness(int direction) const {
  double sum = 0, start = 0;
  for (const TorsionPiece& piece : pieces_) {
    const bool on_bound = piece.sign == direction && piece.radius == radius_ && piece.offset == 0;
    if (!on_bound) sum += CubeDifference(start, piece.end);
    start = piece.end;
  }
  return 16 * modulus_ * sum;
}

double TorsionalMemory::StickRadius(int direction) const {
  double start = 0;
  for (const TorsionPiece& piece : pieces_) {
    if (piece.sign == direction && piece.radius == radius_ && piece.offset == 0) return start;
    start = piece.end;
  }
  return radius_;
}

std::vector<TorsionSlipInterval> TorsionalMemory::SlipIntervals() const {
  std::vector<TorsionSlipInterval> intervals;
  double start = 0;
  for (const TorsionPiece& piece : pieces_) {
    if (piece.sign != 0 && piece.radius == radius_ && piece.offset == 0) {
      intervals.push_back({.start = start, .end = piece.end, .sign = piece.sign});
    }
    start = piece.end;
  }
  return intervals;
}

double TorsionalMemory::SpringDisplacement(double x) const {
  if (!(x >= 0) || x >= radius_) return 0;
  for (const TorsionPiece& piece : pieces_) {
    if (x < piece.end) return Value(piece, x);
  }
  return 0;
}

TorsionTraction TorsionalMemory::Traction(double r) const {
  if (!(r > 0) || r >= radius_) return {};
  // integral_lo^hi B'(x; radius) / sqrt(x^2 - r^2) dx over lo >= r, in s = sqrt(x^2 - r^2)
  // (dx / sqrt(x^2 - r^2) = ds / x): smooth in s, on the scale r near s = 0.
  auto abel = [&](double radius, double lo, double hi) {
    if (!(hi > lo)) return 0.0;
    auto integrand = [&](double s) {
      const double x = std::sqrt(r * r + s * s);
      return bound_->Slope(x, radius) / x;
    };
    // [0, r] in s: two 16-point intervals; beyond r, intervals a factor 2 apart (Integrate).
    double sum = 0;
    internal::ForEachAbelInterval(
        r, std::sqrt((lo - r) * (lo + r)), std::sqrt((hi - r) * (hi + r)), [&](double a, double b) {
          sum += a >= r ? Integrate(integrand, a, b)
                        : Gauss16(integrand, a, (a + b) / 2) + Gauss16(integrand, (a + b) / 2, b);
        });
    return sum;
  };
  double first = 0, second = 0, start = 0;
  for (const TorsionPiece& piece : pieces_) {
    const double lo = std::max(start, r), hi = piece.end;
    start = piece.end;
    if (piece.sign == 0 || hi <= lo) continue;
    first += piece.sign * abel(piece.radius, lo, hi);
    // The whole of [r, a_k) is -(pi / (4 r)) mu p(r; a_k) / G_t; the rest of it is subtracted.
    const double whole = -(kPi / (4 * r)) * bound_->SlidingTractionPerModulus(r, piece.radius);
    second +=
        piece.sign * (whole - abel(piece.radius, hi, piece.radius) - abel(piece.radius, r, lo));
  }
  const double factor = -(4 * modulus_ / kPi) * r;
  return {.value = factor * first, .route_difference = std::abs(factor * (first - second))};
}

bool TorsionalMemory::IsExact() const {
  return std::all_of(pieces_.begin(), pieces_.end(), [&](const TorsionPiece& piece) {
    return piece.sign == 0 || piece.radius <= radius_;
  });
}

Result<TorsionalContact> TorsionalContact::Create(ProfilePtr profile, double friction,
                                                  double effective_modulus,
                                                  double torsional_modulus) {
  if (profile == nullptr) return InvalidArgument("profile", "required");
  Result<std::shared_ptr<const TorsionBound>> bound =
      MakeTorsionBound(profile, friction, effective_modulus, torsional_modulus);
  if (!bound.ok()) return bound.status();
  Result<TorsionalMemory> memory = TorsionalMemory::Create(*bound, torsional_modulus, 0);
  if (!memory.ok()) return memory.status();
  return TorsionalContact(std::move(profile), effective_modulus, std::move(memory).value());
}

Result<TorsionalContact> TorsionalContact::Restore(ProfilePtr profile, double friction,
                                                   double effective_modulus,
                                                   double torsional_modulus, double depth,
                                                   const TorsionSnapshot& memory) {
  if (profile == nullptr) return InvalidArgument("profile", "required");
  if (Status s = RequireFinite("depth", depth); !s.ok()) return s;
  const double radius = profile->RadiusAtDepth(depth);
  if (!SameBits(memory.contact_radius, radius)) {
    // Every digit: the two may differ in the last bit only.
    std::ostringstream message;
    message.precision(17);
    message << "must be exactly the profile's contact radius at the depth, " << radius << " m, got "
            << memory.contact_radius;
    return InvalidArgument("contact_radius", message.str());
  }
  Result<std::shared_ptr<const TorsionBound>> bound =
      MakeTorsionBound(profile, friction, effective_modulus, torsional_modulus);
  if (!bound.ok()) return bound.status();
  Result<TorsionalMemory> restored = TorsionalMemory::Restore(*bound, torsional_modulus, memory);
  if (!restored.ok()) return restored.status();
  TorsionalContact contact(std::move(profile), effective_modulus, std::move(restored).value());
  contact.depth_ = depth;
  return contact;
}

double TorsionalContact::normal_force() const {
  return effective_modulus_ * profile_->NormalForcePerModulus(depth_);
}

Result<double> TorsionalContact::TargetDepth(NormalControl control, double value) const {
  if (Status s = RequireFinite("normal_value", value); !s.ok()) return s;
  switch (control) {
    case NormalControl::kDepth:
      return value;
    case NormalControl::kDepthIncrement: {
      const double depth = depth_ + value;
      if (!std::isfinite(depth)) {
        return InvalidArgument("normal_value", "takes the depth beyond the finite doubles");
      }
      return depth;
    }
    case NormalControl::kForce:
      if (Status s = RequireNonNegative("normal_value", value); !s.ok()) return s;
      return profile_->DepthAtNormalForcePerModulus(value / effective_modulus_);
  }
  return InvalidArgument("normal_value", "has an unknown control");
}

Status TorsionalContact::Apply(const TorsionStep& step) {
  if (step.normal && step.twist) {
    return InvalidArgument("step",
                           "moves both the normal load and the twist: a simultaneous ramp has no "
                           "exact finite memory; apply the normal step and the twist as two steps");
  }
  // The memory's errors belong to the step's value of the channel that moved.
  auto as_field = [](const Status& s, const char* field) {
    return s.ok() ? s : Status(s.code(), field, s.message());
  };
  if (step.normal) {
    Result<double> depth = TargetDepth(*step.normal, step.normal_value);
    if (!depth.ok()) return depth.status();
    const Status s = memory_.SetContactRadius(profile_->RadiusAtDepth(*depth));
    if (!s.ok()) return as_field(s, "normal_value");
    depth_ = *depth;
    return OkStatus();
  }
  if (!step.twist) return memory_.Twist(0);
  switch (*step.twist) {
    case TwistControl::kAngle:
      return as_field(memory_.TwistTo(step.twist_value), "twist_value");
    case TwistControl::kAngleIncrement:
      return as_field(memory_.Twist(step.twist_value), "twist_value");
    case TwistControl::kMoment:
      return as_field(memory_.TwistToMoment(step.twist_value), "twist_value");
  }
  return InvalidArgument("twist_value", "has an unknown control");
}

}  // namespace mdr
