// Interfaces and contact lists of many exact contacts (interface.h), and asperity populations
// (population.h). Deterministic: fixed seeds, no timing.
#include "mdr/core/interface.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "mdr/core/population.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::RandomHistory;
using testing::SameBits;
using testing::SameInterfaceState;
using testing::SameSnapshot;

EffectiveMaterial Steel() { return *ElasticPair(210e9, 0.3, 210e9, 0.3); }

// n Hertz asperities, R = 0.1 mm, Gaussian summit heights of 1 um standard deviation.
// log_sigma > 0: lognormal radii (every summit its own sphere), else all of radius 1e-4 m.
InterfaceConfig RoughInterface(std::size_t n, std::uint64_t seed, double friction = 0.3,
                               double log_sigma = 0) {
  PopulationSpec spec;
  spec.count = n;
  spec.height_scale = 1e-6;
  spec.radius = 1e-4;
  spec.seed = seed;
  if (log_sigma > 0) {
    spec.radii = RadiusDistribution::kLognormal;
    spec.log_sigma = log_sigma;
  }
  return *HertzInterfaceConfig(*GeneratePopulation(spec), Steel(), friction);
}

// ---------------------------------------------------------------- population

TEST(PopulationTest, UniformsAreTheTop53Bits) {
  EXPECT_EQ(UniformFrom64(0), 0.0);
  EXPECT_EQ(UniformFrom64(~std::uint64_t{0}), 1.0 - 0x1p-53);
  EXPECT_EQ(UniformFrom64(std::uint64_t{1} << 63), 0.5);
  // The engine is the standard's: its 10000th output is fixed by [rand.predef].
  std::mt19937_64 rng;
  rng.discard(9999);
  EXPECT_EQ(rng(), 9981545732273789042ULL);
}

TEST(PopulationTest, BoxMullerGivesTheClosedForm) {
  double z1 = 0, z2 = 0;
  BoxMuller(0.0, 0.0, &z1, &z2);  // 1 - u1 = 1: radius 0
  EXPECT_EQ(z1, 0.0);
  EXPECT_EQ(z2, 0.0);
  BoxMuller(1 - std::exp(-0.5), 0.25, &z1, &z2);  // radius 1, angle pi/2
  EXPECT_NEAR(z1, 0.0, 1e-15);
  EXPECT_NEAR(z2, 1.0, 1e-15);
}

TEST(PopulationTest, GaussianHeightsHaveTheirMoments) {
  PopulationSpec spec;
  spec.count = 100001;  // odd: the last pair is cut
  spec.height_scale = 2e-6;
  spec.radius = 1e-4;
  spec.seed = 7;
  const Population p = *GeneratePopulation(spec);
  ASSERT_EQ(p.heights.size(), spec.count);
  double mean = 0, square = 0;
  for (double h : p.heights) mean += h, square += h * h;
  mean /= spec.count;
  const double sigma = std::sqrt(square / spec.count - mean * mean);
  // Sampling error of 1e5 draws: ~0.3 % of sigma; 5 standard errors.
  EXPECT_NEAR(mean, 0, 5 * 2e-6 / std::sqrt(1e5));
  EXPECT_NEAR(sigma, 2e-6, 0.02 * 2e-6);
  for (double r : p.radii) EXPECT_EQ(r, 1e-4);
}

TEST(PopulationTest, ExponentialHeightsAndLognormalRadii) {
  PopulationSpec spec;
  spec.count = 100000;
  spec.heights = HeightDistribution::kExponential;
  spec.height_scale = 1e-6;
  spec.radii = RadiusDistribution::kLognormal;
  spec.radius = 1e-4;
  spec.log_sigma = 0.5;
  spec.seed = 11;
  const Population p = *GeneratePopulation(spec);
  double mean = 0, log_mean = 0;
  for (double h : p.heights) {
    EXPECT_GE(h, 0);
    mean += h;
  }
  for (double r : p.radii) log_mean += std::log(r / 1e-4);
  EXPECT_NEAR(mean / spec.count, 1e-6, 0.02e-6);
  EXPECT_NEAR(log_mean / spec.count, 0, 0.01);  // median R = radius
}

TEST(PopulationTest, SameSeedSamePopulationAndHeightsIndependentOfRadii) {
  PopulationSpec spec;
  spec.count = 1001;
  spec.height_scale = 1e-6;
  spec.radius = 1e-4;
  spec.seed = 3;
  const Population a = *GeneratePopulation(spec);
  const Population b = *GeneratePopulation(spec);
  EXPECT_TRUE(SameBits(a.heights, b.heights));
  spec.radii = RadiusDistribution::kLognormal;
  spec.log_sigma = 1;
  const Population c = *GeneratePopulation(spec);
  EXPECT_TRUE(SameBits(a.heights, c.heights));
  spec.seed = 4;
  const Population d = *GeneratePopulation(spec);
  EXPECT_NE(a.heights, d.heights);
}

TEST(PopulationTest, BadSpecsNameTheField) {
  PopulationSpec spec;
  spec.count = 10;
  spec.height_scale = 1e-6;
  spec.radius = 1e-4;
  auto field = [](const PopulationSpec& s) { return GeneratePopulation(s).status().field(); };
  PopulationSpec bad = spec;
  bad.count = 0;
  EXPECT_EQ(field(bad), "count");
  bad = spec;
  bad.count = kMaxInterfaceContacts + 1;
  EXPECT_EQ(field(bad), "count");
  bad = spec;
  bad.height_scale = -1;
  EXPECT_EQ(field(bad), "height_scale");
  bad = spec;
  bad.height_scale = NAN;
  EXPECT_EQ(field(bad), "height_scale");
  bad = spec;
  bad.radius = 0;
  EXPECT_EQ(field(bad), "radius");
  bad = spec;
  bad.radii = RadiusDistribution::kLognormal;
  bad.log_sigma = 4;
  EXPECT_EQ(field(bad), "log_sigma");
  EXPECT_EQ(GeneratePopulation(bad).status().code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(ExplicitPopulation({}, {}).status().field(), "heights");
  EXPECT_EQ(ExplicitPopulation({0, 1e-6}, {1e-4}).status().field(), "radii");
  EXPECT_EQ(ExplicitPopulation({0, INFINITY}, {1e-4, 1e-4}).status().field(), "heights[1]");
  EXPECT_EQ(ExplicitPopulation({0, 0}, {1e-4, -1}).status().field(), "radii[1]");
  EXPECT_TRUE(ExplicitPopulation({0, -1e-6}, {1e-4, 2e-4}).ok());
}

// Without radii (a shared profile), the heights are those of any radius distribution, the radius
// is not looked at, and a shared-profile config refuses radii.
TEST(PopulationTest, NoRadiiForASharedProfile) {
  PopulationSpec spec;
  spec.count = 50;
  spec.height_scale = 1e-6;
  spec.radius = 1e-4;
  spec.seed = 5;
  const Population spheres = *GeneratePopulation(spec);
  spec.radii = RadiusDistribution::kNone;
  spec.radius = 0;
  const Population shared = *GeneratePopulation(spec);
  EXPECT_EQ(shared.heights, spheres.heights);
  EXPECT_TRUE(shared.radii.empty());
  EXPECT_TRUE(ExplicitPopulation({0, -1e-6}, {}).ok());

  ContactConfig cone;
  cone.profile = *MakeCone(0.05);
  cone.material = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  cone.friction = 0.3;
  const InterfaceConfig config = *SharedProfileInterfaceConfig(shared, cone);
  ASSERT_EQ(config.contacts.size(), 50u);
  EXPECT_EQ(config.contacts[7].profile, cone.profile);  // one profile object, shared
  EXPECT_EQ(config.heights[7], -shared.heights[7]);
  EXPECT_EQ(SharedProfileInterfaceConfig(spheres, cone).status().field(), "radii");
}

// ---------------------------------------------------------------- shared motion

// The reference: a single Contact driven at depth delta - h and displacement ux.
Status MoveSingle(Contact& contact, double depth, double ux) {
  return contact.Apply({NormalControl::kDepth, depth, TangentialControl::kDisplacement, ux});
}

TEST(InterfaceTest, OneContactIsBitIdenticalToASingleContact) {
  for (const double height : {0.0, -3e-7, 2e-7}) {
    ContactConfig config;
    config.profile = *MakeSphere(0.01);
    config.material = Steel();
    config.friction = 0.3;
    InterfaceConfig one;
    one.contacts = {config};
    one.heights = {height};
    Interface interface = *Interface::Create(one);
    Contact single = *Contact::Create(config);
    ASSERT_TRUE(MoveSingle(single, interface.approach() - height, 0).ok());
    ASSERT_TRUE(SameSnapshot(interface.contact(0).Snapshot(), single.Snapshot()));
    const double d0 = 1e-6;
    RandomHistory history{std::mt19937_64(5), d0, 0.3 * single.mu_kappa() * d0};
    for (int k = 0; k < 400; ++k) {
      const auto [depth, ux] = history.Next();
      // Alternate absolute and incremental steps of the interface.
      Step step =
          k % 2 ? Step{NormalControl::kDepth, depth + height, TangentialControl::kDisplacement, ux}
                : Step{NormalControl::kDepthIncrement, depth + height - interface.approach(),
                       TangentialControl::kDisplacementIncrement,
                       ux - interface.tangential_displacement()};
      ASSERT_TRUE(interface.Apply(step).ok());
      ASSERT_TRUE(
          MoveSingle(single, interface.approach() - height, interface.tangential_displacement())
              .ok());
      ASSERT_TRUE(SameSnapshot(interface.contact(0).Snapshot(), single.Snapshot())) << "step " << k;
      const InterfaceTotals totals = *interface.Totals();
      ASSERT_TRUE(SameBits(totals.tangential_force, single.tangential_force()));
      ASSERT_TRUE(SameBits(totals.normal_force, single.normal_force()));
      ASSERT_TRUE(SameBits(totals.dissipated_energy, single.dissipated_energy()));
    }
  }
}

// Contact i on the grid method, which sends every step through a new record array
// (Interface::StepContacts) instead of in place.
InterfaceConfig WithGridContact(InterfaceConfig config, std::size_t i) {
  config.contacts[i].method = Method::kGrid;
  config.contacts[i].grid_size = 64;
  config.contacts[i].grid_max_radius = 1e-4;
  return config;
}

// Contacts of several settings, and several profiles of each (ConfigTable): lognormal radii,
// every third contact with another friction and every fifth one without energy.
InterfaceConfig MixedSettings(std::size_t n, std::uint64_t seed) {
  InterfaceConfig config = RoughInterface(n, seed, 0.3, /*log_sigma=*/0.4);
  for (std::size_t i = 0; i < n; i += 3) config.contacts[i].friction = 0.45;
  for (std::size_t i = 0; i < n; i += 5) config.contacts[i].track_energy = false;
  return config;
}

// Totals of an interface equal the in-order sums over independent contacts, bit for bit, with
// and without worker threads.
void CheckSumOfIndependentContacts(const InterfaceConfig& config, int workers, int steps = 60) {
  const std::size_t n = config.contacts.size();
  Interface interface = *Interface::Create(config);
  if (workers > 1) interface.set_parallel(*MakeThreadParallelFor(workers));
  std::vector<Contact> singles;
  for (std::size_t i = 0; i < n; ++i) {
    singles.push_back(*Contact::Create(config.contacts[i]));
    // Where the interface starts: touching its highest summit.
    ASSERT_TRUE(MoveSingle(singles[i], interface.approach() - config.heights[i], 0).ok());
  }
  const double d0 = 2e-6;
  RandomHistory history{std::mt19937_64(9), d0, 0.3 * singles[0].mu_kappa() * d0};
  for (int k = 0; k < steps; ++k) {
    const auto [depth, ux] = history.Next();
    ASSERT_TRUE(
        interface.Apply({NormalControl::kDepth, depth - 2e-6, TangentialControl::kDisplacement, ux})
            .ok());
    double fn = 0, fx = 0, energy = 0, limit = 0;
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(MoveSingle(singles[i], interface.approach() - config.heights[i], ux).ok());
      fn += singles[i].normal_force();
      fx += singles[i].tangential_force();
      energy += singles[i].dissipated_energy();
      limit += singles[i].friction_limit();
    }
    ASSERT_EQ(interface.vertex_count(), interface.CountVertices().now) << k;
    const InterfaceTotals totals = *interface.Totals();
    ASSERT_TRUE(SameBits(totals.normal_force, fn)) << k;
    ASSERT_TRUE(SameBits(totals.tangential_force, fx)) << k;
    ASSERT_TRUE(SameBits(totals.dissipated_energy, energy)) << k;
    ASSERT_TRUE(SameBits(totals.friction_limit, limit)) << k;
  }
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(SameSnapshot(interface.contact(i).Snapshot(), singles[i].Snapshot())) << i;
  }
}

TEST(InterfaceTest, TotalsAreSumsOfIndependentContacts) {
  CheckSumOfIndependentContacts(RoughInterface(40, 21), 1);
}

TEST(InterfaceTest, TwoWorkersGiveTheSameBits) {
  CheckSumOfIndependentContacts(RoughInterface(5000, 21), 2);
}

TEST(InterfaceTest, StepsThroughNewRecordsGiveTheSameBits) {
  // A grid contact, or more contacts than a step makes in place, send every step through a new
  // record array (Interface::StepContacts).
  CheckSumOfIndependentContacts(WithGridContact(RoughInterface(40, 21), 1), 1);
  CheckSumOfIndependentContacts(WithGridContact(RoughInterface(3000, 21), 1), 2);
  CheckSumOfIndependentContacts(RoughInterface(Interface::kMaxInPlaceContacts + 1000, 21), 2,
                                /*steps=*/8);
}

// A cursor that goes from contact to contact switches profiles and settings (ContactCursor::
// Bind): the contacts still step as single contacts of their own configs.
TEST(InterfaceTest, DistinctRadiiAndSettingsGiveTheSameBits) {
  const InterfaceConfig mixed = MixedSettings(300, 26);
  const Interface interface = *Interface::Create(mixed);
  EXPECT_EQ(interface.distinct_profiles(), 300u);
  EXPECT_EQ(interface.distinct_configs(), 300u);
  CheckSumOfIndependentContacts(mixed, 1);
  CheckSumOfIndependentContacts(MixedSettings(3000, 27), 2);
  CheckSumOfIndependentContacts(WithGridContact(MixedSettings(300, 28), 4), 2);
}

// A contact that fails in the middle of a step (grid reach, vertex limit): no contact changes.
TEST(InterfaceTest, AContactFailingMidStepChangesNoContact) {
  InterfaceConfig config = RoughInterface(30, 22);
  config.contacts[17].method = Method::kGrid;
  config.contacts[17].grid_size = 16;
  config.contacts[17].grid_max_radius = 2e-6;
  Interface interface = *Interface::Create(config);
  ASSERT_TRUE(interface.Apply({NormalControl::kDepth, config.heights[17] + 1e-8}).ok());
  const InterfaceSnapshot before = interface.Snapshot();
  const Status s = interface.Apply({NormalControl::kDepthIncrement, 1e-6});
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.field(), "contacts[17].grid_max_radius");
  EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), before));

  config = RoughInterface(30, 23);
  for (ContactConfig& c : config.contacts) c.max_memory_vertices = 8;
  interface = *Interface::Create(config);
  ASSERT_TRUE(interface.Apply({NormalControl::kDepth, 3e-6}).ok());
  const double slip = interface.contact(0).mu_kappa() * 1e-6;
  Status failed;
  InterfaceSnapshot last_good;
  for (int k = 0; k < 40 && failed.ok(); ++k) {  // a ring-down nests vertices
    last_good = interface.Snapshot();
    failed = interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement,
                              slip * std::pow(-0.7, k)});
  }
  EXPECT_EQ(failed.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(failed.field().find(".max_memory_vertices"), std::string::npos) << failed.field();
  EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), last_good));
  EXPECT_EQ(interface.vertex_count(), interface.CountVertices().now);  // kept through a failure
}

TEST(InterfaceTest, NormalForceTargetIsReached) {
  Interface interface = *Interface::Create(RoughInterface(500, 2));
  for (const double target : {10.0, 0.5, 40.0, 40.0, 1e-3, 0.0, 7.0}) {
    InterfaceStepReport report;
    ASSERT_TRUE(interface.Apply({NormalControl::kForce, target}, &report).ok()) << target;
    const InterfaceTotals totals = *interface.Totals();
    EXPECT_LE(std::abs(totals.normal_force - target), kInterfaceForceTolerance * target) << target;
    EXPECT_EQ(report.force_residual, std::abs(totals.normal_force - target));
    EXPECT_LE(report.solver_iterations, 30);
  }
}

TEST(InterfaceTest, TangentialForceTargetIsReached) {
  Interface interface = *Interface::Create(RoughInterface(300, 4));
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 20.0}).ok());
  const double limit = interface.Totals()->friction_limit;
  ASSERT_GT(limit, 0);
  // Loading, reversal, reloading, gross slip and back: a Mindlin-Deresiewicz path in force.
  for (const double fraction : {0.3, 0.9, -0.5, 0.6, 1.0, -1.0, 0.2, 0.2}) {
    const double target = fraction * limit;
    InterfaceStepReport report;
    ASSERT_TRUE(interface
                    .Apply({NormalControl::kDepthIncrement, 0,
                            TangentialControl::kForce, target},
                           &report)
                    .ok())
        << fraction;
    const InterfaceTotals totals = *interface.Totals();
    EXPECT_LE(std::abs(totals.tangential_force - target), kInterfaceForceTolerance * limit)
        << fraction;
    if (std::abs(fraction) == 1) {
      EXPECT_EQ(totals.gross_slip, totals.in_contact);
    }
  }
  const InterfaceSnapshot before = interface.Snapshot();
  const Status beyond =
      interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 1.01 * limit});
  EXPECT_EQ(beyond.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(beyond.field(), "tangential_force");
  EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), before));
}

TEST(InterfaceTest, AllOutOfContact) {
  Interface interface = *Interface::Create(RoughInterface(100, 5));
  ASSERT_TRUE(interface.Apply({NormalControl::kDepthIncrement, -1e-5,
                               TangentialControl::kDisplacementIncrement, 1e-6})
                  .ok());
  InterfaceTotals totals = *interface.Totals();
  EXPECT_EQ(totals.in_contact, 0u);
  EXPECT_EQ(totals.normal_force, 0);
  EXPECT_EQ(totals.tangential_force, 0);
  EXPECT_EQ(totals.dissipated_energy, 0);
  EXPECT_EQ(totals.normal_stiffness, 0);
  EXPECT_TRUE(
      interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 0}).ok());
  EXPECT_EQ(
      interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 1e-9}).field(),
      "tangential_force");
  std::vector<std::size_t> histogram = *interface.SlipHistogram(4);
  EXPECT_EQ(histogram, std::vector<std::size_t>(4, 0));
  // A zero normal force target from no contact holds the approach.
  const double approach = interface.approach();
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 0}).ok());
  EXPECT_EQ(interface.approach(), approach);
}

TEST(InterfaceTest, AllInGrossSlip) {
  Interface interface = *Interface::Create(RoughInterface(200, 6));
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 30.0}).ok());
  const InterfaceTotals loaded = *interface.Totals();
  ASSERT_GT(loaded.in_contact, 10u);
  ASSERT_EQ(loaded.sticking, loaded.in_contact);
  // Far beyond every contact's slip distance: every contact slides, F_x = sum mu F_N.
  ASSERT_TRUE(interface.Apply({NormalControl::kDepthIncrement, 0,
                               TangentialControl::kDisplacementIncrement, 1e-3})
                  .ok());
  const InterfaceTotals sliding = *interface.Totals();
  EXPECT_EQ(sliding.gross_slip, sliding.in_contact);
  EXPECT_EQ(sliding.tangential_stiffness.positive, 0);
  EXPECT_NEAR(sliding.tangential_force, sliding.friction_limit, 1e-12 * sliding.friction_limit);
  EXPECT_GT(sliding.dissipated_energy, 0);
  const std::vector<std::size_t> histogram = *interface.SlipHistogram(10);
  EXPECT_EQ(histogram.back(), sliding.in_contact);
  // A small reversal: every contact sticks again, then slips partially.
  ASSERT_TRUE(interface.Apply({NormalControl::kDepthIncrement, 0,
                               TangentialControl::kDisplacementIncrement, -1e-9})
                  .ok());
  const InterfaceTotals reversed = *interface.Totals();
  EXPECT_EQ(reversed.gross_slip, 0u);
  EXPECT_EQ(reversed.partial_slip + reversed.sticking, reversed.in_contact);
}

TEST(InterfaceTest, OneAsperityMatchesTheClosedFormDepth) {
  Population population = *ExplicitPopulation({1e-6}, {1e-2});
  Interface interface = *Interface::Create(*HertzInterfaceConfig(population, Steel(), 0.3));
  EXPECT_EQ(interface.approach(), -1e-6);
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 100.0}).ok());
  const Contact& c = interface.contact(0);
  EXPECT_NEAR(c.depth(), c.DepthAtNormalForce(100.0), 1e-13 * c.depth());
  EXPECT_LE(std::abs(c.normal_force() - 100.0), kInterfaceForceTolerance * 100.0);
}

TEST(InterfaceTest, SnapshotRestoreContinuesBitIdentically) {
  const InterfaceConfig config = RoughInterface(120, 8);
  Interface a = *Interface::Create(config);
  ASSERT_TRUE(a.Apply({NormalControl::kForce, 15.0}).ok());
  ASSERT_TRUE(
      a.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 3e-7})
          .ok());
  Interface b = *Interface::Restore(config, a.Snapshot());
  ASSERT_TRUE(SameInterfaceState(a.Snapshot(), b.Snapshot()));
  ASSERT_EQ(b.vertex_count(), a.vertex_count());
  ASSERT_EQ(b.vertex_count(), b.CountVertices().now);
  const double d0 = 1e-6;
  RandomHistory history{std::mt19937_64(13), d0, 1e-6};
  for (int k = 0; k < 50; ++k) {
    const auto [depth, ux] = history.Next();
    const Step step{NormalControl::kDepth, depth - 1e-6, TangentialControl::kDisplacement, ux};
    ASSERT_TRUE(a.Apply(step).ok());
    ASSERT_TRUE(b.Apply(step).ok());
  }
  EXPECT_TRUE(SameInterfaceState(a.Snapshot(), b.Snapshot()));

  InterfaceSnapshot bad = a.Snapshot();
  bad.contacts[3].tangential_displacement += 1e-9;
  EXPECT_EQ(Interface::Restore(config, bad).status().field(),
            "contacts[3].tangential_displacement");
  bad = a.Snapshot();
  bad.approach += 1e-9;
  EXPECT_EQ(Interface::Restore(config, bad).status().field(), "contacts[0].depth");
  bad = a.Snapshot();
  bad.contacts.pop_back();
  EXPECT_EQ(Interface::Restore(config, bad).status().field(), "contacts");
  bad = a.Snapshot();
  bad.contacts[7].dissipated_energy = -1;
  EXPECT_EQ(Interface::Restore(config, bad).status().field(), "contacts[7].dissipated_energy");
}

TEST(InterfaceTest, BadInputsNameTheFieldAndChangeNothing) {
  InterfaceConfig config = RoughInterface(50, 10);
  Interface interface = *Interface::Create(config);
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 5.0}).ok());
  const InterfaceSnapshot before = interface.Snapshot();
  auto field = [&](const Step& step) {
    const Status s = interface.Apply(step);
    EXPECT_FALSE(s.ok());
    EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), before)) << s.ToString();
    return s.field();
  };
  EXPECT_EQ(field({NormalControl::kDepth, NAN}), "approach");
  EXPECT_EQ(field({NormalControl::kDepthIncrement, INFINITY}), "approach_increment");
  EXPECT_EQ(field({NormalControl::kDepth, 1e200}), "approach");
  EXPECT_EQ(field({NormalControl::kForce, -1}), "normal_force");
  EXPECT_EQ(field({NormalControl::kForce, 1e300}), "normal_force");
  EXPECT_EQ(field({NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement, NAN}),
            "displacement");
  EXPECT_EQ(field({NormalControl::kForce, 6.0, TangentialControl::kDisplacementIncrement, 1e-8}),
            "displacement_increment");
  EXPECT_EQ(field({NormalControl::kDepthIncrement, 1e-8, TangentialControl::kForce, 0.1}),
            "approach_increment");
  ContactListStep list;
  EXPECT_EQ(interface.ApplyEach(list).field(), "kind");

  InterfaceConfig bad = config;
  bad.heights.pop_back();
  EXPECT_EQ(Interface::Create(bad).status().field(), "heights");
  bad = config;
  bad.heights[4] = NAN;
  EXPECT_EQ(Interface::Create(bad).status().field(), "heights[4]");
  bad = config;
  bad.contacts[2].friction = -1;
  EXPECT_EQ(Interface::Create(bad).status().field(), "contacts[2].friction");
  bad = config;
  bad.contacts.clear();
  EXPECT_EQ(Interface::Create(bad).status().field(), "contacts");
  bad = config;
  bad.kind = InterfaceKind::kContactList;
  EXPECT_EQ(Interface::Create(bad).status().field(), "heights");
  EXPECT_EQ(interface.SlipHistogram(0).status().field(), "bins");
  EXPECT_EQ(MakeThreadParallelFor(0).status().field(), "workers");
  Population population = *ExplicitPopulation({0, 0}, {1e-4, 1e-4});
  EXPECT_EQ(HertzInterfaceConfig(population, EffectiveMaterial{-1, 1}, 0.3)
                .value()
                .contacts[0]
                .material.e_star,
            -1);  // built as given, refused at Create:
  EXPECT_EQ(Interface::Create(*HertzInterfaceConfig(population, EffectiveMaterial{-1, 1}, 0.3))
                .status()
                .field(),
            "contacts[0].material.e_star");
}

// The thread pool's runs: every index of [0, n) exactly once, in non-empty ranges, over many
// runs back to back (the workers then find the next run while they still spin), for more workers
// than indices and sizes that split unevenly, and with more threads than the machine has cores.
TEST(InterfaceTest, ThreadParallelForRunsEveryIndexOnce) {
  for (int workers : {1, 2, 3, 5, 64}) {
    std::shared_ptr<ParallelFor> parallel = *MakeThreadParallelFor(workers);
    EXPECT_EQ(parallel->workers(), workers);
    for (std::size_t n : {0, 1, 2, 31, 33, 100, 4097}) {
      std::vector<std::atomic<int>> visits(n);
      std::atomic<int> empty_ranges{0};
      const ParallelFor::Body body = [&](std::size_t begin, std::size_t end) {
        if (begin >= end || end > n) ++empty_ranges;
        for (std::size_t i = begin; i < end && i < n; ++i) ++visits[i];
      };
      constexpr int kRuns = 40;
      for (int run = 0; run < kRuns; ++run) parallel->Run(n, body);
      EXPECT_EQ(empty_ranges.load(), 0) << workers << " workers, n = " << n;
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(visits[i].load(), kRuns) << workers << " workers, n = " << n << ", index " << i;
      }
    }
  }
}

TEST(InterfaceTest, ACancelledStepChangesNothing) {
  Interface interface = *Interface::Create(RoughInterface(3 * Interface::kInterruptPeriod, 12));
  interface.set_parallel(*MakeThreadParallelFor(2));
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 50.0}).ok());
  const InterfaceSnapshot before = interface.Snapshot();
  std::atomic<bool> cancelled{true};
  const Interrupt interrupt(Interrupt::Clock::time_point::max(), &cancelled);
  for (const Step& step :
       {Step{NormalControl::kDepthIncrement, 1e-7}, Step{NormalControl::kForce, 60.0},
        Step{NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 1.0}}) {
    EXPECT_EQ(interface.Apply(step, nullptr, interrupt).code(), StatusCode::kCancelled);
    EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), before));
  }
  EXPECT_EQ(interface.Totals(interrupt).status().code(), StatusCode::kCancelled);
}

// An interface too large to step in place writes each step into the array the step before
// replaced (its spare): a step that was cancelled or refused half-way through it leaves the
// state as it was, and the next steps give the bits of a copy that never had a spare.
TEST(InterfaceTest, ALargeInterfaceReusesItsRecordsAndStaysExact) {
  const std::size_t n = Interface::kMaxInPlaceContacts + 300;
  Interface interface = *Interface::Create(RoughInterface(n, 15));
  interface.set_parallel(*MakeThreadParallelFor(2));
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 50.0}).ok());
  const std::size_t state_bytes = Interface(interface).MemoryBytes();  // a copy has no spare
  EXPECT_EQ(interface.MemoryBytes(), state_bytes + n * PackedContacts::kRecordBytes);
  Interface twin = interface;
  std::atomic<bool> cancelled{true};
  const Interrupt interrupt(Interrupt::Clock::time_point::max(), &cancelled);
  const double slip = interface.contact(0).mu_kappa() * 1e-6;
  const Step shear{NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement,
                   0.4 * slip};
  EXPECT_EQ(interface.Apply(shear, nullptr, interrupt).code(), StatusCode::kCancelled);
  const auto refuse = [](const Interface::StepCommit&) {
    return ResourceExhausted("budget", "refused by the test");
  };
  EXPECT_EQ(interface.Apply(shear, nullptr, {}, refuse).code(), StatusCode::kResourceExhausted);
  EXPECT_TRUE(SameInterfaceState(interface.Snapshot(), twin.Snapshot()));
  for (const double dux : {0.4, -0.7, 0.5, -0.3}) {
    const Step step{NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement,
                    dux * slip};
    ASSERT_TRUE(interface.Apply(step).ok());
    Interface fresh = twin;  // a copy: its step writes a new array
    ASSERT_TRUE(fresh.Apply(step).ok());
    ASSERT_TRUE(SameInterfaceState(interface.Snapshot(), fresh.Snapshot())) << dux;
    twin = std::move(fresh);
  }
}

// Each contact is one record (PackedContacts) beside its height; the configs are shared. A
// memory longer than a record holds takes a heap block, which MemoryBytes counts; a copy holds
// the same state and bytes.
TEST(InterfaceTest, MemoryBytesCountRecordsBlocksAndSharedConfigs) {
  Interface interface = *Interface::Create(RoughInterface(1000, 14));
  ASSERT_TRUE(interface.Apply({NormalControl::kForce, 50.0}).ok());
  EXPECT_EQ(interface.distinct_configs(), 1u);
  const auto per_contact = [&] {
    return static_cast<double>(interface.MemoryBytes()) / static_cast<double>(interface.size());
  };
  constexpr double kRecordAndHeight = PackedContacts::kRecordBytes + sizeof(double);
  EXPECT_GE(per_contact(), kRecordAndHeight);
  EXPECT_LE(per_contact(), kRecordAndHeight + 2);  // the config and the object, shared
  // Reversals of decreasing amplitude nest: the memories outgrow their records.
  const double slip = interface.contact(0).mu_kappa() * 1e-6;
  for (const double dux : {0.4, -0.7, 0.5, -0.3, 0.2, -0.1}) {
    ASSERT_TRUE(interface
                    .Apply({NormalControl::kDepthIncrement, 0,
                            TangentialControl::kDisplacementIncrement, dux * slip})
                    .ok());
  }
  EXPECT_GT(per_contact(), kRecordAndHeight + 8);  // blocks of 64 bytes for some contacts
  EXPECT_LT(per_contact(), kRecordAndHeight + 2 + 64 * 4);
  const Interface copy = interface;
  EXPECT_EQ(copy.MemoryBytes(), interface.MemoryBytes());
  EXPECT_TRUE(SameInterfaceState(copy.Snapshot(), interface.Snapshot()));
  // Steps that shorten the memories again give their blocks back.
  ASSERT_TRUE(interface
                  .Apply({NormalControl::kDepthIncrement, 0,
                          TangentialControl::kDisplacementIncrement, 3 * slip})
                  .ok());
  EXPECT_LE(per_contact(), kRecordAndHeight + 2);
}

// Each distinct config once; equal settings once whatever the profile; a config taken out owns
// its profile, a borrowed pointer does not.
TEST(ConfigTableTest, KeepsEachConfigAndSettingsOnce) {
  ContactConfig base;
  base.material = Steel();
  base.friction = 0.3;
  const ProfilePtr one = *MakeSphere(1e-4), two = *MakeSphere(2e-4);
  const auto with = [&](const ProfilePtr& profile, double friction) {
    ContactConfig config = base;
    config.profile = profile;
    config.friction = friction;
    return config;
  };
  ConfigTable table;
  bool added = false;
  EXPECT_EQ(table.Add(with(one, 0.3), &added), 0u);
  EXPECT_TRUE(added);
  EXPECT_EQ(table.Add(with(one, 0.3), &added), 0u);
  EXPECT_FALSE(added);
  EXPECT_EQ(table.Add(with(two, 0.3), &added), 1u);
  EXPECT_TRUE(added);
  EXPECT_EQ(table.Add(with(one, 0.5), &added), 2u);
  EXPECT_EQ(table.Add(with(two, 0.5), &added), 3u);
  EXPECT_EQ(table.Add(with(two, 0.5), &added), 3u);
  EXPECT_FALSE(added);
  table.FinishAdding();
  EXPECT_EQ(table.size(), 4u);
  EXPECT_EQ(table.profiles(), 2u);
  EXPECT_EQ(table.settings_index(0), table.settings_index(1));
  EXPECT_EQ(table.settings_index(2), table.settings_index(3));
  EXPECT_NE(table.settings_index(0), table.settings_index(2));
  EXPECT_EQ(table.settings(3).profile, nullptr);
  EXPECT_TRUE(SameConfig(table.Config(3), with(two, 0.5)));
  EXPECT_TRUE(SameConfig(table.Config(0), with(one, 0.3)));
  EXPECT_GT(table.Config(1).profile.use_count(), two.use_count() - 1);
  EXPECT_EQ(table.BorrowedProfile(1).use_count(), 0);
  EXPECT_EQ(table.BorrowedProfile(1).get(), two.get());
  EXPECT_EQ(&table.profile(2), one.get());
  EXPECT_GE(table.MemoryBytes(), 4 * 16 + 2 * sizeof(ContactConfig) + 2 * 32);
}

// Summits of distinct radii share their settings (ConfigTable): each costs a 16-byte entry, its
// depth limit and its 32-byte sphere beside its record and height.
TEST(InterfaceTest, DistinctRadiiCostAnEntryAndASphereEach) {
  const Interface interface = *Interface::Create(RoughInterface(1000, 14, 0.3, 0.5));
  EXPECT_EQ(interface.distinct_profiles(), 1000u);
  const double per_contact =
      static_cast<double>(interface.MemoryBytes()) / static_cast<double>(interface.size());
  constexpr double kRecordAndHeight = PackedContacts::kRecordBytes + sizeof(double);
  constexpr double kEntryLimitAndSphere = 16 + sizeof(double) + 32;
  EXPECT_GE(per_contact, kRecordAndHeight + kEntryLimitAndSphere);
  EXPECT_LE(per_contact, kRecordAndHeight + kEntryLimitAndSphere + 2);
}

// A contact taken out of an interface owns its profile (the interface's cursors only borrow
// theirs): it outlives the interface and the config it was made from.
TEST(InterfaceTest, AContactTakenOutOwnsItsProfile) {
  std::optional<Contact> taken;
  {
    InterfaceConfig config = RoughInterface(20, 29, 0.3, 0.5);
    Interface interface = *Interface::Create(config);
    ASSERT_TRUE(interface.Apply({NormalControl::kDepthIncrement, 2e-6}).ok());
    taken = interface.contact(7);
  }
  EXPECT_GT(taken->config().profile.use_count(), 0);
  EXPECT_NE(taken->config().profile->Describe().find("sphere R = "), std::string::npos);
  Contact single = *Contact::Create(taken->config());
  ASSERT_TRUE(MoveSingle(single, taken->depth(), 0).ok());
  ASSERT_TRUE(SameSnapshot(single.Snapshot(), taken->Snapshot()));
  ASSERT_TRUE(taken
                  ->Apply({NormalControl::kDepthIncrement, 1e-7,
                           TangentialControl::kDisplacementIncrement, 1e-8})
                  .ok());
}

// The commit gate sees what the step holds when it commits: for a step through a new record
// array the exact bytes of that array and the vertices after it (well below the a-priori bound);
// for one in place the bounds known before it runs. A refusal by the gate changes nothing.
TEST(InterfaceTest, TheCommitGateSeesWhatTheStepHolds) {
  for (const std::size_t n : {std::size_t{300}, Interface::kMaxInPlaceContacts + 100}) {
    Interface interface = *Interface::Create(RoughInterface(n, 30));
    // Fresh records hold no heap block: the rest of MemoryBytes is what no step changes.
    const std::size_t fixed = interface.MemoryBytes() - n * PackedContacts::kRecordBytes;
    ASSERT_TRUE(interface.Apply({NormalControl::kDepthIncrement, 2e-6}).ok());
    const double slip = interface.contact(0).mu_kappa() * 1e-6;
    for (const double dux : {0.4, -0.7, 0.5, -0.3, 0.2}) {
      const Step step{NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement,
                      dux * slip};
      const std::size_t bound = interface.StepBytesBound();
      const std::size_t after_one_move = interface.CountVertices().after_one_move;
      const InterfaceSnapshot before = interface.Snapshot();
      const std::size_t bytes_before = interface.MemoryBytes();
      const auto refuse = [](const Interface::StepCommit&) {
        return ResourceExhausted("budget", "refused by the test");
      };
      ASSERT_EQ(interface.Apply(step, nullptr, {}, refuse).code(), StatusCode::kResourceExhausted);
      ASSERT_TRUE(SameInterfaceState(interface.Snapshot(), before));
      ASSERT_EQ(interface.MemoryBytes(), bytes_before);
      Interface::StepCommit seen;
      ASSERT_TRUE(interface
                      .Apply(step, nullptr, {},
                             [&](const Interface::StepCommit& commit) {
                               seen = commit;
                               return OkStatus();
                             })
                      .ok());
      if (n <= Interface::kMaxInPlaceContacts) {
        EXPECT_FALSE(seen.exact);
        EXPECT_EQ(seen.extra_bytes, bound) << dux;
        EXPECT_EQ(seen.vertices, after_one_move) << dux;
      } else {
        // The array the step replaced is kept for the next one (its records only).
        const std::size_t spare = n * PackedContacts::kRecordBytes;
        EXPECT_TRUE(seen.exact);
        EXPECT_EQ(seen.extra_bytes, interface.MemoryBytes() - fixed - spare) << dux;
        EXPECT_EQ(seen.vertices, interface.CountVertices().now) << dux;
        EXPECT_LT(seen.extra_bytes, bound) << dux;
      }
    }
  }
}

// The bound of what a step holds while it runs covers what it holds after it, and a new record
// array besides.
TEST(InterfaceTest, StepBytesBoundCoversTheStep) {
  Interface interface = *Interface::Create(RoughInterface(500, 15));
  const double slip = interface.contact(0).mu_kappa() * 1e-6;
  const std::vector<Step> steps = {
      {NormalControl::kForce, 20.0},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 0.3 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 1.0},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, -0.7 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 0.4 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, -0.2 * slip},
      {NormalControl::kDepthIncrement, 2e-7, TangentialControl::kDisplacementIncrement, 0.1 * slip},
      {NormalControl::kForce, 5.0}};
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const std::size_t before = interface.MemoryBytes();
    const std::size_t bound = interface.StepBytesBound();
    EXPECT_GE(bound, interface.size() * PackedContacts::kRecordBytes) << k;
    ASSERT_TRUE(interface.Apply(steps[k]).ok()) << k;
    EXPECT_LE(interface.MemoryBytes(), before + bound) << k;
  }
}

// set_keep_step_forces: SumForces after any kind of step, refused steps included, must give the
// bits of a twin that computes every force afresh (the kept values are used only while no other
// change has happened since the in-place step that computed them).
// The bits of the four sums, in one array so that one comparison names all of them.
std::array<std::uint64_t, 4> SumBits(const Interface::ForceSums& sums) {
  return {std::bit_cast<std::uint64_t>(sums.normal_force),
          std::bit_cast<std::uint64_t>(sums.tangential_force),
          std::bit_cast<std::uint64_t>(sums.dissipated_energy),
          std::bit_cast<std::uint64_t>(sums.friction_limit)};
}

void ExpectSameSums(const Interface& kept, const Interface& fresh, const std::string& where) {
  for (const bool normal : {false, true}) {
    for (const bool tangential : {false, true}) {
      EXPECT_EQ(SumBits(kept.SumForces(normal, tangential, true)),
                SumBits(fresh.SumForces(normal, tangential, true)))
          << where << ", normal " << normal << ", tangential " << tangential;
    }
  }
  const InterfaceTotals totals = *fresh.Totals();
  EXPECT_EQ(kept.SumForces(true, true, true).tangential_force, totals.tangential_force) << where;
}

TEST(InterfaceTest, KeptStepForcesSumToTheBitsOfFreshOnesAfterEveryKindOfStep) {
  Interface kept = *Interface::Create(RoughInterface(300, 23));
  kept.set_keep_step_forces(true);
  Interface fresh = *Interface::Create(RoughInterface(300, 23));
  EXPECT_EQ(kept.MemoryBytes(), fresh.MemoryBytes() + 2 * 300 * sizeof(double));
  const double slip = kept.contact(0).mu_kappa() * 1e-6;
  const std::vector<Step> steps = {
      {NormalControl::kForce, 20.0},  // solved through the step buffer
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 0.3 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kForce, 1.0},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, -0.7 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement, 1.0},  // refused
      {NormalControl::kDepthIncrement, 2e-7, TangentialControl::kDisplacementIncrement, 0.1 * slip},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 50 * slip},
      {NormalControl::kForce, 5.0},
      {NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacementIncrement, 0.2 * slip}};
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const StatusCode code = kept.Apply(steps[k]).code();
    EXPECT_EQ(fresh.Apply(steps[k]).code(), code) << k;
    ExpectSameSums(kept, fresh, "shared motion, step " + std::to_string(k));
  }
  Interface copy = kept;  // a copy keeps the values with the state they belong to
  ExpectSameSums(copy, fresh, "copy");
  ASSERT_TRUE(copy.Apply(steps.back()).ok());
  ASSERT_TRUE(fresh.Apply(steps.back()).ok());
  ExpectSameSums(copy, fresh, "copy, stepped");

  const std::size_t n = 40;
  InterfaceConfig config = RoughInterface(n, 24);
  config.kind = InterfaceKind::kContactList;
  config.heights.clear();
  Interface kept_list = *Interface::Create(config);
  kept_list.set_keep_step_forces(true);
  Interface fresh_list = *Interface::Create(config);
  std::mt19937_64 rng(25);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> dn(n), dt(n);
  for (int k = 0; k < 30; ++k) {
    const bool force = k % 7 == 6;      // force targets: through the step buffer
    const bool refused = k % 11 == 10;  // one contact's value is not finite
    for (std::size_t i = 0; i < n; ++i) {
      dn[i] = force ? 0 : (k == 0 ? 1e-6 : 2e-7 * u(rng));
      dt[i] = force ? 0.5 * u(rng) * fresh_list.contact(i).friction_limit() : 0.5 * slip * u(rng);
    }
    if (refused) dt[n / 2] = std::numeric_limits<double>::infinity();
    const ContactListStep step{
        NormalControl::kDepthIncrement, dn,
        force ? TangentialControl::kForce : TangentialControl::kDisplacementIncrement, dt};
    const StatusCode code = kept_list.ApplyEach(step).code();
    EXPECT_EQ(fresh_list.ApplyEach(step).code(), code) << k;
    EXPECT_EQ(code == StatusCode::kOk, !refused) << k;
    ExpectSameSums(kept_list, fresh_list, "contact list, step " + std::to_string(k));
  }
}

// ---------------------------------------------------------------- contact list

void CheckListAgainstSingleContacts(InterfaceConfig config) {
  const std::size_t n = config.contacts.size();
  config.kind = InterfaceKind::kContactList;
  config.heights.clear();
  Interface list = *Interface::Create(config);
  std::vector<Contact> singles;
  for (const ContactConfig& c : config.contacts) singles.push_back(*Contact::Create(c));
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  const double slip = singles[0].mu_kappa() * 1e-6;
  std::vector<double> dn(n), dt(n);
  for (int k = 0; k < 100; ++k) {
    const bool force = k % 10 == 9;  // a force-controlled tangential step now and then
    for (std::size_t i = 0; i < n; ++i) {
      dn[i] = force ? 0 : (k == 0 ? 1e-6 : 2e-7 * u(rng));
      dt[i] = force ? 0.5 * u(rng) * singles[i].friction_limit() : 0.5 * slip * u(rng);
    }
    ContactListStep step{
        NormalControl::kDepthIncrement, dn,
        force ? TangentialControl::kForce : TangentialControl::kDisplacementIncrement, dt};
    ASSERT_TRUE(list.ApplyEach(step).ok()) << k;
    ASSERT_EQ(list.vertex_count(), list.CountVertices().now) << k;
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(singles[i].Apply({step.normal, dn[i], step.tangential, dt[i]}).ok());
      ASSERT_TRUE(SameSnapshot(list.contact(i).Snapshot(), singles[i].Snapshot())) << k << " " << i;
    }
  }
}

TEST(ContactListTest, EachContactIsBitIdenticalToASingleContact) {
  CheckListAgainstSingleContacts(RoughInterface(30, 15));
  CheckListAgainstSingleContacts(WithGridContact(RoughInterface(30, 15), 2));
  CheckListAgainstSingleContacts(WithGridContact(MixedSettings(30, 15), 2));
}

TEST(ContactListTest, AFailingContactChangesNoContact) {
  const std::size_t n = 10;
  InterfaceConfig config = RoughInterface(n, 16);
  config.kind = InterfaceKind::kContactList;
  config.heights.clear();
  Interface list = *Interface::Create(config);
  std::vector<double> dn(n, 1e-6), dt(n, 0);
  ASSERT_TRUE(list.ApplyEach({NormalControl::kDepthIncrement, dn,
                              TangentialControl::kDisplacementIncrement, dt})
                  .ok());
  const InterfaceSnapshot before = list.Snapshot();
  std::vector<double> fx(n, 0);
  for (std::size_t i = 0; i < n; ++i) fx[i] = 0.5 * list.contact(i).friction_limit();
  fx[6] = 2 * list.contact(6).friction_limit();
  std::vector<double> zero(n, 0);
  Status s = list.ApplyEach({NormalControl::kDepthIncrement, zero, TangentialControl::kForce, fx});
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.field(), "contacts[6].tangential_force");
  EXPECT_TRUE(SameInterfaceState(list.Snapshot(), before));

  std::vector<double> bad = zero;
  bad[3] = NAN;
  EXPECT_EQ(list.ApplyEach({NormalControl::kDepthIncrement, bad,
                            TangentialControl::kDisplacementIncrement, zero})
                .field(),
            "normal_values[3]");
  EXPECT_EQ(list.ApplyEach({NormalControl::kDepthIncrement, zero,
                            TangentialControl::kDisplacementIncrement, bad})
                .field(),
            "tangential_values[3]");
  bad = zero;
  bad[8] = 1e200;
  EXPECT_EQ(
      list.ApplyEach({NormalControl::kDepth, bad, TangentialControl::kDisplacementIncrement, zero})
          .field(),
      "normal_values[8]");
  std::vector<double> short_values(n - 1, 0);
  EXPECT_EQ(list.ApplyEach({NormalControl::kDepthIncrement, short_values,
                            TangentialControl::kDisplacementIncrement, zero})
                .field(),
            "normal_values");
  EXPECT_EQ(list.Apply({}).field(), "kind");
  EXPECT_TRUE(SameInterfaceState(list.Snapshot(), before));
}

}  // namespace
}  // namespace mdr
