// The steady periodic evaluation (periodic.h, issue #51): the loss per period against the
// Mindlin-Deresiewicz closed form of Masing's rule, periods that repeat bit for bit, and the exact
// sensitivities against central finite differences wherever the force is smooth in the samples.
#include "mdr/core/periodic.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <numbers>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/core/material.h"

namespace mdr {
namespace {

constexpr double kPi = std::numbers::pi;

ContactConfig SceneOf(ProfilePtr profile, double friction = 0.3) {
  ContactConfig config = reference::H1Config(true);
  config.profile = std::move(profile);
  config.friction = friction;
  return config;
}

std::vector<double> Sine(int samples, double amplitude, double phase = 0) {
  std::vector<double> u(samples);
  for (int j = 0; j < samples; ++j) u[j] = amplitude * std::sin(2 * kPi * j / samples + phase);
  return u;
}

// A waveform with inner reversals (a third harmonic): nested loops in every period.
std::vector<double> Nested(int samples, double amplitude) {
  std::vector<double> u(samples);
  for (int j = 0; j < samples; ++j) {
    const double t = 2 * kPi * j / samples;
    u[j] = amplitude * (std::sin(t) + 0.45 * std::sin(3 * t + 0.7) + 0.05 * std::cos(2 * t));
  }
  return u;
}

// The slip distance u_s = mu kappa delta of the contact pressed to P.
double SlipDistance(const ContactConfig& config, double normal_force) {
  Contact c = *Contact::Create(config);
  Step press;
  press.normal = NormalControl::kForce;
  press.normal_value = normal_force;
  EXPECT_TRUE(c.Apply(press).ok());
  return c.mu_kappa() * c.depth();
}

// Masing's loss per cycle between -U and U for the virgin curve of a power law g ~ x^n,
// F_v(u) = mu P (1 - r^m), r = 1 - u / u_s, m = 1 + 1/n: W = 8 int_0^U F_v - 4 U F_v(U).
// In long double: at small amplitudes the terms cancel to W ~ U^3 (a million at U = 1e-3 u_s).
double MasingLoss(double mu_p, double u_s, double n, double amplitude) {
  using Long = long double;
  const Long m = 1 + 1 / Long(n), s = Long(amplitude) / u_s, r = 1 - s;
  const Long integral = s - (1 - std::pow(r, m + 1)) / (m + 1);
  return static_cast<double>(mu_p * u_s * (8 * integral - 4 * s * (1 - std::pow(r, m))));
}

TEST(PeriodicTest, TheLossPerPeriodIsMindlinDeresiewiczs) {
  struct Case {
    ProfilePtr profile;
    double n;
  };
  for (const Case& c :
       {Case{*MakeSphere(0.01), 2}, Case{*MakePowerLaw(3e4, 3), 3}, Case{*MakeCone(0.1), 1}}) {
    const ContactConfig config = SceneOf(c.profile);
    const double u_s = SlipDistance(config, 100);
    for (double relative : {1e-3, 0.01, 0.2, 0.7, 0.999}) {
      SCOPED_TRACE(c.profile->Describe() + ", U/u_s = " + std::to_string(relative));
      const PeriodicResponse r = *SteadyPeriod(config, 100, Sine(128, relative * u_s));
      EXPECT_TRUE(r.steady);
      const double expected = MasingLoss(0.3 * 100, u_s, c.n, relative * u_s);
      // The engine's loss carries an absolute error of about eps mu P U (docs/dynamics.md), so
      // relative to W ~ U^3 it grows like (u_s / U)^2: 4e-11 at U = 1e-3 u_s, 3e-13 at 1e-2.
      const double tolerance = relative < 0.01 ? 5e-10 : 1e-12;
      EXPECT_NEAR(r.dissipated_energy, expected, tolerance * expected);
      // The force at the amplitude's samples: the virgin curve at U.
      const double peak = 0.3 * 100 * (1 - std::pow(1 - relative, 1 + 1 / c.n));
      EXPECT_NEAR(r.force[32], peak, 1e-12 * peak);
      EXPECT_NEAR(r.force[96], -peak, 1e-12 * peak);
    }
  }
  // H1's reference cycle: Q* = 15 N at u0 = 4.6949658143e-7 m, W = 1.0723816356e-6 J.
  const PeriodicResponse h1 =
      *SteadyPeriod(reference::H1Config(true), 100, Sine(64, 4.6949658143e-7));
  EXPECT_NEAR(h1.force[16], 15, 1e-9 * 15);
  EXPECT_NEAR(h1.dissipated_energy, 1.0723816356e-6, 1e-9 * 1.0723816356e-6);
}

TEST(PeriodicTest, PeriodsRepeatBitForBit) {
  const ContactConfig config = SceneOf(*MakeSphere(0.01));
  const std::vector<double> u = Nested(128, 0.6 * SlipDistance(config, 100));
  // 1, 2 and 5 periods marched (the recorded one included).
  PeriodicOptions once, twice, five;
  twice.warmup_periods = 1;
  five.warmup_periods = 4;
  const PeriodicResponse a = *SteadyPeriod(config, 100, u, once);
  const PeriodicResponse b = *SteadyPeriod(config, 100, u, twice);
  const PeriodicResponse c = *SteadyPeriod(config, 100, u, five);
  EXPECT_TRUE(a.steady && b.steady && c.steady);
  EXPECT_EQ(a.force, b.force);
  EXPECT_EQ(a.force, c.force);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.dissipated_energy),
            std::bit_cast<std::uint64_t>(c.dissipated_energy));
  EXPECT_EQ(a.jacobian.column, c.jacobian.column);
  EXPECT_EQ(a.jacobian.value, c.jacobian.value);
  // Near gross slip the virgin start's memory differs from the loop's by round-off: the first
  // period does not end where it began, and is marched again; any warm-up gives the same bits.
  const ContactConfig cubic = SceneOf(*MakePowerLaw(3e4, 3));
  const std::vector<double> near = Sine(128, 0.999 * SlipDistance(cubic, 100));
  const PeriodicResponse first = *SteadyPeriod(cubic, 100, near, once);
  const PeriodicResponse later = *SteadyPeriod(cubic, 100, near, five);
  EXPECT_TRUE(first.steady && later.steady);
  EXPECT_EQ(first.periods, 2);
  EXPECT_EQ(first.force, later.force);
  // The same period started anywhere: the forces move with the samples.
  std::vector<double> shifted(u.begin() + 37, u.end());
  shifted.insert(shifted.end(), u.begin(), u.begin() + 37);
  const PeriodicResponse d = *SteadyPeriod(config, 100, shifted);
  for (std::size_t j = 0; j < u.size(); ++j) {
    EXPECT_EQ(d.force[j], a.force[(j + 37) % u.size()]) << j;
  }
}

// Central differences of the forces against the samples, column by column, against the exact
// sparse rows: to 1e-6 of the largest stiffness, for waveforms whose turning points are clear of
// their neighbours (a perturbation creates or removes no reversal).
// Returns how many entries off the diagonal the rows hold.
int ExpectJacobianIsTheDifferences(const ContactConfig& config, double normal_force,
                                   const std::vector<double>& u, double step) {
  const PeriodicResponse exact = *SteadyPeriod(config, normal_force, u);
  double scale = 0;
  for (double v : exact.jacobian.value) scale = std::max(scale, std::abs(v));
  EXPECT_GT(scale, 0);
  const std::size_t n = u.size();
  int off_diagonal = 0;
  for (std::size_t j = 0; j < n; ++j) {
    std::vector<double> up = u, down = u;
    up[j] += step, down[j] -= step;
    PeriodicOptions forces_only;
    forces_only.jacobian = false;
    const PeriodicResponse plus = *SteadyPeriod(config, normal_force, up, forces_only);
    const PeriodicResponse minus = *SteadyPeriod(config, normal_force, down, forces_only);
    for (std::size_t i = 0; i < n; ++i) {
      const double difference = (plus.force[i] - minus.force[i]) / (2 * step);
      EXPECT_NEAR(exact.jacobian.At(i, j), difference, 1e-6 * scale)
          << "dF_" << i << "/du_" << j << " " << config.profile->Describe();
      off_diagonal += i != j && exact.jacobian.At(i, j) != 0;
    }
  }
  return off_diagonal;
}

TEST(PeriodicTest, TheSensitivitiesAreTheFiniteDifferences) {
  for (const ProfilePtr& profile :
       {*MakeSphere(0.01), *MakeCone(0.1), *MakePowerLaw(3e4, 3), *MakeFlatPunch(1e-4)}) {
    const ContactConfig config = SceneOf(profile);
    const double u_s = SlipDistance(config, 100);
    const bool punch = profile->RadiusAtDepth(0) > 0;
    for (double relative : {0.3, 0.9, 2.5}) {  // partial slip, near and beyond gross slip
      SCOPED_TRACE(profile->Describe() + ", " + std::to_string(relative));
      const int off_diagonal =
          ExpectJacobianIsTheDifferences(config, 100, Nested(48, relative * u_s), 1e-7 * u_s);
      // In partial slip every row remembers turning points; a punch sticks whole below gross
      // slip (its rows are the stiffness alone; the waveform peaks at 1.33 of its amplitude).
      if (!punch && relative < 1) {
        EXPECT_GT(off_diagonal, 24);
      }
      if (punch && relative < 0.5) {
        EXPECT_EQ(off_diagonal, 0);
      }
      if (relative > 1) {
        EXPECT_GT(off_diagonal, 0);
      }
    }
  }
}

// In full stick (a flat punch below gross slip: a smooth profile's edge always slips) every spring
// follows u: each row is the contact's stiffness on the diagonal, exactly, and nothing else.
TEST(PeriodicTest, InFullStickTheSensitivitiesAreTheStiffness) {
  const ContactConfig config = SceneOf(*MakeFlatPunch(1e-4));
  Contact c = *Contact::Create(config);
  Step press;
  press.normal = NormalControl::kForce;
  press.normal_value = 100;
  ASSERT_TRUE(c.Apply(press).ok());
  const double stiffness = c.tangential_stiffness().positive;
  const PeriodicResponse r = *SteadyPeriod(config, 100, Nested(32, 0.5 * c.mu_kappa() * c.depth()));
  EXPECT_EQ(r.dissipated_energy, 0);
  for (std::size_t i = 0; i < 32; ++i) {
    ASSERT_EQ(r.jacobian.row_begin[i + 1] - r.jacobian.row_begin[i], 1u) << i;
    EXPECT_EQ(r.jacobian.At(i, i), stiffness);
  }
}

// Contacts pressed apart (an interface's asperities under a shared approach) add up.
TEST(PeriodicTest, ContactsAddUp) {
  std::vector<Contact> pressed;
  PeriodicResponse sum;
  const std::vector<double> u = Nested(40, 3e-7);
  for (double depth : {2e-6, 3.5e-6, 5e-6, -1e-6}) {
    Contact c = *Contact::Create(SceneOf(*MakeSphere(0.01)));
    ASSERT_TRUE(c.MoveTo(depth, 0).ok());
    pressed.push_back(c);
  }
  const PeriodicResponse all = *SteadyPeriod(pressed, u);
  std::vector<double> force(u.size(), 0);
  double energy = 0;
  for (const Contact& c : pressed) {
    const PeriodicResponse one = *SteadyPeriod(std::vector<Contact>{c}, u);
    for (std::size_t j = 0; j < u.size(); ++j) force[j] += one.force[j];
    energy += one.dissipated_energy;
    for (std::size_t i = 0; i < u.size(); ++i) {
      for (std::size_t j = 0; j < u.size(); ++j) {
        if (one.jacobian.At(i, j) != 0) {
          EXPECT_NE(all.jacobian.At(i, j), 0);
        }
      }
    }
  }
  EXPECT_EQ(all.force, force);
  EXPECT_DOUBLE_EQ(all.dissipated_energy, energy);
}

TEST(PeriodicTest, BadInputIsRefusedNamingTheField) {
  const ContactConfig config = SceneOf(*MakeSphere(0.01));
  std::vector<double> u = Sine(16, 1e-7);
  EXPECT_EQ(SteadyPeriod(config, 100, std::vector<double>{1e-7}).status().field(), "displacement");
  u[3] = NAN;
  EXPECT_EQ(SteadyPeriod(config, 100, u).status().field(), "displacement[3]");
  u[3] = 2;
  EXPECT_EQ(SteadyPeriod(config, 100, u).status().field(), "displacement[3]");
  u = Sine(16, 1e-7);
  EXPECT_EQ(SteadyPeriod(config, 0, u).status().field(), "normal_force");
  ContactConfig rig = config;
  rig.rig.tangential = 1e-8;
  EXPECT_EQ(SteadyPeriod(rig, 100, u).status().field(), "rig");
  ContactConfig grid = config;
  grid.method = Method::kGrid;
  grid.grid_size = 64;
  grid.grid_max_radius = 1e-3;
  EXPECT_EQ(SteadyPeriod(grid, 100, u).status().field(), "method");
  PeriodicOptions negative;
  negative.warmup_periods = -1;
  EXPECT_EQ(SteadyPeriod(config, 100, u, negative).status().field(), "warmup_periods");
  PeriodicOptions few;
  few.max_periods = 0;
  EXPECT_EQ(SteadyPeriod(config, 100, u, few).status().field(), "max_periods");
}

}  // namespace
}  // namespace mdr
