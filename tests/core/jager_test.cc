// The Jäger picture: weights, Cattaneo-Mindlin decompositions and their inverse, sampled u(x).
#include "mdr/core/jager.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mdr/core/contact.h"
#include "mdr/core/sampled_weight.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::MakeContact;
using testing::RelNear;

Contact LoadedByForces(Contact c, double fn, double fx) {
  EXPECT_TRUE(c.Apply(testing::NormalForceStep(fn)).ok());
  EXPECT_TRUE(c.Apply(testing::TangentialForceStep(fx)).ok());
  return c;
}

// H1 loaded to F_x = 27 N (s = 0.9), then unloaded to F_x = -5 N, with the Mindlin-Deresiewicz
// radii: g(c) = d - ux*/(mu kappa) and g(c') = d - (ux* - ux)/(2 mu kappa), g = x^2/R.
struct Unloaded {
  Contact contact = LoadedByForces(testing::SteelSphere(), 100, 27);
  double c_stick = 0, c_reversal = 0;
  Unloaded() {
    const double ux_star = contact.tangential_displacement(), d = contact.depth();
    const double m = contact.mu_kappa();
    EXPECT_TRUE(contact.Apply(testing::TangentialForceStep(-5)).ok());
    const double ux = contact.tangential_displacement();
    c_stick = std::sqrt(0.01 * (d - ux_star / m));
    c_reversal = std::sqrt(0.01 * (d - (ux_star - ux) / (2 * m)));
  }
};

// u of the `sampled` memory at every vertex of `reference` and vice versa: max difference.
double MaxDifference(const PiecewiseLinearMemory& a, const PiecewiseLinearMemory& b) {
  double diff = 0;
  for (double z : a.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  for (double z : b.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  return diff;
}

double MaxAbsU(const PiecewiseLinearMemory& m) {
  double scale = 0;
  for (double u : m.u()) scale = std::max(scale, std::abs(u));
  return scale;
}

TEST(JagerWeightsTest, CattaneoMindlinIsOneOnTheSlipAnnulusAndZeroInTheStickZone) {
  const Contact c = LoadedByForces(testing::SteelSphere(), 100, 15);
  const double a = c.contact_radius(), c_stick = a * std::cbrt(0.5);
  const JagerWeights w = *ComputeJagerWeights(c);
  EXPECT_EQ(w.contact_radius, a);
  EXPECT_EQ(w.edge_weight, 0);
  ASSERT_EQ(w.intervals.size(), 2u);
  EXPECT_EQ(w.intervals[0].r_begin, 0);
  EXPECT_EQ(w.intervals[0].weight, 0);
  EXPECT_TRUE(RelNear(w.intervals[0].r_end, c_stick, 1e-12));
  EXPECT_EQ(w.intervals[1].r_begin, w.intervals[0].r_end);
  EXPECT_EQ(w.intervals[1].r_end, a);
  EXPECT_EQ(w.intervals[1].depth_end, c.depth());
  EXPECT_NEAR(w.intervals[1].weight, 1, 1e-12);
  const std::vector<double> sampled = *SampleJagerWeights(
      w, {0, 0.5 * c_stick, 0.99 * c_stick, 1.01 * c_stick, 0.99 * a, a, 2 * a});
  const std::vector<double> expected = {0, 0, 0, 1, 1, 0, 0};
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(sampled[i], expected[i], 1e-12);
  EXPECT_EQ(SampleJagerWeights(w, {0, std::nan("")}).status().field(), "radii[1]");
}

// Issue #11: with mu kappa ~ 1e6 and a thin slip annulus the rounded crossing vertex made the
// annulus weigh 1.0000000001841545. A piece on a bound weighs exactly +-1, and no weight leaves
// [-1, 1], over random histories across the whole friction range (all analytic profiles).
TEST(JagerWeightsTest, PiecesOnABoundWeighExactlyOneAndNoWeightLeavesTheUnitRange) {
  const EffectiveMaterial steel = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  for (double relative : {1e-9, 1e-7, 1e-4}) {
    Contact c = MakeContact(*MakeSphere(0.005), steel, 1e6 / steel.kappa(), /*energy=*/false);
    ASSERT_TRUE(c.MoveTo(2e-6, 0).ok());
    ASSERT_TRUE(c.MoveTo(2e-6, relative * c.mu_kappa() * 2e-6).ok());
    const JagerWeights w = *ComputeJagerWeights(c);
    ASSERT_EQ(w.intervals.size(), 2u) << relative;
    EXPECT_EQ(w.intervals[0].weight, 0);
    EXPECT_EQ(w.intervals[1].weight, 1) << relative;
  }
  testing::RandomScene random{std::mt19937_64(3)};
  int bound_pieces = 0;
  for (int history = 0; history < 400; ++history) {
    const double mu = std::max(random.Friction(), 1e-9);
    Contact c = MakeContact(random.Profile(), steel, mu, /*energy=*/false);
    const double d0 = random.LogUniform(1e-9, 1e-4), slip = c.mu_kappa() * d0;
    testing::RandomHistory history_steps{.rng = std::mt19937_64(history), .d0 = d0, .slip = slip};
    for (int i = 0; i < 40; ++i) {
      auto [depth, ux] = history_steps.Next();
      ASSERT_TRUE(c.MoveTo(depth, ux + slip * random.RelativeAmplitude() * 1e-3).ok());
      const JagerWeights w = *ComputeJagerWeights(c);
      ASSERT_LE(std::abs(w.edge_weight), 1);
      for (const MemoryPiece& piece : c.memory_pieces()) {
        if (piece.bound != kOnUpper && piece.bound != kOnLower) continue;
        if (!(piece.x_end > piece.x_begin) || piece.z_end == piece.z_begin) continue;  // atom
        ++bound_pieces;
        ASSERT_EQ(w.At(0.5 * (piece.x_begin + piece.x_end)), piece.bound == kOnUpper ? 1 : -1)
            << c.config().profile->Describe() << " mu " << mu;
      }
      for (const WeightInterval& interval : w.intervals) {
        ASSERT_LE(std::abs(interval.weight), 1) << "history " << history;
      }
    }
  }
  EXPECT_GT(bound_pieces, 1000);
}

TEST(JagerWeightsTest, FlatPunchWeightSitsAtTheEdge) {
  const double a0 = 1e-3, d = 1e-6;
  Contact c = MakeContact(*MakeFlatPunch(a0), *RigidOnHalfSpace(1e9, 0.3), 0.4);
  ASSERT_TRUE(c.MoveTo(d, 0.3 * c.mu_kappa() * d).ok());
  JagerWeights w = *ComputeJagerWeights(c);
  EXPECT_TRUE(w.intervals.empty());
  EXPECT_EQ(w.contact_radius, a0);
  EXPECT_TRUE(RelNear(w.edge_weight, 0.3, 1e-14));  // u_0 / (mu kappa delta)
  EXPECT_EQ(w.At(0.5 * a0), 0);
  ASSERT_TRUE(c.MoveTo(0.5 * d, -c.mu_kappa() * d).ok());  // gross slip in -x
  EXPECT_TRUE(RelNear(ComputeJagerWeights(c)->edge_weight, -1, 1e-14));
}

TEST(JagerWeightsTest, MuZeroIsAnErrorAndNoContactIsEmpty) {
  Contact frictionless = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(1e9, 0.3), 0.0);
  ASSERT_TRUE(frictionless.MoveTo(1e-6, 1e-7).ok());
  const Status s = ComputeJagerWeights(frictionless).status();
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.field(), "friction");
  EXPECT_EQ(s.message(), "weights are undefined for mu = 0: every spring is at the bound");
  EXPECT_EQ(DecomposeMemory(frictionless).status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(
      ComputeJagerWeights(frictionless.memory(), *MakeSphere(0.01).value(), 0).status().field(),
      "mu_kappa");
  EXPECT_EQ(
      ComputeJagerWeights(frictionless.memory(), *MakeSphere(0.01).value(), -1).status().code(),
      StatusCode::kInvalidArgument);

  Contact lifted = testing::SteelSphere();
  ASSERT_TRUE(lifted.MoveTo(1e-6, 1e-7).ok());
  ASSERT_TRUE(lifted.MoveTo(-1e-7, 1e-7).ok());
  const JagerWeights w = *ComputeJagerWeights(lifted);
  EXPECT_EQ(w.contact_radius, 0);
  EXPECT_TRUE(w.intervals.empty());
  EXPECT_EQ(w.edge_weight, 0);
  EXPECT_TRUE(DecomposeMemory(lifted)->empty());
}

TEST(JagerDecompositionTest, CattaneoMindlinAndMindlinDeresiewiczAreShortSums) {
  const Contact cm = LoadedByForces(testing::SteelSphere(), 100, 15);
  const std::vector<CattaneoMindlinTerm> one = *DecomposeMemory(cm);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one[0].weight, 1, 1e-12);
  EXPECT_EQ(one[0].a, cm.contact_radius());
  EXPECT_TRUE(RelNear(one[0].c, 1.4812480342e-4, 1e-9));  // H1 at s = 0.5

  // Unloading adds -2 u_B(a, c'): F = 1 on (c, c'], -1 on (c', a].
  const Unloaded md;
  const std::vector<CattaneoMindlinTerm> two = *DecomposeMemory(md.contact);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_NEAR(two[0].weight, 1, 1e-12);
  EXPECT_TRUE(RelNear(two[0].c, md.c_stick, 1e-12));
  EXPECT_TRUE(RelNear(two[0].a, md.c_reversal, 1e-12));
  EXPECT_NEAR(two[1].weight, -1, 1e-12);
  EXPECT_EQ(two[1].c, two[0].a);
  EXPECT_EQ(two[1].a, md.contact.contact_radius());
}

TEST(JagerDecompositionTest, SuperpositionRuleMergesAdjacentBasisSolutions) {
  // tau_B(a_i, a_j) + tau_B(a_j, a_k) = tau_B(a_i, a_k): as memories, and decomposed back.
  const ProfilePtr sphere = *MakeSphere(0.01);
  const double a_k = 1e-4, a_j = 0.7e-4, a_i = 0.3e-4, mu_kappa = 0.5;
  const double depth = sphere->G(a_k);
  const PiecewiseLinearMemory split =
      *MemoryFromTerms({*CattaneoMindlinTermFromRadii(1, a_k, a_j, *sphere),
                        *CattaneoMindlinTermFromRadii(1, a_j, a_i, *sphere)},
                       depth, mu_kappa);
  const PiecewiseLinearMemory whole =
      *MemoryFromTerms({*CattaneoMindlinTermFromRadii(1, a_k, a_i, *sphere)}, depth, mu_kappa);
  EXPECT_EQ(split.vertex_count(), 4u);
  EXPECT_LE(MaxDifference(split, whole), 1e-15 * MaxAbsU(whole));
  const std::vector<CattaneoMindlinTerm> merged = *DecomposeMemory(split, *sphere, mu_kappa);
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_NEAR(merged[0].weight, 1, 1e-15);
  EXPECT_TRUE(RelNear(merged[0].c, a_i, 1e-15));
  // Slip vertices are tagged on the upper bound, the stick vertex at the centre is inside.
  EXPECT_EQ(whole.tags(), (std::vector<std::uint8_t>{kInside, kOnUpper, kOnBoth}));
}

TEST(JagerDecompositionTest, TermsFromRadiiRebuildTheEngineState) {
  const Unloaded md;
  const Contact& c = md.contact;
  const Profile& sphere = *c.config().profile;
  const double a = c.contact_radius();
  const PiecewiseLinearMemory rebuilt =
      *MemoryFromTerms({*CattaneoMindlinTermFromRadii(1, md.c_reversal, md.c_stick, sphere),
                        *CattaneoMindlinTermFromRadii(-1, a, md.c_reversal, sphere)},
                       c.depth(), c.mu_kappa());
  EXPECT_LE(MaxDifference(rebuilt, c.memory()), 1e-12 * MaxAbsU(c.memory()));
}

std::vector<ProfilePtr> Profiles() {
  return {*MakeSphere(0.01), *MakeCone(0.2), *MakePowerLaw(1e9, 4), *MakePowerLaw(1e-3, 0.5),
          *MakeFlatPunch(1e-3)};
}

TEST(JagerDecompositionTest, RoundTripIsExactAndTheRebuiltStateEvolvesAlike) {
  unsigned seed = 0;
  for (const ProfilePtr& profile : Profiles()) {
    SCOPED_TRACE(profile->Describe());
    Contact c = MakeContact(profile, *RigidOnHalfSpace(1e9, 0.3), 0.4, /*energy=*/false);
    const double d0 = 1e-6, m = c.mu_kappa();
    testing::RandomHistory history{.rng = std::mt19937_64(++seed), .d0 = d0, .slip = m * d0};
    int rebuilt_states = 0;
    for (int i = 0; i < 300; ++i) {
      auto [depth, ux] = history.Next();
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      const PiecewiseLinearMemory& memory = c.memory();
      const std::vector<CattaneoMindlinTerm> terms = *DecomposeMemory(c);
      Result<PiecewiseLinearMemory> rebuilt = MemoryFromTerms(terms, c.depth(), m);
      ASSERT_TRUE(rebuilt.ok()) << rebuilt.status().ToString();
      if (!memory.in_contact()) continue;
      ++rebuilt_states;
      ASSERT_EQ(rebuilt->z(), memory.z());
      EXPECT_EQ(rebuilt->tags(), memory.tags());
      const double scale = MaxAbsU(memory);
      for (std::size_t k = 0; k < memory.vertex_count(); ++k) {
        ASSERT_LE(std::abs(rebuilt->u()[k] - memory.u()[k]), 1e-15 * scale) << "vertex " << k;
      }
      // Weights: |F| <= 1 (to round-off); intervals contiguous from the centre to the edge.
      const JagerWeights w = *ComputeJagerWeights(c);
      EXPECT_LE(std::abs(w.edge_weight), 1 + 1e-12);
      for (std::size_t k = 0; k < w.intervals.size(); ++k) {
        EXPECT_LE(std::abs(w.intervals[k].weight), 1 + 1e-12);
        if (k > 0) {
          EXPECT_EQ(w.intervals[k].r_begin, w.intervals[k - 1].r_end);
        }
      }
      if (!w.intervals.empty()) {
        EXPECT_EQ(w.intervals.front().r_begin, 0);
        EXPECT_EQ(w.intervals.back().r_end, c.contact_radius());
      }
      // The rebuilt memory is the state: the next step takes both to the same state.
      if (i % 10 == 0) {
        PiecewiseLinearMemory original = memory, copy = *rebuilt;
        const auto [depth1, ux1] = history.Next();
        // A memory rebuilt from terms stands at its own ux = 0 (jager.h): the same increment.
        original.ApplyLinearStep({depth1, ux1 - ux, ux, ux1}, m, nullptr);
        copy.ApplyLinearStep({depth1, ux1 - ux, 0, ux1 - ux}, m, nullptr);
        EXPECT_LE(MaxDifference(original, copy), 1e-15 * std::max(MaxAbsU(original), scale));
      }
    }
    EXPECT_GE(rebuilt_states, 250);
  }
}

TEST(JagerDecompositionTest, InverseRejectsInadmissibleTerms) {
  const ProfilePtr sphere = *MakeSphere(0.01);
  const double depth = sphere->G(1e-4);
  const CattaneoMindlinTerm full = *CattaneoMindlinTermFromRadii(1, 1e-4, 0, *sphere);
  EXPECT_EQ(MemoryFromTerms({full, full}, depth, 0.5).status().field(), "terms");  // F = 2
  CattaneoMindlinTerm deep = full;
  deep.depth_a = 2 * depth;
  EXPECT_EQ(MemoryFromTerms({full, deep}, depth, 0.5).status().field(), "terms[1].depth_a");
  EXPECT_EQ(MemoryFromTerms({full}, -1e-9, 0.5).status().field(), "terms");
  EXPECT_TRUE(MemoryFromTerms({}, -1e-9, 0.5).ok());
  EXPECT_EQ(CattaneoMindlinTermFromRadii(1, 1e-3, 0, **MakeFlatPunch(1e-3)).status().field(), "a");
  EXPECT_EQ(CattaneoMindlinTermFromRadii(1, 1e-4, 2e-4, *sphere).status().field(), "c");
}

// u(x_j) of a contact on an even grid over [0, a].
std::vector<double> Grid(double a, int cells) {
  std::vector<double> x;
  for (int j = 0; j <= cells; ++j) x.push_back(a * j / cells);
  return x;
}

std::vector<double> Sample(const Contact& c, const std::vector<double>& x) {
  std::vector<double> u;
  for (double xj : x) u.push_back(c.tangential_displacement_at(xj));
  return u;
}

TEST(SampledWeightTest, CattaneoMindlinIsAStepFunctionWithItsRadii) {
  const Contact c = LoadedByForces(testing::SteelSphere(), 100, 15);
  const double a = c.contact_radius();
  const std::vector<double> x = Grid(a, 200);
  const SampledWeight w =
      *AnalyzeSampledDisplacement(x, Sample(c, x), *c.config().profile, c.mu_kappa());
  EXPECT_EQ(w.kind, WeightKind::kStepFunction);
  EXPECT_EQ(w.tolerance, 1e-6);
  EXPECT_EQ(w.weights.size(), 200u);
  ASSERT_EQ(w.terms.size(), 1u);
  EXPECT_NEAR(w.terms[0].weight, 1, 1e-12);
  EXPECT_TRUE(RelNear(w.terms[0].a, a, 1e-15));
  EXPECT_TRUE(RelNear(w.terms[0].c, a * std::cbrt(0.5), 1e-10));
  EXPECT_LT(w.max_residual, 1e-12);
}

TEST(SampledWeightTest, MindlinDeresiewiczIsTwoTerms) {
  const Unloaded md;
  const Contact& c = md.contact;
  const std::vector<double> x = Grid(c.contact_radius(), 300);
  const SampledWeight w =
      *AnalyzeSampledDisplacement(x, Sample(c, x), *c.config().profile, c.mu_kappa());
  EXPECT_EQ(w.kind, WeightKind::kStepFunction);
  ASSERT_EQ(w.terms.size(), 2u);
  EXPECT_NEAR(w.terms[0].weight, 1, 1e-12);
  EXPECT_TRUE(RelNear(w.terms[0].c, md.c_stick, 1e-10));
  EXPECT_TRUE(RelNear(w.terms[0].a, md.c_reversal, 1e-10));
  EXPECT_NEAR(w.terms[1].weight, -1, 1e-12);
  EXPECT_TRUE(RelNear(w.terms[1].a, c.contact_radius(), 1e-15));
}

TEST(SampledWeightTest, WeightProportionalToRadiusIsContinuous) {
  // Hertz, F = x/a: u = mu kappa integral_x^a (t/a) g'(t) dt = mu kappa 2 (a^3 - x^3) / (3 a R).
  const ProfilePtr sphere = *MakeSphere(0.01);
  const double a = 1e-4, R = 0.01, m = 0.5;
  const int cells = 200;
  const std::vector<double> x = Grid(a, cells);
  std::vector<double> u;
  for (double xj : x) u.push_back(m * 2 * (a * a * a - xj * xj * xj) / (3 * a * R));
  u.back() = 0;
  const SampledWeight w = *AnalyzeSampledDisplacement(x, u, *sphere, m);
  EXPECT_EQ(w.kind, WeightKind::kContinuous);
  EXPECT_TRUE(w.terms.empty());
  ASSERT_EQ(w.midpoints.size(), static_cast<std::size_t>(cells));
  // The cell mean of x/a over its depths differs from the midpoint value by at most h/(6a).
  for (std::size_t j = 0; j < w.midpoints.size(); ++j) {
    EXPECT_NEAR(w.weights[j], w.midpoints[j] / a, 1.0 / (6 * cells) + 1e-12);
  }
}

TEST(SampledWeightTest, CurvedStickingPathGivesAContinuousWeight) {
  // ux = k delta^2 sticks (|dux/ddelta| < mu kappa); each spring keeps u = k (delta^2 - z^2), so
  // F = 2 k g(x) / (mu kappa): an infinite superposition, here built from 400 linear steps.
  Contact c = MakeContact(*MakeSphere(0.01), *RigidOnHalfSpace(1e9, 0.3), 0.4, false);
  const double d = 1e-6, k = 0.4 * c.mu_kappa() / d;
  for (int i = 1; i <= 400; ++i) {
    const double di = d * i / 400;
    ASSERT_TRUE(c.MoveTo(di, k * di * di).ok());
  }
  const std::vector<double> x = Grid(c.contact_radius(), 100);
  const SampledWeight w =
      *AnalyzeSampledDisplacement(x, Sample(c, x), *c.config().profile, c.mu_kappa());
  EXPECT_EQ(w.kind, WeightKind::kContinuous);
  for (std::size_t j = 0; j < w.midpoints.size(); ++j) {
    const double g = c.config().profile->G(w.midpoints[j]);
    EXPECT_NEAR(w.weights[j], 2 * k * g / c.mu_kappa(), 0.01);
  }
}

TEST(SampledWeightTest, Validation) {
  const ProfilePtr sphere = *MakeSphere(0.01);
  const std::vector<double> x = {0, 1e-5, 2e-5, 3e-5};
  const std::vector<double> u = {3e-9, 2e-9, 1e-9, 0};
  EXPECT_TRUE(AnalyzeSampledDisplacement(x, u, *sphere, 0.5).ok());
  EXPECT_EQ(AnalyzeSampledDisplacement(x, u, *sphere, 0).status().code(),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(AnalyzeSampledDisplacement({0, 2e-5, 1e-5, 3e-5}, u, *sphere, 0.5).status().field(),
            "x[2]");
  EXPECT_EQ(AnalyzeSampledDisplacement(x, {3e-9, 2e-9, 1e-9, 1e-9}, *sphere, 0.5).status().field(),
            "u[3]");
  EXPECT_EQ(AnalyzeSampledDisplacement(x, {1e-9, 0}, *sphere, 0.5).status().field(), "u");
  EXPECT_EQ(AnalyzeSampledDisplacement({0, 5e-4, 1e-3}, {1e-9, 1e-9, 0}, **MakeFlatPunch(1e-3), 0.5)
                .status()
                .field(),
            "x");
  SampledWeightOptions bad;
  bad.tolerance = 0;
  EXPECT_EQ(AnalyzeSampledDisplacement(x, u, *sphere, 0.5, bad).status().field(),
            "options.tolerance");
}

}  // namespace
}  // namespace mdr
