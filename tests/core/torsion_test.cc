// The exact torsional memory (torsion.h) against the torsion reference values (closed forms and
// an independent ring model of the half-space; docs/physics.md, "Torsion"): the virgin curve,
// the stiffness and the full-slip moment, Masing's rule, the loss per cycle, normal-load changes
// that stay exact, the decrease that would not (refused, nothing changed), and random histories.
#include "mdr/core/torsion.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>
#include <gsl/gsl_sf_ellint.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

#include "mdr/core/material.h"
#include "mdr/core/profile.h"
#include "mdr/core/tabulated_profile.h"

namespace mdr {
namespace {

constexpr double kPi = std::numbers::pi;

// The reference units: G = 1, nu = 0 (E* = 2, G_t = 1), mu = 1, R = 1, a = 1; F_N = 8/3 and the
// full-slip moment M_slip = 3 pi mu F_N a / 16 = pi / 2.
constexpr double kSlipMoment = kPi / 2;

std::shared_ptr<const TorsionBound> UnitHertz() { return *MakeHertzTorsionBound(1, 2, 1, 1); }
TorsionalMemory UnitMemory(double radius = 1) {
  return *TorsionalMemory::Create(UnitHertz(), 1, radius);
}

void ExpectRelative(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected)) << "expected " << expected;
}

struct VirginPoint {
  double stick_radius, twist, moment_over_slip;
};

TEST(TorsionTest, TheVirginCurveIsTheReferences) {
  const VirginPoint points[] = {{0.9, 0.1027036775, 0.2993732176},
                                {0.7, 0.3291633346, 0.6955936469},
                                {0.5, 0.6018982880, 0.8973384290},
                                {0.3, 0.9748531930, 0.9793216052},
                                {0.1, 1.705914237, 0.9992721527}};
  for (const VirginPoint& point : points) {
    SCOPED_TRACE(point.stick_radius);
    const double twist = UnitHertz()->Bound(point.stick_radius, 1);
    ExpectRelative(twist, point.twist, 1e-9);
    TorsionalMemory memory = UnitMemory();
    ASSERT_TRUE(memory.Twist(twist).ok());
    ExpectRelative(memory.StickRadius(+1), point.stick_radius, 1e-13);
    ExpectRelative(memory.Moment() / kSlipMoment, point.moment_over_slip, 1e-9);
    EXPECT_TRUE(memory.IsExact());
    // The stick disk turns rigidly; the outer annulus slides: stiffness 16 G_t c^3 / 3.
    ExpectRelative(memory.Stiffness(+1), 16 * std::pow(point.stick_radius, 3) / 3, 1e-13);
    ExpectRelative(memory.Stiffness(-1), 16.0 / 3, 1e-15);
    ASSERT_EQ(memory.SlipIntervals().size(), 1u);
    EXPECT_EQ(memory.SlipIntervals()[0].sign, 1);
    EXPECT_EQ(memory.SlipIntervals()[0].end, 1);
  }
}

TEST(TorsionTest, TheHertzBoundIsKMinusEToRoundOff) {
  // B = (2/pi) (K(m) - E(m)) and B' = -(2/pi) E(m) / x in the reference units, m = 1 - x^2, from
  // 30-digit arithmetic (mpmath), near the centre, inside and at the edge.
  struct Value {
    double x, bound, slope;
  };
  const Value values[] = {{1e-8, 11.97289221031386842, -63661977.23675819576},
                          {0.01, 3.177569665101504734, -63.67945769720861372},
                          {0.3, 0.9748531929767253211, -2.326797558428034705},
                          {0.5, 0.6018982880233301465, -1.541964425190040036},
                          {0.9, 0.1027036775165470703, -1.056286676352500054},
                          {0.999, 0.001000250187648559674, -1.000500563094360972}};
  for (const Value& v : values) {
    SCOPED_TRACE(v.x);
    ExpectRelative(UnitHertz()->Bound(v.x, 1), v.bound, 2e-15);
    ExpectRelative(UnitHertz()->Slope(v.x, 1), v.slope, 2e-15);
  }
}

// The Hertz bound reads h = K - E, its slope, its inverse and the tails of x^2 B and x^2 B^2 off
// the universal function's Chebyshev tables; GSL's Carlson integrals and adaptive quadrature are
// the independent reference, over the centre (down to 1e-300 of the radius), the middle and the
// edge (down to 1e-15 of the radius from it). In the reference units B = (2/pi) h(x).
TEST(TorsionTest, TheHertzTablesAreTheEllipticIntegralsToRoundOff) {
  const auto bound = UnitHertz();
  auto gsl_h = [](double x) {  // (m / 3) R_D(0, 1 - m, 1), m = 1 - x^2, exact at both ends
    const double m = (1 - x) * (1 + x);
    return m / 3 * gsl_sf_ellint_RD(0, x * x, 1, GSL_PREC_DOUBLE);
  };
  auto gsl_e = [](double x) {
    const double m = (1 - x) * (1 + x);
    return gsl_sf_ellint_RF(0, x * x, 1, GSL_PREC_DOUBLE) -
           m / 3 * gsl_sf_ellint_RD(0, x * x, 1, GSL_PREC_DOUBLE);
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst_bound = 0, worst_slope = 0, worst_inverse = 0;
  for (int i = 0; i < 30000; ++i) {
    // A third each: uniform, log-uniform towards the centre, log-uniform towards the edge.
    const double u = unit(rng);
    const double x = i % 3 == 0   ? u
                     : i % 3 == 1 ? std::pow(10.0, -300 * u)
                                  : 1 - std::pow(10.0, -15 * u);
    if (!(x > 0 && x < 1)) continue;
    // Below 1e-100 GSL's R_D refuses x^2: h = ln(4 / x) - 1 there to far below round-off (the
    // next term is of order x^2 ln x). GSL's E = R_F - (m/3) R_D cancels ln(4 / x) near the
    // centre, so below 1e-3 E is its expansion 1 + (x^2/2)(L - 1/2) + (3 x^4/16)(L - 13/12),
    // L = ln(4 / x), whose next term is below 1e-17.
    const double h = x < 1e-100 ? std::log(4 / x) - 1 : gsl_h(x);
    const double l = std::log(4 / x);
    const double e =
        x < 1e-3 ? 1 + x * x / 2 * (l - 0.5) + 3 * std::pow(x, 4) / 16 * (l - 13.0 / 12) : gsl_e(x);
    worst_bound = std::max(worst_bound, std::abs(bound->Bound(x, 1) / (2 / kPi * h) - 1));
    // GSL's E from 1e-3 on still cancels a term of the size of L: allowed for.
    worst_slope = std::max(
        worst_slope, std::abs(bound->Slope(x, 1) / (-2 / kPi * e / x) - 1) / std::max(1.0, l));
    // The inverse, relative in x towards the centre and in 1 - x towards the edge; h's own
    // round-off moves the root by (dh / h) h / E relative in x, which the tolerance allows.
    const double back = bound->RadiusAtBound(bound->Bound(x, 1), 1);
    const double error = x > 0.5 ? std::abs((1 - back) / (1 - x) - 1) : std::abs(back / x - 1);
    worst_inverse = std::max(worst_inverse, error / std::max(1.0, h));
  }
  EXPECT_LT(worst_bound, 2e-15);
  EXPECT_LT(worst_slope, 2e-15);
  EXPECT_LT(worst_inverse, 1e-14);
  // The tails against GSL's QAGS of the same integrands (GSL's own Carlson integrals inside).
  gsl_set_error_handler_off();
  gsl_integration_workspace* workspace = gsl_integration_workspace_alloc(200);
  for (double x : {0.0, 1e-12, 1e-6, 0.003, 0.2, 0.5, 0.77, 0.95, 0.999, 1 - 1e-9}) {
    SCOPED_TRACE(x);
    double expected[2] = {0, 0};
    for (int power : {1, 2}) {
      // In w = 1 - v, from the edge: v near 1 would resolve m = 1 - v^2 to eps / m only.
      auto integrand = [](double w, void* data) {
        const int k = *static_cast<int*>(data);
        const double v = 1 - w;
        if (v <= 1e-100) return 0.0;  // v^2 B below 1e-197, and v^2 would underflow in R_D
        const double m = w * (2 - w);
        const double b = 2 / kPi * m / 3 * gsl_sf_ellint_RD(0, v * v, 1, GSL_PREC_DOUBLE);
        return v * v * (k == 1 ? b : b * b);
      };
      gsl_function f{integrand, &power};
      double error = 0;
      // 2e-14 relative (QAGS takes no less than 50 eps) may be more than round-off lets GSL
      // prove (GSL_EROUND); its estimate must then still be below the comparison's tolerance.
      const int status = gsl_integration_qags(&f, 0, 1 - x, 0, 2e-14, 200, workspace,
                                              &expected[power - 1], &error);
      EXPECT_TRUE(status == GSL_SUCCESS || status == GSL_EROUND) << status;
      EXPECT_LE(error, 1e-13 * expected[power - 1] + 1e-300);
    }
    const TorsionBound::Integrals tails = bound->TailIntegrals(x, 1);
    ExpectRelative(tails.first, expected[0], 1e-13);
    ExpectRelative(tails.second, expected[1], 1e-13);
  }
  gsl_integration_workspace_free(workspace);
  // The whole: integral_0^1 x^2 B dx = (2/pi) pi^2 / 64, so 16 G_t of it is M_slip = pi / 2.
  ExpectRelative(bound->TailIntegrals(0, 1).first, kPi / 32, 2e-16);
  EXPECT_EQ(bound->TailIntegrals(1, 1).first, 0);
  EXPECT_EQ(bound->TailIntegrals(2, 1).second, 0);
  // A scale: every radius maps to the same function.
  ExpectRelative(bound->TailIntegrals(3e-5, 1e-4).first,
                 std::pow(1e-4, 4) * bound->TailIntegrals(0.3, 1).first, 1e-15);
  EXPECT_TRUE(std::isnan(MakePowerLawTorsionBound(1, 2, 1, 1, 1).value()->RadiusAtBound(1, 1)));
}

TEST(TorsionTest, PowerLawsGiveTheReferences) {
  struct Case {
    double exponent;
    VirginPoint points[5];
  };
  const Case cases[] = {
      {1,
       {{0.9, 0.05407988336, 0.2358207552},
        {0.7, 0.1946903750, 0.5997585839},
        {0.5, 0.4097797360, 0.8334750372},
        {0.3, 0.7984051816, 0.9569796158},
        {0.1, 1.902682350, 0.9978241277}}},
      {2,
       {{0.9, 0.1027036775, 0.2993732176},
        {0.7, 0.3291633346, 0.6955936469},
        {0.5, 0.6018982880, 0.8973384290},
        {0.3, 0.9748531930, 0.9793216052},
        {0.1, 1.705914237, 0.9992721527}}},
      {4,
       {{0.9, 0.1857202297, 0.4082047175},
        {0.7, 0.4852962919, 0.8116977452},
        {0.5, 0.7251371838, 0.9488842044},
        {0.3, 0.9712143601, 0.9903675061},
        {0.1, 1.429450694, 0.9996441609}}},
  };
  for (const Case& c : cases) {
    // M_slip = pi (n+1)/(4 (n+2)) mu F_N a = pi n / (n+2) in the reference units.
    const double slip_moment = kPi * c.exponent / (c.exponent + 2);
    auto bound = *MakePowerLawTorsionBound(1, 2, 1, 1, c.exponent);
    for (const VirginPoint& point : c.points) {
      SCOPED_TRACE(testing::Message() << "n = " << c.exponent << ", c = " << point.stick_radius);
      const double twist = bound->Bound(point.stick_radius, 1);
      ExpectRelative(twist, point.twist, 1e-9);
      // The slope is the bound's derivative (central difference, h = 1e-5).
      const double h = 1e-5, x = point.stick_radius;
      ExpectRelative(bound->Slope(x, 1),
                     (bound->Bound(x + h, 1) - bound->Bound(x - h, 1)) / (2 * h), 1e-8);
      TorsionalMemory memory = *TorsionalMemory::Create(bound, 1, 1);
      ASSERT_TRUE(memory.Twist(twist).ok());
      ExpectRelative(memory.StickRadius(+1), point.stick_radius, 1e-12);
      ExpectRelative(memory.Moment() / slip_moment, point.moment_over_slip, 1e-9);
    }
  }
  // n = 2 is Hertz: the quadrature equals the closed form to round-off, at every scale.
  auto power = *MakePowerLawTorsionBound(0.3, 1.2e11, 4e10, 100, 2);
  auto hertz = *MakeHertzTorsionBound(0.3, 1.2e11, 4e10, 0.01);
  for (double x : {1e-9, 1e-6, 3e-5, 9.9e-5, 9.99999e-5}) {
    ExpectRelative(power->Bound(x, 1e-4), hertz->Bound(x, 1e-4), 1e-13);
    ExpectRelative(power->Slope(x, 1e-4), hertz->Slope(x, 1e-4), 1e-13);
  }
  EXPECT_EQ(MakePowerLawTorsionBound(1, 2, 1, 1, 0.2).status().field(), "exponent");
  EXPECT_EQ(MakePowerLawTorsionBound(1, 2, 1, 0, 2).status().field(), "coefficient");
}

TEST(TorsionTest, SteelOnSteelGivesTheReferenceStiffnessAndMoments) {
  // Test vector H1: steel sphere R = 10 mm on a steel flat, mu = 0.3, F_N = 100 N.
  const double young = 210e9, poisson = 0.3, radius = 0.01, friction = 0.3;
  const double effective_modulus = young / (2 * (1 - poisson * poisson));
  const double torsional_modulus = young / (2 * (1 + poisson)) / 2;
  const double contact_radius = 1.8662555784e-4;
  auto bound = *MakeHertzTorsionBound(friction, effective_modulus, torsional_modulus, radius);
  TorsionalMemory memory = *TorsionalMemory::Create(bound, torsional_modulus, contact_radius);
  ExpectRelative(memory.Stiffness(+1), 1.4, 1e-9);
  const double twist = bound->Bound(contact_radius / 2, contact_radius);
  ExpectRelative(twist, 4.8141258757e-3, 1e-9);
  ASSERT_TRUE(memory.Twist(twist).ok());
  ExpectRelative(memory.Moment(), 2.9593735330e-3, 1e-9);
  // Deep in full slip the moment tends to M_slip = 3 pi mu F_N a / 16 (logarithmically).
  ASSERT_TRUE(memory.Twist(1e3 * twist).ok());
  EXPECT_LT(memory.Moment(), 3.2979458334e-3);
  EXPECT_GT(memory.Moment(), 3.2979458334e-3 * (1 - 1e-5));
}

// Behind a rig's torsional compliance C the actuator's angle is the contact's twist plus C M; the
// contact follows its own Masing loop whatever C is.
TEST(TorsionTest, ATwistThroughACompliancePutsTheRigInSeries) {
  const double compliance = 0.4;  // rad / (N m): the rig's twist at the moment 1 N m
  TorsionalMemory through = UnitMemory(), direct = UnitMemory();
  for (double actuator : {0.9, 1.3, -0.2, -1.1, 0.4, 0.4, 2.5, -3.0}) {
    SCOPED_TRACE(actuator);
    ASSERT_TRUE(through.TwistThroughCompliance(actuator, compliance).ok());
    EXPECT_NEAR(through.twist() + compliance * through.Moment(), actuator, 1e-14 * 3);
    // The same contact twisted directly to the twist the rig left it at.
    ASSERT_TRUE(direct.TwistTo(through.twist()).ok());
    EXPECT_NEAR(through.Moment(), direct.Moment(), 1e-14 * kSlipMoment);
    EXPECT_EQ(through.StickRadius(+1), direct.StickRadius(+1));
  }
  // Without a compliance it is TwistTo, bit for bit.
  TorsionalMemory a = UnitMemory(), b = UnitMemory();
  ASSERT_TRUE(a.TwistThroughCompliance(0.7, 0).ok());
  ASSERT_TRUE(b.TwistTo(0.7).ok());
  EXPECT_EQ(a.Snapshot(), b.Snapshot());
  // Refusals name their field and change nothing.
  const TorsionSnapshot before = a.Snapshot();
  EXPECT_EQ(a.TwistThroughCompliance(NAN, 1).field(), "actuator");
  EXPECT_EQ(a.TwistThroughCompliance(1, -1).field(), "compliance");
  EXPECT_EQ(a.TwistThroughCompliance(1, INFINITY).field(), "compliance");
  EXPECT_EQ(a.Snapshot(), before);
}

TEST(TorsionTest, AMomentTargetFindsItsTwist) {
  TorsionalMemory memory = UnitMemory();
  ExpectRelative(memory.FullSlipMoment(), kSlipMoment, 1e-14);
  // The reference virgin point c = 0.5: M = 0.8973384290 M_slip at phi = 0.6018982880.
  ASSERT_TRUE(memory.TwistToMoment(0.8973384290 * kSlipMoment).ok());
  ExpectRelative(memory.twist(), 0.6018982880, 1e-8);
  ExpectRelative(memory.StickRadius(+1), 0.5, 1e-8);
  ExpectRelative(memory.Moment(), 0.8973384290 * kSlipMoment, 1e-15);
  // Back down a reversal, and close to full sliding the other way.
  for (double target : {0.2, -0.7, -(1 - 1e-9)}) {
    SCOPED_TRACE(target);
    ASSERT_TRUE(memory.TwistToMoment(target * kSlipMoment).ok());
    EXPECT_NEAR(memory.Moment(), target * kSlipMoment, 2e-15 * kSlipMoment);
  }
  // The same twist as a twist-controlled step reached, from the same state.
  TorsionalMemory by_twist = UnitMemory(), by_moment = UnitMemory();
  ASSERT_TRUE(by_twist.Twist(0.37).ok());
  ASSERT_TRUE(by_moment.TwistToMoment(by_twist.Moment()).ok());
  ExpectRelative(by_moment.twist(), 0.37, 1e-13);
  // Full sliding needs an infinite twist: refused, nothing changed.
  const std::vector<TorsionPiece> before = memory.pieces();
  const Status refused = memory.TwistToMoment(-kSlipMoment * (1 + 1e-12));
  EXPECT_EQ(refused.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(refused.field(), "moment");
  EXPECT_EQ(memory.TwistToMoment(NAN).field(), "moment");
  EXPECT_EQ(memory.pieces(), before);
  // Without contact there is no moment to reach but 0.
  TorsionalMemory free = UnitMemory(0);
  EXPECT_EQ(free.TwistToMoment(1e-9).code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(free.TwistToMoment(0).ok());
}

// M = 2 pi integral_0^a tau r^2 dr from the tractions, piece by piece in r = end - (end -
// start)(1 - u)^2: tau meets mu p like a square root at a stick radius and at the edge, which this
// makes smooth; 16-point Gauss-Legendre on `parts` parts of [0, 1] in u.
double MomentOfTractions(const TorsionalMemory& memory, int parts = 16) {
  static const double nodes[] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274,
                                 0.6178762444026438, 0.7554044083550030, 0.8656312023878318,
                                 0.9445750230732326, 0.9894009349916499};
  static const double weights[] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025,
                                   0.1495959888165767, 0.1246289712555339, 0.0951585116824928,
                                   0.0622535239386479, 0.0271524594117541};
  double sum = 0, start = 0;
  for (const TorsionPiece& piece : memory.pieces()) {
    const double width = piece.end - start;
    for (int part = 0; part < parts; ++part) {
      const double lo = double(part) / parts, hi = double(part + 1) / parts;
      for (int i = 0; i < 8; ++i) {
        for (double sign : {-1.0, 1.0}) {
          const double u = (lo + hi) / 2 + sign * (hi - lo) / 2 * nodes[i];
          const double r = piece.end - width * (1 - u) * (1 - u);
          sum +=
              (hi - lo) / 2 * weights[i] * memory.Traction(r).value * r * r * 2 * width * (1 - u);
        }
      }
    }
    start = piece.end;
  }
  return 2 * kPi * sum;
}

TEST(TorsionTest, TractionsSlideAtMuPAndGiveTheMoment) {
  const double mu_p0 = 4 / kPi;  // mu p0 = 2 E* a / (pi R) in the reference units
  auto sliding = [&](double r) { return mu_p0 * std::sqrt(1 - r * r); };
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(UnitHertz()->Bound(0.5, 1)).ok());
  for (double r : {0.55, 0.7, 0.9, 0.999}) {
    const TorsionTraction traction = memory.Traction(r);
    ExpectRelative(traction.value, sliding(r), 1e-12);
    EXPECT_LE(traction.route_difference, 1e-12 * mu_p0);
  }
  for (double r : {0.01, 0.2, 0.45, 0.4999}) {
    const TorsionTraction traction = memory.Traction(r);
    EXPECT_GT(traction.value, 0);
    EXPECT_LT(traction.value, sliding(r));
    EXPECT_LE(traction.route_difference, 1e-10 * mu_p0);
  }
  EXPECT_EQ(memory.Traction(0).value, 0);
  EXPECT_EQ(memory.Traction(1).value, 0);
  ExpectRelative(MomentOfTractions(memory), memory.Moment(), 1e-7);
  // After a reversal and an exact load decrease: within mu p of the new contact, and the moment.
  ASSERT_TRUE(memory.Twist(-0.5).ok());
  ASSERT_TRUE(memory.SetContactRadius(0.5).ok());
  ASSERT_TRUE(memory.Twist(0.05).ok());
  for (double r : {0.05, 0.2, 0.3, 0.4, 0.45, 0.49}) {
    const TorsionTraction traction = memory.Traction(r);
    EXPECT_LE(std::abs(traction.value), mu_p0 * std::sqrt(0.25 - r * r) * (1 + 1e-12)) << r;
    EXPECT_LE(traction.route_difference, 1e-10 * mu_p0) << r;
  }
  ExpectRelative(MomentOfTractions(memory), memory.Moment(), 1e-7);
}

TEST(TorsionTest, PowerLawTractionsSlideAtMuP) {
  for (double exponent : {1.0, 4.0}) {
    SCOPED_TRACE(exponent);
    auto bound = *MakePowerLawTorsionBound(1, 2, 1, 1, exponent);
    TorsionalMemory memory = *TorsionalMemory::Create(bound, 1, 1);
    ASSERT_TRUE(memory.Twist(bound->Bound(0.4, 1)).ok());
    for (double r : {0.5, 0.8, 0.99}) {
      const TorsionTraction traction = memory.Traction(r);
      ExpectRelative(traction.value, bound->SlidingTractionPerModulus(r, 1), 1e-10);
      EXPECT_LE(traction.route_difference, 1e-10 * bound->SlidingTractionPerModulus(r, 1));
    }
    ExpectRelative(MomentOfTractions(memory, 4), memory.Moment(), 1e-6);
  }
  // n = 2 is Hertz's p0 sqrt(1 - r^2/a^2).
  auto power = *MakePowerLawTorsionBound(1, 2, 1, 1, 2);
  for (double r : {0.0, 0.3, 0.9}) {
    ExpectRelative(power->SlidingTractionPerModulus(r, 1),
                   UnitHertz()->SlidingTractionPerModulus(r, 1), 1e-13);
  }
}

TEST(TorsionTest, AnyStepSizeGivesTheSameState) {
  TorsionalMemory once = UnitMemory(), many = UnitMemory();
  ASSERT_TRUE(once.Twist(0.9).ok());
  ASSERT_TRUE(once.Twist(-1.3).ok());
  for (int i = 0; i < 900; ++i) ASSERT_TRUE(many.Twist(0.001).ok());
  for (int i = 0; i < 1300; ++i) ASSERT_TRUE(many.Twist(-0.001).ok());
  ExpectRelative(many.Moment(), once.Moment(), 1e-12);
  ExpectRelative(many.dissipated_energy(), once.dissipated_energy(), 1e-12);
  ASSERT_EQ(many.pieces().size(), once.pieces().size());
  for (std::size_t i = 0; i < once.pieces().size(); ++i) {
    ExpectRelative(many.pieces()[i].end, once.pieces()[i].end, 1e-12);
    EXPECT_EQ(many.pieces()[i].sign, once.pieces()[i].sign);
  }
}

// M_v(phi): the virgin moment at twist phi.
double VirginMoment(double twist) {
  TorsionalMemory memory = UnitMemory();
  EXPECT_TRUE(memory.Twist(twist).ok());
  return memory.Moment();
}

TEST(TorsionTest, UnloadingFollowsMasingAndTheLoopCloses) {
  const double peak = UnitHertz()->Bound(0.3, 1);
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(peak).ok());
  const double peak_moment = memory.Moment();
  const std::vector<TorsionPiece> virgin = memory.pieces();
  double twist = peak;
  for (double to : {0.8 * peak, 0.2 * peak, -0.5 * peak, -peak}) {
    ASSERT_TRUE(memory.Twist(to - twist).ok());
    twist = to;
    EXPECT_NEAR(memory.Moment(), peak_moment - 2 * VirginMoment((peak - twist) / 2),
                1e-14 * kSlipMoment)
        << twist;
  }
  // Reloading to the peak wipes the reversal out: the virgin state again.
  ASSERT_TRUE(memory.Twist(2 * peak).ok());
  EXPECT_NEAR(memory.Moment(), peak_moment, 1e-14 * kSlipMoment);
  ASSERT_EQ(memory.pieces().size(), virgin.size());
  EXPECT_EQ(memory.pieces().back(), virgin.back());
}

TEST(TorsionTest, TheLossPerCycleIsTheReferences) {
  const std::pair<double, double> cases[] = {
      {0.9, 0.0101546934808}, {0.5, 1.08221447558}, {0.1, 7.34107074862}};
  for (const auto& [stick_radius, loss] : cases) {
    SCOPED_TRACE(stick_radius);
    const double peak = UnitHertz()->Bound(stick_radius, 1);
    TorsionalMemory memory = UnitMemory();
    ASSERT_TRUE(memory.Twist(peak).ok());
    ASSERT_TRUE(memory.Twist(-2 * peak).ok());
    const double before = memory.dissipated_energy();
    ASSERT_TRUE(memory.Twist(2 * peak).ok());
    ASSERT_TRUE(memory.Twist(-2 * peak).ok());
    // A steady cycle: +peak -> -peak -> +peak dissipates W twice over half-cycles.
    ExpectRelative(memory.dissipated_energy() - before, loss, 1e-10);
  }
}

TEST(TorsionTest, TheLossOfSmallOscillationsGrowsAsTheCubeOfTheMoment) {
  // Deresiewicz: W = 3 M*^3 / (16 mu F_N G_t a^4) (1 + ~M*/M_slip). Over M* = 0.3 % .. 0.7 % of
  // M_slip the fitted exponent is 3.004 (reference values), within 3 +- 0.01.
  double sum_x = 0, sum_y = 0, sum_xx = 0, sum_xy = 0;
  const int points = 5;
  for (int i = 0; i < points; ++i) {
    const double target = (0.003 + 0.001 * i) * kSlipMoment;
    TorsionalMemory memory = UnitMemory();
    ASSERT_TRUE(memory.TwistToMoment(target).ok());
    ASSERT_TRUE(memory.TwistToMoment(-target).ok());
    const double before = memory.dissipated_energy();
    ASSERT_TRUE(memory.TwistToMoment(target).ok());
    ASSERT_TRUE(memory.TwistToMoment(-target).ok());
    const double loss = memory.dissipated_energy() - before;
    const double leading = 3 * std::pow(target, 3) / (16 * 8.0 / 3);  // mu F_N G_t a^4 = 8/3
    EXPECT_GT(loss, leading);
    EXPECT_LT(loss, leading * (1 + 2 * target / kSlipMoment));
    const double x = std::log(target), y = std::log(loss);
    sum_x += x, sum_y += y, sum_xx += x * x, sum_xy += x * y;
  }
  const double exponent = (points * sum_xy - sum_x * sum_y) / (points * sum_xx - sum_x * sum_x);
  EXPECT_NEAR(exponent, 3, 0.01);
}

TEST(TorsionTest, LoadChangesThatKeepTheBoundOrderAreExact) {
  // D1: twist to c = 0.5, halve F_N, twist to -0.3, restore F_N, twist to 0.8. The ring model
  // of the half-space ends at 0.943727 M_slip (the springs agree with it to 3.4e-6 M_slip).
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(UnitHertz()->Bound(0.5, 1)).ok());
  ASSERT_TRUE(memory.SetContactRadius(std::cbrt(0.5)).ok());
  EXPECT_TRUE(memory.IsExact());
  ASSERT_TRUE(memory.Twist(-0.3 - memory.twist()).ok());
  ASSERT_TRUE(memory.SetContactRadius(1).ok());
  EXPECT_TRUE(memory.IsExact());
  ASSERT_TRUE(memory.Twist(0.8 - memory.twist()).ok());
  EXPECT_NEAR(memory.Moment() / kSlipMoment, 0.943727, 4e-6);
  EXPECT_GT(memory.dissipated_energy(), 0);
}

TEST(TorsionTest, ADecreaseThatBreaksTheMappingIsRefusedAndChangesNothing) {
  // X: twist to c = 0.1, back to 0.7 of it, then F_N / 5. The springs would give 0.969 M_slip'
  // where the half-space gives 0.99985: refused.
  TorsionalMemory memory = UnitMemory();
  const double peak = UnitHertz()->Bound(0.1, 1);
  ASSERT_TRUE(memory.Twist(peak).ok());
  ASSERT_TRUE(memory.Twist(-0.3 * peak).ok());
  EXPECT_NEAR(memory.Moment() / kSlipMoment, -0.197623, 1e-6);
  const std::vector<TorsionPiece> before = memory.pieces();
  const double moment = memory.Moment(), dissipated = memory.dissipated_energy();
  const Status refused = memory.SetContactRadius(std::cbrt(0.2));
  EXPECT_EQ(refused.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(refused.field(), "contact_radius");
  EXPECT_NE(refused.message().find("|F| > 1"), std::string::npos) << refused.message();
  EXPECT_EQ(memory.pieces(), before);
  EXPECT_EQ(memory.Moment(), moment);
  EXPECT_EQ(memory.dissipated_energy(), dissipated);
  EXPECT_EQ(memory.contact_radius(), 1);
  EXPECT_TRUE(memory.IsExact());
  // Below a' = 0.561 a the decrease wipes the reversed memory out: exact again, accepted.
  ASSERT_TRUE(memory.SetContactRadius(0.55).ok());
  EXPECT_TRUE(memory.IsExact());
}

TEST(TorsionTest, TheRuleIsSufficientNotNecessaryAndSaysSo) {
  // D2 (twist 0.8, -0.4, a -> 0.8 a, ...) leaves a piece with |F| = 1.19 whose state the ring
  // model still confirms (|tau| <= mu p, one outer slip interval). The structural rule cannot see
  // that and refuses the decrease: conservative, never silently wrong.
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(0.8).ok());
  ASSERT_TRUE(memory.Twist(-1.2).ok());
  EXPECT_EQ(memory.SetContactRadius(0.8).code(), StatusCode::kFailedPrecondition);
  // The same decrease before the reversal is exact and accepted.
  TorsionalMemory monotone = UnitMemory();
  ASSERT_TRUE(monotone.Twist(0.8).ok());
  ASSERT_TRUE(monotone.SetContactRadius(0.8).ok());
  EXPECT_EQ(monotone.SlipIntervals().size(), 1u);
}

// Simpson's rule for the work integral_phi^(phi + increment) M dphi of one twist step, on a copy.
double TwistWork(TorsionalMemory memory, double increment) {
  constexpr int kIntervals = 1024;
  const double h = increment / kIntervals;
  double sum = memory.Moment();
  for (int i = 1; i <= kIntervals; ++i) {
    EXPECT_TRUE(memory.Twist(h).ok());
    sum += (i == kIntervals ? 1 : (i % 2 == 1 ? 4 : 2)) * memory.Moment();
  }
  return sum * h / 3;
}

// Seeded random histories of twists and load changes (loss and regain of contact included):
// after every accepted step the pieces cover the contact in order, |v| <= B, the state is exact,
// the energy balances (work = stored + dissipated; at fixed twist to fixed_twist_energy relative,
// which a tabulated bound, C1 only at its grid nodes, leaves above round-off); every refusal
// changes nothing.
void RunRandomHistories(const std::shared_ptr<const TorsionBound>& bound, int histories,
                        int steps_per_history, int work_every, double fixed_twist_energy = 1e-12) {
  std::mt19937_64 random(47);
  std::uniform_real_distribution<double> twist(-1.5, 1.5), radius(0.2, 1.4), unit(0, 1);
  int refused = 0, steps = 0;
  for (int history = 0; history < histories; ++history) {
    TorsionalMemory memory = *TorsionalMemory::Create(bound, 1, 1);
    for (int step = 0; step < steps_per_history; ++step, ++steps) {
      const std::vector<TorsionPiece> before = memory.pieces();
      const double stored = memory.StoredEnergy();
      const double dissipated = memory.dissipated_energy();
      if (unit(random) < 0.6) {
        const double increment = twist(random) * (unit(random) < 0.3 ? 0.05 : 1);
        const double work =
            work_every > 0 && history % work_every == 0 ? TwistWork(memory, increment) : NAN;
        ASSERT_TRUE(memory.Twist(increment).ok());
        if (!std::isnan(work)) {
          EXPECT_NEAR(memory.StoredEnergy() - stored + memory.dissipated_energy() - dissipated,
                      work, 1e-6 * (std::abs(work) + 1e-3));
        }
      } else {
        const double to = unit(random) < 0.05 ? 0 : radius(random);
        const Status status = memory.SetContactRadius(to);
        if (!status.ok()) {
          ++refused;
          EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
          EXPECT_EQ(memory.pieces(), before);
          EXPECT_EQ(memory.dissipated_energy(), dissipated);
          continue;
        }
        // At fixed twist the load does no work on the springs: what they lose is dissipated.
        EXPECT_NEAR(memory.StoredEnergy() - stored + memory.dissipated_energy() - dissipated, 0,
                    fixed_twist_energy * (stored + 1));
      }
      ASSERT_TRUE(memory.IsExact());
      EXPECT_GE(memory.last_step_dissipation(), 0);
      // Every state round-trips through its snapshot.
      Result<TorsionalMemory> restored = TorsionalMemory::Restore(bound, 1, memory.Snapshot());
      ASSERT_TRUE(restored.ok()) << restored.status().ToString() << [&] {
        std::ostringstream out;
        out.precision(17);
        double start = 0;
        out << " a=" << memory.contact_radius();
        for (const TorsionPiece& p : memory.pieces()) {
          out << "\n [" << start << ", " << p.end << ") s=" << int(p.sign) << " ak=" << p.radius
              << " C=" << p.offset << " v(start)=" << memory.SpringDisplacement(start)
              << " B(start)=" << bound->Bound(start, memory.contact_radius());
          start = p.end;
        }
        return out.str();
      }();
      EXPECT_EQ(restored->Snapshot(), memory.Snapshot());
      double start = 0;
      for (const TorsionPiece& piece : memory.pieces()) {
        ASSERT_GT(piece.end, start);
        for (double t : {0.1, 0.5, 0.9}) {
          const double x = start + t * (piece.end - start);
          const double b = bound->Bound(x, memory.contact_radius());
          EXPECT_LE(std::abs(memory.SpringDisplacement(x)), b * (1 + 1e-12) + 1e-300);
        }
        start = piece.end;
      }
      EXPECT_EQ(start, memory.contact_radius());
    }
  }
  // The histories do reach decreases that would break the mapping.
  EXPECT_GT(refused, histories * steps_per_history / 100);
  EXPECT_EQ(steps, histories * steps_per_history);
}

TEST(TorsionTest, RandomHistoriesKeepTheInvariants) { RunRandomHistories(UnitHertz(), 60, 25, 20); }

TEST(TorsionTest, RandomHistoriesOfConesAndPowerLawsKeepTheInvariants) {
  RunRandomHistories(*MakePowerLawTorsionBound(1, 2, 1, 1, 1), 8, 15, 0);
  RunRandomHistories(*MakePowerLawTorsionBound(1, 2, 1, 1, 4), 8, 15, 0);
}

// A profile sampled at count radii uniform on [0, extent] (a profilometer's trace).
ProfilePtr Sampled(double (*f)(double), double extent, int count) {
  std::vector<double> radii, heights;
  for (int i = 0; i < count; ++i) {
    radii.push_back(extent * i / (count - 1));
    heights.push_back(f(radii.back()));
  }
  return *MakeTabulatedProfile(radii, heights);
}
double UnitSphere(double r) { return r * r / 2; }
double UnitCone(double r) { return r; }

// Largest relative difference of the two bounds and their slopes over x in [from a, a).
double LargestBoundDifference(const TorsionBound& actual, const TorsionBound& expected, double a,
                              double from) {
  double largest = 0;
  for (double t : {1e-6, 1e-3, 0.01, 0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999}) {
    if (t < from) continue;
    const double x = t * a;
    largest = std::max({largest, std::abs(actual.Bound(x, a) / expected.Bound(x, a) - 1),
                        std::abs(actual.Slope(x, a) / expected.Slope(x, a) - 1)});
  }
  return largest;
}

// B(x; a) of a profile by GSL's adaptive QAGS over the s form, with GSL's own K: independent of
// the bound's substitution, rule and elliptic integrals.
double BoundByQags(const Profile& profile, double x, double a, double scale) {
  struct Integrand {
    const Profile* profile;
    double x;
  } integrand{&profile, x};
  gsl_function f{[](double s, void* p) {
                   const auto* in = static_cast<const Integrand*>(p);
                   const double k = std::sqrt(1 - (in->x / s) * (in->x / s));
                   return in->profile->Slope(s) * gsl_sf_ellint_Kcomp(k, GSL_PREC_DOUBLE) / s;
                 },
                 &integrand};
  gsl_integration_workspace* workspace = gsl_integration_workspace_alloc(10000);
  double result = 0, error = 0;
  gsl_integration_qags(&f, x, a, 0, 1e-13, 10000, workspace, &result, &error);
  gsl_integration_workspace_free(workspace);
  return scale * result;
}

// A tabulated profile takes the quadrature over its own g'.
// - Against QAGS on the same profile: 1e-10 beyond the first sample intervals (measured 8e-11);
//   within them, where Steffen's end condition bends g' sharply (g' off the sphere's by 15 % at
//   one sample spacing), the unit panels leave 7e-5 (200 samples) and 2e-6 (2000) -- far below
//   the profile's own difference from the shape there.
// - Sampled spheres and cones against the closed form and the power-law quadrature for
//   x >= a/10, what the interpolated f leaves (measured: sphere 3.1e-7 at 200 samples, 3.0e-11
//   at 2000).
// A coarse tabulated profile (7 samples of a power law, the engine fuzzer's find): its g' has a
// square-root term at every sample radius, which the quadratures now split at. The moment of a
// fully slipping contact (piece by piece, 16 G_t integral x^2 B) and the full-slip moment (the
// single integral of x^2 g') are two quadratures of one integral; they differed by up to 4.4e-3
// before the split, and agree to 1e-8 now, at every contact radius.
TEST(TorsionTest, ACoarseTabulatedProfileGivesOneFullSlipMoment) {
  const double coefficient = 91.845505334365924, exponent = 2.8770492422380882;
  const double extent = 6.982927567155897e-4;
  std::vector<double> radii, heights;
  for (int i = 0; i < 7; ++i) {
    radii.push_back(extent * i / 6);
    heights.push_back(coefficient * std::pow(radii.back(), exponent));
  }
  const ProfilePtr profile = *MakeTabulatedProfile(radii, heights);
  const double modulus = 1e12;
  const auto bound = *MakeTorsionBound(profile, 19.64481226336876, 1.0053594122274635e12, modulus);
  for (const double a : {1e-4, 3e-4, 5e-4, 6.6542295611978788e-4, 6.9e-4, 8e-4, 1.5e-3}) {
    TorsionalMemory memory = *TorsionalMemory::Create(bound, modulus, a);
    ASSERT_TRUE(memory.Twist(1e3).ok());  // every spring on the bound
    ExpectRelative(memory.Moment(), memory.FullSlipMoment(), 1e-8);
  }
}

TEST(TorsionTest, TabulatedProfilesTakeTheirOwnSlope) {
  auto hertz = UnitHertz();
  const auto exact_cone = *MakePowerLawTorsionBound(1, 2, 1, kPi / 2, 1);  // f = r: g = pi x / 2
  struct Case {
    double (*f)(double);
    int count;
    double within;
  };
  for (const auto& [f, count, within] : {Case{UnitSphere, 200, 1e-6}, Case{UnitSphere, 2000, 1e-10},
                                         Case{UnitCone, 200, 1e-10}, Case{UnitCone, 2000, 1e-10}}) {
    const ProfilePtr profile = Sampled(f, 2, count);
    auto bound = *MakeTorsionBound(profile, 1, 2, 1);
    const auto& expected = f == UnitSphere ? hertz : exact_cone;
    SCOPED_TRACE(testing::Message() << profile->Describe());
    const double spacing = 2.0 / (count - 1);
    for (double a : {0.3, 1.0, 1.7}) {
      for (double t : {1e-6, 1e-3, 0.01, 0.05, 0.1, 0.3, 0.7, 0.99, 0.999}) {
        const double x = t * a;
        ExpectRelative(bound->Bound(x, a), BoundByQags(*profile, x, a, 1 / kPi),
                       x > 5 * spacing ? 1e-10 : 1e-4);
      }
    }
    EXPECT_LE(LargestBoundDifference(*bound, *expected, 1, 0.1), within);
    // The sliding traction is mu p of the profile's own normal problem.
    for (double r : {0.1, 0.5, 0.9}) {
      ExpectRelative(bound->SlidingTractionPerModulus(r, 1),
                     expected->SlidingTractionPerModulus(r, 1), within);
    }
    // Through the memory: the virgin moment at stick radius a/2 and the full-slip moment.
    TorsionalMemory memory = *TorsionalMemory::Create(bound, 1, 1);
    TorsionalMemory reference = *TorsionalMemory::Create(expected, 1, 1);
    ASSERT_TRUE(memory.Twist(expected->Bound(0.5, 1)).ok());
    ASSERT_TRUE(reference.Twist(expected->Bound(0.5, 1)).ok());
    ExpectRelative(memory.Moment(), reference.Moment(), within);
    ExpectRelative(memory.FullSlipMoment(), reference.FullSlipMoment(), within);
    // The single integral of the full-slip moment is the bound's own double integral, to what
    // the bound's panels leave near the tip (measured 5.3e-9 at a = 0.3 with 200 samples).
    for (double a : {0.3, 1.0, 1.7}) {
      ExpectRelative(bound->FullSlipMomentPerModulus(a),
                     bound->TorsionBound::FullSlipMomentPerModulus(a), 2e-8);
    }
  }
  RunRandomHistories(*MakeTorsionBound(Sampled(UnitSphere, 2, 200), 1, 2, 1), 4, 15, 0, 1e-10);
}

// An independent reference for the piece bookkeeping: n play springs at the midpoints of
// [0, extent), each clamped to its own bound after every twist and every load change, the moment
// by the midpoint rule. It shares only the bound B(x; a) with the memory (tested above against
// the references).
class SpringGrid {
 public:
  SpringGrid(std::shared_ptr<const TorsionBound> bound, double extent, int n)
      : bound_(std::move(bound)), h_(extent / n), v_(n, 0.0) {}
  void Twist(double increment) {
    for (std::size_t i = 0; i < v_.size(); ++i) Clamp(i, v_[i] + increment);
  }
  void SetContactRadius(double a) {
    radius_ = a;
    for (std::size_t i = 0; i < v_.size(); ++i) Clamp(i, v_[i]);
  }
  double Moment() const {
    double sum = 0;
    for (std::size_t i = 0; i < v_.size(); ++i) sum += X(i) * X(i) * v_[i];
    return 16 * sum * h_;
  }

 private:
  double X(std::size_t i) const { return (i + 0.5) * h_; }
  void Clamp(std::size_t i, double value) {
    const double b = bound_->Bound(X(i), radius_);
    v_[i] = X(i) < radius_ ? std::clamp(value, -b, b) : 0;
  }
  std::shared_ptr<const TorsionBound> bound_;
  double h_, radius_ = 0;
  std::vector<double> v_;
};

// A history of its own per channel: the load grows at fixed twist (twice, once after a partial
// reversal), a twist either way between, a decrease that stays exact, loss and regain of contact.
template <typename State>
void LoadAndTwist(State& state) {
  state.SetContactRadius(0.6);
  state.Twist(0.4);
  state.Twist(-0.15);
  state.SetContactRadius(1.0);  // the load grows at fixed twist: new springs at 0
  state.Twist(0.5);
  state.Twist(-0.3);
  state.SetContactRadius(1.2);
  state.Twist(0.25);
  state.SetContactRadius(0.9);  // a decrease that wipes the reversal out
  state.Twist(-0.6);
}
struct MemoryState {
  TorsionalMemory memory;
  void SetContactRadius(double a) { ASSERT_TRUE(memory.SetContactRadius(a).ok()) << a; }
  void Twist(double increment) { ASSERT_TRUE(memory.Twist(increment).ok()); }
};

// The grid converges to the memory at second order, erratically as the slip boundaries fall
// between grid points (measured relative errors of M for Hertz: 6.7e-6, 2.0e-8, 3.8e-9, 4.9e-10
// at n = 1000, 4000, 16000, 64000; error n^2 stays below 7 for every profile here up to
// n = 128000, where the error is 3e-10; the test stops at 16000 for time). Sphere, cone and a
// tabulated profile.
TEST(TorsionTest, LoadChangesAgreeWithAGridOfSprings) {
  const std::shared_ptr<const TorsionBound> bounds[] = {
      UnitHertz(), *MakePowerLawTorsionBound(1, 2, 1, 1, 1),
      *MakeTorsionBound(Sampled(UnitSphere, 2, 200), 1, 2, 1)};
  for (const auto& bound : bounds) {
    MemoryState exact{*TorsionalMemory::Create(bound, 1, 0)};
    LoadAndTwist(exact);
    const double moment = exact.memory.Moment();
    for (int n : {1000, 4000, 16000}) {
      SpringGrid grid(bound, 1.2, n);
      LoadAndTwist(grid);
      const double error = std::abs(grid.Moment() / moment - 1);
      EXPECT_LT(error * n * n, 10) << "n = " << n << ", error " << error;
    }
  }
}

// Load and twist ramped together: each spring leaves its moving bound at its own instant, so no
// finite list of pieces is the exact state, and the memory takes the ramp as alternating
// sub-steps of one channel each (a step moving both is refused). Two claims: the memory with k
// sub-steps equals the grid with the same sub-steps (to the grid's convergence), and the
// sub-stepped answer converges to the ramp (the grid at 512 sub-steps), measured at second order:
// relative errors 8.3e-5, 2.0e-5, 5.0e-6, 1.2e-6 at 8, 16, 32, 64 sub-steps (memory and grid
// within 3e-8 of each other at each).
TEST(TorsionTest, ARampOfLoadAndTwistConvergesWithItsSubSteps) {
  auto bound = UnitHertz();
  auto ramp = [](auto& state, int substeps) {
    state.SetContactRadius(0.5);
    for (int k = 1; k <= substeps; ++k) {
      state.SetContactRadius(0.5 + 0.5 * k / substeps);
      state.Twist(0.6 / substeps);
    }
  };
  auto memory_after = [&](int substeps) {
    MemoryState state{*TorsionalMemory::Create(bound, 1, 0)};
    ramp(state, substeps);
    return state.memory.Moment();
  };
  SpringGrid fine(bound, 1, 4000);
  ramp(fine, 512);
  const double ramp_moment = fine.Moment();
  double previous = INFINITY;
  for (int substeps : {8, 16, 32, 64}) {
    const double moment = memory_after(substeps);
    SpringGrid grid(bound, 1, 4000);
    ramp(grid, substeps);
    ExpectRelative(grid.Moment(), moment, 2e-7);
    const double error = std::abs(moment / ramp_moment - 1);
    SCOPED_TRACE(testing::Message() << substeps << " sub-steps: " << error);
    EXPECT_LT(error, previous * 0.3);  // second order: a quarter with each doubling
    previous = error;
  }
}

TorsionStep NormalStep(NormalControl control, double value) {
  TorsionStep step;
  step.normal = control;
  step.normal_value = value;
  return step;
}
TorsionStep TwistStep(TwistControl control, double value) {
  TorsionStep step;
  step.twist = control;
  step.twist_value = value;
  return step;
}

TEST(TorsionalContactTest, ATabulatedProfileCarriesItsNormalProblem) {
  const ProfilePtr profile = Sampled(UnitSphere, 2, 2000);
  TorsionalContact sampled = *TorsionalContact::Create(profile, 0.5, 2, 1);
  TorsionalContact exact = *TorsionalContact::Create(*MakeSphere(1), 0.5, 2, 1);
  for (TorsionalContact* contact : {&sampled, &exact}) {
    ASSERT_TRUE(contact->Apply(NormalStep(NormalControl::kDepth, 0.36)).ok());
    ASSERT_TRUE(contact->Apply(TwistStep(TwistControl::kAngle, 0.05)).ok());
    ASSERT_TRUE(contact->Apply(NormalStep(NormalControl::kDepth, 0.64)).ok());
    ASSERT_TRUE(contact->Apply(TwistStep(TwistControl::kAngleIncrement, -0.2)).ok());
  }
  ExpectRelative(sampled.memory().contact_radius(), exact.memory().contact_radius(), 1e-9);
  ExpectRelative(sampled.memory().Moment(), exact.memory().Moment(), 1e-7);
  ExpectRelative(sampled.memory().StickRadius(-1), exact.memory().StickRadius(-1), 1e-7);
}

// Test vector H1 through the contact: steel on steel, the normal problem of the sphere.
TorsionalContact SteelSphereOnSteel() {
  const EffectiveMaterial material = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  const double torsional_modulus = *TorsionalModulusOfPair(210e9, 0.3, 210e9, 0.3);
  return *TorsionalContact::Create(*MakeSphere(0.01), 0.3, material.e_star, torsional_modulus);
}

TEST(TorsionalContactTest, TheNormalLoadSetsTheContactOfTheTwist) {
  ExpectRelative(*TorsionalModulusOfPair(210e9, 0.3, 210e9, 0.3), 4.0384615385e10, 1e-10);
  TorsionalContact contact = SteelSphereOnSteel();
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kForce, 100)).ok());
  ExpectRelative(contact.normal_force(), 100, 1e-13);
  ExpectRelative(contact.memory().contact_radius(), 1.8662555784e-4, 1e-9);
  ExpectRelative(contact.memory().Stiffness(+1), 1.4, 1e-9);
  ExpectRelative(contact.memory().FullSlipMoment(), 3.2979458334e-3, 1e-9);
  // The moment at stick radius a/2, reached by a moment target and by the angle.
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kMoment, 2.9593735330e-3)).ok());
  ExpectRelative(contact.memory().twist(), 4.8141258757e-3, 1e-8);
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngle, 4.8141258757e-3)).ok());
  EXPECT_EQ(contact.memory().twist(), 4.8141258757e-3);
  ExpectRelative(contact.memory().StickRadius(+1), 1.8662555784e-4 / 2, 1e-9);
  // More load at fixed twist: the contact grows, nothing slips, the new springs carry nothing.
  const double moment = contact.memory().Moment();
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kForce, 200)).ok());
  EXPECT_EQ(contact.memory().last_step_dissipation(), 0);
  ExpectRelative(contact.memory().Moment(), moment, 1e-14);
  EXPECT_TRUE(contact.memory().SlipIntervals().empty());
  // Loss of contact forgets every spring; contact regained carries no moment at the same twist.
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kDepth, -1e-9)).ok());
  EXPECT_EQ(contact.memory().contact_radius(), 0);
  EXPECT_EQ(contact.memory().Moment(), 0);
  EXPECT_GT(contact.memory().dissipated_energy(), 0);
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kDepthIncrement, 2e-6)).ok());
  EXPECT_EQ(contact.memory().Moment(), 0);
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngleIncrement, 1e-4)).ok());
  EXPECT_GT(contact.memory().Moment(), 0);
}

// Materials and friction over their range -- two elastic bodies, nu 0 and 0.5, mu from 1e-3 to
// 10 -- only scale the references: the initial stiffness is 16 G_t a^3 / 3, the full-slip moment
// 3 pi mu F_N a / 16, and the virgin curve in c/a, M/M_slip and phi / (mu p0 / (2 G_t)) is the
// table's (c = a/2: phi = (K - E)(3/4) mu p0 / (2 G_t), M = 0.8973384290 M_slip).
TEST(TorsionalContactTest, MaterialsAndFrictionOnlyScaleTheReferences) {
  struct Pair {
    double e1, nu1, e2, nu2;
  };
  const double radius = 5e-3, force = 20;
  for (const Pair& pair : {Pair{210e9, 0.3, 70e9, 0.33}, Pair{1e9, 0.0, 3e9, 0.0},
                           Pair{5e6, 0.5, 2e11, 0.5}, Pair{1e11, 0.5, 1e11, 0.0}}) {
    for (double friction : {1e-3, 0.1, 10.0}) {
      SCOPED_TRACE(testing::Message() << "E1 " << pair.e1 << ", nu1 " << pair.nu1 << ", E2 "
                                      << pair.e2 << ", nu2 " << pair.nu2 << ", mu " << friction);
      const EffectiveMaterial material = *ElasticPair(pair.e1, pair.nu1, pair.e2, pair.nu2);
      const double modulus = *TorsionalModulusOfPair(pair.e1, pair.nu1, pair.e2, pair.nu2);
      ExpectRelative(1 / modulus, 2 * (1 + pair.nu1) / pair.e1 + 2 * (1 + pair.nu2) / pair.e2,
                     1e-15);
      TorsionalContact contact =
          *TorsionalContact::Create(*MakeSphere(radius), friction, material.e_star, modulus);
      ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kForce, force)).ok());
      const TorsionalMemory& memory = contact.memory();
      const double a = memory.contact_radius();
      ExpectRelative(a, std::cbrt(3 * force * radius / (4 * material.e_star)), 1e-12);
      ExpectRelative(memory.Stiffness(+1), 16 * modulus * a * a * a / 3, 1e-12);
      ExpectRelative(memory.FullSlipMoment(), 3 * kPi * friction * force * a / 16, 1e-12);
      const double unit = friction * (2 * material.e_star * a / (kPi * radius)) / (2 * modulus);
      ASSERT_TRUE(
          contact.Apply(TwistStep(TwistControl::kAngle, 0.6018982880 * kPi / 2 * unit)).ok());
      ExpectRelative(memory.StickRadius(+1) / a, 0.5, 1e-9);
      ExpectRelative(memory.Moment() / memory.FullSlipMoment(), 0.8973384290, 1e-9);
    }
  }
}

// A twist whose sliding work overflows the doubles is refused and changes nothing: no snapshot
// could hold its energy (the C fuzzer's find: 1.5e308 rad on the steel sphere 18 m deep). A
// twist whose work is finite goes on, its energy finite.
TEST(TorsionalContactTest, ATwistWhoseLossOverflowsTheDoublesIsRefused) {
  TorsionalContact contact = SteelSphereOnSteel();
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kDepth, 18.229107342665447)).ok());
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngle, 1e-3)).ok());
  const TorsionSnapshot before = contact.memory().Snapshot();
  const Status slide = contact.Apply(TwistStep(TwistControl::kAngle, 1.5062237341988156e308));
  EXPECT_EQ(slide.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(slide.field(), "twist_value");
  EXPECT_EQ(contact.memory().Snapshot(), before);
  const Status increment =
      contact.Apply(TwistStep(TwistControl::kAngleIncrement, -1.5062237341988156e308));
  EXPECT_EQ(increment.field(), "twist_value");
  EXPECT_EQ(contact.memory().Snapshot(), before);
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngle, 1e290)).ok());
  EXPECT_GT(contact.memory().dissipated_energy(), 1e290);
  EXPECT_TRUE(std::isfinite(contact.memory().dissipated_energy()));
}

TEST(TorsionalContactTest, StepsThatCannotBeExactAreRefusedAndChangeNothing) {
  TorsionalContact contact = SteelSphereOnSteel();
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kForce, 100)).ok());
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngle, 2e-2)).ok());
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngleIncrement, -6e-3)).ok());
  const std::vector<TorsionPiece> before = contact.memory().pieces();
  const double depth = contact.depth();
  TorsionStep both_channels = NormalStep(NormalControl::kForce, 50);
  both_channels.twist = TwistControl::kAngleIncrement;
  both_channels.twist_value = 1e-3;
  const Status both = contact.Apply(both_channels);
  EXPECT_EQ(both.field(), "step");
  // A decrease after the reversal would break |F| <= 1: refused on the normal channel.
  const Status decrease = contact.Apply(NormalStep(NormalControl::kForce, 20));
  EXPECT_EQ(decrease.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(decrease.field(), "normal_value");
  EXPECT_EQ(contact.Apply(NormalStep(NormalControl::kForce, -1)).field(), "normal_value");
  EXPECT_EQ(contact.Apply(TwistStep(TwistControl::kMoment, 1)).field(), "twist_value");
  EXPECT_EQ(contact.Apply(TwistStep(TwistControl::kAngle, NAN)).field(), "twist_value");
  EXPECT_EQ(contact.memory().pieces(), before);
  EXPECT_EQ(contact.depth(), depth);
  // A load so large that the full-slip moment overflows (the request fuzzer's 2.7e277 N).
  const Status huge = contact.Apply(NormalStep(NormalControl::kForce, 2.658993438149576e277));
  EXPECT_EQ(huge.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(huge.field(), "normal_value");
  EXPECT_EQ(contact.memory().pieces(), before);
  EXPECT_EQ(contact.depth(), depth);
  // A load so small that the full-slip moment per modulus is subnormal (the request fuzzer's
  // 8.4e-227 N, which answered |M| = 1.0000015 M_slip); unloading to 0 stays allowed.
  const Status tiny = contact.Apply(NormalStep(NormalControl::kForce, 8.448726018105168e-227));
  EXPECT_EQ(tiny.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(tiny.field(), "normal_value");
  EXPECT_NE(tiny.message().find("full precision"), std::string::npos) << tiny.message();
  EXPECT_EQ(contact.memory().pieces(), before);
  EXPECT_EQ(contact.depth(), depth);
  // Profiles without a torsional bound yet are refused by name.
  const Status punch = TorsionalContact::Create(*MakeFlatPunch(1e-3), 0.3, 1e11, 4e10).status();
  EXPECT_EQ(punch.field(), "profile");
  EXPECT_EQ(TorsionalContact::Create(*MakeSphere(0.01), 0, 1e11, 4e10).status().field(),
            "friction");
  // A cone and a power law take the quadrature; their moment grows with the twist.
  for (ProfilePtr profile : {*MakeCone(0.1), *MakePowerLaw(1e3, 3)}) {
    TorsionalContact other = *TorsionalContact::Create(profile, 0.3, 1e11, 4e10);
    ASSERT_TRUE(other.Apply(NormalStep(NormalControl::kDepth, 1e-6)).ok());
    ASSERT_TRUE(other.Apply(TwistStep(TwistControl::kAngle, 1e-4)).ok());
    EXPECT_GT(other.memory().Moment(), 0);
    EXPECT_LT(other.memory().Moment(), other.memory().FullSlipMoment());
  }
}

// A contact restores from its depth and memory, the memory's contact radius exactly the
// profile's at the depth, and continues bit for bit.
TEST(TorsionalContactTest, ARestoredContactContinuesBitForBit) {
  TorsionalContact contact = SteelSphereOnSteel();
  ASSERT_TRUE(contact.Apply(NormalStep(NormalControl::kForce, 100)).ok());
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngle, 3e-3)).ok());
  ASSERT_TRUE(contact.Apply(TwistStep(TwistControl::kAngleIncrement, -4e-3)).ok());
  const EffectiveMaterial material = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  const double modulus = *TorsionalModulusOfPair(210e9, 0.3, 210e9, 0.3);
  auto restore = [&](double depth, const TorsionSnapshot& memory) {
    return TorsionalContact::Restore(*MakeSphere(0.01), 0.3, material.e_star, modulus, depth,
                                     memory);
  };
  Result<TorsionalContact> twin = restore(contact.depth(), contact.memory().Snapshot());
  ASSERT_TRUE(twin.ok()) << twin.status().ToString();
  for (const TorsionStep& step :
       {NormalStep(NormalControl::kForce, 140), TwistStep(TwistControl::kMoment, 1e-3),
        TwistStep(TwistControl::kAngle, -2e-3)}) {
    ASSERT_TRUE(contact.Apply(step).ok());
    ASSERT_TRUE(twin->Apply(step).ok());
    EXPECT_EQ(twin->memory().Snapshot(), contact.memory().Snapshot());
    EXPECT_TRUE(SameBits(twin->depth(), contact.depth()));
    EXPECT_TRUE(SameBits(twin->normal_force(), contact.normal_force()));
  }
  // The radius must be the depth's to the bit; the depth finite.
  TorsionSnapshot moved = contact.memory().Snapshot();
  moved.contact_radius = std::nextafter(moved.contact_radius, 1.0);
  EXPECT_EQ(restore(contact.depth(), moved).status().field(), "contact_radius");
  EXPECT_EQ(restore(NAN, contact.memory().Snapshot()).status().field(), "depth");
  EXPECT_EQ(restore(contact.depth() * 1.001, contact.memory().Snapshot()).status().field(),
            "contact_radius");
  // Out of contact: an empty memory at depth <= 0.
  EXPECT_TRUE(restore(-1e-6, TorsionSnapshot{}).ok());
}

TEST(TorsionTest, ARestoredMemoryContinuesBitForBit) {
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(0.7).ok());
  ASSERT_TRUE(memory.Twist(-0.9).ok());
  ASSERT_TRUE(memory.SetContactRadius(1.2).ok());
  TorsionalMemory twin = *TorsionalMemory::Restore(UnitHertz(), 1, memory.Snapshot());
  for (TorsionalMemory* m : {&memory, &twin}) {
    ASSERT_TRUE(m->Twist(0.4).ok());
    ASSERT_TRUE(m->SetContactRadius(1.3).ok());
    ASSERT_TRUE(m->TwistToMoment(-0.3).ok());
  }
  EXPECT_EQ(twin.Snapshot(), memory.Snapshot());
  EXPECT_EQ(twin.Moment(), memory.Moment());
}

TEST(TorsionTest, StatesAtTheResolutionOfTheRadiusRoundTrip) {
  // Found by the fuzzer: a reversal of 2e-18 rad leaves +B + C with C = -2e-18, whose clip near
  // the edge lies below the radius' resolution; and a clip root within 1e-12 of the edge.
  for (double reversal : {-2e-18, -1e-12 * 0.6, -1e-9}) {
    SCOPED_TRACE(reversal);
    TorsionalMemory memory = UnitMemory(1.3921037380226426e-05);
    ASSERT_TRUE(memory.Twist(0.05).ok());
    ASSERT_TRUE(memory.Twist(reversal).ok());
    Result<TorsionalMemory> restored = TorsionalMemory::Restore(UnitHertz(), 1, memory.Snapshot());
    ASSERT_TRUE(restored.ok()) << restored.status().ToString();
    EXPECT_EQ(restored->Snapshot(), memory.Snapshot());
  }
}

TEST(TorsionTest, ADamagedSnapshotIsRefusedByField) {
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(0.7).ok());
  ASSERT_TRUE(memory.Twist(-0.2).ok());
  const TorsionSnapshot good = memory.Snapshot();
  ASSERT_EQ(good.pieces.size(), 3u);
  auto field_of = [](const TorsionSnapshot& snapshot) {
    return TorsionalMemory::Restore(UnitHertz(), 1, snapshot).status().field();
  };
  TorsionSnapshot bad = good;
  bad.pieces[1].end = bad.pieces[0].end;
  EXPECT_EQ(field_of(bad), "pieces[1].end");
  bad = good, bad.pieces.back().end = 0.9;
  EXPECT_EQ(field_of(bad), "pieces[2].end");
  bad = good, bad.pieces[1].sign = 2;
  EXPECT_EQ(field_of(bad), "pieces[1].sign");
  bad = good, bad.pieces[1].radius = 1.5;  // a piece of a larger contact: not exact
  EXPECT_EQ(field_of(bad), "pieces[1].radius");
  bad = good, bad.pieces[0].offset = 5;  // beyond the bound at the stick radius
  EXPECT_EQ(field_of(bad), "pieces[0]");
  bad = good, bad.pieces[0].offset = NAN;
  EXPECT_EQ(field_of(bad), "pieces[0].offset");
  bad = good, bad.twist = INFINITY;
  EXPECT_EQ(field_of(bad), "twist");
  bad = good, bad.dissipated_energy = -1;
  EXPECT_EQ(field_of(bad), "dissipated_energy");
  bad = good, bad.pieces.clear();
  EXPECT_EQ(field_of(bad), "pieces");
  bad = good, bad.contact_radius = -1;
  EXPECT_EQ(field_of(bad), "contact_radius");
  EXPECT_TRUE(TorsionalMemory::Restore(UnitHertz(), 1, good).ok());
  // A contact the doubles do not carry, too small or too large, is refused as a step refuses
  // it (a snapshot of one constant piece at v = 0 is otherwise valid at any radius).
  for (const double radius : {1e-110, 1e110}) {
    SCOPED_TRACE(radius);
    TorsionSnapshot extreme{.contact_radius = radius, .pieces = {{.end = radius}}};
    TorsionalMemory unit = UnitMemory();
    const Status step = unit.SetContactRadius(radius);
    EXPECT_EQ(step.field(), "contact_radius");
    const Status restored = TorsionalMemory::Restore(UnitHertz(), 1, extreme).status();
    EXPECT_EQ(restored.field(), "contact_radius");
    EXPECT_EQ(restored.message(), step.message());
    extreme.contact_radius = extreme.pieces[0].end = radius < 1 ? 1e-60 : 1e60;
    const Result<TorsionalMemory> carried = TorsionalMemory::Restore(UnitHertz(), 1, extreme);
    EXPECT_TRUE(carried.ok()) << carried.status().ToString();
  }
}

TEST(TorsionTest, BadInputsNameTheirFieldAndChangeNothing) {
  EXPECT_EQ(MakeHertzTorsionBound(0, 2, 1, 1).status().field(), "friction");
  EXPECT_EQ(MakeHertzTorsionBound(1, NAN, 1, 1).status().field(), "effective_modulus");
  EXPECT_EQ(MakeHertzTorsionBound(1, 2, -1, 1).status().field(), "torsional_modulus");
  EXPECT_EQ(MakeHertzTorsionBound(1, 2, 1, INFINITY).status().field(), "radius");
  EXPECT_EQ(TorsionalMemory::Create(nullptr, 1, 1).status().field(), "bound");
  EXPECT_EQ(TorsionalMemory::Create(UnitHertz(), 0, 1).status().field(), "torsional_modulus");
  EXPECT_EQ(TorsionalMemory::Create(UnitHertz(), 1, -1).status().field(), "contact_radius");
  TorsionalMemory memory = UnitMemory();
  ASSERT_TRUE(memory.Twist(0.4).ok());
  const std::vector<TorsionPiece> before = memory.pieces();
  EXPECT_EQ(memory.Twist(NAN).field(), "twist_increment");
  EXPECT_EQ(memory.Twist(INFINITY).field(), "twist_increment");
  EXPECT_EQ(memory.SetContactRadius(-1).field(), "contact_radius");
  EXPECT_EQ(memory.SetContactRadius(NAN).field(), "contact_radius");
  EXPECT_EQ(memory.pieces(), before);
  EXPECT_EQ(memory.twist(), 0.4);
}

}  // namespace
}  // namespace mdr
