// Slip state after loading reversals against the closed forms (issue #23; docs/physics.md,
// "Slip zone and stiffness after reversals"). For every profile kind and both material kinds, at
// random normal loads and amplitudes from 1e-3 to 0.999 of gross slip, the canonical
// Mindlin-Deresiewicz histories (loading, unloading, partial reloading, the return to an inner
// turning point, full reloading, by displacement and by force) must give after every step the
// slip annulus [c, a] and its direction, both tangential stiffnesses (2 G* c toward the slip,
// 2 G* a the other way) to 1e-12, and Jäger weights of exactly the slip direction on the annulus.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "fixtures/slip_state_check.h"
#include "mdr/core/contact.h"
#include "mdr/core/jager.h"
#include "mdr/core/tabulated_profile.h"
#include "test_util.h"

namespace mdr {
namespace {

// A profile with its closed-form inverse g^-1 and F_N(c)/F_N(a) (power laws: (c/a)^(n+1)).
struct ProfileCase {
  std::string name;
  ProfilePtr profile;
  // Radius of the springs at depth z, independent of the profile code (tabulated: the profile's
  // own g^-1, whose accuracy is the spline's; the slip state is checked in z all the same).
  std::function<double(double)> radius_at;
  double exponent;  // n of F_N ~ a^(n+1); 0: flat punch (no partial slip)
};

std::vector<ProfileCase> ProfileCases(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<ProfileCase> cases;
  const double radius = 1e-3 * std::pow(1e3, unit(rng));  // 1 mm .. 1 m
  cases.push_back(
      {"sphere", *MakeSphere(radius), [=](double z) { return std::sqrt(radius * z); }, 2});
  const double angle = 0.05 + 1.3 * unit(rng);
  const double cone_k = std::numbers::pi / 2 * std::tan(angle);
  cases.push_back({"cone", *MakeCone(angle), [=](double z) { return z / cone_k; }, 1});
  for (double n : {0.5, 1.5, 3.0, 8.0}) {
    const double c = std::pow(10.0, 2 - 2 * unit(rng));
    const double k =
        c * std::sqrt(std::numbers::pi) * std::tgamma(n / 2 + 1) / std::tgamma(n / 2 + 0.5);
    cases.push_back({"power law n = " + std::to_string(n), *MakePowerLaw(c, n),
                     [=](double z) { return std::pow(z / k, 1 / n); }, n});
  }
  const double a0 = 1e-4 * std::pow(1e3, unit(rng));
  cases.push_back({"flat punch", *MakeFlatPunch(a0), [=](double) { return a0; }, 0});
  std::vector<double> r, f;  // a sampled sphere
  for (int i = 0; i <= 400; ++i) {
    r.push_back(i * 2.5e-6);
    f.push_back(r.back() * r.back() / (2 * 0.01));
  }
  ProfilePtr tabulated = *MakeTabulatedProfile(r, f);
  cases.push_back(
      {"tabulated sphere", tabulated, [=](double z) { return tabulated->RadiusAtDepth(z); }, 2});
  return cases;
}

EffectiveMaterial RandomMaterial(std::mt19937_64& rng, bool pair) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double modulus = 1e6 * std::pow(1e6, unit(rng)), nu = 0.5 * unit(rng);
  if (!pair) return *RigidOnHalfSpace(modulus, nu);
  return *ElasticPair(modulus, nu, modulus * std::pow(10.0, 2 * unit(rng) - 1), 0.5 * unit(rng));
}

// The state a step must leave: the slip annulus from depth z_c (its direction +1, -1), or none.
struct Expected {
  int direction = 0;
  double z_c = 0;
};

// Checks the contact against the expected state: slip interval, stiffnesses, weights.
::testing::AssertionResult MatchesClosedForm(const Contact& c, const ProfileCase& p,
                                             const Expected& expected) {
  const double a = c.contact_radius(), k = 2 * c.config().material.g_star;
  const std::vector<SlipInterval> slip = c.slip_intervals();
  const TangentialStiffness stiffness = c.tangential_stiffness();
  auto near = [](double value, double want, double tolerance) {
    return std::abs(value - want) <= tolerance * std::abs(want);
  };
  if (expected.direction == 0) {
    if (!slip.empty()) return ::testing::AssertionFailure() << "slips, expected stick";
    if (!near(stiffness.positive, k * a, 1e-12) || !near(stiffness.negative, k * a, 1e-12)) {
      return ::testing::AssertionFailure() << "stiffness of a sticking contact is not 2 G* a";
    }
    return ::testing::AssertionSuccess();
  }
  const double c_radius = p.radius_at(expected.z_c);
  if (slip.size() != 1 || slip[0].direction != expected.direction) {
    return ::testing::AssertionFailure()
           << slip.size() << " slip intervals, expected one in direction " << expected.direction;
  }
  if (!near(slip[0].r_begin, c_radius, 1e-12) || slip[0].r_end != a) {
    return ::testing::AssertionFailure()
           << "slip interval [" << slip[0].r_begin << ", " << slip[0].r_end << "], expected ["
           << c_radius << ", " << a << "]";
  }
  const double toward = expected.direction > 0 ? stiffness.positive : stiffness.negative;
  const double away = expected.direction > 0 ? stiffness.negative : stiffness.positive;
  if (!near(toward, k * c_radius, 1e-12) || away != k * a) {
    return ::testing::AssertionFailure()
           << "stiffness toward the slip " << toward << " (expected " << k * c_radius << "), away "
           << away << " (expected " << k * a << ")";
  }
  const JagerWeights weights = *ComputeJagerWeights(c);
  for (const WeightInterval& w : weights.intervals) {
    if (std::abs(w.weight) > 1) return ::testing::AssertionFailure() << "weight " << w.weight;
    if (w.r_begin >= slip[0].r_begin && w.weight != expected.direction) {
      return ::testing::AssertionFailure() << "weight " << w.weight << " on the slip annulus";
    }
  }
  return ::testing::AssertionSuccess();
}

Step Displacement(double ux) {
  Step s;
  s.tangential = TangentialControl::kDisplacement;
  s.tangential_value = ux;
  return s;
}

Step TangentialForce(double fx) {
  Step s;
  s.tangential = TangentialControl::kForce;
  s.tangential_value = fx;
  return s;
}

// The canonical histories at amplitude s (of gross slip) from the virgin state: each step and
// the state it must leave. Displacement: amplitude A = s mu kappa delta, the slip annulus after
// a move of D from the last turning point (or A from virgin) from g(c) = delta - D / (2 mu
// kappa) (D / (mu kappa) from virgin). Force: amplitude T = s mu F_N, g(c) from F_N(c) = F_N -
// (F* - F) / (2 mu) (F / mu from virgin), F_N(c) = F_N (c / a)^(n+1).
struct HistoryStep {
  Step step;
  Expected expected;
};

std::vector<HistoryStep> DisplacementHistory(const Contact& c, double s) {
  const double d = c.depth(), mk = c.mu_kappa(), amplitude = s * mk * d;
  auto annulus = [&](int direction, double travel) {
    return Expected{direction, d - travel / (2 * mk)};
  };
  return {{Displacement(amplitude), annulus(+1, 2 * amplitude)},
          {Displacement(-amplitude), annulus(-1, 2 * amplitude)},
          {Displacement(amplitude / 2), annulus(+1, 1.5 * amplitude)},
          {Displacement(-amplitude), annulus(-1, 2 * amplitude)},  // inner loop closes
          {Displacement(amplitude), annulus(+1, 2 * amplitude)},   // main loop closes
          {Displacement(0), annulus(-1, amplitude)},
          {Displacement(amplitude), annulus(+1, 2 * amplitude)}};
}

std::vector<HistoryStep> ForceHistory(const Contact& c, const ProfileCase& p, double s) {
  const double fn = c.normal_force(), mu = c.config().friction, a = c.contact_radius();
  const double amplitude = s * mu * fn;
  // The annulus whose inner springs carry F_N(c) = F_N - drop.
  auto annulus = [&](int direction, double drop) {
    const double c_over_a = std::pow(1 - drop / fn, 1 / (p.exponent + 1));
    return Expected{direction, c.config().profile->G(c_over_a * a)};
  };
  return {{TangentialForce(amplitude), annulus(+1, amplitude / mu)},
          {TangentialForce(-amplitude), annulus(-1, amplitude / mu)},
          {TangentialForce(amplitude / 2), annulus(+1, 0.75 * amplitude / mu)},
          {TangentialForce(-amplitude), annulus(-1, amplitude / mu)},
          {TangentialForce(amplitude), annulus(+1, amplitude / mu)}};
}

TEST(SlipStateTest, ReversalsMatchTheClosedFormsForEveryProfileAndMaterial) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> unit(0, 1);
  long states = 0, slipping = 0;
  for (int round = 0; round < 1000; ++round) {
    const double s = 1e-3 * std::pow(999.0, unit(rng));  // 1e-3 .. 0.999 of gross slip
    for (bool pair : {false, true})
      for (const ProfileCase& p : ProfileCases(rng)) {
        const EffectiveMaterial material = RandomMaterial(rng, pair);
        ContactConfig config;
        config.profile = p.profile;
        config.material = material;
        config.friction = 0.05 + 1.5 * unit(rng);
        Contact fresh = std::move(Contact::Create(config)).value();
        // A random normal load: the force at a depth of 1e-7 .. 5e-5 m (the tabulated sphere's
        // samples reach a contact radius of 1 mm, depth 1e-4 m).
        Step load;
        load.normal = NormalControl::kForce;
        load.normal_value = fresh.NormalForceAtDepth(1e-7 * std::pow(500.0, unit(rng)));
        ASSERT_TRUE(fresh.Apply(load).ok());
        const bool has_force_form = p.exponent > 0 && p.name != "tabulated sphere";
        for (bool by_force : {false, true}) {
          if (by_force && !has_force_form && p.exponent != 0) continue;
          Contact c = fresh;
          const std::vector<HistoryStep> history =
              by_force ? ForceHistory(c, p, s) : DisplacementHistory(c, s);
          for (std::size_t i = 0; i < history.size(); ++i) {
            const Contact before = c;
            StepReport report;
            ASSERT_TRUE(c.Apply(history[i].step, &report).ok());
            // A flat punch has no partial slip: it sticks below the slip limit.
            const Expected expected = p.exponent == 0 ? Expected{} : history[i].expected;
            ASSERT_TRUE(MatchesClosedForm(c, p, expected))
                << p.name << (pair ? ", elastic pair" : ", rigid on half-space") << ", s = " << s
                << (by_force ? ", by force" : ", by displacement") << ", step " << i;
            const std::string consistent = testing::SlipStateViolation(before, c, true);
            ASSERT_TRUE(consistent.empty()) << consistent;
            ++states;
            slipping += expected.direction != 0;
          }
        }
      }
  }
  std::printf("[ slip ] %ld states against the closed forms (%ld with a slip annulus)\n", states,
              slipping);
  EXPECT_GT(slipping, 150000);
}

// The reversal of the reproduction (H1, A = k * 1e-8 m): before the fix, 30 of the 40
// amplitudes reported full stick toward -x after 0 -> +A -> -A.
TEST(SlipStateTest, TheReportedReversalsSlipBackwards) {
  for (int k = 1; k <= 40; ++k) {
    Contact c = testing::MakeContact(*MakeSphere(0.01), *ElasticPair(210e9, 0.3, 210e9, 0.3), 0.3);
    Step load;
    load.normal = NormalControl::kForce;
    load.normal_value = 100;
    ASSERT_TRUE(c.Apply(load).ok());
    const double amplitude = k * 1e-8;
    ASSERT_TRUE(c.Apply(Displacement(amplitude)).ok());
    ASSERT_TRUE(c.Apply(Displacement(-amplitude)).ok());
    const double z_c = c.depth() - amplitude / c.mu_kappa();
    const std::vector<SlipInterval> slip = c.slip_intervals();
    ASSERT_EQ(slip.size(), 1u) << "k = " << k;
    EXPECT_EQ(slip[0].direction, -1);
    EXPECT_NEAR(c.tangential_stiffness().negative,
                2 * c.config().material.g_star * std::sqrt(0.01 * z_c),
                1e-12 * c.tangential_stiffness().positive)
        << "k = " << k;
    EXPECT_EQ(ComputeJagerWeights(c)->intervals.back().weight, -1) << "k = " << k;
  }
}

}  // namespace
}  // namespace mdr
