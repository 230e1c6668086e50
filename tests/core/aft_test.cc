// The harmonic-balance element (aft.h, issue #51): coefficients to samples and back, the linear
// case exactly, the Jacobian dF_h/dU_k against central differences, the loss per period, periods
// that repeat bit for bit, and bad input named.
#include "mdr/core/aft.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "fixtures/reference_scenes.h"

namespace mdr {
namespace {

constexpr double kPi = std::numbers::pi;
const std::vector<int> kHarmonics = {0, 1, 2, 3, 4, 5};

ContactConfig SceneOf(ProfilePtr profile) {
  ContactConfig config = reference::H1Config(true);
  config.profile = std::move(profile);
  return config;
}

double SlipDistance(const ContactConfig& config, double normal_force) {
  const Contact c = *PressForPeriod(config, normal_force);
  return c.mu_kappa() * c.depth();
}

// U_0 + U_1^c cos + U_1^s sin + smaller higher harmonics, scaled by `amplitude`.
std::vector<double> Coefficients(double amplitude) {
  return {0.1 * amplitude,   amplitude,        0.3 * amplitude,  0.05 * amplitude,
          -0.04 * amplitude, 0.15 * amplitude, 0.02 * amplitude, 0.01 * amplitude,
          -0.03 * amplitude, 0.02 * amplitude, 0.01 * amplitude};
}

TEST(AftTest, SamplesAreTheSeries) {
  const std::vector<double> c = Coefficients(1.0);
  const std::vector<double> u = *SamplesOf(c, kHarmonics, 64);
  for (int j = 0; j < 64; ++j) {
    const double tau = 2 * kPi * j / 64;
    double expected = c[0];
    for (int h = 1; h <= 5; ++h) {
      expected += c[2 * h - 1] * std::cos(h * tau) + c[2 * h] * std::sin(h * tau);
    }
    EXPECT_NEAR(u[j], expected, 4e-15) << j;
  }
  // tmdsimpy's lists skip harmonics: {1, 3} has four coefficients and no mean.
  const std::vector<int> odd = {1, 3};
  EXPECT_EQ(CoefficientCount(odd), 4u);
  const std::vector<double> v = *SamplesOf(std::vector<double>{1, 0, 0, 2}, odd, 16);
  EXPECT_NEAR(v[4], std::cos(kPi / 2) + 2 * std::sin(3 * kPi / 2), 1e-15);
}

// A flat punch below gross slip sticks whole: F = k u, so the force's coefficients are k U and
// the Jacobian k times the identity, to round-off.
TEST(AftTest, AStickingElementIsItsStiffness) {
  const ContactConfig punch = SceneOf(*MakeFlatPunch(1e-4));
  const Contact c = *PressForPeriod(punch, 100);
  const double k = c.tangential_stiffness().positive;
  const std::vector<double> u = Coefficients(0.3 * c.mu_kappa() * c.depth());
  const AftResponse r = *ContactAft(punch, 100, u, kHarmonics);
  const std::size_t m = u.size();
  for (std::size_t a = 0; a < m; ++a) {
    EXPECT_NEAR(r.force[a], k * u[a], 1e-13 * k * std::abs(u[1])) << a;
    for (std::size_t b = 0; b < m; ++b) {
      EXPECT_NEAR(r.jacobian[a * m + b], a == b ? k : 0, 1e-13 * k) << a << ", " << b;
    }
  }
  EXPECT_EQ(r.dissipated_energy, 0);
}

// Central differences in each coefficient, where the force is smooth in them (a perturbation of
// 1e-7 of the amplitude moves no reversal across another).
TEST(AftTest, TheJacobianIsTheDifferences) {
  for (const ProfilePtr& profile : {*MakeSphere(0.01), *MakePowerLaw(3e4, 3)}) {
    const ContactConfig config = SceneOf(profile);
    const double u_s = SlipDistance(config, 100);
    for (double relative : {0.2, 0.6, 2.0}) {
      SCOPED_TRACE(profile->Describe() + ", " + std::to_string(relative));
      const std::vector<double> u = Coefficients(relative * u_s);
      const AftResponse r = *ContactAft(config, 100, u, kHarmonics);
      EXPECT_TRUE(r.steady);
      const std::size_t m = u.size();
      double scale = 0;
      for (double v : r.jacobian) scale = std::max(scale, std::abs(v));
      const double step = 1e-7 * relative * u_s;
      AftOptions forces_only;
      forces_only.jacobian = false;
      for (std::size_t b = 0; b < m; ++b) {
        std::vector<double> up = u, down = u;
        up[b] += step, down[b] -= step;
        const AftResponse plus = *ContactAft(config, 100, up, kHarmonics, forces_only);
        const AftResponse minus = *ContactAft(config, 100, down, kHarmonics, forces_only);
        for (std::size_t a = 0; a < m; ++a) {
          const double difference = (plus.force[a] - minus.force[a]) / (2 * step);
          EXPECT_NEAR(r.jacobian[a * m + b], difference, 1e-6 * scale) << a << ", " << b;
        }
      }
    }
  }
}

TEST(AftTest, TheLossAndThePeriodsAgree) {
  const ContactConfig h1 = reference::H1Config(true);
  // H1's reference cycle: a sine of U = 4.6949658143e-7 m makes Q* = 15 N and W = 1.0723816356e-6
  // J. The loss is the work of the force's cosine part against u's sine, W = pi U F_1^c, which
  // the sampled force's coefficient gives to its sampling's accuracy.
  const double amplitude = 4.6949658143e-7;
  const std::vector<double> sine = {0, 0, amplitude, 0, 0, 0, 0, 0, 0, 0, 0};
  const AftResponse r = *ContactAft(h1, 100, sine, kHarmonics);
  EXPECT_NEAR(r.dissipated_energy, 1.0723816356e-6, 1e-9 * 1.0723816356e-6);
  EXPECT_NEAR(kPi * amplitude * r.force[1], r.dissipated_energy, 1e-3 * r.dissipated_energy);
  // Odd harmonics only: a symmetric loop has no even ones nor a mean.
  EXPECT_NEAR(r.force[0], 0, 1e-12 * 15);
  EXPECT_NEAR(r.force[3], 0, 1e-12 * 15);
  EXPECT_NEAR(r.force[4], 0, 1e-12 * 15);
  // 1, 2 and 5 periods marched: the same bits.
  const std::vector<double> u = Coefficients(0.8 * SlipDistance(h1, 100));
  AftOptions two, five;
  two.periodic.warmup_periods = 1;
  five.periodic.warmup_periods = 4;
  const AftResponse a = *ContactAft(h1, 100, u, kHarmonics);
  const AftResponse b = *ContactAft(h1, 100, u, kHarmonics, two);
  const AftResponse c = *ContactAft(h1, 100, u, kHarmonics, five);
  EXPECT_EQ(a.force, b.force);
  EXPECT_EQ(a.force, c.force);
  EXPECT_EQ(a.jacobian, c.jacobian);
}

TEST(AftTest, BadInputIsRefusedNamingTheArgument) {
  const ContactConfig h1 = reference::H1Config(true);
  const std::vector<double> u = Coefficients(1e-7);
  AftOptions odd;
  odd.samples = 100;
  EXPECT_EQ(ContactAft(h1, 100, u, kHarmonics, odd).status().field(), "samples");
  AftOptions few;
  few.samples = 8;  // harmonic 5 needs more than 10
  EXPECT_EQ(ContactAft(h1, 100, u, kHarmonics, few).status().field(), "harmonics[4]");
  const std::vector<int> unordered = {0, 2, 1};
  EXPECT_EQ(ContactAft(h1, 100, std::vector<double>(5), unordered).status().field(),
            "harmonics[2]");
  EXPECT_EQ(ContactAft(h1, 100, std::vector<double>(3), kHarmonics).status().field(),
            "coefficients");
  std::vector<double> bad = u;
  bad[6] = INFINITY;
  EXPECT_EQ(ContactAft(h1, 100, bad, kHarmonics).status().field(), "coefficients[6]");
  EXPECT_EQ(ContactAft(h1, -1, u, kHarmonics).status().field(), "normal_force");
}

}  // namespace
}  // namespace mdr
