// The Jäger picture, tractions and Transform through the generated stub against a real server on
// a free port: Query's jager_weights, jager_decomposition, tractions and pressure on the H1
// Cattaneo-Mindlin state against closed forms, the Transform round trips, and the grid and
// tabulated methods with their error estimates.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using bridge::Output;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// H1 after the tangential load: contact radius a, stick radius c, Hertz peak pressure p0.
struct CattaneoMindlinState {
  double a, c, p0;
};

// The closed form (docs/physics.md): a = sqrt(R delta), c = a (1 - F_x / (mu F_N))^(1/3).
CattaneoMindlinState H1State(double fx, double fn) {
  const double a = std::sqrt(kRadius * kDepth);
  return {a, a * std::cbrt(1 - fx / (kFriction * fn)),
          2 * EffectiveYoungsModulus() * a / (M_PI * kRadius)};
}

// Hertz pressure of contact radius `radius` (0 outside).
double HertzPressure(double r, double radius, double p0_of_radius) {
  return r < radius ? p0_of_radius * std::sqrt((radius - r) * (radius + r)) / radius : 0;
}

// Cattaneo-Mindlin: tau = mu [p(r; a) - p(r; c)] (docs/physics.md).
double CattaneoMindlinTraction(double r, const CattaneoMindlinState& s) {
  const double p0_c = s.p0 * s.c / s.a;
  return kFriction * (HertzPressure(r, s.a, s.p0) - HertzPressure(r, s.c, p0_c));
}

class JagerTransformTest : public ServiceTest {
 protected:
  // A session in the H1 state (F_N = 100 N, F_x = 15 N). Returns the closed-form state with the
  // session's own a and c (checked against the closed form), so that radii at r = c and r = a,
  // where the tractions have infinite slope, sit exactly on the kinks of both.
  CattaneoMindlinState LoadH1(const std::string& session) {
    v1::ApplyResponse applied;
    grpc::Status status =
        Apply(session, {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}, &applied);
    EXPECT_TRUE(status.ok()) << status.error_message();
    EXPECT_NEAR(applied.state().normal_force(), 100, 1e-6);
    EXPECT_NEAR(applied.state().tangential_force(), 15, 1e-6);
    v1::QueryResponse slip;
    EXPECT_TRUE(Query(session, &slip, {"slip_intervals", "state.contact_radius"}).ok());
    EXPECT_EQ(slip.slip_intervals_size(), 1);
    const CattaneoMindlinState closed_form =
        H1State(applied.state().tangential_force(), applied.state().normal_force());
    CattaneoMindlinState s = closed_form;
    s.a = slip.state().contact_radius();
    s.c = slip.slip_intervals(0).r_begin();
    EXPECT_NEAR(s.a, closed_form.a, 1e-12 * closed_form.a);
    EXPECT_NEAR(s.c, closed_form.c, 1e-9 * closed_form.a);
    s.p0 = 2 * EffectiveYoungsModulus() * s.a / (M_PI * kRadius);
    return s;
  }

  grpc::Status QueryRadial(const std::string& session, const std::vector<std::string>& read_mask,
                           const std::vector<double>& radii, v1::TractionRoute route,
                           v1::QueryResponse* response) {
    v1::QueryRequest request;
    request.set_session(session);
    *request.mutable_read_mask() = Mask(read_mask);
    request.mutable_radii()->Add(radii.begin(), radii.end());
    request.set_traction_route(route);
    return stub_->Query(Context().get(), request, response);
  }

  grpc::Status Transform(const v1::TransformRequest& request, v1::TransformResponse* response) {
    return stub_->Transform(Context().get(), request, response);
  }
};

TEST_F(JagerTransformTest, CattaneoMindlinTractionsMatchTheClosedFormByBothRoutes) {
  const std::string session = CreateOrDie();
  const CattaneoMindlinState s = LoadH1(session);
  const double peak = kFriction * s.p0;
  const std::vector<double> radii = {
      0, 0.3 * s.c, 0.9 * s.c, s.c, 1.1 * s.c, 0.5 * (s.c + s.a), 0.999 * s.a, s.a, 2 * s.a};
  v1::QueryResponse response;
  grpc::Status status = QueryRadial(session, {"tractions", "pressure"}, radii,
                                    v1::TRACTION_ROUTE_UNSPECIFIED, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.tractions_size(), static_cast<int>(radii.size()));
  ASSERT_EQ(response.pressure_size(), static_cast<int>(radii.size()));
  double largest_difference = 0;
  for (std::size_t i = 0; i < radii.size(); ++i) {
    SCOPED_TRACE("r = " + std::to_string(radii[i]));
    const v1::RadialValue& tau = response.tractions(static_cast<int>(i));
    EXPECT_EQ(tau.radius(), radii[i]);
    EXPECT_EQ(tau.route(), v1::TRACTION_ROUTE_BOTH);
    ASSERT_TRUE(tau.has_abel() && tau.has_jager());
    EXPECT_EQ(tau.value(), tau.jager());
    // The routes' difference plus the bound of the memory's own rounding (docs/engine.md).
    EXPECT_GE(tau.error_estimate(), std::abs(tau.abel() - tau.jager()));
    largest_difference = std::max(largest_difference, tau.error_estimate());
    EXPECT_NEAR(tau.value(), CattaneoMindlinTraction(radii[i], s), 1e-9 * peak);
    const v1::RadialValue& p = response.pressure(static_cast<int>(i));
    EXPECT_NEAR(p.value(), HertzPressure(radii[i], s.a, s.p0), 1e-9 * s.p0);
  }
  // The two routes agree to far below the peak traction; the largest estimate is reported. At
  // r = c the stick radius' own rounding (eps * depth / g') dominates: ~1e-7 of the peak.
  EXPECT_LT(response.error_estimate().traction_error(), 1e-6 * peak);
  EXPECT_EQ(response.error_estimate().traction_error(), largest_difference);
  EXPECT_LT(response.error_estimate().pressure_error(), 1e-9 * s.p0);
  EXPECT_EQ(response.error_estimate().grid_spacing(), 0);
  EXPECT_EQ(response.error_estimate().profile_tolerance(), 0);
  EXPECT_EQ(counters_[Output::kTractions], 1u);
  EXPECT_EQ(counters_[Output::kPressure], 1u);
  std::printf("two-route traction error / peak = %.3g, compute %.3g s for %zu radii\n",
              response.error_estimate().traction_error() / peak, response.compute_seconds(),
              radii.size());
}

TEST_F(JagerTransformTest, SingleRoutesReportOnlyTheirOwnValue) {
  const std::string session = CreateOrDie();
  const CattaneoMindlinState s = LoadH1(session);
  const std::vector<double> radii = {0.5 * s.c, 0.5 * (s.c + s.a)};
  for (const v1::TractionRoute route : {v1::TRACTION_ROUTE_ABEL, v1::TRACTION_ROUTE_JAGER}) {
    SCOPED_TRACE(v1::TractionRoute_Name(route));
    v1::QueryResponse response;
    ASSERT_TRUE(QueryRadial(session, {"tractions"}, radii, route, &response).ok());
    ASSERT_EQ(response.tractions_size(), 2);
    for (const v1::RadialValue& tau : response.tractions()) {
      EXPECT_EQ(tau.route(), route);
      EXPECT_EQ(tau.has_abel(), route == v1::TRACTION_ROUTE_ABEL);
      EXPECT_EQ(tau.has_jager(), route == v1::TRACTION_ROUTE_JAGER);
      EXPECT_NEAR(tau.value(), CattaneoMindlinTraction(tau.radius(), s), 1e-9 * kFriction * s.p0);
    }
    EXPECT_FALSE(response.has_state());  // only what was selected
    EXPECT_EQ(response.pressure_size(), 0);
  }
}

TEST_F(JagerTransformTest, InfiniteTractionsAreEncodedAsInfinity) {
  // A cone's pressure is infinite at its tip (log singularity).
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_cone()->set_slope_angle(0.1);
  v1::Session created;
  ASSERT_TRUE(Create(scene, &created).ok());
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(created.name(), {DepthStep(1e-6)}, &applied).ok());
  v1::QueryResponse response;
  ASSERT_TRUE(
      QueryRadial(created.name(), {"pressure"}, {0, 1e-6}, v1::TRACTION_ROUTE_JAGER, &response)
          .ok());
  EXPECT_EQ(response.pressure(0).value(), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isfinite(response.pressure(1).value()));
  EXPECT_GT(response.pressure(1).value(), 0);
}

TEST_F(JagerTransformTest, JagerWeightsAreZeroInStickAndOneInSlip) {
  const std::string session = CreateOrDie();
  const CattaneoMindlinState s = LoadH1(session);
  v1::QueryResponse response;
  grpc::Status status = Query(session, &response, {"jager_weights", "jager_decomposition"});
  ASSERT_TRUE(status.ok()) << status.error_message();
  const v1::JagerWeights& weights = response.jager_weights();
  EXPECT_NEAR(weights.contact_radius(), s.a, 1e-12 * s.a);
  EXPECT_EQ(weights.edge_weight(), 0);
  ASSERT_EQ(weights.intervals_size(), 2);
  EXPECT_EQ(weights.intervals(0).r_begin(), 0);
  EXPECT_NEAR(weights.intervals(0).r_end(), s.c, 1e-9 * s.a);
  EXPECT_EQ(weights.intervals(0).weight(), 0);  // stick
  EXPECT_EQ(weights.intervals(1).r_begin(), weights.intervals(0).r_end());
  EXPECT_NEAR(weights.intervals(1).r_end(), s.a, 1e-12 * s.a);
  EXPECT_NEAR(weights.intervals(1).weight(), 1, 1e-12);  // slip in +x
  EXPECT_NEAR(weights.intervals(1).depth_end(), kDepth, 1e-12 * kDepth);

  // One basis solution: weight 1 from c to a.
  ASSERT_EQ(response.jager_decomposition_size(), 1);
  const v1::CattaneoMindlinTerm& term = response.jager_decomposition(0);
  EXPECT_NEAR(term.weight(), 1, 1e-12);
  EXPECT_NEAR(term.a(), s.a, 1e-12 * s.a);
  EXPECT_NEAR(term.c(), s.c, 1e-9 * s.a);
  EXPECT_NEAR(term.depth_a(), kDepth, 1e-12 * kDepth);
  EXPECT_EQ(counters_[Output::kJagerWeights], 1u);
  EXPECT_EQ(counters_[Output::kJagerDecomposition], 1u);
}

TEST_F(JagerTransformTest, FlatPunchWeightSitsAtTheEdge) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_flat_punch()->set_radius(1e-3);
  v1::Session created;
  ASSERT_TRUE(Create(scene, &created).ok());
  // Beyond mu kappa delta: gross slip.
  const double depth = 1e-6;
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(created.name(),
                    {DepthStep(depth), DisplacementStep(2 * kFriction * Kappa() * depth)}, &applied)
                  .ok());
  v1::QueryResponse response;
  ASSERT_TRUE(Query(created.name(), &response, {"jager_weights"}).ok());
  EXPECT_EQ(response.jager_weights().intervals_size(), 0);
  EXPECT_NEAR(response.jager_weights().edge_weight(), 1, 1e-12);
  EXPECT_EQ(response.jager_weights().contact_radius(), 1e-3);
}

TEST_F(JagerTransformTest, JagerOutputsNeedFrictionAndTheExactMethod) {
  v1::Scene frictionless = SteelSphereOnSteelFlat();
  frictionless.set_friction(0);
  v1::Session created;
  ASSERT_TRUE(Create(frictionless, &created).ok());
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(created.name(), {DepthStep(kDepth)}, &applied).ok());
  v1::QueryResponse response;
  for (const char* output : {"jager_weights", "jager_decomposition"}) {
    grpc::Status status = Query(created.name(), &response, {output});
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << output;
    EXPECT_EQ(status.error_message(),
              "scene.friction: weights are undefined for mu = 0: every spring is at the bound");
  }
  // Tractions exist without friction: all 0.
  ASSERT_TRUE(Query(created.name(), &response, {"tractions"}, {0}).ok());
  EXPECT_EQ(response.tractions(0).value(), 0);

  ExpectInvalidArgument(Query(created.name(), &response, {"tractions"}), "radii");
  ExpectInvalidArgument(Query(created.name(), &response, {"pressure"}), "radii");
  ExpectInvalidArgument(Query(created.name(), &response, {"tractions"}, {1e-5, -1}), "radii[1]");
  ExpectInvalidArgument(Query(created.name(), &response, {"tractions.value"}, {0}),
                        "read_mask.paths[0]");
  ExpectInvalidArgument(
      QueryRadial(created.name(), {"tractions"}, {0}, static_cast<v1::TractionRoute>(9), &response),
      "traction_route");
}

// A grid session: its Apply and Query report the spacing, and the outputs that need the exact
// memory fail with FAILED_PRECONDITION.
TEST_F(JagerTransformTest, GridSessionReportsItsSpacingAndRefusesJagerOutputs) {
  const double a = std::sqrt(kRadius * kDepth);
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_size(4000);
  scene.mutable_grid()->set_max_radius(2 * a);
  v1::Session created;
  grpc::Status status = Create(scene, &created);
  ASSERT_TRUE(status.ok()) << status.error_message();
  v1::ApplyResponse applied;
  ASSERT_TRUE(
      Apply(created.name(), {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}, &applied)
          .ok());
  const double spacing = 2 * a / 4000;
  EXPECT_DOUBLE_EQ(applied.error_estimate().grid_spacing(), spacing);
  // Converges like h^2: at h = a/2000 the forces are close to Cattaneo-Mindlin's.
  ExpectRelativelyNear(applied.state().normal_force(), 100, 1e-5);
  ExpectRelativelyNear(applied.state().tangential_force(), 15, 1e-5);

  v1::QueryResponse response;
  ASSERT_TRUE(Query(created.name(), &response, {"state.normal_force", "pressure"}, {0}).ok());
  EXPECT_DOUBLE_EQ(response.error_estimate().grid_spacing(), spacing);
  ExpectRelativelyNear(response.pressure(0).value(), H1State(15, 100).p0, 1e-9);
  for (const char* output : {"jager_weights", "jager_decomposition", "tractions"}) {
    status = Query(created.name(), &response, {output}, {0});
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << output;
    EXPECT_THAT(status.error_message(),
                StartsWith(std::string(output) + ": available for method EXACT"));
  }

  // Beyond the grid's reach the step fails and changes nothing.
  status = Apply(created.name(), {DepthStep(5 * kDepth)}, &applied);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), StartsWith("steps[0].grid_max_radius: "));
  EXPECT_EQ(StateOf(created.name()).depth(), kDepth);
}

TEST_F(JagerTransformTest, GridAndTabulatedScenesAreValidatedByField) {
  const auto expect_invalid = [&](const v1::Scene& scene, const std::string& field) {
    v1::Session session;
    ExpectInvalidArgument(Create(scene, &session), field);
  };
  v1::Scene grid = SteelSphereOnSteelFlat();
  grid.set_method(v1::METHOD_GRID);
  expect_invalid(grid, "session.scene.grid.max_radius");  // required for the grid method
  grid.mutable_grid()->set_max_radius(1e-3);
  grid.mutable_grid()->set_size(1);
  expect_invalid(grid, "session.scene.grid.size");
  grid.mutable_grid()->set_size(0);
  grid.mutable_grid()->set_step_rule(static_cast<v1::GridStepRule>(7));
  expect_invalid(grid, "session.scene.grid.step_rule");
  grid.mutable_grid()->set_step_rule(v1::GRID_STEP_RULE_NAIVE);
  grid.set_method(static_cast<v1::Method>(9));
  expect_invalid(grid, "session.scene.method");

  v1::Scene tabulated = SteelSphereOnSteelFlat();
  v1::TabulatedProfile* profile = tabulated.mutable_tabulated();
  for (double r : {0.0, 1e-4, 2e-4, 3e-4}) {
    profile->add_radii(r);
    profile->add_heights(r * r / (2 * kRadius));
  }
  profile->set_radii(0, 1e-5);
  expect_invalid(tabulated, "session.scene.tabulated.radii[0]");
  profile->set_radii(0, 0);
  profile->set_radii(2, 1e-4);
  expect_invalid(tabulated, "session.scene.tabulated.radii[2]");
  profile->set_radii(2, 2e-4);
  profile->add_heights(0);
  expect_invalid(tabulated, "session.scene.tabulated.heights");
  profile->mutable_heights()->RemoveLast();
  profile->set_tolerance(0.5);
  expect_invalid(tabulated, "session.scene.tabulated.tolerance");
  profile->clear_tolerance();
  profile->set_interpolation(static_cast<v1::TabulatedProfile::Interpolation>(5));
  expect_invalid(tabulated, "session.scene.tabulated.interpolation");
  profile->set_interpolation(v1::TabulatedProfile::INTERPOLATION_CUBIC_SPLINE);
  v1::Session created;
  EXPECT_TRUE(Create(tabulated, &created).ok());
}

// A sphere given as samples: the H1 forces, and the table's accuracy as the error estimate.
TEST_F(JagerTransformTest, TabulatedSphereReproducesHertzAndReportsItsTolerance) {
  const double a = std::sqrt(kRadius * kDepth);
  v1::Scene scene = SteelSphereOnSteelFlat();
  v1::TabulatedProfile* profile = scene.mutable_tabulated();
  const int samples = 400;
  for (int i = 0; i <= samples; ++i) {
    const double r = 2 * a * i / samples;
    profile->add_radii(r);
    profile->add_heights(r * r / (2 * kRadius));
  }
  profile->set_tolerance(1e-9);
  v1::Session created;
  grpc::Status status = Create(scene, &created);
  ASSERT_TRUE(status.ok()) << status.error_message();
  v1::ApplyResponse applied;
  ASSERT_TRUE(
      Apply(created.name(), {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}, &applied)
          .ok());
  const double tolerance = applied.error_estimate().profile_tolerance();
  EXPECT_GT(tolerance, 0);
  EXPECT_LE(tolerance, 1e-9);
  EXPECT_EQ(applied.error_estimate().grid_spacing(), 0);
  // Steffen's end condition gives the sampled sphere a slight conical tip near the axis.
  ExpectRelativelyNear(applied.state().normal_force(), 100, 1e-4);
  ExpectRelativelyNear(applied.state().tangential_force(), 15, 1e-4);

  v1::QueryResponse response;
  ASSERT_TRUE(Query(created.name(), &response, {"tractions"}, {0.5 * a}).ok());
  EXPECT_EQ(response.error_estimate().profile_tolerance(), tolerance);
  EXPECT_GT(response.tractions(0).value(), 0);

  // Export spells out the defaults, so the snapshot behaves the same elsewhere.
  const v1::SessionSnapshot snapshot = ExportOrDie(created.name());
  EXPECT_EQ(snapshot.scene().tabulated().interpolation(),
            v1::TabulatedProfile::INTERPOLATION_STEFFEN);
  EXPECT_EQ(snapshot.scene().method(), v1::METHOD_EXACT);
  std::printf("tabulated sphere (%d samples): profile tolerance %.3g, F_N %.9g N\n", samples + 1,
              tolerance, applied.state().normal_force());
}

TEST_F(JagerTransformTest, DecompositionRoundTripsThroughTransform) {
  // Nested reversals leave several terms of alternating sign.
  const std::string session = CreateOrDie();
  std::vector<v1::Step> steps = {DepthStep(kDepth)};
  for (double fraction : {1.0, -0.6, 0.3, -0.1}) {
    steps.push_back(DisplacementStep(fraction * kDisplacementAt15N));
  }
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(session, steps, &applied).ok());
  const double a = applied.state().contact_radius();
  const std::vector<double> radii = {0, 0.2 * a, 0.4 * a, 0.6 * a, 0.8 * a, 0.95 * a};
  v1::QueryResponse queried;
  ASSERT_TRUE(QueryRadial(session, {"jager_decomposition", "tractions"}, radii,
                          v1::TRACTION_ROUTE_JAGER, &queried)
                  .ok());
  ASSERT_GE(queried.jager_decomposition_size(), 4);
  const v1::SessionSnapshot snapshot = ExportOrDie(session);

  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  v1::CattaneoMindlinSuperposition* superposition = request.mutable_superposition();
  superposition->set_depth(kDepth);
  *superposition->mutable_terms() = queried.jager_decomposition();
  request.mutable_radii()->Add(radii.begin(), radii.end());
  request.set_traction_route(v1::TRACTION_ROUTE_JAGER);
  v1::TransformResponse transformed;
  grpc::Status status = Transform(request, &transformed);
  ASSERT_TRUE(status.ok()) << status.error_message();

  // The memory of the session, vertex for vertex (u to round-off of the weights).
  ASSERT_EQ(transformed.memory_size(), snapshot.contact().memory_size());
  double max_u = 0;
  for (const v1::MemoryVertex& vertex : snapshot.contact().memory()) {
    max_u = std::max(max_u, std::abs(vertex.u()));
  }
  for (int i = 0; i < transformed.memory_size(); ++i) {
    SCOPED_TRACE("vertex " + std::to_string(i));
    EXPECT_EQ(transformed.memory(i).z(), snapshot.contact().memory(i).z());
    EXPECT_NEAR(transformed.memory(i).u(), snapshot.contact().memory(i).u(), 8e-16 * max_u);
    EXPECT_EQ(transformed.memory(i).bound(), snapshot.contact().memory(i).bound());
  }
  // And its tractions.
  ASSERT_EQ(transformed.tractions_size(), static_cast<int>(radii.size()));
  const double peak = kFriction * H1State(15, 100).p0;
  for (int i = 0; i < transformed.tractions_size(); ++i) {
    EXPECT_NEAR(transformed.tractions(i).value(), queried.tractions(i).value(), 1e-12 * peak);
  }
  EXPECT_EQ(transformed.error_estimate().traction_error(),
            queried.error_estimate().traction_error());
  EXPECT_FALSE(transformed.has_sampled_weight());
  EXPECT_GT(transformed.compute_seconds(), 0);
}

TEST_F(JagerTransformTest, TermsByRadiiEqualTermsByDepths) {
  const double a = std::sqrt(kRadius * kDepth);
  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  v1::CattaneoMindlinSuperposition* superposition = request.mutable_superposition();
  superposition->set_depth(kDepth);
  superposition->set_coordinates(v1::CattaneoMindlinSuperposition::COORDINATES_RADII);
  v1::CattaneoMindlinTerm* term = superposition->add_terms();
  term->set_weight(-0.5);
  term->set_a(0.8 * a);
  term->set_c(0.4 * a);
  v1::TransformResponse by_radii;
  grpc::Status status = Transform(request, &by_radii);
  ASSERT_TRUE(status.ok()) << status.error_message();

  superposition->set_coordinates(v1::CattaneoMindlinSuperposition::COORDINATES_DEPTHS);
  term->clear_a();
  term->clear_c();
  term->set_depth_a(std::pow(0.8 * a, 2) / kRadius);  // g(r) = r^2 / R
  term->set_depth_c(std::pow(0.4 * a, 2) / kRadius);
  v1::TransformResponse by_depths;
  ASSERT_TRUE(Transform(request, &by_depths).ok());
  ASSERT_EQ(by_radii.memory_size(), 4);  // 0, depth_c, depth_a, depth
  ASSERT_EQ(by_depths.memory_size(), 4);
  const double u_centre = -0.5 * kFriction * Kappa() * (term->depth_a() - term->depth_c());
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(by_radii.memory(i).z(), by_depths.memory(i).z(), 1e-14 * kDepth);
    EXPECT_NEAR(by_radii.memory(i).u(), by_depths.memory(i).u(), 1e-14 * std::abs(u_centre));
    EXPECT_EQ(by_radii.memory(i).bound(), i < 3 ? v1::MEMORY_BOUND_INSIDE : v1::MEMORY_BOUND_BOTH)
        << i;
  }
  EXPECT_NEAR(by_depths.memory(0).u(), u_centre, 1e-14 * std::abs(u_centre));
}

TEST_F(JagerTransformTest, SampledCattaneoMindlinStateIsAStepFunction) {
  const std::string session = CreateOrDie();
  const CattaneoMindlinState s = LoadH1(session);
  // u(x) on a uniform grid ending at the contact edge.
  const int cells = 200;
  std::vector<double> x;
  for (int j = 0; j <= cells; ++j) x.push_back(s.a * j / cells);
  x.back() = StateOf(session).contact_radius();
  v1::QueryResponse springs;
  ASSERT_TRUE(Query(session, &springs, {"springs.tangential_displacement"}, x).ok());

  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  v1::SampledDisplacement* samples = request.mutable_samples();
  samples->mutable_x()->Add(x.begin(), x.end());
  *samples->mutable_u() = springs.springs().tangential_displacement();
  samples->set_tolerance(1e-9);
  const std::vector<double> radii = {0, 0.5 * s.c, 0.5 * (s.c + s.a)};
  request.mutable_radii()->Add(radii.begin(), radii.end());
  v1::TransformResponse response;
  grpc::Status status = Transform(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();

  const v1::SampledWeight& weight = response.sampled_weight();
  EXPECT_EQ(weight.kind(), v1::SampledWeight::KIND_STEP_FUNCTION);
  EXPECT_EQ(weight.tolerance(), 1e-9);
  ASSERT_EQ(weight.weights_size(), cells);
  ASSERT_EQ(weight.midpoints_size(), cells);
  for (int j = 0; j < cells; ++j) {
    const double r = weight.midpoints(j);
    if (r < 0.98 * s.c) {
      EXPECT_NEAR(weight.weights(j), 0, 1e-9) << r;
    } else if (r > 1.02 * s.c) {
      EXPECT_NEAR(weight.weights(j), 1, 1e-9) << r;
    }
  }
  ASSERT_EQ(weight.terms_size(), 1);
  EXPECT_NEAR(weight.terms(0).weight(), 1, 1e-9);
  EXPECT_NEAR(weight.terms(0).c(), s.c, 1e-6 * s.a);  // the jump is placed inside its cell
  EXPECT_NEAR(weight.terms(0).a(), s.a, 1e-12 * s.a);
  EXPECT_LT(weight.max_residual(), 1e-9);
  // Tractions of the recovered superposition.
  ASSERT_EQ(response.tractions_size(), 3);
  const double peak = kFriction * s.p0;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(response.tractions(i).value(), CattaneoMindlinTraction(radii[i], s), 1e-5 * peak);
  }
  EXPECT_LT(response.error_estimate().traction_error(), 1e-9 * peak);
  EXPECT_GE(response.memory_size(), 3);
}

TEST_F(JagerTransformTest, SampledContinuousWeightIsRecognisedAndGivesTractions) {
  // u = mu kappa (delta - z)^2 / (2 delta): F = (delta - z) / delta, continuous from 1 to 0.
  const double mu_kappa = kFriction * Kappa();
  const double a = std::sqrt(kRadius * kDepth);
  const int cells = 100;
  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  v1::SampledDisplacement* samples = request.mutable_samples();
  for (int j = 0; j <= cells; ++j) {
    const double x = a * j / cells, z = std::min(x * x / kRadius, kDepth);
    samples->add_x(x);
    samples->add_u(mu_kappa * (kDepth - z) * (kDepth - z) / (2 * kDepth));
  }
  request.add_radii(0.5 * a);
  v1::TransformResponse response;
  grpc::Status status = Transform(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const v1::SampledWeight& weight = response.sampled_weight();
  EXPECT_EQ(weight.kind(), v1::SampledWeight::KIND_CONTINUOUS);
  EXPECT_EQ(weight.terms_size(), 0);
  ASSERT_EQ(weight.weights_size(), cells);
  for (int j = 0; j < cells; ++j) {
    const double r = weight.midpoints(j);
    // The cell mean of F, linear in z: F at the cell's mean depth.
    const double z_mean =
        0.5 * (std::pow(r - 0.5 * a / cells, 2) + std::pow(r + 0.5 * a / cells, 2)) / kRadius;
    EXPECT_NEAR(weight.weights(j), (kDepth - z_mean) / kDepth, 1e-9) << r;
  }
  // The memory joins the samples: one vertex per sample.
  ASSERT_EQ(response.memory_size(), cells + 1);
  EXPECT_NEAR(response.memory(0).u(), samples->u(0), 1e-12 * samples->u(0));
  ASSERT_EQ(response.tractions_size(), 1);
  EXPECT_GT(response.tractions(0).value(), 0);
  EXPECT_LT(response.tractions(0).value(), kFriction * H1State(15, 100).p0);
}

TEST_F(JagerTransformTest, TransformRejectsInvalidInputNamingTheField) {
  v1::TransformRequest samples_request;
  *samples_request.mutable_scene() = SteelSphereOnSteelFlat();
  const double a = std::sqrt(kRadius * kDepth);
  for (int j = 0; j <= 10; ++j) {
    samples_request.mutable_samples()->add_x(a * j / 10);
    samples_request.mutable_samples()->add_u(0);
  }
  v1::TransformResponse response;
  ASSERT_TRUE(Transform(samples_request, &response).ok());  // all stick: F = 0

  v1::TransformRequest bad = samples_request;
  bad.mutable_samples()->set_x(3, bad.samples().x(2));
  ExpectInvalidArgument(Transform(bad, &response), "samples.x[3]");
  bad = samples_request;
  bad.mutable_samples()->set_u(4, std::nan(""));
  ExpectInvalidArgument(Transform(bad, &response), "samples.u[4]");
  bad = samples_request;
  bad.mutable_samples()->add_u(0);
  ExpectInvalidArgument(Transform(bad, &response), "samples.u");
  bad = samples_request;
  bad.mutable_samples()->set_tolerance(2);
  ExpectInvalidArgument(Transform(bad, &response), "samples.tolerance");
  bad = samples_request;
  bad.mutable_samples()->set_max_plateaus(0);
  ExpectInvalidArgument(Transform(bad, &response), "samples.max_plateaus");
  bad = samples_request;
  bad.add_radii(-1);
  ExpectInvalidArgument(Transform(bad, &response), "radii[0]");
  bad = samples_request;
  bad.mutable_scene()->mutable_sphere()->set_radius(-1);
  ExpectInvalidArgument(Transform(bad, &response), "scene.sphere.radius");
  bad = samples_request;
  bad.clear_samples();
  ExpectInvalidArgument(Transform(bad, &response), "input");
  bad = samples_request;
  bad.mutable_scene()->set_friction(0);
  grpc::Status status = Transform(bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), StartsWith("scene.friction: weights are undefined"));
  bad = samples_request;
  for (int j = 0; j < 10000; ++j) bad.mutable_samples()->add_x(2 * a + j);
  status = Transform(bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), StartsWith("samples.x: 10011 samples exceed the limit"));

  v1::TransformRequest terms_request;
  *terms_request.mutable_scene() = SteelSphereOnSteelFlat();
  v1::CattaneoMindlinSuperposition* superposition = terms_request.mutable_superposition();
  superposition->set_depth(kDepth);
  v1::CattaneoMindlinTerm* term = superposition->add_terms();
  term->set_weight(1);
  term->set_depth_a(kDepth);
  term->set_depth_c(0.5 * kDepth);
  ASSERT_TRUE(Transform(terms_request, &response).ok());
  ExpectRelativelyNear(response.memory(0).u(), kFriction * Kappa() * 0.5 * kDepth, 1e-14);

  bad = terms_request;
  bad.mutable_superposition()->mutable_terms(0)->set_depth_a(2 * kDepth);
  status = Transform(bad, &response);
  ExpectInvalidArgument(status, "superposition.terms[0].depth_a");
  bad = terms_request;
  bad.mutable_superposition()->mutable_terms(0)->set_weight(1.5);  // |F| > 1
  ExpectInvalidArgument(Transform(bad, &response), "superposition.terms");
  bad = terms_request;
  bad.mutable_superposition()->set_coordinates(v1::CattaneoMindlinSuperposition::COORDINATES_RADII);
  bad.mutable_superposition()->mutable_terms(0)->set_a(0.5 * a);
  bad.mutable_superposition()->mutable_terms(0)->set_c(a);
  ExpectInvalidArgument(Transform(bad, &response), "superposition.terms[0].c");
  bad = terms_request;
  bad.mutable_superposition()->set_coordinates(
      static_cast<v1::CattaneoMindlinSuperposition::Coordinates>(4));
  ExpectInvalidArgument(Transform(bad, &response), "superposition.coordinates");
  bad = terms_request;
  bad.mutable_superposition()->set_depth(INFINITY);
  ExpectInvalidArgument(Transform(bad, &response), "superposition.depth");
  bad = terms_request;
  for (int i = 0; i < 10000; ++i) *bad.mutable_superposition()->add_terms() = *term;
  status = Transform(bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), StartsWith("superposition.terms: 10001 terms exceed"));
  bad = terms_request;
  bad.set_traction_route(static_cast<v1::TractionRoute>(-1));
  ExpectInvalidArgument(Transform(bad, &response), "traction_route");
}

TEST_F(JagerTransformTest, ForcesOnlyQueryComputesNoTractions) {
  const std::string session = CreateOrDie();
  LoadH1(session);
  v1::QueryResponse response;
  ASSERT_TRUE(QueryRadial(session, {"state.normal_force", "state.tangential_force"}, {0, 1e-5},
                          v1::TRACTION_ROUTE_BOTH, &response)
                  .ok());
  EXPECT_EQ(response.tractions_size(), 0);
  EXPECT_EQ(response.pressure_size(), 0);
  EXPECT_FALSE(response.has_jager_weights());
  EXPECT_EQ(response.error_estimate().traction_error(), 0);
  for (Output output : {Output::kTractions, Output::kPressure, Output::kJagerWeights,
                        Output::kJagerDecomposition}) {
    EXPECT_EQ(counters_[output], 0u) << static_cast<int>(output);
  }
  EXPECT_EQ(counters_[Output::kNormalForce], 1u);
  EXPECT_EQ(counters_[Output::kTangentialForce], 1u);

  ASSERT_TRUE(Query(session, &response, {"tractions"}, {0}).ok());
  EXPECT_EQ(counters_[Output::kTractions], 1u);
  EXPECT_EQ(counters_[Output::kPressure], 0u);
}

}  // namespace
}  // namespace mdr::service_testing

namespace mdr::service_testing {
namespace {

// Transform works on one contact: a scene describing an interface is refused, not ignored.
TEST_F(JagerTransformTest, AnInterfaceSceneIsRefused) {
  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  request.mutable_scene()->mutable_interface()->set_kind(v1::Interface::KIND_SHARED_MOTION);
  v1::TransformResponse response;
  ExpectInvalidArgument(Transform(request, &response), "scene.interface");
}

}  // namespace
}  // namespace mdr::service_testing
