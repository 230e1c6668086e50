// The classical grid MDR against the exact engine: convergence order, the naive rule's step
// error, step-split invariance and the Contact API on a grid.
#include "mdr/core/grid_memory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "mdr/core/contact.h"
#include "mdr/core/jager.h"
#include "mdr/core/traction.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::RelNear;

const EffectiveMaterial kSteel = *ElasticPair(210e9, 0.3, 210e9, 0.3);
constexpr double kMu = 0.3, kDepth = 3.4829098839e-6;  // H1: F_N = 100 N on R = 10 mm

Contact MakeContactWith(Method method, std::size_t size = 1024,
                        GridStepRule rule = GridStepRule::kExact, double max_radius = 2.5e-4) {
  ContactConfig config;
  config.profile = *MakeSphere(0.01);
  config.material = kSteel;
  config.friction = kMu;
  config.method = method;
  config.grid_size = size;
  config.grid_max_radius = max_radius;  // 1.34 times H1's contact radius
  config.grid_step_rule = rule;
  Result<Contact> contact = Contact::Create(config);
  EXPECT_TRUE(contact.ok()) << contact.status().ToString();
  return std::move(contact).value();
}

Contact GridContact(std::size_t size, GridStepRule rule = GridStepRule::kExact) {
  return MakeContactWith(Method::kGrid, size, rule);
}

// Least-squares slope of -log(error) against log(N): the observed order of convergence.
double ObservedOrder(const std::vector<double>& sizes, const std::vector<double>& errors) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    const double x = std::log(sizes[i]), y = -std::log(errors[i]);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

const std::vector<double> kSizes = {64, 128, 256, 512, 1024, 2048, 4096};

// Where the kinks of u (slip boundary, contact edge) fall inside their cells sets the constant
// of the h^2 error, which therefore jumps between grids; the RMS over 16 grid offsets measures
// the typical error instead. The grid radius 2.5e-4 m is stretched by a fraction (golden-ratio
// sequence) of 1.5 cells, which moves both kinks through about a whole cell.
template <typename ErrorOf>  // double(Contact& grid, Contact& exact)
double RmsOverGridOffsets(double size, ErrorOf error_of) {
  constexpr int kOffsets = 16;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  double sum = 0;
  for (int k = 0; k < kOffsets; ++k) {
    const double fraction = k * golden - std::floor(k * golden);
    Contact grid = MakeContactWith(Method::kGrid, static_cast<std::size_t>(size),
                                   GridStepRule::kExact, 2.5e-4 * (1 + 1.5 * fraction / size));
    Contact exact = MakeContactWith(Method::kExact);
    const double e = error_of(grid, exact);
    sum += e * e;
  }
  return std::sqrt(sum / kOffsets);
}

// Relative error of F_x after indenting to H1's depth and shifting by half the slip length.
double CattaneoMindlinError(Contact& grid, Contact& exact) {
  for (Contact* c : {&grid, &exact}) {
    EXPECT_TRUE(c->MoveTo(kDepth, 0).ok());
    EXPECT_TRUE(c->MoveTo(kDepth, 0.5 * c->mu_kappa() * kDepth).ok());
  }
  return grid.tangential_force() / exact.tangential_force() - 1;
}

// Relative errors of F_x on the unloading branch (ux = 0) and of the energy of one cycle of
// amplitude 0.6 mu kappa delta.
struct LoopErrors {
  double unloading_force, energy;
};
LoopErrors MindlinDeresiewiczErrors(Contact& grid, Contact& exact) {
  double unloading[2], energy[2];
  int k = 0;
  for (Contact* c : {&grid, &exact}) {
    const double amplitude = 0.6 * c->mu_kappa() * kDepth;
    EXPECT_TRUE(c->MoveTo(kDepth, 0).ok());
    EXPECT_TRUE(c->MoveTo(kDepth, amplitude).ok());
    const double before = c->dissipated_energy();
    EXPECT_TRUE(c->MoveTo(kDepth, 0).ok());
    unloading[k] = c->tangential_force();
    EXPECT_TRUE(c->MoveTo(kDepth, -amplitude).ok());
    EXPECT_TRUE(c->MoveTo(kDepth, amplitude).ok());
    energy[k++] = c->dissipated_energy() - before;
  }
  return {unloading[0] / unloading[1] - 1, energy[0] / energy[1] - 1};
}

// Observed orders (least squares over the RMS errors at N = 64 ... 4096, grid radius 1.34 a):
// Cattaneo-Mindlin F_x at s = 0.5: 1.85 (6.2e-5 at N = 64, 2.9e-8 at 4096). Mindlin-
// Deresiewicz, amplitude 0.6 mu kappa delta: unloading force 2.03
// (1.3e-3 to 3.4e-7), energy per cycle 2.08 (8.3e-4 to 1.7e-7).
TEST(GridMemoryTest, CattaneoMindlinConvergesAtSecondOrder) {
  std::vector<double> errors;
  for (double size : kSizes) errors.push_back(RmsOverGridOffsets(size, CattaneoMindlinError));
  const double order = ObservedOrder(kSizes, errors);
  EXPECT_GE(order, 1.8);
  EXPECT_LE(order, 2.2);
}

TEST(GridMemoryTest, MindlinDeresiewiczLoopConvergesAtSecondOrder) {
  std::vector<double> force_errors, energy_errors;
  for (double size : kSizes) {
    force_errors.push_back(RmsOverGridOffsets(size, [](Contact& grid, Contact& exact) {
      return MindlinDeresiewiczErrors(grid, exact).unloading_force;
    }));
    energy_errors.push_back(RmsOverGridOffsets(size, [](Contact& grid, Contact& exact) {
      return MindlinDeresiewiczErrors(grid, exact).energy;
    }));
  }
  EXPECT_GE(ObservedOrder(kSizes, force_errors), 1.8);
  EXPECT_LE(ObservedOrder(kSizes, force_errors), 2.2);
  EXPECT_GE(ObservedOrder(kSizes, energy_errors), 1.8);
  EXPECT_LE(ObservedOrder(kSizes, energy_errors), 2.2);
}

// Oblique loading from zero, ux = r delta with r = 0.7 mu kappa: complete stick, F_x/F_N =
// r/kappa. The naive rule gives each entering spring the whole step's dux, not the part after
// it entered: its error is first order in the step (measured 2.2e-2 for 10 steps, 2.2e-3 for
// 100), on every grid; the exact rule's error is the grid's (2.35e-7 at N = 1024, the same for
// 1 and 100 steps).
TEST(GridMemoryTest, NaiveRuleIsFirstOrderInTheStepUnderObliqueLoading) {
  auto oblique_error = [](GridStepRule rule, int steps) {
    Contact c = GridContact(1024, rule);
    const double r = 0.7 * c.mu_kappa();
    for (int i = 1; i <= steps; ++i) {
      const double depth = kDepth * i / steps;
      EXPECT_TRUE(c.MoveTo(depth, r * depth).ok());
    }
    const double kappa = c.mu_kappa() / kMu;
    return std::abs(c.tangential_force() / c.normal_force() / (r / kappa) - 1);
  };
  const double exact_1 = oblique_error(GridStepRule::kExact, 1);
  const double exact_100 = oblique_error(GridStepRule::kExact, 100);
  const double naive_10 = oblique_error(GridStepRule::kNaive, 10);
  const double naive_100 = oblique_error(GridStepRule::kNaive, 100);
  EXPECT_LT(exact_1, 1e-6);
  EXPECT_NEAR(exact_100, exact_1, 1e-12) << "the exact rule does not see the step count";
  EXPECT_GT(naive_10, 1e-2);
  EXPECT_GT(naive_100, 1e3 * exact_100);
  EXPECT_NEAR(naive_10 / naive_100, 10, 1) << "first order in the step";
}

TEST(GridMemoryTest, ExactRuleIsStepSplitInvariantAndNaiveRuleIsNot) {
  for (GridStepRule rule : {GridStepRule::kExact, GridStepRule::kNaive}) {
    Contact c = GridContact(512, rule);
    const double slip = c.mu_kappa() * kDepth;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(0, 1);
    double worst = 0;
    for (int i = 0; i < 200; ++i) {
      const double depth = kDepth * (unit(rng) < 0.1 ? -0.2 * unit(rng) : 0.2 + 1.1 * unit(rng));
      const double ux = slip * (4 * unit(rng) - 2);
      const int parts = 2 + i % 6;
      Contact split = c;
      const double d0 = c.depth(), ux0 = c.tangential_displacement();
      for (int k = 1; k <= parts; ++k) {
        const double s = static_cast<double>(k) / parts;
        ASSERT_TRUE(split.MoveTo(d0 + s * (depth - d0), ux0 + s * (ux - ux0)).ok());
      }
      ASSERT_TRUE(c.MoveTo(depth, ux).ok());
      worst = std::max(worst, c.grid_memory()->MaxDifference(*split.grid_memory()) / slip);
      if (rule == GridStepRule::kExact) {
        EXPECT_TRUE(RelNear(split.dissipated_energy(), c.dissipated_energy(), 1e-9)) << i;
      }
    }
    if (rule == GridStepRule::kExact) {
      EXPECT_LT(worst, 1e-12);
    } else {
      EXPECT_GT(worst, 1e-2);
    }
  }
}

TEST(GridMemoryTest, ForceControlStiffnessSlipZonesAndQueries) {
  Contact c = GridContact(2048);
  EXPECT_EQ(c.grid_spacing(), 2.5e-4 / 2048);
  ASSERT_TRUE(c.Apply(testing::NormalForceStep(100)).ok());
  ASSERT_TRUE(c.Apply(testing::TangentialForceStep(15)).ok());
  EXPECT_TRUE(RelNear(c.tangential_force(), 15, 1e-12));
  // Reference H1: u0 = 4.6949658143e-7 m, stick radius c = 1.4812480342e-4 m (to O(h^2)).
  EXPECT_TRUE(RelNear(c.tangential_displacement(), 4.6949658143e-7, 1e-6));
  const std::vector<SlipInterval> slip = c.slip_intervals();
  ASSERT_EQ(slip.size(), 1u);
  EXPECT_EQ(slip[0].direction, +1);
  EXPECT_NEAR(slip[0].r_begin, 1.4812480342e-4, c.grid_spacing());
  EXPECT_EQ(slip[0].r_end, c.contact_radius());
  // Stiffness: 2 G* times the sticking radius, to a cell.
  EXPECT_NEAR(c.tangential_stiffness().positive / (2 * kSteel.g_star), 1.4812480342e-4,
              c.grid_spacing());
  EXPECT_EQ(c.tangential_displacement_at(1e-5), c.tangential_displacement());
  EXPECT_EQ(c.tangential_displacement_at(2e-4), 0);
  EXPECT_TRUE(c.memory_pieces().empty());
  EXPECT_EQ(c.memory().vertex_count(), 0u);
  // Gross slip by force control.
  ASSERT_TRUE(c.Apply(testing::TangentialForceStep(c.friction_limit())).ok());
  EXPECT_TRUE(RelNear(c.tangential_force(), c.friction_limit(), 1e-5));
  EXPECT_EQ(c.tangential_stiffness().positive, 0);
}

TEST(GridMemoryTest, SnapshotRestoresBitIdentically) {
  Contact a = GridContact(300);
  ASSERT_TRUE(a.Apply(testing::NormalForceStep(100)).ok());
  ASSERT_TRUE(a.Apply(testing::TangentialForceStep(20)).ok());
  Result<Contact> b = Contact::Restore(a.config(), a.Snapshot());
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  for (Contact* c : {&a, &b.value()}) ASSERT_TRUE(c->MoveTo(0.9 * c->depth(), -1e-7).ok());
  EXPECT_TRUE(*a.grid_memory() == *b->grid_memory());
  EXPECT_EQ(a.dissipated_energy(), b->dissipated_energy());
  ContactSnapshot bad = a.Snapshot();
  bad.grid_u.pop_back();
  EXPECT_EQ(Contact::Restore(a.config(), bad).status().field(), "grid_u");
  bad = a.Snapshot();
  bad.grid_u[0] = 1;
  EXPECT_EQ(Contact::Restore(a.config(), bad).status().field(), "grid_u[0]");
  // The bound is checked exactly (Step clamps to the same expression): 1e-9 above it is refused.
  bad = a.Snapshot();
  const double bound = a.mu_kappa() * (bad.depth - a.grid_memory()->z()[0]);
  ASSERT_EQ(a.grid_memory()->Tag(0), kInside);
  bad.grid_u[0] = bound * (1 + 1e-9);
  EXPECT_EQ(Contact::Restore(a.config(), bad).status().field(), "grid_u[0]");
}

TEST(GridMemoryTest, ConfigAndReachErrorsNameTheirField) {
  ContactConfig config;
  config.profile = *MakeSphere(0.01);
  config.material = kSteel;
  config.method = Method::kGrid;
  config.grid_max_radius = 1e-4;
  config.grid_size = 1;
  EXPECT_EQ(ValidateContactConfig(config).field(), "grid_size");
  config.grid_size = (std::size_t{1} << 22) + 1;
  EXPECT_EQ(ValidateContactConfig(config).field(), "grid_size");
  config.grid_size = 1 << 22;
  EXPECT_TRUE(ValidateContactConfig(config).ok());
  config.grid_size = 64;
  config.grid_max_radius = 0;
  EXPECT_EQ(ValidateContactConfig(config).field(), "grid_max_radius");
  config.method = Method::kExact;
  EXPECT_TRUE(ValidateContactConfig(config).ok()) << "the grid radius matters only on a grid";

  Contact c = GridContact(64);  // radius 2.5e-4 m: depth 6.25e-6 m on R = 10 mm
  const Status s = c.MoveTo(7e-6, 0);
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.field(), "grid_max_radius");
  EXPECT_EQ(c.depth(), 0) << "unchanged";
  EXPECT_EQ(c.Apply(testing::NormalForceStep(1000)).field(), "grid_max_radius");
  EXPECT_TRUE(c.MoveTo(6e-6, 0).ok());
}

// The Jäger picture and the tangential tractions need the exact memory; the core refuses them on
// a grid contact itself (before: an empty memory and zeros), naming the method.
TEST(GridMemoryTest, JagerOutputsAndTractionsNeedTheExactMethod) {
  Contact grid = GridContact(256);
  ASSERT_TRUE(grid.MoveTo(kDepth, 0.5 * kMu * grid.config().material.kappa() * kDepth).ok());
  const Status weights = ComputeJagerWeights(grid).status();
  EXPECT_EQ(weights.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(weights.field(), "method");
  EXPECT_EQ(DecomposeMemory(grid).status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ComputeTangentialTraction(grid, {1e-5}).status().field(), "method");
  EXPECT_EQ(IntegrateTangentialTraction(grid).status().field(), "method");
  // The normal pressure does not depend on the tangential memory.
  EXPECT_TRUE(ComputeNormalPressure(grid, {1e-5}).ok());
  Contact exact = MakeContactWith(Method::kExact);
  ASSERT_TRUE(exact.MoveTo(kDepth, 0.5 * kMu * exact.config().material.kappa() * kDepth).ok());
  EXPECT_TRUE(ComputeJagerWeights(exact).ok());
  EXPECT_TRUE(ComputeTangentialTraction(exact, {1e-5}).ok());
}

}  // namespace
}  // namespace mdr
