// Exact loops, regime thresholds, fretting maps and backbones (issue #24): against the closed
// forms of docs/analysis.md, the series-spring invariances, and the shapes a truncated sphere and a
// soft rig give.
#include "mdr/analysis/exact_loops.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fixtures/reference_scenes.h"
#include "mdr/core/tabulated_profile.h"

namespace mdr::analysis {
namespace {

ContactConfig SceneOf(ProfilePtr profile, double friction = 0.3, RigCompliance rig = {}) {
  ContactConfig scene;
  scene.profile = std::move(profile);
  scene.material = *ElasticPair(210e9, 0.3, 70e9, 0.33);
  scene.friction = friction;
  scene.rig = rig;
  return scene;
}

void ExpectRelative(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected)) << "expected " << expected;
}

// At the onset of gross slip a power law's contact loop has A = 1/(2n+1) and B = 2^(1/(n+1)) - 1
// (docs/analysis.md): the Hertz sphere's 0.2 and 0.26 (C = 0.77), a cone's 1/3 and 0.414.
TEST(ExactLoopsTest, OnsetThresholdsOfPowerLawsAreTheClosedForms) {
  struct Case {
    ProfilePtr profile;
    double n;
  };
  for (const Case& c :
       {Case{*MakeSphere(0.01), 2}, Case{*MakeCone(0.2), 1}, Case{*MakePowerLaw(50, 0.5), 0.5},
        Case{*MakePowerLaw(1e5, 3), 3}, Case{*MakePowerLaw(1e12, 8), 8}}) {
    for (double normal_force : {0.1, 100.0}) {
      Result<LoopFigures> onset = GrossSlipOnset(SceneOf(c.profile), normal_force);
      ASSERT_TRUE(onset.ok()) << onset.status().ToString();
      SCOPED_TRACE(c.profile->Describe() + " at " + std::to_string(normal_force) + " N");
      const double a = 1 / (2 * c.n + 1), b = std::pow(2.0, 1 / (c.n + 1)) - 1;
      ExpectRelative(onset->contact_energy_ratio, a, 1e-9);
      ExpectRelative(onset->contact_sliding_ratio, b, 1e-9);
      ExpectRelative(onset->system_free_ratio, a / b, 1e-9);
      EXPECT_EQ(onset->energy_ratio, onset->contact_energy_ratio) << "no rig";
      ExpectRelative(onset->force_amplitude, 0.3 * normal_force, 1e-12);
    }
  }
  // Hertz: the classical criteria of Fouvry et al.
  const LoopFigures hertz = *GrossSlipOnset(SceneOf(*MakeSphere(0.01)), 100);
  EXPECT_NEAR(hertz.energy_ratio, 0.2, 1e-12);
  EXPECT_NEAR(hertz.sliding_ratio, 0.2599210499, 1e-10);
  EXPECT_NEAR(hertz.system_free_ratio, 0.7694644204, 1e-9);
}

// H1 partial-slip loops: Ed per cycle is Mindlin's W (docs/reference-values.md), Q* the amplitude.
TEST(ExactLoopsTest, HertzLoopsDissipateMindlinsEnergy) {
  const ContactConfig h1 = reference::H1Config();
  ExpectRelative(ExactLoop(h1, 100, AmplitudeKind::kForce, 15)->dissipated_energy, 1.0723816356e-6,
                 1e-9);
  ExpectRelative(ExactLoop(h1, 100, AmplitudeKind::kForce, 27)->dissipated_energy, 1.2217940626e-5,
                 1e-9);
  // The same loop by its displacement amplitude u0 = 4.6949658143e-7 m (F_x = 15 N).
  const LoopFigures by_displacement =
      *ExactLoop(h1, 100, AmplitudeKind::kActuatorDisplacement, 4.6949658143e-7);
  ExpectRelative(by_displacement.force_amplitude, 15, 1e-9);
  ExpectRelative(by_displacement.dissipated_energy, 1.0723816356e-6, 1e-8);
}

// A rig in series changes neither Ed, Q*, delta_0 nor C; the measured amplitude grows by C_t Q*,
// and A and B follow from it (test-rigs: a 10 N/um rig makes the sphere's A read about 0.06 at
// the transition).
TEST(ExactLoopsTest, ARigInSeriesBiasesOnlyTheDisplacementFigures) {
  const ProfilePtr sphere = *MakeSphere(0.0127);
  ContactConfig free = SceneOf(sphere, 0.6), rig = SceneOf(sphere, 0.6, {1e-7, 0});  // 10 N/um
  free.material = rig.material = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  for (double relative : {0.3, 0.9}) {
    const LoopFigures a = *ExactLoop(free, 100, AmplitudeKind::kForce, relative * 60);
    const LoopFigures b = *ExactLoop(rig, 100, AmplitudeKind::kForce, relative * 60);
    ExpectRelative(b.dissipated_energy, a.dissipated_energy, 1e-9);
    ExpectRelative(b.force_amplitude, a.force_amplitude, 1e-12);
    ExpectRelative(b.half_opening, a.half_opening, 1e-9);
    ExpectRelative(b.system_free_ratio, a.system_free_ratio, 1e-9);
    ExpectRelative(b.contact_amplitude, a.contact_amplitude, 1e-9);
    ExpectRelative(b.actuator_amplitude, a.actuator_amplitude + 1e-7 * a.force_amplitude, 1e-9);
    ExpectRelative(b.energy_ratio,
                   a.dissipated_energy / (4 * b.actuator_amplitude * a.force_amplitude), 1e-9);
    ExpectRelative(b.sliding_ratio, a.half_opening / b.actuator_amplitude, 1e-9);
  }
  const LoopFigures onset = *GrossSlipOnset(rig, 100);
  EXPECT_NEAR(onset.energy_ratio, 0.06, 0.01) << "the soft rig's A at the transition";
  EXPECT_NEAR(onset.contact_energy_ratio, 0.2, 1e-9);
}

// A truncated sphere (a worn, flattened cap of radius b) moves from the sphere's thresholds
// toward the flat punch's, which has no partial-slip loop (A = B = 0 at the onset).
TEST(ExactLoopsTest, ATruncatedSphereApproachesTheFlatPunch) {
  const double radius = 0.01, hertz_radius = 1.8662555784e-4;  // H1 at 100 N
  double last_a = 1, last_b = 1;
  for (double flat : {0.0, 1e-4, 1.75e-4}) {  // 0, 0.54 and 0.94 of the Hertz radius
    std::vector<double> r, f;
    for (int i = 0; i <= 2000; ++i) {
      r.push_back(i * 5e-7);
      f.push_back(r.back() > flat ? (r.back() * r.back() - flat * flat) / (2 * radius) : 0);
    }
    ContactConfig scene = reference::H1Config();
    scene.profile = *MakeTabulatedProfile(r, f);
    const LoopFigures onset = *GrossSlipOnset(scene, 100);
    EXPECT_LT(onset.contact_energy_ratio, last_a) << "flat radius " << flat;
    EXPECT_LT(onset.contact_sliding_ratio, last_b) << "flat radius " << flat;
    last_a = onset.contact_energy_ratio;
    last_b = onset.contact_sliding_ratio;
    if (flat == 0) {
      EXPECT_NEAR(onset.contact_energy_ratio, 0.2, 1e-6);
    }
  }
  EXPECT_LT(last_a, 0.05) << "near the Hertz radius the loop closes like a flat punch's";
  EXPECT_LT(last_b, 0.06);
  ContactConfig punch = reference::H1Config();
  punch.profile = *MakeFlatPunch(hertz_radius);
  const LoopFigures onset = *GrossSlipOnset(punch, 100);
  EXPECT_EQ(onset.dissipated_energy, 0);
  EXPECT_EQ(onset.half_opening, 0);
  EXPECT_EQ(onset.system_free_ratio, 0);
}

// The fretting map: below the onset's actuator amplitude the loops stay below its C, above it
// they reach it; through a soft rig the partial-slip loops are almost the rig's elastic line.
TEST(ExactLoopsTest, FrettingMapSeparatesTheRegimesAtTheOnset) {
  const std::vector<double> relative = {0.05, 0.3, 0.6, 0.9, 0.99, 1.01, 1.5, 3};
  for (double compliance : {0.0, 1e-7}) {
    ContactConfig scene = reference::H1Config();
    scene.rig.tangential = compliance;
    Result<std::vector<FrettingMapLoad>> map = FrettingMap(scene, {10, 100, 1000}, relative);
    ASSERT_TRUE(map.ok()) << map.status().ToString();
    for (const FrettingMapLoad& load : *map) {
      for (std::size_t k = 0; k < relative.size(); ++k) {
        const LoopFigures& loop = load.loops[k];
        CycleMetrics cycle;
        cycle.half_opening = loop.half_opening;
        cycle.dissipated_energy = loop.dissipated_energy;
        cycle.system_free_ratio = loop.system_free_ratio;
        cycle.force_amplitude = loop.force_amplitude;
        cycle.opening_resolved = loop.half_opening > 0;
        EXPECT_EQ(ClassifyCycle(cycle, load.onset), load.regimes[k])
            << "P = " << load.onset.normal_force << " relative amplitude " << relative[k];
        if (relative[k] > 1) ExpectRelative(loop.force_amplitude, 0.3 * loop.normal_force, 1e-12);
      }
      // The rig's share of the stroke at the onset: C_t mu P over the whole amplitude.
      ExpectRelative(load.onset.actuator_amplitude - load.onset.contact_amplitude,
                     compliance * load.onset.force_amplitude, 1e-9);
    }
  }
}

// The backbone: at small amplitude the secant stiffness is the full-stick stiffness 2 G* a and
// the damping ratio vanishes like the amplitude; toward gross slip the stiffness falls.
TEST(ExactLoopsTest, BackboneStartsAtTheStickStiffnessWithoutDamping) {
  const ContactConfig h1 = reference::H1Config();
  const std::vector<double> amplitudes = {1e-13, 1e-12, 1e-10, 1e-8, 1e-7, 1e-6, 3e-6};
  Result<std::vector<LoopFigures>> backbone =
      Backbone(h1, 100, AmplitudeKind::kActuatorDisplacement, amplitudes);
  ASSERT_TRUE(backbone.ok()) << backbone.status().ToString();
  ExpectRelative((*backbone)[0].secant_stiffness, 3.5467300585e7, 1e-6);  // 2 G* a of H1
  EXPECT_LT((*backbone)[0].damping_ratio, 1e-4);
  for (std::size_t k = 1; k < amplitudes.size(); ++k) {
    EXPECT_LT((*backbone)[k].secant_stiffness, (*backbone)[k - 1].secant_stiffness);
    EXPECT_GT((*backbone)[k].damping_ratio, (*backbone)[k - 1].damping_ratio);
  }
  // Small amplitudes: Ed ~ s^3 and Q* delta* ~ s^2, so the ratio grows like the amplitude.
  ExpectRelative((*backbone)[1].damping_ratio / (*backbone)[0].damping_ratio, 10, 1e-3);
}

TEST(ExactLoopsTest, BadInputIsRefusedNamingTheField) {
  const ContactConfig h1 = reference::H1Config();
  EXPECT_EQ(ExactLoop(h1, 0, AmplitudeKind::kForce, 1).status().field(), "normal_force");
  EXPECT_EQ(ExactLoop(h1, 100, AmplitudeKind::kForce, 31).status().field(), "amplitude");
  EXPECT_EQ(ExactLoop(h1, 100, AmplitudeKind::kForce, NAN).status().field(), "amplitude");
  EXPECT_EQ(Backbone(h1, 100, AmplitudeKind::kForce, {10, 40}).status().field(), "amplitudes[1]");
  EXPECT_EQ(FrettingMap(h1, {100, -1}, {0.5}).status().field(), "normal_forces[1]");
  EXPECT_EQ(FrettingMap(h1, {100}, {0.5, 0}).status().field(), "relative_amplitudes[1]");
  // Issue #48: a load the engine cannot follow was named by its internal "tangential_force".
  const Status huge = FrettingMap(h1, {100, 1e300}, {0.5}).status();
  EXPECT_EQ(huge.field(), "normal_forces[1]") << huge.ToString();
  EXPECT_EQ(GrossSlipOnset(h1, 1e300).status().field(), "normal_force");
  ContactConfig frictionless = h1;
  frictionless.friction = 0;
  EXPECT_EQ(GrossSlipOnset(frictionless, 100).status().code(), StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace mdr::analysis
