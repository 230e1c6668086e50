#include "mdr/core/profile.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <unordered_map>

#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::kInf;
using internal::kPi;

// f = C r^n maps to g = k x^n (docs/physics.md, "Power law").
double PowerLawScale(double coefficient, double exponent) {
  return coefficient * std::sqrt(kPi) * std::tgamma(exponent / 2 + 1) /
         std::tgamma(exponent / 2 + 0.5);
}

// integral_0^S (r^2 + s^2)^beta ds by adaptive Gauss-Kronrod; the integrand is smooth for r > 0
// but peaks in a layer of width r at s = 0 when beta < 0 (ForEachAbelInterval).
double IntegratePowerOfHypotenuse(double r, double span, double beta) {
  const double r2 = r * r;
  auto integrand = [&](double s) { return std::pow(r2 + s * s, beta); };
  internal::Quadrature quadrature(256);
  double total = 0, error = 0;
  internal::ForEachAbelInterval(r, 0.0, span, [&](double lo, double hi) {
    quadrature.AddWithRule(integrand, lo, hi, 0, 1e-13, GSL_INTEG_GAUSS31, &total, &error);
  });
  return total;
}

// Bytes of a string's buffer outside the object (none within the small-string buffer).
std::size_t HeapBytes(const std::string& text) {
  return text.capacity() > std::string().capacity() ? text.capacity() + 1 : 0;
}

// g = k x^n for any exponent (pow); n = 2 and n = 1 have their own classes below.
class PowerLawProfile final : public Profile {
 public:
  PowerLawProfile(double scale, double exponent, std::string name)
      : n_(exponent), k_(scale), name_(std::move(name)) {}

  double G(double x) const override { return k_ * std::pow(x, n_); }
  double Slope(double x) const override {
    if (x == 0) return n_ < 1 ? kInf : (n_ == 1 ? k_ : 0.0);
    return n_ * k_ * std::pow(x, n_ - 1);
  }
  double RadiusAtDepth(double z) const override { return z > 0 ? std::pow(z / k_, 1 / n_) : 0; }
  std::optional<PowerLawForm> AsPowerLaw() const override { return PowerLawForm{k_, n_}; }
  double Rise(double x, double x_ref) const override {
    if (!(x_ref > 0)) return G(x);
    return G(x_ref) * std::expm1(n_ * std::log1p((x - x_ref) / x_ref));
  }
  double Moment(int j, double x) const override {
    // integral_0^x (k t^n)^j dt = x g(x)^j / (j n + 1).
    return x * std::pow(G(x), j) / (j * n_ + 1);
  }
  double PressurePerModulus(double r, double depth) const override {
    const double a = RadiusAtDepth(depth);
    if (!(r < a)) return 0;
    // Substituting x = sqrt(r^2 + s^2): p/E* = (n k / pi) integral_0^S (r^2+s^2)^((n-2)/2) ds.
    const double span = std::sqrt((a - r) * (a + r));
    if (r == 0) return n_ < 1 ? kInf : n_ * k_ / kPi * std::pow(a, n_ - 1) / (n_ - 1);
    return n_ * k_ / kPi * IntegratePowerOfHypotenuse(r, span, (n_ - 2) / 2);
  }
  double DepthAtNormalForcePerModulus(double f) const override {
    if (!(f > 0)) return 0;
    // F_N/E* = 2 n/(n+1) a z with z = k a^n.
    const double a = std::pow(f * (n_ + 1) / (2 * n_ * k_), 1 / (n_ + 1));
    return G(a);
  }
  std::string Describe() const override { return name_; }
  std::size_t MemoryBytes() const override { return sizeof(*this) + HeapBytes(name_); }

 private:
  double n_, k_;
  std::string name_;
};

// A sphere's name, from its radius when asked: 8 bytes instead of a string (a rough surface has
// a sphere per summit).
struct SphereName {
  double radius;
};
std::string Describe(const SphereName& sphere) {
  std::ostringstream name;
  name << "sphere R = " << sphere.radius << " m";
  return name.str();
}
std::string Describe(const std::string& name) { return name; }
std::size_t HeapBytes(const SphereName&) { return 0; }

// g = k x^2 (sphere, power law n = 2): x = sqrt(z/k), no pow anywhere.
template <typename Name>
class ParabolicProfile final : public Profile {
 public:
  ParabolicProfile(double scale, Name name)
      : k_(scale), inverse_k_(1 / scale), name_(std::move(name)) {}

  double G(double x) const override { return k_ * (x * x); }
  double Slope(double x) const override { return 2 * k_ * x; }
  // z * (1/k): a product instead of a division per vertex and query; x within 1.25 ulp.
  double RadiusAtDepth(double z) const override { return z > 0 ? std::sqrt(z * inverse_k_) : 0; }
  std::optional<PowerLawForm> AsPowerLaw() const override { return PowerLawForm{k_, 2}; }
  double Rise(double x, double x_ref) const override { return k_ * ((x - x_ref) * (x + x_ref)); }
  double Moment(int j, double x) const override {
    // integral_0^x (k t^2)^j dt = x g(x)^j / (2 j + 1).
    const double g = G(x);
    const double g_power = j == 0 ? 1.0 : (j == 1 ? g : g * g);
    return x * g_power / (2 * j + 1);
  }
  PieceIntegrals IntegratePiece(double za, double zb, double xa, double xb,
                                bool with_square) const override {
    // xb = 0 < zb: zb * (1/k) underflowed (a depth of a few subnormals), a piece of no width in x
    // (1 / (xa + xb) would be inf and the integrals NaN).
    if (!(zb > za) || !(xb > 0)) return {};
    // With s = 1 / (xa + xb), d = xb - xa = (zb - za) s / k (no cancellation) and y = x - xa:
    // t = k (2 xa y + y^2) / (zb - za) = s (2 xa y + y^2) / d, so every term below is positive.
    const double s = 1 / (xa + xb), d = (zb - za) * s * inverse_k_;
    PieceIntegrals result{d, d * s * (xa + d / 3), 0};
    if (with_square) result.j2 = d * (s * s) * (4.0 / 3 * xa * xa + xa * d + d * d / 5);
    return result;
  }
  double PressurePerModulus(double r, double depth) const override {
    const double a = RadiusAtDepth(depth);
    if (!(r < a)) return 0;
    return 2 * k_ / kPi * std::sqrt((a - r) * (a + r));
  }
  double DepthAtNormalForcePerModulus(double f) const override {
    if (!(f > 0)) return 0;
    // F_N/E* = (4/3) a z with z = k a^2. pow rather than cbrt: the depth at a force stays the
    // same double as before the parabolic class (8 ulps apart), so recorded histories replay.
    return G(std::pow(f * 3 / (4 * k_), 1.0 / 3));
  }
  std::string Describe() const override { return mdr::Describe(name_); }
  std::size_t MemoryBytes() const override { return sizeof(*this) + HeapBytes(name_); }

 private:
  double k_, inverse_k_;
  Name name_;
};
using SphereProfile = ParabolicProfile<SphereName>;

// g = k x (cone, power law n = 1): x = z/k.
class ConicalProfile final : public Profile {
 public:
  ConicalProfile(double scale, std::string name) : k_(scale), name_(std::move(name)) {}

  double G(double x) const override { return k_ * x; }
  double Slope(double) const override { return k_; }
  double RadiusAtDepth(double z) const override { return z > 0 ? z / k_ : 0; }
  std::optional<PowerLawForm> AsPowerLaw() const override { return PowerLawForm{k_, 1}; }
  double Rise(double x, double x_ref) const override { return k_ * (x - x_ref); }
  double Moment(int j, double x) const override {
    // integral_0^x (k t)^j dt = x g(x)^j / (j + 1).
    const double g = G(x);
    const double g_power = j == 0 ? 1.0 : (j == 1 ? g : g * g);
    return x * g_power / (j + 1);
  }
  PieceIntegrals IntegratePiece(double za, double zb, double, double,
                                bool with_square) const override {
    if (!(zb > za)) return {};
    // t is linear in x: J_m = (xb - xa) / (m + 1), xb - xa = (zb - za) / k.
    const double j0 = (zb - za) / k_;
    return {j0, j0 / 2, with_square ? j0 / 3 : 0.0};
  }
  double PressurePerModulus(double r, double depth) const override {
    const double a = RadiusAtDepth(depth);
    if (!(r < a)) return 0;
    return r == 0 ? kInf : k_ / kPi * std::acosh(a / r);
  }
  double DepthAtNormalForcePerModulus(double f) const override {
    if (!(f > 0)) return 0;
    return G(std::sqrt(f / k_));  // F_N/E* = a z with z = k a
  }
  std::string Describe() const override { return name_; }
  std::size_t MemoryBytes() const override { return sizeof(*this) + HeapBytes(name_); }

 private:
  double k_;
  std::string name_;
};

// g = k x^n by the class that evaluates it most cheaply.
ProfilePtr MakeScaledPowerLaw(double scale, double exponent, std::string name) {
  if (exponent == 2) {
    return std::make_shared<ParabolicProfile<std::string>>(scale, std::move(name));
  }
  if (exponent == 1) return std::make_shared<ConicalProfile>(scale, std::move(name));
  return std::make_shared<PowerLawProfile>(scale, exponent, std::move(name));
}

class FlatPunchProfile final : public Profile {
 public:
  explicit FlatPunchProfile(double radius) : a0_(radius) {}

  double G(double x) const override { return x < a0_ ? 0 : kInf; }
  double Slope(double x) const override { return x < a0_ ? 0 : kInf; }
  double RadiusAtDepth(double) const override { return a0_; }
  double Moment(int j, double x) const override { return j == 0 ? x : 0.0; }
  double PressurePerModulus(double r, double depth) const override {
    if (!(r < a0_) || depth <= 0) return 0;
    return depth / (kPi * std::sqrt((a0_ - r) * (a0_ + r)));
  }
  double DepthAtNormalForcePerModulus(double f) const override { return f > 0 ? f / (2 * a0_) : 0; }
  std::string Describe() const override {
    std::ostringstream out;
    out << "flat punch a0 = " << a0_ << " m";
    return out.str();
  }
  std::size_t MemoryBytes() const override { return sizeof(*this); }

 private:
  double a0_;
};

std::string PowerLawName(double coefficient, double exponent) {
  std::ostringstream out;
  out.precision(10);
  out << "power law f = " << coefficient << " r^" << exponent;
  return out.str();
}

}  // namespace

double Profile::NormalForcePerModulus(double depth) const {
  if (!(depth > 0)) return 0;
  const double a = RadiusAtDepth(depth);
  return 2 * (depth * a - Moment(1, a));
}

PieceIntegrals Profile::IntegratePiece(double za, double zb, double xa, double xb,
                                       bool with_square) const {
  if (!(xb > xa) || !(zb > za)) return {};
  // The shifted moments I_m = integral (g - za)^m dx = (zb - za)^m J_m lose a factor
  // za/(zb - za) (I_1) or its square (I_2) to round-off, so thin pieces are integrated by 16-point
  // Gauss-Legendre in x with g - za from Rise, exact to round-off there. (Differences of moments
  // also lose a/(xb - xa); the thresholds keep the total loss near 1e2..1e3 eps.)
  const double width = zb - za;
  if (za > (with_square ? 4 : 1e3) * width) {
    static const internal::GaussLegendreRule rule(16);
    const double centre = 0.5 * (xa + xb), half = 0.5 * (xb - xa);
    PieceIntegrals sum;
    for (std::size_t i = 0; i < rule.size; ++i) {
      const double x = centre + half * rule.nodes[i], w = half * rule.weights[i];
      const double t = Rise(x, xa) / width;
      sum.j0 += w;
      sum.j1 += w * t;
      sum.j2 += w * t * t;
    }
    if (!with_square) sum.j2 = 0;
    return sum;
  }
  const double d0 = xb - xa;
  const double d1 = Moment(1, xb) - Moment(1, xa);
  PieceIntegrals result{d0, (d1 - za * d0) / width, 0};
  if (with_square) {
    const double d2 = Moment(2, xb) - Moment(2, xa);
    result.j2 = (d2 - 2 * za * d1 + za * za * d0) / (width * width);
  }
  return result;
}

Result<ProfilePtr> MakePowerLaw(double coefficient, double exponent) {
  if (Status s = RequireSceneScale("coefficient", coefficient); !s.ok()) return s;
  if (Status s = RequireInRange("exponent", exponent, 0.3, 10); !s.ok()) return s;
  return MakeScaledPowerLaw(PowerLawScale(coefficient, exponent), exponent,
                            PowerLawName(coefficient, exponent));
}

double SphereScale(double radius) { return PowerLawScale(1 / (2 * radius), 2.0); }

Result<ProfilePtr> MakeSphere(double radius) {
  if (Status s = RequireSceneScale("radius", radius); !s.ok()) return s;
  return ProfilePtr(std::make_shared<SphereProfile>(SphereScale(radius), SphereName{radius}));
}

Result<std::vector<ProfilePtr>> MakeSpheres(std::span<const double> radii) {
  std::unordered_map<double, std::size_t> sphere_of_radius;  // index into the distinct radii
  std::vector<double> distinct;
  std::vector<std::size_t> sphere_of(radii.size());
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const auto [it, added] = sphere_of_radius.try_emplace(radii[i], distinct.size());
    if (added) {
      if (Status s = RequireSceneScale("radius", radii[i]); !s.ok()) {
        return s.WithFieldPrefix(Indexed("radii", i));
      }
      distinct.push_back(radii[i]);
    }
    sphere_of[i] = it->second;
  }
  auto pool = std::make_shared<std::vector<SphereProfile>>();
  pool->reserve(distinct.size());  // never reallocated: the pointers below stay valid
  for (double radius : distinct) pool->emplace_back(SphereScale(radius), SphereName{radius});
  std::vector<ProfilePtr> spheres;
  spheres.reserve(radii.size());
  for (std::size_t k : sphere_of) spheres.emplace_back(pool, &(*pool)[k]);
  return spheres;
}

Result<ProfilePtr> MakeCone(double slope_angle) {
  // tan(theta) is the profile's scale, as a radius is a sphere's; it is finite below pi/2.
  if (!(slope_angle >= kMinSceneScale && slope_angle < kPi / 2)) {
    return InvalidArgument("slope_angle", "must be in [" + FormatNumber(kMinSceneScale) +
                                              ", pi/2) rad, got " + FormatNumber(slope_angle));
  }
  std::ostringstream name;
  name << "cone slope " << slope_angle << " rad";
  return MakeScaledPowerLaw(PowerLawScale(std::tan(slope_angle), 1.0), 1.0, name.str());
}

Result<ProfilePtr> MakeFlatPunch(double radius) {
  if (Status s = RequireSceneScale("radius", radius); !s.ok()) return s;
  return ProfilePtr(std::make_shared<FlatPunchProfile>(radius));
}

}  // namespace mdr
