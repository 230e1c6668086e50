// Stability suite: thousands of random short histories over random materials, friction,
// scales and profiles, checking the invariants that must hold for every state (issue: error
// against run time and numerical stability). Deterministic seeds; about a second in Release.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mdr/core/contact.h"
#include "mdr/core/jager.h"
#include "mdr/core/traction.h"
#include "test_util.h"

namespace mdr {
namespace {

struct RandomScene {
  std::mt19937_64 rng;
  double Uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  double LogUniform(double lo, double hi) { return lo * std::pow(hi / lo, Uniform(0, 1)); }

  ProfilePtr Profile() {
    switch (rng() % 5) {
      case 0:
        return *MakeSphere(LogUniform(1e-4, 1));
      case 1:
        return *MakeCone(Uniform(0.01, 1.4));
      case 2:
        return *MakePowerLaw(LogUniform(1e-2, 1e2), Uniform(0.5, 8));
      case 3:
        return *MakePowerLaw(LogUniform(1e-2, 1e2), Uniform(0.3, 0.6));
      default:
        return *MakeFlatPunch(LogUniform(1e-5, 1e-1));
    }
  }
};

TEST(StabilityTest, RandomHistoriesKeepEveryInvariant) {
  RandomScene random{std::mt19937_64(2026)};
  int histories_with_slip = 0, traction_comparisons = 0;
  for (int history = 0; history < 3000; ++history) {
    ContactConfig config;
    config.profile = random.Profile();
    config.material = *RigidOnHalfSpace(random.LogUniform(1e6, 1e12), random.Uniform(0, 0.5));
    config.friction = random.rng() % 10 == 0 ? 0.0 : random.LogUniform(1e-2, 1e2);
    config.force_path_tolerance = 1e-6;
    Contact c = std::move(Contact::Create(config)).value();
    const double d0 = random.LogUniform(1e-9, 1e-3);
    const double slip = c.mu_kappa() * d0;
    bool slipped = false;
    for (int step = 0; step < 12; ++step) {
      Step s;
      const int kind = static_cast<int>(random.rng() % 4);
      if (kind == 3 && c.friction_limit() > 0) {  // force-controlled: F_x within the limit
        s.tangential = TangentialControl::kForce;
        s.tangential_value = random.Uniform(-0.99, 0.99) * c.friction_limit();
      } else {
        s.normal = NormalControl::kDepth;
        s.normal_value = d0 * random.Uniform(-0.1, 1.5);
        s.tangential = TangentialControl::kDisplacement;
        s.tangential_value = slip * random.Uniform(-2, 2);
      }
      StepReport report;
      const Status status = c.Apply(s, &report);
      ASSERT_TRUE(status.ok()) << status.ToString() << " history " << history;
      const double fx = c.tangential_force(), fn = c.normal_force();
      ASSERT_TRUE(std::isfinite(fx) && std::isfinite(fn) && std::isfinite(c.dissipated_energy()));
      ASSERT_LE(std::abs(fx), c.friction_limit() * (1 + 1e-9) + 1e-300) << "history " << history;
      ASSERT_GE(report.dissipated, -1e-9 * (c.friction_limit() * slip + 1e-300))
          << "history " << history;
      slipped |= !c.slip_intervals().empty();
    }
    histories_with_slip += slipped;
    if (c.config().friction == 0 || !(c.depth() > 0)) continue;
    // Jaeger weights |F| <= 1, and the two traction routes agree away from singular points.
    Result<JagerWeights> weights = ComputeJagerWeights(c);
    ASSERT_TRUE(weights.ok()) << weights.status().ToString();
    for (const auto& interval : weights->intervals) ASSERT_LE(std::abs(interval.weight), 1 + 1e-9);
    const double a = c.contact_radius();
    Result<std::vector<RadialValue>> tau =
        ComputeTangentialTraction(c, {0.13 * a, 0.41 * a, 0.77 * a, 0.93 * a});
    ASSERT_TRUE(tau.ok()) << tau.status().ToString();
    double peak = 0;
    for (const RadialValue& v : *tau) peak = std::max(peak, std::abs(v.value));
    for (const RadialValue& v : *tau) {
      if (!v.abel || !v.jager || !std::isfinite(*v.abel)) continue;
      ++traction_comparisons;
      ASSERT_LE(std::abs(*v.abel - *v.jager), 1e-8 * peak + 1e-300)
          << "history " << history << " r/a " << v.radius / a;
    }
  }
  EXPECT_GT(histories_with_slip, 1000) << "the histories must exercise partial and gross slip";
  EXPECT_GT(traction_comparisons, 4000) << "the two traction routes must be compared often";
}

}  // namespace
}  // namespace mdr
