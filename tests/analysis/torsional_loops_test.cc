// Torsional records (issue #49, item 5): the loop analysis of (twist, moment) samples, the exact
// torsional loops, the full-slip moment and the regime, against the torsion reference values of
// docs/reference-values.md (H1 twisted to the stick radius a/2) and the Masing loop.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fixtures/reference_scenes.h"
#include "mdr/analysis/exact_loops.h"
#include "mdr/analysis/loops.h"
#include "mdr/core/material.h"

namespace mdr::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

// H1: a steel sphere R = 10 mm on a steel flat, mu = 0.3 (G_t = G / 2 for equal bodies).
TorsionalScene H1Torsion(double rig_compliance = 0) {
  const double young = 210e9, poisson = 0.3;
  return {.profile = *MakeSphere(0.01),
          .friction = 0.3,
          .effective_modulus = young / (2 * (1 - poisson * poisson)),
          .torsional_modulus = young / (2 * (1 + poisson)) / 2,
          .rig_compliance = rig_compliance};
}
constexpr double kNormalForce = 100;
constexpr double kContactRadius = 1.8662555784e-4;
// docs/reference-values.md, "Torsion": H1 twisted to the stick radius a/2, and the loss of the
// cycle between +-that twist.
constexpr double kTwistAtHalf = 4.8141258757e-3, kMomentAtHalf = 2.9593735330e-3;
constexpr double kLossAtHalf = 1.8173196119e-5;

void ExpectRelative(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected)) << "expected " << expected;
}

TEST(TorsionalLoopsTest, TheExactLoopIsTheReferenceCycle) {
  const LoopFigures by_twist =
      *ExactTorsionalLoop(H1Torsion(), kNormalForce, AmplitudeKind::kActuatorDisplacement,
                          kTwistAtHalf);
  ExpectRelative(by_twist.force_amplitude, kMomentAtHalf, 1e-9);
  ExpectRelative(by_twist.dissipated_energy, kLossAtHalf, 1e-9);
  EXPECT_EQ(by_twist.actuator_amplitude, by_twist.contact_amplitude) << "no rig";
  // The same loop by its moment amplitude.
  const LoopFigures by_moment =
      *ExactTorsionalLoop(H1Torsion(), kNormalForce, AmplitudeKind::kForce, kMomentAtHalf);
  ExpectRelative(by_moment.actuator_amplitude, kTwistAtHalf, 1e-9);
  ExpectRelative(by_moment.dissipated_energy, kLossAtHalf, 1e-8);
  // Masing: the branch down from (phi*, M*) is the virgin curve doubled, so it reaches M = 0 at
  // phi* - 2 phi_v(M* / 2), phi_v the virgin twist at a moment.
  TorsionalContact virgin = *PressTorsionalContact(H1Torsion(), kNormalForce);
  TorsionStep half;
  half.twist = TwistControl::kMoment;
  half.twist_value = kMomentAtHalf / 2;
  ASSERT_TRUE(virgin.Apply(half).ok());
  ExpectRelative(by_twist.half_opening, kTwistAtHalf - 2 * virgin.memory().twist(), 1e-9);
  // The full-slip moment 3 pi mu F_N a / 16 bounds every loop.
  const double slip = *FullSlipMoment(H1Torsion(), kNormalForce);
  ExpectRelative(slip, 3 * kPi * 0.3 * kNormalForce * kContactRadius / 16, 1e-9);
  EXPECT_EQ(ExactTorsionalLoop(H1Torsion(), kNormalForce, AmplitudeKind::kForce, slip)
                .status()
                .field(),
            "amplitude");
}

// A rig's torsional compliance changes neither Ed, M*, the opening nor C; the actuator's
// amplitude grows by C M*.
TEST(TorsionalLoopsTest, ARigInSeriesBiasesOnlyTheTwistFigures) {
  const double compliance = 2.0;  // rad / (N m): as soft as the contact (k_t = 1.4 N m/rad)
  for (double amplitude : {0.3 * kMomentAtHalf, kMomentAtHalf}) {
    const LoopFigures a =
        *ExactTorsionalLoop(H1Torsion(), kNormalForce, AmplitudeKind::kForce, amplitude);
    const LoopFigures b =
        *ExactTorsionalLoop(H1Torsion(compliance), kNormalForce, AmplitudeKind::kForce, amplitude);
    ExpectRelative(b.dissipated_energy, a.dissipated_energy, 1e-9);
    ExpectRelative(b.half_opening, a.half_opening, 1e-9);
    ExpectRelative(b.system_free_ratio, a.system_free_ratio, 1e-9);
    ExpectRelative(b.actuator_amplitude, a.actuator_amplitude + compliance * amplitude, 1e-9);
    // Driven by the actuator's twist instead, through the rig: the same loop.
    const LoopFigures c = *ExactTorsionalLoop(H1Torsion(compliance), kNormalForce,
                                              AmplitudeKind::kActuatorDisplacement,
                                              b.actuator_amplitude);
    ExpectRelative(c.force_amplitude, amplitude, 1e-9);
    ExpectRelative(c.dissipated_energy, a.dissipated_energy, 1e-8);
  }
}

// The backbone starts at the full-stick stiffness 16 G_t a^3 / 3 without damping, and softens
// and damps as the slip annulus grows.
TEST(TorsionalLoopsTest, TheBackboneStartsAtTheStickStiffness) {
  const std::vector<LoopFigures> backbone = *TorsionalBackbone(
      H1Torsion(), kNormalForce, AmplitudeKind::kActuatorDisplacement,
      {1e-4 * kTwistAtHalf, 0.3 * kTwistAtHalf, kTwistAtHalf, 3 * kTwistAtHalf});
  const double stick = 16 * H1Torsion().torsional_modulus * std::pow(kContactRadius, 3) / 3;
  ExpectRelative(backbone[0].secant_stiffness, stick, 1e-3);
  EXPECT_LT(backbone[0].damping_ratio, 1e-4);
  for (std::size_t k = 1; k < backbone.size(); ++k) {
    EXPECT_LT(backbone[k].secant_stiffness, backbone[k - 1].secant_stiffness);
    EXPECT_GT(backbone[k].damping_ratio, backbone[k - 1].damping_ratio);
  }
  EXPECT_EQ(TorsionalBackbone(H1Torsion(), kNormalForce, AmplitudeKind::kForce, {1e-3, 1})
                .status()
                .field(),
            "amplitudes[1]");
}

// (twist, moment) samples of the engine's own steady loop, triangle waves of `per_cycle` samples.
LoopSamples EngineRecord(const TorsionalScene& scene, double amplitude, int cycles, int per_cycle) {
  TorsionalContact contact = *PressTorsionalContact(scene, kNormalForce);
  LoopSamples s;
  s.channel = LoopChannel::kTorsional;
  for (int k = 0; k <= cycles * per_cycle; ++k) {
    const double actuator = reference::TriangleWave(amplitude, k, per_cycle / 2);
    EXPECT_TRUE(contact.TwistThroughCompliance(actuator, scene.rig_compliance).ok());
    s.displacement.push_back(actuator);
    s.tangential_force.push_back(contact.memory().Moment());
    s.normal_force.push_back(kNormalForce);
  }
  return s;
}

TEST(TorsionalLoopsTest, AnalyzedRecordsGiveTheExactLoop) {
  const double compliance = 1.0;
  const TorsionalScene scene = H1Torsion(compliance);
  const LoopFigures exact = *ExactTorsionalLoop(scene, kNormalForce,
                                                AmplitudeKind::kActuatorDisplacement, kTwistAtHalf);
  LoopOptions options;
  options.rig_compliance = compliance;
  const LoopAnalysis analysis =
      *AnalyzeLoops(EngineRecord(scene, kTwistAtHalf, 3, 800), options);
  ASSERT_GE(analysis.cycles.size(), 2u);
  const CycleMetrics& cycle = analysis.cycles.back();
  ExpectRelative(cycle.force_amplitude, exact.force_amplitude, 1e-12);
  ExpectRelative(cycle.displacement_amplitude, exact.actuator_amplitude, 1e-12);
  // Trapezoids and linear crossings on 800 samples per cycle.
  ExpectRelative(cycle.dissipated_energy, exact.dissipated_energy, 1e-4);
  ExpectRelative(cycle.half_opening, exact.half_opening, 1e-3);
  ExpectRelative(cycle.contact->displacement_amplitude, exact.contact_amplitude, 1e-9);
  EXPECT_TRUE(std::isnan(cycle.friction_coefficient)) << "M* / P is a length";
  EXPECT_TRUE(std::isnan(cycle.energy_friction_coefficient));
  EXPECT_EQ(cycle.normal_force, kNormalForce);
  const double slip = *FullSlipMoment(scene, kNormalForce);
  EXPECT_EQ(ClassifyTorsionalCycle(cycle, slip), Regime::kPartialSlip);
  // A record whose moment reaches the full-slip moment slides as a whole; an elastic line sticks.
  CycleMetrics sliding = cycle;
  sliding.force_amplitude = slip;
  EXPECT_EQ(ClassifyTorsionalCycle(sliding, slip), Regime::kGrossSlip);
  CycleMetrics line = cycle;
  line.opening_resolved = false;
  EXPECT_EQ(ClassifyTorsionalCycle(line, slip), Regime::kSticking);
}

TEST(TorsionalLoopsTest, BadTorsionalSamplesNameTheirColumns) {
  LoopSamples s = EngineRecord(H1Torsion(), kTwistAtHalf, 2, 40);
  LoopSamples twisted = s;
  twisted.displacement[3] = 101;
  EXPECT_EQ(AnalyzeLoops(twisted, {}).status().field(), "twist[3]");
  LoopSamples moment = s;
  moment.tangential_force.pop_back();
  EXPECT_EQ(AnalyzeLoops(moment, {}).status().field(), "twisting_moment");
  EXPECT_NE(AnalyzeLoops(moment, {}).status().message().find("per twist sample"),
            std::string::npos);
  LoopSamples flat = s;
  flat.displacement.assign(flat.displacement.size(), 0.01);
  const Status none = AnalyzeLoops(flat, {}).status();
  EXPECT_EQ(none.field(), "twist");
  EXPECT_NE(none.message().find("rad"), std::string::npos) << none.message();
  // Read as a tangential record the same column is a displacement, and 101 m is beyond its 1 m.
  twisted.channel = LoopChannel::kTangential;
  EXPECT_EQ(AnalyzeLoops(twisted, {}).status().field(), "displacement[3]");
}

}  // namespace
}  // namespace mdr::analysis
