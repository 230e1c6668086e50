// Interface round trips over every state a randomized stress reaches (issue #17): random
// interfaces of 1-8 contacts (shared motion and contact lists; every profile kind, friction from 0
// to 1e6, now and then a grid-method contact) under random steps of every kind, force targets
// included. After every step a copy is restored from the snapshot (the path of ImportSession and
// the journal) and driven by the remaining steps beside the original: the copies must continue
// bit for bit, and a refused step must change nothing. Deterministic seeds, no timing.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <vector>

#include "mdr/core/interface.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::RandomScene;
using testing::SameInterfaceState;

// How far a history reaches: the contacts' depths are around d0.
struct Stress {
  RandomScene random;
  double d0 = 0;

  ContactConfig RandomContact() {
    ContactConfig config;
    config.profile = random.Profile();
    config.material = *RigidOnHalfSpace(random.LogUniform(1e6, 1e12), random.Uniform(0, 0.5));
    config.friction = random.Friction();
    config.force_path_tolerance = 1e-4;  // per-contact curved paths stay cheap
    if (random.rng() % 6 == 0) {         // a grid contact sends every step through the step buffer
      config.method = Method::kGrid;
      config.grid_size = 8 + random.rng() % 120;
      config.grid_max_radius = 1.2 * config.profile->RadiusAtDepth(1.6 * d0);
    }
    return config;
  }

  // 1-8 contacts, each its own scene or all the first's (one shared ProfilePtr); heights within
  // +-d0 for shared motion, or none.
  InterfaceConfig RandomInterface(InterfaceKind kind) {
    InterfaceConfig config;
    config.kind = kind;
    const std::size_t n = 1 + random.rng() % 8;
    const bool one_scene = random.rng() % 3 == 0;
    for (std::size_t i = 0; i < n; ++i) {
      config.contacts.push_back(one_scene && i > 0 ? config.contacts[0] : RandomContact());
    }
    if (kind == InterfaceKind::kSharedMotion && random.rng() % 4 != 0) {
      for (std::size_t i = 0; i < n; ++i) config.heights.push_back(d0 * random.Uniform(-1, 1));
    }
    return config;
  }

  // A shared-motion step of any kind: approaches around min h + d0 (lift-off included), small
  // increments, tangential increments of 1e-12 .. 2 of max(mu kappa) d0, total force targets
  // (normal around the force at depth d0 of every contact, tangential within +-Sum mu F_N) with
  // the other channel held, and now and then one that is refused (a target with the other
  // channel moving, a tangential target beyond the friction limit).
  Step SharedMotionStep(const Interface& interface, double slip, double min_height) {
    Step s;
    s.tangential_value = slip * random.RelativeAmplitude();
    double force_at_d0 = 0, friction_limit = 0;
    for (std::size_t i = 0; i < interface.size(); ++i) {
      force_at_d0 += interface.contact(i).NormalForceAtDepth(d0);
      friction_limit += interface.contact(i).friction_limit();
    }
    switch (random.rng() % 10) {
      case 0:
      case 1:
        s.normal = NormalControl::kDepth;
        s.normal_value = min_height + d0 * random.Uniform(-0.1, 1.5);
        break;
      case 2:
        s.normal_value = d0 * random.Sign() * random.LogUniform(1e-12, 0.2);
        break;
      case 3:
      case 4:
        break;  // tangential increment at constant approach
      case 5:
        s.tangential = TangentialControl::kDisplacement;
        s.tangential_value += interface.tangential_displacement();
        break;
      case 6:
      case 7:
        s.tangential = TangentialControl::kForce;
        s.tangential_value = random.Uniform(-1.05, 1.05) * friction_limit;
        break;
      case 8:
        s.normal = NormalControl::kForce;
        s.normal_value = force_at_d0 * random.Uniform(0, 1.4);
        s.tangential_value = 0;
        break;
      default:
        s.normal = NormalControl::kForce;  // refused: the tangential channel moves
        s.normal_value = force_at_d0;
        break;
    }
    return s;
  }

  // A contact-list step: one control per channel, each contact's value on its own scale (depths
  // around d0, increments, its own force targets, tangential increments of 1e-12 .. 2 of its
  // mu kappa d0, tangential targets within +-1.05 of its mu F_N).
  ContactListStep ListStep(const Interface& list, std::vector<double>* normal_values,
                           std::vector<double>* tangential_values) {
    ContactListStep s;
    s.normal = static_cast<NormalControl>(random.rng() % 3);
    s.tangential = static_cast<TangentialControl>(random.rng() % 3);
    normal_values->clear();
    tangential_values->clear();
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Contact& c = list.contact(i);
      normal_values->push_back(s.normal == NormalControl::kDepth ? d0 * random.Uniform(-0.1, 1.5)
                               : s.normal == NormalControl::kForce
                                   ? c.NormalForceAtDepth(d0) * random.Uniform(0.3, 1.4)
                                   : d0 * random.Sign() * random.LogUniform(1e-12, 0.2));
      const double slip = c.mu_kappa() * d0 * random.RelativeAmplitude();
      tangential_values->push_back(s.tangential == TangentialControl::kForce
                                       ? random.Uniform(-1.05, 1.05) * c.friction_limit()
                                   : s.tangential == TangentialControl::kDisplacement
                                       ? c.tangential_displacement() + slip
                                       : slip);
    }
    s.normal_values = *normal_values;
    s.tangential_values = *tangential_values;
    return s;
  }
};

struct Counts {
  long states = 0, refused = 0, list_states = 0, grid_states = 0, force_target_states = 0;
};

// One history of `steps` random steps with restored copies taken after every step.
void RunHistory(Stress& stress, InterfaceKind kind, int history, int steps, Counts* counts) {
  stress.d0 = stress.random.LogUniform(1e-9, 1e-3);
  const InterfaceConfig config = stress.RandomInterface(kind);
  Result<Interface> created = Interface::Create(config);
  ASSERT_TRUE(created.ok()) << created.status().ToString() << " history " << history;
  Interface original = std::move(created).value();
  bool has_grid = false;
  double max_mu_kappa = 0;
  for (std::size_t i = 0; i < original.size(); ++i) {
    has_grid |= config.contacts[i].method == Method::kGrid;
    max_mu_kappa = std::max(max_mu_kappa, original.contact(i).mu_kappa());
  }
  const double min_height = original.approach();  // a new interface touches its highest contact
  std::vector<Interface> restored;
  std::vector<double> normal_values, tangential_values;
  for (int step = 0; step < steps; ++step) {
    const bool shared = kind == InterfaceKind::kSharedMotion;
    const Step s =
        shared ? stress.SharedMotionStep(original, max_mu_kappa * stress.d0, min_height) : Step{};
    const ContactListStep list_step =
        shared ? ContactListStep{} : stress.ListStep(original, &normal_values, &tangential_values);
    auto apply = [&](Interface& interface) {
      return shared ? interface.Apply(s) : interface.ApplyEach(list_step);
    };
    const InterfaceSnapshot before = original.Snapshot();
    const Status status = apply(original);
    const InterfaceSnapshot after = original.Snapshot();
    ASSERT_EQ(original.vertex_count(), original.CountVertices().now)
        << "history " << history << " step " << step;
    for (Interface& copy : restored) {
      ASSERT_EQ(apply(copy).code(), status.code()) << "history " << history << " step " << step;
      ASSERT_TRUE(SameInterfaceState(copy.Snapshot(), after))
          << "history " << history << " step " << step;
    }
    if (!status.ok()) {
      ASSERT_FALSE(status.field().empty()) << status.ToString();
      ASSERT_TRUE(SameInterfaceState(after, before))
          << "a refused step changed the interface: " << status.ToString() << " history " << history
          << " step " << step;
      ++counts->refused;
      continue;
    }
    Result<Interface> copy = Interface::Restore(config, after);
    ASSERT_TRUE(copy.ok()) << copy.status().ToString() << " history " << history << " step "
                           << step;
    ASSERT_TRUE(SameInterfaceState(copy->Snapshot(), after));
    ASSERT_EQ(copy->vertex_count(), original.vertex_count());
    restored.push_back(std::move(copy).value());
    ++counts->states;
    counts->list_states += !shared;
    counts->grid_states += has_grid;
    counts->force_target_states +=
        shared ? s.normal == NormalControl::kForce || s.tangential == TangentialControl::kForce
               : list_step.normal == NormalControl::kForce ||
                     list_step.tangential == TangentialControl::kForce;
  }
}

TEST(InterfaceRoundTripTest, EveryStateRestoresAndContinuesBitIdentically) {
  Stress stress{RandomScene{std::mt19937_64(17)}};
  Counts counts;
  for (int history = 0; history < 400; ++history) {
    const InterfaceKind kind =
        history % 2 ? InterfaceKind::kContactList : InterfaceKind::kSharedMotion;
    RunHistory(stress, kind, history, 12, &counts);
    if (::testing::Test::HasFatalFailure()) return;
  }
  std::printf(
      "[ restore ] %ld interface states (%ld contact list, %ld with a grid contact, %ld "
      "after a force target) restored and continued bit-identically; %ld steps refused "
      "without a change\n",
      counts.states, counts.list_states, counts.grid_states, counts.force_target_states,
      counts.refused);
  EXPECT_GT(counts.states, 3000) << "most random steps must succeed";
  EXPECT_GT(counts.list_states, 1000);
  EXPECT_GT(counts.grid_states, 500);
  EXPECT_GT(counts.force_target_states, 500);
  EXPECT_GT(counts.refused, 100) << "the refusal path must be exercised too";
}

}  // namespace
}  // namespace mdr
