// Identification from torsional records (issue #49, item 5): mu, the torsional modulus G_t and the
// rig's torsional compliance fitted to (twist, moment) loops, with the honesty rules of the
// tangential fit (issue #47). The records come from the torsional rig of
// tests/fixtures/rig_simulator.h, written apart from the fit: noise-free, the parameters come back
// to rounding; with the sensors' noise the 95 % intervals hold the truth at their rate over seeded
// replicates; a wrong profile is never reported as identified; bad input is named.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "fixtures/identify_campaigns.h"

namespace mdr::analysis {
namespace {

namespace campaigns = identify_campaigns;

// The campaign of tests/fixtures/identify_campaigns.h: a steel ball twisted on a steel flat
// behind a shaft as soft as the contact at 100 N, three loads at 6 mrad.
constexpr double kFriction = 0.3, kCompliance = campaigns::kTorsionalCompliance;
double TrueTorsionalModulus() { return campaigns::TorsionalSteel().torsional_modulus; }

struct Noise {
  double twist = 0, moment = 0;  // rad, N m (standard deviations)
};

std::vector<LoopSet> Campaign(const rig_simulator::TorsionalRig& rig, Noise noise = {},
                              std::uint64_t seed = 1, int per_cycle = 120) {
  campaigns::Spec spec = campaigns::TorsionalSpec();
  spec.displacement_noise = noise.twist;
  spec.force_noise = noise.moment;
  spec.samples_per_cycle = per_cycle;
  spec.seed = seed;
  return campaigns::MakeTorsional(rig, spec);
}
rig_simulator::TorsionalRig TrueRig(ProfilePtr profile = nullptr) {
  return campaigns::TorsionalSteel(profile);
}
ContactConfig StartScene() { return campaigns::TorsionalStart(); }
FitOptions ThreeFree() { return campaigns::TorsionalThreeFree(); }

TEST(TorsionalIdentifyTest, NoiseFreeLoopsGiveTheParametersBack) {
  Result<FitResult> fit = FitLoops(StartScene(), Campaign(TrueRig()), ThreeFree());
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_TRUE(fit->converged);
  EXPECT_NEAR(fit->estimates[0].value, kFriction, 1e-8 * kFriction);
  EXPECT_NEAR(fit->estimates[1].value, TrueTorsionalModulus(), 1e-8 * TrueTorsionalModulus());
  EXPECT_NEAR(fit->estimates[2].value, kCompliance, 1e-8 * kCompliance);
  ASSERT_TRUE(fit->fitted_torsion);
  EXPECT_EQ(fit->fitted_torsion->torsional_modulus, fit->estimates[1].value);
  EXPECT_EQ(fit->fitted_torsion->rig_compliance, fit->estimates[2].value);
  EXPECT_EQ(fit->fitted.friction, fit->estimates[0].value);
  EXPECT_TRUE(fit->identified);
  for (const SetFit& set : fit->sets) EXPECT_FALSE(set.gross_slip) << "the centre never slips";
}

// Per free parameter, how many 95 % intervals hold the truth and the mean (estimate - truth) /
// standard error over seeded replicates; and how many fits call a set a misfit.
struct Tally {
  std::array<int, 3> covered{};
  std::array<double, 3> mean_z{};
  int misfit = 0, identified = 0, replicates = 0;
};

Tally Replicate(const rig_simulator::TorsionalRig& rig, Noise noise, int replicates,
                int per_cycle = 120) {
  const double truth[] = {kFriction, TrueTorsionalModulus(), kCompliance};
  Tally tally;
  for (int replicate = 0; replicate < replicates; ++replicate) {
    Result<FitResult> fit = FitLoops(
        StartScene(),
        Campaign(rig, noise, 100 + static_cast<std::uint64_t>(replicate), per_cycle), ThreeFree());
    EXPECT_TRUE(fit.ok()) << fit.status().ToString();
    if (!fit.ok()) return tally;
    ++tally.replicates;
    for (int k = 0; k < 3; ++k) {
      const ParameterEstimate& e = fit->estimates[k];
      tally.covered[k] += e.lower_95 <= truth[k] && truth[k] <= e.upper_95;
      tally.mean_z[k] += (e.value - truth[k]) / e.standard_error / replicates;
    }
    for (const SetFit& s : fit->sets) {
      if (s.misfit) {
        ++tally.misfit;
        break;
      }
    }
    tally.identified += fit->identified;
  }
  return tally;
}

// The fewest of 20 intervals that true 95 % intervals fall below with a probability of at most
// 2 % (the binomial's), and the bias allowed: 3 / sqrt(20) standard errors.
constexpr int kReplicates = 20, kFewestCovered = 17;

TEST(TorsionalIdentifyTest, IntervalsHoldWithTheSensorsNoise) {
  // An encoder's 2 urad and a torque sensor's 20 uN m (0.7 % of the moment amplitude at 100 N).
  const Tally tally = Replicate(TrueRig(), {.twist = 2e-6, .moment = 2e-5}, kReplicates);
  ASSERT_EQ(tally.replicates, kReplicates);
  const char* names[] = {"friction", "torsional_modulus", "rig_compliance"};
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(tally.covered[k], kFewestCovered) << names[k];
    EXPECT_LT(std::abs(tally.mean_z[k]), 3 / std::sqrt(double(kReplicates))) << names[k];
  }
  EXPECT_LE(tally.misfit, 1);
  EXPECT_GE(tally.identified, kReplicates - 1);
}

// A cone's loops fitted as a sphere's: the loop shape differs, and the fit must say so (40
// samples per cycle: the cone's records take a quadrature per simulated step).
TEST(TorsionalIdentifyTest, AWrongProfileIsAMisfitNeverIdentified) {
  const Tally tally =
      Replicate(TrueRig(*MakeCone(0.2)), {.twist = 2e-6, .moment = 2e-5}, 5, /*per_cycle=*/40);
  ASSERT_EQ(tally.replicates, 5);
  EXPECT_EQ(tally.misfit, 5);
  EXPECT_EQ(tally.identified, 0);
}

TEST(TorsionalIdentifyTest, BadInputIsRefusedNamingTheField) {
  std::vector<LoopSet> sets = Campaign(TrueRig(), {}, 1, 40);
  // A tangential record in a torsional fit, and a torsional one in a tangential fit.
  std::vector<LoopSet> mixed = sets;
  mixed[1].samples.channel = LoopChannel::kTangential;
  EXPECT_EQ(FitLoops(StartScene(), mixed, ThreeFree()).status().field(), "sets[1].samples");
  FitOptions tangential = ThreeFree();
  tangential.torsion.reset();
  tangential.free.erase(tangential.free.begin() + 1);
  EXPECT_EQ(FitLoops(StartScene(), sets, tangential).status().field(), "sets[0].samples");
  // G_t free without a torsional fit, and a torsional fit's own scene.
  FitOptions stray = tangential;
  stray.free.push_back({Parameter::kTorsionalModulus, 1e10, 1e9, 1e12});
  EXPECT_EQ(FitLoops(StartScene(), mixed, stray).status().field(), "free[2].parameter");
  FitOptions bad = ThreeFree();
  bad.torsion->torsional_modulus = 0;
  EXPECT_EQ(FitLoops(StartScene(), sets, bad).status().field(), "torsion.torsional_modulus");
  bad = ThreeFree();
  bad.torsion->rig_compliance = -1;
  EXPECT_EQ(FitLoops(StartScene(), sets, bad).status().field(), "torsion.rig_compliance");
  // The samples are named as a torsional record's.
  sets[2].samples.displacement[5] = 200;
  EXPECT_EQ(FitLoops(StartScene(), sets, ThreeFree()).status().field(), "sets[2].samples.twist[5]");
}

}  // namespace
}  // namespace mdr::analysis
