// Identification from measured loops (issues #24, #47): synthetic records from the engine with a
// rig in series (tests/fixtures/rig_simulator.h, written apart from the fit), fitted back.
// Noise-free, every separable parameter comes back to rounding; with the noise, offsets, drift,
// inertia and varying load of real records the 95 % intervals hold the truth at their rate over
// seeded replicates; a wrong profile or a wrong declared load is never reported as identified;
// what the data cannot separate is reported so; bad input is refused naming the field.
#include "mdr/analysis/identify.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>

#include "fixtures/identify_campaigns.h"
#include "fixtures/reference_scenes.h"

namespace mdr::analysis {
namespace {

namespace campaigns = identify_campaigns;

constexpr double kRig = 2e-8;  // m/N: 50 N/um, softer than H1's contact at 100 N (35 N/um)

ContactConfig TrueScene() {
  ContactConfig scene = reference::H1Config();
  scene.rig.tangential = kRig;
  return scene;
}

// Loops as a rig records them: the actuator on a triangle wave of `amplitude` from 0 (the
// contact pressed at u = 0), `cycles` cycles of `per_cycle` samples, F_x with Gaussian noise of
// `noise` N.
LoopSet Record(const ContactConfig& scene, double normal_force, double amplitude, int cycles,
               int per_cycle, double noise = 0, std::uint64_t seed = 1) {
  rig_simulator::Run run;
  run.normal_force = normal_force;
  run.amplitude = amplitude;
  run.waveform = rig_simulator::Waveform::kTriangle;
  run.cycles = cycles;
  run.samples_per_cycle = per_cycle;
  run.force_noise = noise;
  run.record_time = false;
  run.seed = seed;
  const rig_simulator::Record r = rig_simulator::Simulate(scene, run);
  LoopSet set;
  set.normal_force = normal_force;
  set.samples.displacement = r.displacement;
  set.samples.tangential_force = r.tangential_force;
  return set;
}

// Three loads, the actuator at 0.6, 1.2 and 2 times the contact's gross-slip displacement of
// H1 at 100 N (the lightest set slides, the heaviest stays in partial slip).
std::vector<LoopSet> Campaign(double noise = 0, std::uint64_t seed = 1) {
  const ContactConfig scene = TrueScene();
  std::vector<LoopSet> sets;
  for (double load : {30.0, 100.0, 300.0}) {
    sets.push_back(Record(scene, load, 2e-6, 2, 120, noise, seed++));
  }
  return sets;
}

FitOptions ThreeFree() {
  FitOptions options;
  options.free = {{Parameter::kFriction, 0.4, 0.05, 2},
                  {Parameter::kEffectiveModulus, 0.8e11, 1e9, 1e13},
                  {Parameter::kRigCompliance, 1e-8, 0, 1e-6}};
  return options;
}

TEST(IdentifyTest, NoiseFreeLoopsGiveTheParametersBack) {
  const ContactConfig truth = TrueScene();
  Result<FitResult> fit = FitLoops(truth, Campaign(), ThreeFree());
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_TRUE(fit->converged);
  EXPECT_NEAR(fit->estimates[0].value, truth.friction, 1e-9 * truth.friction);
  EXPECT_NEAR(fit->estimates[1].value, truth.material.e_star, 1e-9 * truth.material.e_star);
  EXPECT_NEAR(fit->estimates[2].value, kRig, 1e-9 * kRig);
  EXPECT_LT(fit->residual_rms, 1e-9);
  EXPECT_EQ(fit->fitted.rig.tangential, fit->estimates[2].value);
  // The triangle's sets, sampled on its corners, leave nothing to smooth and no noise to find.
  for (const SetFit& set : fit->sets) EXPECT_LT(set.displacement_noise, 1e-12);
}

// What the replicates of a campaign give: per free parameter how many 95 % intervals hold the
// truth and the mean (estimate - truth) / standard error; per nuisance the same over the sets
// where it is identified; how many fits say misfit, load mismatch, identified.
struct Tally {
  std::array<int, 3> covered{};
  std::array<double, 3> mean_z{};
  struct Nuisance {
    int covered = 0, identified = 0;
    double mean_z = 0;
  };
  std::map<analysis::Nuisance, Nuisance> nuisances;
  int misfit = 0, mismatch = 0, identified = 0, replicates = 0;
};

double TrueNuisance(const campaigns::Spec& spec, const NuisanceEstimate& e) {
  switch (e.nuisance) {
    case Nuisance::kForceOffset:
      return spec.force_offset;
    case Nuisance::kDisplacementOffset:
      return *e.set % 2 == 0 ? spec.displacement_offset : -spec.displacement_offset;
    case Nuisance::kDisplacementDrift:
      return spec.displacement_drift;
    case Nuisance::kMovingMass:
      return spec.mass;
  }
  return 0;
}

Tally Replicate(const ContactConfig& truth, campaigns::Spec spec, const FitOptions& options,
                int replicates) {
  const ContactConfig start = campaigns::SteelOnTitanium();
  const double values[] = {truth.friction, truth.material.e_star, truth.rig.tangential};
  Tally tally;
  for (int replicate = 0; replicate < replicates; ++replicate) {
    spec.seed = 100 + static_cast<std::uint64_t>(replicate);
    Result<FitResult> fit = FitLoops(start, campaigns::Make(truth, spec), options);
    EXPECT_TRUE(fit.ok()) << fit.status().ToString();
    if (!fit.ok()) return tally;
    ++tally.replicates;
    for (int k = 0; k < 3; ++k) {
      const ParameterEstimate& e = fit->estimates[k];
      tally.covered[k] += e.lower_95 <= values[k] && values[k] <= e.upper_95;
      tally.mean_z[k] += (e.value - values[k]) / e.standard_error / replicates;
    }
    for (const NuisanceEstimate& e : fit->nuisances) {
      if (!e.identified) continue;
      const double truth_value = TrueNuisance(spec, e);
      Tally::Nuisance& n = tally.nuisances[e.nuisance];
      ++n.identified;
      n.covered += e.lower_95 <= truth_value && truth_value <= e.upper_95;
      n.mean_z += (e.value - truth_value) / e.standard_error;
    }
    for (const SetFit& s : fit->sets) {
      if (s.misfit) {
        ++tally.misfit;
        break;
      }
    }
    for (const SetFit& s : fit->sets) {
      if (s.load_mismatch) {
        ++tally.mismatch;
        break;
      }
    }
    tally.identified += fit->identified;
  }
  for (auto& [kind, n] : tally.nuisances) n.mean_z /= std::max(n.identified, 1);
  return tally;
}

campaigns::Spec NoisySpec(double displacement_noise) {
  campaigns::Spec spec;
  spec.samples_per_cycle = 100;
  spec.displacement_noise = displacement_noise;
  spec.force_noise = 0.1;
  return spec;
}

// The fewest intervals of `replicates` that may hold the truth: of 100, 90 (what the issue asks);
// of fewer, as strict a test of 95 % coverage: the count that intervals of true 95 % coverage
// fall below with a probability of at most 2 % (the binomial's; 90 of 100: 1.1 %, 26 of 30:
// 1.6 %, 17 of 20: 1.6 %).
int FewestCovered(int replicates) {
  if (replicates >= 100) return 90 * replicates / 100;
  double below = 0;  // P(covered < m) for m = 0, 1, ...
  for (int m = 0; m <= replicates; ++m) {
    const double p = std::exp(std::lgamma(replicates + 1.0) - std::lgamma(m + 1.0) -
                              std::lgamma(replicates - m + 1.0) + m * std::log(0.95) +
                              (replicates - m) * std::log(0.05));
    if (below + p > 0.02) return m;
    below += p;
  }
  return replicates;
}

TEST(IdentifyTest, TheFewestCoveredIsAsStrictForFewerReplicates) {
  EXPECT_EQ(FewestCovered(100), 90);
  EXPECT_EQ(FewestCovered(30), 26);
  EXPECT_EQ(FewestCovered(20), 17);
}

// The criteria: every interval holds the truth in at least 90 of 100 replicates, the
// estimates are unbiased to 0.3 standard errors, and clean data of the right model are called a
// misfit in at most 5 of 100. Fewer replicates (the slow campaigns) take FewestCovered, and the
// bias allowed grows with the mean's own scatter (3/sqrt(replicates) standard errors).
void ExpectTrustworthy(const Tally& tally, int replicates) {
  const char* names[] = {"friction", "effective_modulus", "rig_compliance"};
  ASSERT_EQ(tally.replicates, replicates);
  const double bias = std::max(0.3, 3 / std::sqrt(static_cast<double>(replicates)));
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(tally.covered[k], FewestCovered(replicates)) << names[k];
    EXPECT_LT(std::abs(tally.mean_z[k]), bias) << names[k];
  }
  EXPECT_LE(tally.misfit, 5 * replicates / 100);
  EXPECT_GE(tally.identified, 95 * replicates / 100);
}

// Before the turning points were fitted, 5 nm put mu's interval around the truth in 0 of 30.
TEST(IdentifyTest, IntervalsHoldWithTwoNanometresOfDisplacementNoise) {
  ExpectTrustworthy(
      Replicate(campaigns::SteelOnTitanium(), NoisySpec(2e-9), campaigns::ThreeFree(), 100), 100);
}
TEST(IdentifyTest, IntervalsHoldWithFiveNanometresOfDisplacementNoise) {
  ExpectTrustworthy(
      Replicate(campaigns::SteelOnTitanium(), NoisySpec(5e-9), campaigns::ThreeFree(), 100), 100);
}
TEST(IdentifyTest, IntervalsHoldWithTenNanometresOfDisplacementNoise) {
  ExpectTrustworthy(
      Replicate(campaigns::SteelOnTitanium(), NoisySpec(10e-9), campaigns::ThreeFree(), 100), 100);
}

// The noise each channel carries, estimated from the samples alone, is the generator's.
TEST(IdentifyTest, TheNoiseIsEstimatedFromTheDataItself) {
  campaigns::Spec spec = NoisySpec(5e-9);
  const ContactConfig truth = campaigns::SteelOnTitanium();
  Result<FitResult> fit =
      FitLoops(campaigns::SteelOnTitanium(), campaigns::Make(truth, spec), campaigns::ThreeFree());
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  for (const SetFit& s : fit->sets) {
    EXPECT_NEAR(s.displacement_noise, 5e-9, 1.5e-9);
    EXPECT_NEAR(s.force_noise, 0.1, 0.03);
    EXPECT_NEAR(s.displacement_noise_correlation, -0.75, 0.1);
    EXPECT_TRUE(s.noise_estimated);
    EXPECT_FALSE(s.misfit);
  }
}

// A normal force varying +-15 % within each cycle, recorded in its column, is replayed as
// measured: noise-free the parameters come back to 1e-6, with noise the intervals hold.
TEST(IdentifyTest, AVaryingNormalLoadIsReplayedAsMeasured) {
  campaigns::Spec spec;
  spec.samples_per_cycle = 100;
  spec.normal_variation = 0.15;
  spec.record_normal_force = true;
  const ContactConfig truth = campaigns::SteelOnTitanium();
  Result<FitResult> fit =
      FitLoops(campaigns::SteelOnTitanium(), campaigns::Make(truth, spec), campaigns::ThreeFree());
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_NEAR(fit->estimates[0].value / truth.friction, 1, 1e-6);
  EXPECT_NEAR(fit->estimates[1].value / truth.material.e_star, 1, 1e-6);
  EXPECT_NEAR(fit->estimates[2].value / truth.rig.tangential, 1, 1e-6);
  for (const SetFit& s : fit->sets) {
    EXPECT_TRUE(s.normal_force_measured);
    EXPECT_LT(s.normal_force_min, 0.86 * s.normal_force);
    EXPECT_GT(s.normal_force_max, 1.14 * s.normal_force);
  }
}

// 30 replicates (a curved path per sample makes these fits ten times slower); the study's 100
// are in docs/analysis.md, "Coverage measured".
TEST(IdentifyTest, IntervalsHoldUnderAVaryingNormalLoad) {
  campaigns::Spec spec = NoisySpec(5e-9);
  spec.normal_variation = 0.15;
  spec.record_normal_force = true;
  spec.normal_noise = 0.1;
  ExpectTrustworthy(Replicate(campaigns::SteelOnTitanium(), spec, campaigns::ThreeFree(), 30), 30);
}

// Offsets of both sensors (0.8 N, +-0.5 um) and a drift of 50 nm per run, fitted as nuisances
// from the virgin loading on (burn_in_reversals 0: where the contact was pressed is in the
// data): the contact parameters' intervals hold, and every nuisance's.
TEST(IdentifyTest, OffsetsAndDriftAreFittedWithIntervalsThatHold) {
  campaigns::Spec spec = NoisySpec(5e-9);
  spec.force_offset = 0.8;
  spec.displacement_offset = 0.5e-6;
  spec.displacement_drift = 50e-9;
  FitOptions options = campaigns::ThreeFree();
  options.nuisances.force_offset = options.nuisances.displacement_drift = true;
  options.burn_in_reversals = 0;
  const Tally tally = Replicate(campaigns::SteelOnTitanium(), spec, options, 100);
  ExpectTrustworthy(tally, 100);
  for (Nuisance kind :
       {Nuisance::kForceOffset, Nuisance::kDisplacementOffset, Nuisance::kDisplacementDrift}) {
    const Tally::Nuisance& n = tally.nuisances.at(kind);
    EXPECT_GE(n.identified, 300) << NuisanceName(kind);  // of 900 sets
    EXPECT_GE(n.covered, 9 * n.identified / 10) << NuisanceName(kind);
    EXPECT_LT(std::abs(n.mean_z), 0.3) << NuisanceName(kind);
  }
}

// After the burn-in, loops of partial slip fix a force offset and the press point only together:
// neither is identified there, whatever the covariance at the solution says; gross slip fixes
// the force offset alone.
TEST(IdentifyTest, OffsetsThePartialSlipLoopsCannotSeparateAreNotIdentified) {
  campaigns::Spec spec = NoisySpec(5e-9);
  spec.force_offset = 0.8;
  spec.displacement_offset = 0.5e-6;
  FitOptions options = campaigns::ThreeFree();
  options.nuisances.force_offset = true;
  const ContactConfig truth = campaigns::SteelOnTitanium();
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    spec.seed = seed;
    Result<FitResult> fit =
        FitLoops(campaigns::SteelOnTitanium(), campaigns::Make(truth, spec), options);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    for (const NuisanceEstimate& e : fit->nuisances) {
      const SetFit& set = fit->sets[*e.set];
      if (e.nuisance == Nuisance::kDisplacementOffset) {
        EXPECT_FALSE(e.identified);
      }
      if (e.nuisance == Nuisance::kForceOffset && !set.gross_slip) {
        EXPECT_FALSE(e.identified);
      }
      if (e.nuisance == Nuisance::kForceOffset && set.gross_slip && e.identified) {
        EXPECT_NEAR(e.value, 0.8, 5 * e.standard_error);
      }
    }
  }
}

// The inertia of 0.5 kg in the force chain of a 100 Hz rig, fitted from the time stamps.
TEST(IdentifyTest, AMovingMassIsRecoveredWithinItsInterval) {
  campaigns::Spec spec = NoisySpec(5e-9);
  spec.frequency = 100;
  spec.mass = 0.5;
  FitOptions options = campaigns::ThreeFree();
  options.nuisances.moving_mass = true;
  const Tally tally = Replicate(campaigns::SteelOnTitanium(), spec, options, 20);
  ExpectTrustworthy(tally, 20);
  const Tally::Nuisance& mass = tally.nuisances.at(Nuisance::kMovingMass);
  EXPECT_EQ(mass.identified, 20);
  EXPECT_GE(mass.covered, FewestCovered(20));
}

// A cone's loops declared as a sphere: the residuals carry a structure in every cycle, and the
// fit is a misfit, never identified.
TEST(IdentifyTest, AWrongProfileIsAMisfitNeverIdentified) {
  const Tally tally = Replicate(campaigns::SteelOnTitanium(*MakeCone(0.02)), NoisySpec(5e-9),
                                campaigns::ThreeFree(), 100);
  EXPECT_GE(tally.misfit, 95);
  EXPECT_EQ(tally.identified, 0);
}

// Files recorded at their loads but declared at 60 N, their normal-force columns saying
// otherwise: a mismatch, never identified.
TEST(IdentifyTest, AWrongDeclaredLoadIsAMismatchNeverIdentified) {
  campaigns::Spec spec = NoisySpec(5e-9);
  spec.loads = {20};
  spec.record_normal_force = true;
  spec.normal_noise = 0.1;
  spec.declared_normal_force = 60;
  const Tally tally = Replicate(campaigns::SteelOnTitanium(), spec, campaigns::ThreeFree(), 100);
  EXPECT_GE(tally.mismatch, 95);
  EXPECT_EQ(tally.identified, 0);
}

// One partial-slip loop at one load: mu, E* and the rig enter the loop only through its curvature,
// which noise hides; and tangential loops fix E* and R only together. Both are said.
TEST(IdentifyTest, WhatTheDataCannotSeparateIsReported) {
  const ContactConfig truth = TrueScene();
  const std::vector<LoopSet> one = {Record(truth, 100, 0.6e-6, 2, 120, 0.05, 7)};
  Result<FitResult> fit = FitLoops(truth, one, ThreeFree());
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_FALSE(fit->identified);
  ASSERT_FALSE(fit->notes.empty());

  FitOptions both;
  both.free = {{Parameter::kEffectiveModulus, 1e11, 1e9, 1e13},
               {Parameter::kProfileScale, 0.012, 1e-4, 1}};
  both.profile_family = [](double radius) { return MakeSphere(radius); };
  Result<FitResult> pair = FitLoops(truth, Campaign(), both);
  ASSERT_TRUE(pair.ok()) << pair.status().ToString();
  EXPECT_FALSE(pair->identified);
  EXPECT_GT(std::abs(pair->correlation[0][1]), 0.99);
}

TEST(IdentifyTest, BadInputIsRefusedNamingTheField) {
  const ContactConfig truth = TrueScene();
  const std::vector<LoopSet> sets = Campaign();
  EXPECT_EQ(FitLoops(truth, {}, ThreeFree()).status().field(), "sets");
  std::vector<LoopSet> bad = sets;
  bad[1].normal_force = -1;
  EXPECT_EQ(FitLoops(truth, bad, ThreeFree()).status().field(), "sets[1].normal_force");
  bad = sets;
  bad[1].normal_force.reset();  // and no column
  EXPECT_EQ(FitLoops(truth, bad, ThreeFree()).status().field(), "sets[1].normal_force");
  bad = sets;
  bad[2].samples.displacement[3] = NAN;
  EXPECT_EQ(FitLoops(truth, bad, ThreeFree()).status().field(), "sets[2].samples.displacement[3]");
  bad = sets;
  bad[0].samples.tangential_force.pop_back();
  EXPECT_EQ(FitLoops(truth, bad, ThreeFree()).status().field(), "sets[0].samples.tangential_force");
  FitOptions options = ThreeFree();
  options.free[0].initial = 3;  // outside (0.05, 2)
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[0].initial");
  options = ThreeFree();
  options.free[1].upper = options.free[1].lower;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[1].upper");
  options = ThreeFree();
  options.free[0].lower = -1e308;  // issue #48: was refused as "friction: ... got inf"
  options.free[0].upper = 1e308;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[0].upper");
  options = ThreeFree();
  options.free[0].lower = -0.5;  // a negative friction coefficient would be tried
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[0].lower");
  options = ThreeFree();
  options.free[2].parameter = Parameter::kFriction;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[2].parameter");
  options = ThreeFree();
  options.free.push_back({Parameter::kProfileScale, std::nullopt, 1e-4, 1});
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "free[3].parameter");
  options = ThreeFree();
  options.burn_in_reversals = 50;
  EXPECT_EQ(FitLoops(truth, sets, options).status().code(), StatusCode::kFailedPrecondition);
  options = ThreeFree();
  options.burn_in_reversals = -1;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "burn_in_reversals");
  options = ThreeFree();
  options.displacement_noise = 0;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "displacement_noise");
  options = ThreeFree();
  options.force_noise = NAN;
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "force_noise");
  options = ThreeFree();
  options.nuisances.moving_mass = true;  // the triangle's sets have no time
  EXPECT_EQ(FitLoops(truth, sets, options).status().field(), "sets[0].samples.time");
}

// The practitioners' guess: 1 / k against P^(-1/3) has the rig's compliance as intercept. The
// reversal chords sit a little below the full-stick stiffness, so the guess is near, not exact.
TEST(IdentifyTest, TheComplianceGuessIsTheInterceptAgainstLoad) {
  const ContactConfig truth = TrueScene();
  std::vector<LoopSet> sets;
  for (double load : {20.0, 60.0, 150.0, 400.0}) {
    sets.push_back(Record(truth, load, 0.3e-6, 2, 400));  // small loops: near full stick
  }
  Result<ComplianceGuess> guess = GuessRigCompliance(sets);
  ASSERT_TRUE(guess.ok()) << guess.status().ToString();
  EXPECT_NEAR(guess->rig_compliance, kRig, 0.15 * kRig);
  EXPECT_GT(guess->slope, 0);
  EXPECT_GT(guess->standard_error, 0);  // three loads leave one residual
  // Two loads fix the line exactly: its error is unknown, not zero.
  Result<ComplianceGuess> two = GuessRigCompliance({sets[0], sets[1]});
  ASSERT_TRUE(two.ok());
  EXPECT_TRUE(std::isnan(two->standard_error));
  EXPECT_EQ(GuessRigCompliance({sets[0]}).status().code(), StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace mdr::analysis
