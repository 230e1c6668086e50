// Stability suite: thousands of random short histories over random materials, friction,
// scales and profiles, checking the invariants that must hold for every state (issue: error
// against run time and numerical stability). Deterministic seeds; about a second in Release.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fixtures/slip_state_check.h"
#include "mdr/core/contact.h"
#include "mdr/core/jager.h"
#include "mdr/core/torsion.h"
#include "mdr/core/traction.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::RandomScene;

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
    std::vector<double> turning_points = {0.0};
    for (int step = 0; step < 12; ++step) {
      Step s;
      const int kind = static_cast<int>(random.rng() % 5);
      if (kind == 3 && c.friction_limit() > 0) {  // force-controlled: F_x within the limit
        s.tangential = TangentialControl::kForce;
        s.tangential_value = random.Uniform(-0.99, 0.99) * c.friction_limit();
      } else if (kind == 4) {  // back to an earlier displacement, or its mirror image, exactly
        s.tangential = TangentialControl::kDisplacement;
        s.tangential_value = turning_points[random.rng() % turning_points.size()];
        if (random.rng() % 2 == 0) s.tangential_value = -s.tangential_value;
      } else {
        s.normal = NormalControl::kDepth;
        s.normal_value = d0 * random.Uniform(-0.1, 1.5);
        s.tangential = TangentialControl::kDisplacement;
        s.tangential_value = slip * random.Uniform(-2, 2);
      }
      StepReport report;
      const Contact before = c;
      const Status status = c.Apply(s, &report);
      ASSERT_TRUE(status.ok()) << status.ToString() << " history " << history;
      turning_points.push_back(c.tangential_displacement());
      const std::string slip_state = testing::SlipStateViolation(before, c, report.substeps == 1);
      ASSERT_TRUE(slip_state.empty()) << slip_state << " history " << history << " step " << step
                                      << " " << c.config().profile->Describe();
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
    for (const auto& interval : weights->intervals) ASSERT_LE(std::abs(interval.weight), 1);
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

using testing::SameSnapshot;

// What a history has visited, for steps that return exactly (the turning points of
// Mindlin-Deresiewicz and Masing loops, where a whole memory segment lands back on its bound).
struct Visited {
  std::vector<double> displacements = {0.0}, tangential_forces = {0.0};
  void Add(const Contact& c) {
    displacements.push_back(c.tangential_displacement());
    tangential_forces.push_back(c.tangential_force());
  }
};

// A random step of any kind, scaled to the scene: depths around d0 (lift-off included) or small
// depth increments, tangential increments of 1e-12 .. 2 of mu kappa d0, tangential forces within
// the limit, returns to a displacement or force visited before (or its mirror image), and
// (rarely, they cost sub-steps) curved force-controlled paths.
Step RandomStep(RandomScene& random, const Contact& c, double d0, const Visited& visited) {
  Step s;
  const double slip = c.mu_kappa() * d0;
  s.tangential_value = slip * random.RelativeAmplitude();
  auto any_of = [&](const std::vector<double>& values) {
    const double value = values[random.rng() % values.size()];
    return random.rng() % 2 == 0 ? value : -value;
  };
  switch (random.rng() % 11) {
    case 8:
    case 9:
      s.tangential = TangentialControl::kDisplacement;
      s.tangential_value = any_of(visited.displacements);
      break;
    case 10:
      s.tangential = TangentialControl::kForce;
      s.tangential_value =
          std::clamp(any_of(visited.tangential_forces), -c.friction_limit(), c.friction_limit());
      break;
    case 0:
    case 1:
      s.normal = NormalControl::kDepth;
      s.normal_value = d0 * random.Uniform(-0.1, 1.5);
      break;
    case 2:
      s.normal_value = d0 * random.Sign() * random.LogUniform(1e-12, 0.2);
      break;
    case 3:
    case 4:
      break;  // tangential increment at constant depth
    case 5:
      s.tangential = TangentialControl::kDisplacement;
      s.tangential_value += c.tangential_displacement();
      break;
    case 6:
      s.tangential = TangentialControl::kForce;
      s.tangential_value = random.Uniform(-0.99, 0.99) * c.friction_limit();
      break;
    default:
      s.normal = NormalControl::kForce;
      s.normal_value = c.NormalForceAtDepth(d0) * random.Uniform(0.3, 1.4);
      break;
  }
  return s;
}

ContactConfig RandomConfig(RandomScene& random, double d0, bool grid) {
  ContactConfig config;
  config.profile = random.Profile();
  config.material = *RigidOnHalfSpace(random.LogUniform(1e6, 1e12), random.Uniform(0, 0.5));
  config.friction = random.Friction();
  config.force_path_tolerance = 1e-4;
  if (grid) {
    config.method = Method::kGrid;
    config.grid_size = 8 + random.rng() % 120;
    config.grid_max_radius = 1.2 * config.profile->RadiusAtDepth(1.6 * d0);
  }
  return config;
}

// Issue #11: every state the engine reaches must restore (Snapshot -> Restore, the path of
// ImportSession and the journal) and the restored contact must continue bit for bit. After every
// step of every history a copy is restored from the snapshot and then driven by the remaining
// steps next to the original.
TEST(StabilityTest, EveryStateRestoresAndContinuesBitIdentically) {
  RandomScene random{std::mt19937_64(11)};
  long states = 0, grid_states = 0;
  for (int history = 0; history < 1500; ++history) {
    const bool grid = history % 4 == 3;
    const double d0 = random.LogUniform(1e-9, 1e-3);
    const ContactConfig config = RandomConfig(random, d0, grid);
    Contact original = std::move(Contact::Create(config)).value();
    std::vector<Contact> restored;
    Visited visited;
    for (int step = 0; step < 12; ++step) {
      const Step s = RandomStep(random, original, d0, visited);
      const Contact before = original;
      StepReport report;
      const Status status = original.Apply(s, &report);
      if (status.ok()) {
        visited.Add(original);
        const std::string slip_state =
            testing::SlipStateViolation(before, original, report.substeps == 1);
        ASSERT_TRUE(slip_state.empty())
            << slip_state << " history " << history << " step " << step << " "
            << config.profile->Describe() << (grid ? " grid" : "");
      }
      for (Contact& copy : restored) {
        ASSERT_EQ(copy.Apply(s).code(), status.code()) << "history " << history;
        ASSERT_TRUE(SameSnapshot(copy.Snapshot(), original.Snapshot()))
            << "history " << history << " step " << step;
      }
      Result<Contact> copy = Contact::Restore(config, original.Snapshot());
      ASSERT_TRUE(copy.ok()) << copy.status().ToString() << " history " << history << " step "
                             << step << " mu " << config.friction << " "
                             << config.profile->Describe();
      ASSERT_TRUE(SameSnapshot(copy->Snapshot(), original.Snapshot()));
      restored.push_back(std::move(copy).value());
      if (!status.ok()) continue;  // the same state as before
      ++states;
      grid_states += grid;
    }
  }
  std::printf(
      "[ restore ] %ld random-history states (%ld grid) restored and continued "
      "bit-identically\n",
      states, grid_states);
  EXPECT_GT(states, 15000) << "most random steps must succeed";
  EXPECT_GT(grid_states, 3000);
}

// The reproduction as a dense scan: one tangential step of 1e-12 .. 1 of
// mu kappa delta from a fresh indentation, several profiles, mu kappa up to ~1e6 and beyond.
TEST(StabilityTest, SmallAmplitudeFrettingStatesAllRestore) {
  const std::vector<ProfilePtr> profiles = {*MakeSphere(0.005), *MakeCone(0.1),
                                            *MakePowerLaw(1e3, 3), *MakePowerLaw(10, 0.5),
                                            *MakeFlatPunch(1e-3)};
  const EffectiveMaterial steel = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  long states = 0;
  for (const ProfilePtr& profile : profiles) {
    for (double mu : {0.3, 3e5, 1e6}) {
      Contact fresh = testing::MakeContact(profile, steel, mu);
      const double depth = 2e-6;
      ASSERT_TRUE(fresh.MoveTo(depth, 0).ok());
      for (int k = 0; k < 2000; ++k) {
        const double amplitude = 1e-12 * std::pow(1e12, k / 1999.0) * fresh.mu_kappa() * depth;
        for (double depth1 : {depth, depth * (1 + 1e-9)}) {
          Contact c = fresh;
          ASSERT_TRUE(c.MoveTo(depth1, amplitude).ok());
          Result<Contact> copy = Contact::Restore(c.config(), c.Snapshot());
          ASSERT_TRUE(copy.ok()) << copy.status().ToString() << " " << profile->Describe() << " mu "
                                 << mu << " amplitude " << amplitude;
          for (Contact* each : {&c, &copy.value()}) {
            ASSERT_TRUE(each->MoveTo(depth, -0.5 * amplitude).ok());
          }
          ASSERT_TRUE(SameSnapshot(copy->Snapshot(), c.Snapshot()));
          ASSERT_TRUE(Contact::Restore(c.config(), c.Snapshot()).ok());
          states += 2;
        }
      }
    }
  }
  std::printf("[ restore ] %ld small-amplitude fretting states restored\n", states);
}

// Torsion (issue #49): random histories of twisted contacts over materials (nu 0 .. 0.5, moduli
// 1e6 .. 1e12 Pa), friction 1e-3 .. 10, scales (depths 1e-9 .. 1e-3 m) and profiles (spheres and,
// as their steps cost a quadrature, fewer cones and power laws), twisted by angle, increment,
// moment and back to earlier twists exactly, with the normal load raised and lowered (a decrease
// the memory refuses must change nothing). After every step: the exact regime (|F| <= 1, decided
// from the pieces), |M| below the full-slip moment, finite non-negative energies, a loss >= 0,
// and the snapshot restored, continuing bit for bit with the history's remaining steps.
TEST(StabilityTest, TorsionalHistoriesKeepTheirInvariantsAndRestore) {
  RandomScene random{std::mt19937_64(4949)};
  int refused_decreases = 0, restored = 0;
  for (int history = 0; history < 400; ++history) {
    const bool sphere = history % 8 != 0;
    const ProfilePtr profile =
        sphere              ? *MakeSphere(random.LogUniform(1e-4, 1))
        : history % 16 == 0 ? *MakeCone(random.Uniform(0.01, 1.4))
                            : *MakePowerLaw(random.LogUniform(1e-2, 1e2), random.Uniform(0.5, 6));
    const double young = random.LogUniform(1e6, 1e12), nu = random.Uniform(0, 0.5);
    const double e_star = young / (1 - nu * nu), g_t = young / (2 * (1 + nu));
    const double friction = random.LogUniform(1e-3, 10);
    TorsionalContact c = *TorsionalContact::Create(profile, friction, e_star, g_t);
    const double d0 = random.LogUniform(1e-9, 1e-3);
    TorsionStep press;
    press.normal = NormalControl::kDepth;
    press.normal_value = d0;
    ASSERT_TRUE(c.Apply(press).ok());
    // The twist scale: the bound at half the contact radius.
    const double scale = MakeTorsionBound(profile, friction, e_star, g_t)
                             .value()
                             ->Bound(c.memory().contact_radius() / 2, c.memory().contact_radius());
    std::vector<double> twists = {0.0};
    std::vector<TorsionStep> steps;
    for (int k = 0; k < (sphere ? 14 : 5); ++k) {
      TorsionStep s;
      switch (random.rng() % 6) {
        case 0:
          s.normal = NormalControl::kDepth;
          s.normal_value = d0 * random.Uniform(0.3, 1.6);
          break;
        case 1:
          s.twist = TwistControl::kAngle;
          s.twist_value = twists[random.rng() % twists.size()];  // back exactly
          break;
        case 2:
          s.twist = TwistControl::kMoment;
          s.twist_value = random.Uniform(-0.98, 0.98);  // of the full-slip moment, set below
          break;
        case 3:
          s.twist = TwistControl::kAngleIncrement;
          s.twist_value = random.Sign() * random.LogUniform(1e-12, 3) * scale;
          break;
        default:
          s.twist = TwistControl::kAngle;
          s.twist_value = random.Uniform(-3, 3) * scale;
      }
      steps.push_back(s);
    }
    for (std::size_t k = 0; k < steps.size(); ++k) {
      TorsionStep s = steps[k];
      if (s.twist == TwistControl::kMoment) s.twist_value *= c.memory().FullSlipMoment();
      const TorsionSnapshot before = c.memory().Snapshot();
      const Status status = c.Apply(s);
      if (!status.ok()) {
        // Only a load decrease that would leave the exact regime may be refused, changing nothing.
        ASSERT_EQ(status.code(), StatusCode::kFailedPrecondition)
            << status.ToString() << " history " << history;
        ASSERT_EQ(c.memory().Snapshot(), before);
        ++refused_decreases;
        continue;
      }
      const TorsionalMemory& m = c.memory();
      ASSERT_TRUE(m.IsExact()) << "history " << history << " step " << k;
      const double moment = m.Moment(), slip = m.FullSlipMoment();
      ASSERT_TRUE(std::isfinite(moment) && std::isfinite(m.StoredEnergy()));
      ASSERT_LE(std::abs(moment), slip * (1 + 1e-9) + 1e-300)
          << "history " << history << " step " << k << " " << profile->Describe();
      ASSERT_GE(m.StoredEnergy(), 0);
      ASSERT_GE(m.last_step_dissipation(), 0);
      ASSERT_GE(m.dissipated_energy(), 0);
      twists.push_back(m.twist());
      // Restored from its snapshot, the contact continues bit for bit.
      Result<TorsionalContact> copy =
          TorsionalContact::Restore(profile, friction, e_star, g_t, c.depth(), m.Snapshot());
      ASSERT_TRUE(copy.ok()) << copy.status().ToString() << " history " << history;
      TorsionalContact original = c;
      for (std::size_t j = k + 1; j < steps.size(); ++j) {
        TorsionStep next = steps[j];
        if (next.twist == TwistControl::kMoment) {
          next.twist_value *= original.memory().FullSlipMoment();
        }
        const Status a = original.Apply(next), b = copy->Apply(next);
        ASSERT_EQ(a.code(), b.code()) << "history " << history << " step " << j;
      }
      ASSERT_EQ(original.memory().Snapshot(), copy->memory().Snapshot())
          << "history " << history << " restored after step " << k;
      ++restored;
    }
  }
  EXPECT_GT(refused_decreases, 20) << "the histories must reach the refused decreases";
  EXPECT_GT(restored, 3000);
}

}  // namespace
}  // namespace mdr
