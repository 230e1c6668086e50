// Properties of the exact memory over random piecewise-linear histories.
#include "mdr/core/memory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mdr/core/contact.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::MakeContact;
using testing::RelNear;

// Stored tangential energy G* integral_0^a u^2 dx, from the pieces u = A + B g.
double StoredEnergy(const Contact& c) {
  const Profile& p = *c.config().profile;
  double sum = 0;
  for (const MemoryPiece& piece : c.memory_pieces()) {
    const double a = piece.intercept, b = piece.slope;
    if (piece.z_end == piece.z_begin) {  // flat punch atom: u constant on [0, a0]
      sum += a * a * (piece.x_end - piece.x_begin);
      continue;
    }
    auto delta_moment = [&](int j) {
      return p.Moment(j, piece.x_end) - p.Moment(j, piece.x_begin);
    };
    sum += a * a * delta_moment(0) + 2 * a * b * delta_moment(1) + b * b * delta_moment(2);
  }
  return c.config().material.g_star * sum;
}

std::vector<ProfilePtr> Profiles() {
  return {*MakeSphere(0.01), *MakeCone(0.2), *MakePowerLaw(50.0, 4.0), *MakePowerLaw(1e-3, 0.5),
          *MakeFlatPunch(1e-3)};
}

// Random step targets in (delta, ux), including lift-off, re-contact and gross slip.
struct RandomSteps {
  std::mt19937_64 rng{12345};
  double d0, slip;
  std::pair<double, double> Next() {
    std::uniform_real_distribution<double> u(0, 1);
    const double depth = d0 * (u(rng) < 0.1 ? -0.2 * u(rng) : 0.2 + 1.3 * u(rng));
    return {depth, slip * (4 * u(rng) - 2)};
  }
};

TEST(MemoryTest, SplittingALinearStepGivesTheSameState) {
  for (const ProfilePtr& profile : Profiles()) {
    Contact c = MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.4);
    const double d0 = 1e-6;
    RandomSteps steps{.d0 = d0, .slip = c.mu_kappa() * d0};
    for (int i = 0; i < 200; ++i) {
      auto [depth, ux] = steps.Next();
      const int k = 2 + i % 6;
      Contact split = c;
      for (int j = 1; j <= k; ++j) {
        const double s = static_cast<double>(j) / k;
        ASSERT_TRUE(
            split
                .MoveTo(c.depth() + s * (depth - c.depth()),
                        c.tangential_displacement() + s * (ux - c.tangential_displacement()))
                .ok());
      }
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      const double scale = c.mu_kappa() * std::max(depth, d0);
      for (int q = 0; q <= 50; ++q) {
        const double z = std::max(depth, 0.0) * q / 50;
        ASSERT_LE(std::abs(c.memory().UAtDepth(z) - split.memory().UAtDepth(z)), 1e-13 * scale)
            << profile->Describe() << " step " << i << " k " << k;
      }
      const double force_scale = c.friction_limit() + 1e-300;
      ASSERT_LE(std::abs(c.tangential_force() - split.tangential_force()), 1e-13 * force_scale);
      // Energy of a split step equals that of the whole step (each part is exact).
      ASSERT_TRUE(RelNear(split.dissipated_energy(), c.dissipated_energy(), 1e-10)
                  << profile->Describe() << " step " << i);
      c = split;  // continue from either; they agree
    }
  }
}

TEST(MemoryTest, InvariantsHoldOverRandomHistories) {
  for (const ProfilePtr& profile : Profiles()) {
    Contact c = MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.4);
    const double d0 = 1e-6;
    RandomSteps steps{.d0 = d0, .slip = c.mu_kappa() * d0};
    for (int i = 0; i < 2000; ++i) {
      auto [depth, ux] = steps.Next();
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      ASSERT_GE(c.last_step_dissipation(), 0) << profile->Describe() << " step " << i;
      ASSERT_TRUE(std::isfinite(c.tangential_force()) && std::isfinite(c.normal_force()));
      ASSERT_LE(std::abs(c.tangential_force()), c.friction_limit() * (1 + 1e-12));
      const auto& z = c.memory().z();
      const auto& u = c.memory().u();
      for (std::size_t j = 0; j + 1 < z.size(); ++j) {
        ASSERT_LT(z[j], z[j + 1]);
        // Jaeger weight |F| = |du/dz| / (mu kappa) <= 1.
        ASSERT_LE(std::abs(u[j + 1] - u[j]), c.mu_kappa() * (z[j + 1] - z[j]) * (1 + 1e-9));
        ASSERT_LE(std::abs(u[j]), c.mu_kappa() * (depth - z[j]) * (1 + 1e-12));
      }
      ASSERT_LE(c.memory().vertex_count(), 64u);
    }
  }
}

TEST(MemoryTest, DissipationEqualsWorkMinusStoredEnergy) {
  // Energy balance W = integral F_x dux - Delta(G* integral u^2 dx) along each linear step,
  // the work integral by the trapezoidal rule over 2000 exact sub-steps.
  for (const ProfilePtr& profile : Profiles()) {
    Contact c = MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.4);
    const double d0 = 1e-6;
    RandomSteps steps{.d0 = d0, .slip = c.mu_kappa() * d0};
    double energy_scale = 0;
    for (int i = 0; i < 30; ++i) {
      auto [depth, ux] = steps.Next();
      Contact fine = c;
      const int kN = 2000;
      double work = 0;
      const double dux = (ux - c.tangential_displacement()) / kN;
      for (int j = 1; j <= kN; ++j) {
        const double s = static_cast<double>(j) / kN;
        const double f_before = fine.tangential_force();
        ASSERT_TRUE(
            fine.MoveTo(c.depth() + s * (depth - c.depth()),
                        c.tangential_displacement() + s * (ux - c.tangential_displacement()))
                .ok());
        work += 0.5 * (f_before + fine.tangential_force()) * dux;
      }
      const double stored_before = StoredEnergy(c);
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      energy_scale = std::max(energy_scale, c.friction_limit() * c.mu_kappa() * d0);
      const double balance = work - (StoredEnergy(c) - stored_before);
      EXPECT_NEAR(c.last_step_dissipation(), balance, 2e-5 * energy_scale)
          << profile->Describe() << " step " << i;
    }
  }
}

TEST(MemoryTest, IncrementForIntegralUGivesTheTargetAfterTheStep) {
  // The closed-form solve against the step itself, from states of random histories, to depths
  // that cut the memory, hold it or add entering springs, for targets across the whole range.
  for (const ProfilePtr& profile : Profiles()) {
    Contact c = MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.4);
    const double d0 = 1e-6, m = c.mu_kappa();
    RandomSteps steps{.d0 = d0, .slip = m * d0};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uniform(0, 1);
    for (int i = 0; i < 300; ++i) {
      auto [depth, ux] = steps.Next();
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      const PiecewiseLinearMemory& memory = c.memory();
      const double depth1 =
          i % 3 == 0 ? memory.depth() : d0 * (i % 3 == 1 ? 0.3 + uniform(rng) : 0.05);
      auto integral_after = [&](double dux) {
        PiecewiseLinearMemory stepped = memory;
        stepped.ApplyLinearStep(
            {depth1, dux, c.tangential_displacement(), c.tangential_displacement() + dux}, m,
            nullptr);
        return stepped.IntegralU(*profile);
      };
      const double lo = integral_after(memory.GrossSlipIncrement(depth1, m, -1));
      const double hi = integral_after(memory.GrossSlipIncrement(depth1, m, +1));
      ForceSolveBuffers buffers;
      for (double q : {1e-9, 0.1, 0.5 + 0.4 * uniform(rng), 1 - 1e-9}) {
        const double target = lo + q * (hi - lo);
        const double dux = memory.IncrementForIntegralU(depth1, m, *profile, target, buffers);
        ASSERT_LE(std::abs(integral_after(dux) - target), 1e-12 * std::max(-lo, hi))
            << profile->Describe() << " step " << i << " q " << q;
      }
    }
  }
}

TEST(MemoryTest, StickRegionsMoveRigidlyAndSlipRegionsMerge) {
  PiecewiseLinearMemory m;
  const double k = 2.0;  // mu kappa
  double ux = 0;
  auto move = [&](double depth1, double dux) {
    m.ApplyLinearStep({depth1, dux, ux, ux + dux}, k, nullptr);
    ux += dux;
  };
  move(1.0, 0.0);
  EXPECT_EQ(m.vertex_count(), 2u);
  move(1.0, 0.5);  // slip annulus from z = 0.75
  ASSERT_EQ(m.vertex_count(), 3u);
  EXPECT_DOUBLE_EQ(m.z()[1], 0.75);
  EXPECT_EQ(m.tags()[1], kOnUpper);
  move(1.0, 0.25);  // annulus grows to z = 0.625, old vertex merged away
  ASSERT_EQ(m.vertex_count(), 3u);
  EXPECT_DOUBLE_EQ(m.z()[1], 0.625);
  move(1.0, -0.5);  // reversal: a new annulus inside the old one
  EXPECT_EQ(m.vertex_count(), 4u);
  move(1.0, 10.0);  // gross slip wipes everything
  EXPECT_EQ(m.vertex_count(), 2u);
  EXPECT_EQ(m.tags()[0], kOnUpper);
}

}  // namespace
}  // namespace mdr
