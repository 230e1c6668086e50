// The stiff and extreme cases of docs/physics.md: each must stay finite and exact.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "fixtures/slip_state_check.h"
#include "mdr/core/contact.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::MakeContact;
using testing::NormalForceStep;
using testing::RelNear;
using testing::TangentialForceStep;

double CattaneoMindlin(const Contact& c, double d, double ux) {
  return c.config().friction *
         (c.NormalForceAtDepth(d) - c.NormalForceAtDepth(d - ux / c.mu_kappa()));
}

TEST(ExtremeTest, PoissonRatioLimits) {
  for (double nu : {0.5, 0.0}) {
    Contact c = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(80e9, nu), 0.3);
    const double d = 1e-6, ux = 0.5 * c.mu_kappa() * d;
    ASSERT_TRUE(c.MoveTo(d, ux).ok());  // oblique ramp within the cone: complete stick
    EXPECT_TRUE(RelNear(c.tangential_force() / c.normal_force(), 0.5 * 0.3, 1e-12)) << nu;
    ASSERT_TRUE(c.MoveTo(d, ux * 1.5).ok());
    EXPECT_TRUE(std::isfinite(c.tangential_force()));
  }
}

TEST(ExtremeTest, ZeroFrictionCarriesNoTangentialForce) {
  Contact c = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(80e9, 0.3), 0.0);
  ASSERT_TRUE(c.MoveTo(1e-6, 1e-6).ok());
  EXPECT_EQ(c.tangential_force(), 0);
  EXPECT_EQ(c.dissipated_energy(), 0);
  EXPECT_EQ(c.memory().vertex_count(), 2u);
  EXPECT_EQ(c.tangential_stiffness().positive, 0);
  EXPECT_TRUE(c.Apply(TangentialForceStep(0)).ok());
  Status s = c.Apply(TangentialForceStep(1e-9));
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("mu F_N = 0"), std::string::npos) << s.message();
}

TEST(ExtremeTest, HugeFrictionTendsToCompleteStick) {
  Contact c = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(80e9, 0.3), 1e6);
  ASSERT_TRUE(c.Apply(NormalForceStep(10)).ok());
  const double d = c.depth(), ux = 1e-5;
  ASSERT_TRUE(c.MoveTo(d, ux).ok());
  // Springs at the very edge (w -> 0) still slip: an annulus of width ux/(mu kappa) in z.
  EXPECT_TRUE(RelNear(c.tangential_force(), testing::CattaneoMindlinPowerLaw(c, 2, d, ux), 1e-12));
  const double full_stick = 2 * c.config().material.g_star * c.contact_radius() * ux;
  EXPECT_TRUE(RelNear(c.tangential_force(), full_stick, ux / (c.mu_kappa() * d)));
  EXPECT_LT(c.dissipated_energy(), 1e-5 * c.tangential_force() * ux);
  ASSERT_TRUE(c.Apply(TangentialForceStep(-3.5)).ok());
  EXPECT_TRUE(RelNear(c.tangential_force(), -3.5, 1e-12));
}

TEST(ExtremeTest, IncrementsFromTinyToGrossSlipInOneStep) {
  Contact base = MakeContact(*MakeSphere(0.01), *ElasticPair(210e9, 0.3, 210e9, 0.3), 0.3);
  ASSERT_TRUE(base.Apply(NormalForceStep(100)).ok());
  const double d = base.depth(), slip = base.mu_kappa() * d;
  ASSERT_TRUE(base.MoveTo(d, 0.3 * slip).ok());
  for (double frac : {1e-12, 1e-9, 1e-6, 1e-3, 0.1, 0.69}) {
    Contact c = base;
    const double ux = (0.3 + frac) * slip;
    ASSERT_TRUE(c.MoveTo(d, ux).ok());
    EXPECT_TRUE(RelNear(c.tangential_force(), CattaneoMindlin(c, d, ux), 1e-12)) << frac;
    EXPECT_GE(c.last_step_dissipation(), 0);
    // The dissipation of a tiny step is third order in it, and finite.
    EXPECT_TRUE(std::isfinite(c.last_step_dissipation()));
  }
  Contact c = base;
  ASSERT_TRUE(c.MoveTo(d, 5 * slip).ok());
  EXPECT_TRUE(RelNear(c.tangential_force(), c.friction_limit(), 1e-14));
  // Tiny reversal from the gross-slip state: Mindlin-Deresiewicz to first order.
  ASSERT_TRUE(c.MoveTo(d, 5 * slip - 1e-12 * slip).ok());
  EXPECT_TRUE(RelNear(
      c.tangential_force(),
      c.friction_limit() - 2 * 0.3 * (c.normal_force() - c.NormalForceAtDepth(d - 1e-12 * d / 2)),
      1e-12));
}

TEST(ExtremeTest, PowerLawExponentLimitsMatchEnergyFormula) {
  for (double n : {0.5, 8.0}) {
    const double mu = 0.3, d = 1e-6, s = 0.5;
    Contact c = MakeContact(*MakePowerLaw(1.0, n), *RigidOnHalfSpace(1e9, 0.3), mu);
    ASSERT_TRUE(c.MoveTo(d, 0).ok());
    const double fn = c.normal_force(), kappa = c.mu_kappa() / mu;
    const double ux_star = c.mu_kappa() * d * (1 - std::pow(1 - s, n / (n + 1)));
    ASSERT_TRUE(c.MoveTo(d, ux_star).ok());
    EXPECT_TRUE(RelNear(c.tangential_force(), s * mu * fn, 1e-12)) << n;
    const double w0 = c.dissipated_energy();
    ASSERT_TRUE(c.MoveTo(d, -ux_star).ok());
    ASSERT_TRUE(c.MoveTo(d, ux_star).ok());
    const double expected = mu * mu * fn * kappa * d * testing::EnergyPerCycleRatio(n, s);
    EXPECT_TRUE(RelNear(c.dissipated_energy() - w0, expected, 1e-11)) << n;
  }
}

TEST(ExtremeTest, ModuliAndDepthsOverTwelveDecades) {
  for (double modulus : {1e6, 1e9, 1e12}) {
    for (double d : {1e-9, 1e-6, 1e-3}) {
      Contact c = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(modulus, 0.3), 0.3);
      const double ux = 0.4 * c.mu_kappa() * d;
      ASSERT_TRUE(c.MoveTo(d, 0).ok());
      ASSERT_TRUE(c.MoveTo(d, ux).ok());
      EXPECT_TRUE(RelNear(c.tangential_force(), CattaneoMindlin(c, d, ux), 1e-12))
          << modulus << " " << d;
      ASSERT_TRUE(c.Apply(TangentialForceStep(-0.2 * c.friction_limit())).ok());
      EXPECT_TRUE(RelNear(c.tangential_force(), -0.2 * c.friction_limit(), 1e-12));
      EXPECT_GT(c.dissipated_energy(), 0);
    }
  }
}

TEST(ExtremeTest, MillionMindlinDeresiewiczCyclesDoNotDrift) {
  Contact c = MakeContact(*MakeSphere(0.01), *ElasticPair(210e9, 0.3, 210e9, 0.3), 0.3);
  ASSERT_TRUE(c.Apply(NormalForceStep(100)).ok());
  const double d = c.depth(), amp = 0.6 * c.mu_kappa() * d;
  ASSERT_TRUE(c.MoveTo(d, amp).ok());
  double first_min = 0, first_max = 0, first_energy = 0;
  std::size_t max_vertices = 0;
  for (int cycle = 0; cycle < 1000000; ++cycle) {
    double energy = 0;
    for (double target : {-1.0, 0.3, 0.1, 1.0}) {  // a nested inner reversal each cycle
      ASSERT_TRUE(c.MoveTo(d, target * amp).ok());
      energy += c.last_step_dissipation();
      if (target == -1.0 && cycle == 0) first_min = c.tangential_force();
      if (target == -1.0 && cycle % 1000 == 999) {
        ASSERT_TRUE(RelNear(c.tangential_force(), first_min, 1e-12)) << cycle;
      }
    }
    max_vertices = std::max(max_vertices, c.memory().vertex_count());
    if (cycle == 0) {
      first_max = c.tangential_force(), first_energy = energy;
    } else if (cycle % 1000 == 999) {
      ASSERT_TRUE(RelNear(c.tangential_force(), first_max, 1e-12)) << cycle;
      ASSERT_TRUE(RelNear(energy, first_energy, 1e-12)) << cycle;
    }
  }
  EXPECT_LE(max_vertices, 6u);
}

TEST(ExtremeTest, NoNanOrInfinityLeavesTheEngine) {
  Contact c = MakeContact(*MakeCone(0.3), *RigidOnHalfSpace(1e9, 0.5), 0.5);
  const double big = 1e300;
  EXPECT_FALSE(c.MoveTo(std::numeric_limits<double>::infinity(), 0).ok());
  ASSERT_TRUE(c.MoveTo(1e-6, big).ok());
  EXPECT_TRUE(std::isfinite(c.tangential_force()));
  EXPECT_TRUE(RelNear(c.tangential_force(), c.friction_limit(), 1e-12));
  EXPECT_TRUE(std::isfinite(c.dissipated_energy()));
}

}  // namespace
}  // namespace mdr

namespace mdr {
namespace {

TEST(ExtremeTest, LiftOffWhoseTangentialRateEqualsTheBoundRateDissipatesNothing) {
  // Found by the engine fuzzer: a spring on the bound whose tangential motion exactly keeps pace
  // with the shrinking bound never slides; round-off used to give 0/0 here.
  for (ProfilePtr profile : {*MakeFlatPunch(0.01), *MakeSphere(0.01)}) {
    Contact c = testing::MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.5);
    const double d = 1e-6, m = c.mu_kappa();
    ASSERT_TRUE(c.MoveTo(d, 0).ok());
    ASSERT_TRUE(c.MoveTo(d, 2 * m * d).ok());  // gross slip: every spring on the upper bound
    ASSERT_TRUE(c.MoveTo(-d, 2 * m * d - m * 2 * d).ok());  // dux = mu kappa ddelta, to lift-off
    EXPECT_TRUE(std::isfinite(c.dissipated_energy()));
    EXPECT_NEAR(c.last_step_dissipation(), 0, 1e-12 * c.dissipated_energy());
  }
}

}  // namespace
}  // namespace mdr

namespace mdr {
namespace {

TEST(ExtremeTest, ForceStepAfterLongSlidingStaysCheapAndExact) {
  // Found by the request fuzzer: after sliding 851 m (|ux| ~ 1e10 times mu kappa delta), a curved
  // force path ran to the bisection cap for minutes, because a root in ux carried eps |ux| of
  // noise. The solver's unknown is now the increment.
  Contact c = testing::SteelSphere();
  ASSERT_TRUE(c.Apply(testing::NormalForceStep(100)).ok());
  ASSERT_TRUE(c.Apply(testing::TangentialForceStep(-5)).ok());
  ASSERT_TRUE(c.MoveTo(1.6241224783242103e-07, 851.3675989857666).ok());
  Step step;
  step.normal = NormalControl::kForce;
  step.normal_value = 80.54688743967563;
  step.tangential = TangentialControl::kForce;
  step.tangential_value = -10.499999999068677;
  StepReport report;
  ASSERT_TRUE(c.Apply(step, &report).ok());
  EXPECT_TRUE(testing::RelNear(c.tangential_force(), -10.499999999068677, 1e-12));
  EXPECT_TRUE(testing::RelNear(c.normal_force(), 80.54688743967563, 1e-12));
  EXPECT_LE(report.substeps, 16);
  EXPECT_LE(report.path_error, c.config().force_path_tolerance);
}

}  // namespace
}  // namespace mdr

namespace mdr {
namespace {

TEST(ExtremeTest, SubnormalDepthsGiveFiniteForces) {
  // Found by the request fuzzer (a contact list stepped to a depth of 4 subnormals): a sphere's
  // contact radius underflows to 0 there, and the memory's integral used to be 0 * inf = NaN.
  const double tiny = std::numeric_limits<double>::denorm_min();
  for (ProfilePtr profile : {*MakeSphere(0.02), *MakeSphere(1e-4), *MakeCone(1.2),
                             *MakePowerLaw(10, 3), *MakePowerLaw(10, 0.5), *MakeFlatPunch(1e-3)}) {
    for (const double depth : {tiny, 4 * tiny, 1e-320, 1e-310}) {
      for (const bool loaded : {false, true}) {
        Contact c = testing::MakeContact(profile, *ElasticPair(210e9, 0.3, 210e9, 0.3), 0.3);
        if (loaded) {
          ASSERT_TRUE(c.MoveTo(4e-6, 5e-8).ok());  // partly slipping memory
        }
        for (const double ux : {0.0, 1e-309, 1e-7}) {
          const Contact before = c;
          ASSERT_TRUE(c.MoveTo(depth, ux).ok());
          SCOPED_TRACE(profile->Describe() + " depth " + std::to_string(depth / tiny) +
                       " subnormals, ux " + std::to_string(ux));
          EXPECT_EQ(testing::SlipStateViolation(before, c, true), "");
          EXPECT_TRUE(std::isfinite(c.normal_force()));
          EXPECT_TRUE(std::isfinite(c.tangential_force()));
          EXPECT_LE(std::abs(c.tangential_force()), c.friction_limit() * (1 + 1e-9) + 1e-300);
          EXPECT_TRUE(std::isfinite(c.dissipated_energy()));
          EXPECT_TRUE(std::isfinite(c.tangential_stiffness().positive) &&
                      std::isfinite(c.tangential_stiffness().negative));
          EXPECT_TRUE(Contact::Restore(c.config(), c.Snapshot()).ok());
        }
      }
    }
  }
}

}  // namespace
}  // namespace mdr

namespace mdr {
namespace {

// Found by the C interface's fuzzer: every state a step leaves must restore from its snapshot.
// Two finite increments of -1.5e308 m overflow ux; and a history from a depth of 90 m (and a
// displacement of 55 m) back to microns rounds the memory at the large scale, beyond the friction
// cone's slack. Both steps are refused and change nothing (bit for bit), and every accepted
// state restores.
TEST(ExtremeTest, StepsWhoseStateCouldNotBeRestoredAreRefused) {
  const auto restores = [](const Contact& c) {
    return Contact::Restore(c.config(), c.Snapshot()).ok();
  };
  const auto same = [](const ContactSnapshot& a, const ContactSnapshot& b) {
    return a.depth == b.depth && a.tangential_displacement == b.tangential_displacement &&
           a.dissipated_energy == b.dissipated_energy && a.z == b.z && a.u == b.u &&
           a.tags == b.tags;
  };
  Contact overflow = testing::MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(80e9, 0.3), 0.3);
  const Step down{NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement,
                  -1.5e308};
  ASSERT_TRUE(overflow.Apply(down).ok());
  const ContactSnapshot before = overflow.Snapshot();
  const Status refused = overflow.Apply(down);
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(refused.field(), "displacement_increment");
  EXPECT_TRUE(same(overflow.Snapshot(), before));
  EXPECT_TRUE(restores(overflow));

  // H1, then the fuzzer's history.
  Contact c = testing::SteelSphere();
  const Step history[] = {
      {NormalControl::kDepth, 3e-6, TangentialControl::kDisplacement, 2e-7},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kForce, -19.213867187500547},
      {NormalControl::kDepthIncrement, 90.791308879995128, TangentialControl::kDisplacement,
       -55.473339557284625},
      {NormalControl::kForce, 55.293965339547661, TangentialControl::kForce,
       5.5294117657467292e-06},
  };
  int refusals = 0;
  for (const Step& step : history) {
    const ContactSnapshot previous = c.Snapshot();
    const Status status = c.Apply(step);
    if (!status.ok()) {
      ++refusals;
      EXPECT_TRUE(same(c.Snapshot(), previous)) << status.ToString();
    }
    EXPECT_TRUE(restores(c)) << status.ToString();
  }
  EXPECT_LE(refusals, 1);
}

}  // namespace
}  // namespace mdr
