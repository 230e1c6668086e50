// The analysis RPCs (issue #24) through a real server: AnalyzeLoops, FitLoops, FrettingMap and
// Backbone answer exactly what the mdr_analysis library answers for the same input, label every
// figure by what it measures, stream a fit's progress before its result, stop a fit the client
// cancels, and refuse bad input naming the request's field, returning nothing half-done.
#include <grpcpp/client_context.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>

#include "mdr/analysis/exact_loops.h"
#include "mdr/analysis/identify.h"
#include "mdr/analysis/loops.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/core/material.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

constexpr double kRig = 2e-8;            // m/N, softer than H1's contact at 100 N
constexpr double kPartialSlip = 0.5e-6;  // m, actuator amplitudes at 100 N behind kRig
constexpr double kGrossSlip = 3e-6;

v1::Scene RigScene() {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_rig()->set_tangential_compliance(kRig);
  return scene;
}

ContactConfig CoreOf(const v1::Scene& scene) {
  Result<ContactConfig> config = bridge::ToContactConfig(scene, 1'000'000, Interrupt());
  EXPECT_TRUE(config.ok()) << config.status().ToString();
  return std::move(config).value();
}

// A rig's record of `cycles` triangle cycles of the actuator from 0 (the contact pressed there
// to `normal_force`), `per_cycle` samples each, the normal force sampled too.
analysis::LoopSet Record(double normal_force, double amplitude, int cycles = 3,
                         int per_cycle = 200) {
  Contact contact = std::move(Contact::Create(CoreOf(RigScene()))).value();
  Step press;
  press.normal = NormalControl::kForce;
  press.normal_value = normal_force;
  EXPECT_TRUE(contact.Apply(press).ok());
  analysis::LoopSet set;
  set.normal_force = normal_force;
  Step move;
  move.tangential = TangentialControl::kDisplacement;
  for (int k = 0; k <= cycles * per_cycle; ++k) {
    const double phase = static_cast<double>(k % per_cycle) / per_cycle;
    const double wave = phase < 0.25 ? 4 * phase : phase < 0.75 ? 2 - 4 * phase : 4 * phase - 4;
    move.tangential_value = amplitude * wave;
    EXPECT_TRUE(contact.Apply(move).ok());
    set.samples.displacement.push_back(move.tangential_value);
    set.samples.tangential_force.push_back(contact.tangential_force());
    set.samples.normal_force.push_back(contact.normal_force());
  }
  return set;
}

void ToProto(const analysis::LoopSamples& samples, v1::LoopSamples* out) {
  out->mutable_displacement()->Add(samples.displacement.begin(), samples.displacement.end());
  out->mutable_tangential_force()->Add(samples.tangential_force.begin(),
                                       samples.tangential_force.end());
  out->mutable_normal_force()->Add(samples.normal_force.begin(), samples.normal_force.end());
  out->mutable_time()->Add(samples.time.begin(), samples.time.end());
}

v1::AnalyzeLoopsRequest AnalyzeRequest(const analysis::LoopSet& set) {
  v1::AnalyzeLoopsRequest request;
  ToProto(set.samples, request.mutable_samples());
  request.mutable_options()->set_rig_compliance(kRig);
  return request;
}

v1::FitLoopsRequest FitRequest(const std::vector<analysis::LoopSet>& sets) {
  v1::FitLoopsRequest request;
  *request.mutable_scene() = RigScene();
  request.mutable_scene()->set_friction(0.4);  // the truth is H1's 0.3
  request.mutable_scene()->mutable_rig()->set_tangential_compliance(1e-8);
  for (const analysis::LoopSet& set : sets) {
    auto* out = request.add_sets();
    ToProto(set.samples, out->mutable_samples());
    if (set.normal_force) out->set_normal_force(*set.normal_force);
  }
  auto* friction = request.add_free();
  friction->set_parameter(v1::FIT_PARAMETER_FRICTION);
  friction->set_lower(0.05);
  friction->set_upper(2);
  auto* rig = request.add_free();
  rig->set_parameter(v1::FIT_PARAMETER_RIG_COMPLIANCE);
  rig->set_lower(0);
  rig->set_upper(1e-6);
  return request;
}

// The responses of a FitLoops stream and its status.
struct FitStream {
  std::vector<v1::FitLoopsResponse> responses;
  grpc::Status status;
};

class AnalysisServiceTest : public ServiceTest {
 protected:
  FitStream Fit(const v1::FitLoopsRequest& request, grpc::ClientContext* context) {
    FitStream out;
    auto reader = stub_->FitLoops(context, request);
    v1::FitLoopsResponse response;
    while (reader->Read(&response)) out.responses.push_back(response);
    out.status = reader->Finish();
    return out;
  }
  FitStream Fit(const v1::FitLoopsRequest& request) {
    return Fit(request, Context(std::chrono::seconds(60)).get());
  }
};

TEST_F(AnalysisServiceTest, AnalyzeLoopsAnswersTheLibrarysFiguresWithTheirLabels) {
  const analysis::LoopSet set = Record(100, kGrossSlip);
  v1::AnalyzeLoopsRequest request = AnalyzeRequest(set);
  v1::AnalyzeLoopsResponse response;
  ASSERT_TRUE(stub_->AnalyzeLoops(Context().get(), request, &response).ok());
  analysis::LoopOptions options;
  options.rig_compliance = kRig;
  const analysis::LoopAnalysis expected = *analysis::AnalyzeLoops(set.samples, options);
  ASSERT_EQ(response.cycles_size(), static_cast<int>(expected.cycles.size()));
  ASSERT_EQ(response.cycles_size(), 2);
  EXPECT_EQ(response.reversal_threshold(), expected.reversal_threshold);
  EXPECT_EQ(static_cast<std::size_t>(response.reversals_size()), expected.reversals.size());
  for (int k = 0; k < response.cycles_size(); ++k) {
    const v1::CycleFigures& got = response.cycles(k);
    const analysis::CycleMetrics& want = expected.cycles[k];
    EXPECT_EQ(got.force_amplitude(), want.force_amplitude);
    EXPECT_EQ(got.dissipated_energy(), want.dissipated_energy);
    EXPECT_EQ(got.half_opening(), want.half_opening);
    EXPECT_EQ(got.energy_ratio(), want.energy_ratio);
    ExpectRelativelyNear(got.normal_force(), 100, 1e-12);  // the cycle's mean
    EXPECT_EQ(got.contact().secant_stiffness(), want.contact->secant_stiffness);
    EXPECT_EQ(got.regime(), v1::REGIME_UNSPECIFIED);  // no scene, no regime
  }
  EXPECT_GT(response.compute_seconds(), 0);
  const auto& measures = response.measures();
  EXPECT_EQ(measures.at("dissipated_energy"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("force_amplitude"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("half_opening"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("system_free_ratio"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("energy_ratio"), v1::MEASURES_CONTACT_AND_RIG);
  EXPECT_EQ(measures.at("displacement_amplitude"), v1::MEASURES_CONTACT_AND_RIG);
  EXPECT_EQ(measures.at("contact.secant_stiffness"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("onset_system_free_ratio"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.at("friction_drift"), v1::MEASURES_CONTACT);
  EXPECT_EQ(measures.count("start_time"), 0u);
}

TEST_F(AnalysisServiceTest, TheScenesOwnOnsetClassifiesEachCycle) {
  for (const auto& [amplitude, regime] : {std::pair{kPartialSlip, v1::REGIME_PARTIAL_SLIP},
                                          std::pair{kGrossSlip, v1::REGIME_GROSS_SLIP}}) {
    v1::AnalyzeLoopsRequest request = AnalyzeRequest(Record(100, amplitude));
    *request.mutable_scene() = RigScene();
    v1::AnalyzeLoopsResponse response;
    ASSERT_TRUE(stub_->AnalyzeLoops(Context().get(), request, &response).ok());
    for (const v1::CycleFigures& cycle : response.cycles()) {
      const analysis::LoopFigures onset =
          *analysis::GrossSlipOnset(CoreOf(RigScene()), cycle.normal_force());
      EXPECT_EQ(cycle.regime(), regime) << amplitude;
      EXPECT_EQ(cycle.onset_system_free_ratio(), onset.system_free_ratio);
    }
  }
}

// Loops no sensor could tell from an elastic line F = k u: the line itself (the branches the
// same samples to the last bit), the line with the way back 2 ulps to the right (a positive area;
// an opening of ~1e-37 m, far below what the numbers resolve), and a loop 1 nm wide that runs the
// wrong way round (Ed < 0: noise, not dissipation). All stick. Before the round-off floor of the
// resolution (CycleMetrics::half_opening_round_off) and the Ed > 0 rule, the second was gross slip
// (C ~ 1e15) and the third partial slip (C < 0). The first two have no resolved opening, so C and
// mu_e, ratios over it, are not identified (NaN, not 1e15 or inf); the third's opening is resolved
// and its C is the (negative) formula's value.
TEST_F(AnalysisServiceTest, LoopsWithoutResolvedDissipationStick) {
  constexpr double kAmplitude = 1e-6, kStiffness = 2e7;
  enum Shape { kLine, kRoundOffWide, kBackwards };
  for (const Shape shape : {kLine, kRoundOffWide, kBackwards}) {
    v1::AnalyzeLoopsRequest request;
    *request.mutable_scene() = RigScene();
    request.mutable_options()->set_normal_force(100);
    v1::LoopSamples& samples = *request.mutable_samples();
    for (int k = 0; k <= 600; ++k) {
      const double phase = 2 * std::numbers::pi * (k * 1e-3) * 5;
      const double u = kAmplitude * std::sin(phase);
      double measured = u;
      if (std::cos(phase) < 0) {  // the way back
        if (shape == kRoundOffWide) measured = std::nextafter(std::nextafter(u, 1.0), 1.0);
        if (shape == kBackwards) measured = u - 1e-9;
      }
      samples.add_displacement(measured);
      samples.add_tangential_force(kStiffness * u);
    }
    v1::AnalyzeLoopsResponse response;
    ASSERT_TRUE(stub_->AnalyzeLoops(Context().get(), request, &response).ok());
    ASSERT_GE(response.cycles_size(), 2);
    for (const v1::CycleFigures& cycle : response.cycles()) {
      EXPECT_EQ(cycle.regime(), v1::REGIME_STICKING)
          << "shape " << shape << ": delta_0 " << cycle.half_opening() << ", Ed "
          << cycle.dissipated_energy() << ", C " << cycle.system_free_ratio();
      EXPECT_EQ(std::isnan(cycle.system_free_ratio()), shape != kBackwards)
          << "shape " << shape << ": C " << cycle.system_free_ratio();
      EXPECT_EQ(std::isnan(cycle.energy_friction_coefficient()), shape != kBackwards)
          << "shape " << shape << ": mu_e " << cycle.energy_friction_coefficient();
    }
  }
}

TEST_F(AnalysisServiceTest, AnalyzeLoopsRefusesBadSamplesNamingThem) {
  const v1::AnalyzeLoopsRequest good = AnalyzeRequest(Record(100, kGrossSlip));
  v1::AnalyzeLoopsResponse response;
  auto expect_refused = [&](const v1::AnalyzeLoopsRequest& request, const std::string& field) {
    response.Clear();
    ExpectInvalidArgument(stub_->AnalyzeLoops(Context().get(), request, &response), field);
    EXPECT_EQ(response.cycles_size(), 0);
  };
  v1::AnalyzeLoopsRequest bad = good;
  bad.mutable_samples()->set_displacement(12, std::numeric_limits<double>::quiet_NaN());
  expect_refused(bad, "samples.displacement[12]");
  bad = good;
  bad.mutable_samples()->set_tangential_force(7, std::numeric_limits<double>::infinity());
  expect_refused(bad, "samples.tangential_force[7]");
  bad = good;
  bad.mutable_samples()->mutable_tangential_force()->RemoveLast();
  expect_refused(bad, "samples.tangential_force");
  bad = good;
  bad.mutable_samples()->mutable_normal_force()->RemoveLast();
  expect_refused(bad, "samples.normal_force");  // a column's length, not the option
  bad = good;
  bad.mutable_samples()->set_normal_force(3, -1);
  expect_refused(bad, "samples.normal_force[3]");
  bad = good;
  for (int i = 0; i < bad.samples().displacement_size(); ++i) bad.mutable_samples()->add_time(i);
  bad.mutable_samples()->set_time(5, 4);
  expect_refused(bad, "samples.time[5]");
  bad = good;
  bad.mutable_options()->set_normal_force(-100);
  expect_refused(bad, "options.normal_force");
  bad = good;
  bad.mutable_options()->set_reversal_threshold(-1e-9);
  expect_refused(bad, "options.reversal_threshold");
  bad = good;
  bad.mutable_options()->set_displacement_resolution(std::nan(""));
  expect_refused(bad, "options.displacement_resolution");
  bad = good;
  *bad.mutable_scene() = RigScene();
  bad.mutable_scene()->mutable_interface()->set_kind(v1::Interface::KIND_CONTACT_LIST);
  expect_refused(bad, "scene.interface");
  bad = good;
  *bad.mutable_scene() = RigScene();
  bad.mutable_scene()->set_friction(-0.1);
  expect_refused(bad, "scene.friction");

  // Fewer samples than one cycle.
  bad = good;
  for (auto* column : {bad.mutable_samples()->mutable_displacement(),
                       bad.mutable_samples()->mutable_tangential_force(),
                       bad.mutable_samples()->mutable_normal_force()}) {
    column->Truncate(150);
  }
  grpc::Status status = stub_->AnalyzeLoops(Context().get(), bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::StartsWith("samples.displacement: "));
  EXPECT_EQ(response.cycles_size(), 0);

  // A scene classifies at the cycle's normal force, which must be known.
  bad = good;
  bad.mutable_samples()->clear_normal_force();
  *bad.mutable_scene() = RigScene();
  status = stub_->AnalyzeLoops(Context().get(), bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::StartsWith("options.normal_force: "));
  EXPECT_EQ(response.cycles_size(), 0);
}

TEST_F(AnalysisServiceTest, FitLoopsStreamsProgressThenTheLibrarysResult) {
  const std::vector<analysis::LoopSet> sets = {Record(60, 2e-6), Record(150, 2e-6)};
  const FitStream stream = Fit(FitRequest(sets));
  ASSERT_TRUE(stream.status.ok()) << stream.status.error_message();
  ASSERT_GE(stream.responses.size(), 2u);
  for (std::size_t k = 0; k + 1 < stream.responses.size(); ++k) {
    ASSERT_TRUE(stream.responses[k].has_progress()) << k;
    EXPECT_EQ(stream.responses[k].progress().values_size(), 2);
    if (k > 0) {
      EXPECT_GT(stream.responses[k].progress().iteration(),
                stream.responses[k - 1].progress().iteration());
    }
  }
  ASSERT_TRUE(stream.responses.back().has_result());
  const v1::FitResult& result = stream.responses.back().result();

  analysis::FitOptions options;
  options.free = {{analysis::Parameter::kFriction, std::nullopt, 0.05, 2},
                  {analysis::Parameter::kRigCompliance, std::nullopt, 0, 1e-6}};
  const analysis::FitResult expected =
      *analysis::FitLoops(CoreOf(FitRequest(sets).scene()), sets, options);
  ASSERT_EQ(result.estimates_size(), 2);
  EXPECT_EQ(result.estimates(0).parameter(), v1::FIT_PARAMETER_FRICTION);
  EXPECT_EQ(result.estimates(1).parameter(), v1::FIT_PARAMETER_RIG_COMPLIANCE);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(result.estimates(k).value(), expected.estimates[k].value);
    EXPECT_EQ(result.estimates(k).standard_error(), expected.estimates[k].standard_error);
    EXPECT_EQ(result.estimates(k).identified(), expected.estimates[k].identified);
  }
  ExpectRelativelyNear(result.estimates(0).value(), 0.3, 1e-6);
  ExpectRelativelyNear(result.estimates(1).value(), kRig, 1e-6);
  EXPECT_EQ(result.correlation_size(), 4);
  EXPECT_EQ(result.iterations(), expected.iterations);
  EXPECT_TRUE(result.identified()) << (result.notes().empty() ? "" : result.notes(0));
  EXPECT_LT(std::abs(result.correlation(1)), 0.99);  // defined although the fit is exact
  EXPECT_EQ(result.fitted_scene().friction(), result.estimates(0).value());
  EXPECT_EQ(result.fitted_scene().rig().tangential_compliance(), result.estimates(1).value());
  ASSERT_TRUE(result.has_guessed_rig_compliance());         // two loads of a sphere
  EXPECT_FALSE(result.has_guessed_rig_compliance_error());  // no residual to estimate it
  EXPECT_GT(result.compute_seconds(), 0);
}

TEST_F(AnalysisServiceTest, FitLoopsRefusesBadRequestsNamingTheField) {
  const v1::FitLoopsRequest good = FitRequest({Record(60, 2e-6), Record(150, 2e-6)});
  auto expect_refused = [&](const v1::FitLoopsRequest& request, const std::string& field) {
    const FitStream stream = Fit(request);
    ExpectInvalidArgument(stream.status, field);
    EXPECT_TRUE(stream.responses.empty());
  };
  v1::FitLoopsRequest bad = good;
  bad.mutable_sets(1)->mutable_samples()->set_tangential_force(
      3, std::numeric_limits<double>::quiet_NaN());
  expect_refused(bad, "sets[1].samples.tangential_force[3]");
  bad = good;
  bad.mutable_sets(0)->mutable_samples()->mutable_displacement()->RemoveLast();
  expect_refused(bad, "sets[0].samples.tangential_force");
  bad = good;
  bad.mutable_sets(0)->set_normal_force(-5);
  expect_refused(bad, "sets[0].normal_force");
  bad = good;
  bad.clear_sets();
  expect_refused(bad, "sets");
  bad = good;
  bad.mutable_free(1)->set_upper(5e-9);  // the initial 1e-8 lies outside
  expect_refused(bad, "free[1].initial");
  bad = good;
  bad.mutable_free(0)->set_parameter(v1::FIT_PARAMETER_UNSPECIFIED);
  expect_refused(bad, "free[0].parameter");
  bad = good;
  bad.mutable_free(1)->set_parameter(v1::FIT_PARAMETER_FRICTION);
  expect_refused(bad, "free[1].parameter");  // twice
  bad = good;
  bad.mutable_free(0)->set_parameter(v1::FIT_PARAMETER_PROFILE_SCALE);
  bad.mutable_scene()->mutable_flat_punch()->set_radius(1e-3);  // no scale to fit
  expect_refused(bad, "free[0].parameter");
  bad = good;
  bad.set_reversal_threshold(-1);
  expect_refused(bad, "reversal_threshold");
  bad = good;
  bad.set_max_iterations(1001);
  expect_refused(bad, "max_iterations");
  bad = good;
  bad.mutable_scene()->mutable_sphere()->set_radius(-1);
  expect_refused(bad, "scene.sphere.radius");
}

TEST_F(AnalysisServiceTest, ACancelledFitStopsAndTheServerGoesOn) {
  v1::FitLoopsRequest request = FitRequest({Record(60, 2e-6, 20), Record(150, 2e-6, 20)});
  request.set_max_iterations(1000);
  grpc::ClientContext context;
  auto reader = stub_->FitLoops(&context, request);
  v1::FitLoopsResponse response;
  ASSERT_TRUE(reader->Read(&response));  // the fit runs
  EXPECT_TRUE(response.has_progress());
  context.TryCancel();
  while (reader->Read(&response)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // The worker is free again: a cheap call is answered.
  v1::AnalyzeLoopsResponse answer;
  EXPECT_TRUE(
      stub_->AnalyzeLoops(Context().get(), AnalyzeRequest(Record(100, kGrossSlip)), &answer).ok());
}

TEST_F(AnalysisServiceTest, AFitPastItsDeadlineEndsWithDeadlineExceeded) {
  const v1::FitLoopsRequest request = FitRequest({Record(60, 2e-6, 20), Record(150, 2e-6, 20)});
  const FitStream stream = Fit(request, Context(std::chrono::milliseconds(20)).get());
  EXPECT_EQ(stream.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  for (const v1::FitLoopsResponse& response : stream.responses) {
    EXPECT_FALSE(response.has_result());
  }
}

// A call whose client sets no deadline stops at the server's bound (--max-call-seconds) and
// returns nothing half-done (issue #27: a legal call could hold a worker for a third of an hour).
TEST_F(AnalysisServiceTest, AFitWithoutADeadlineStopsAtTheServersBound) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_call_duration = std::chrono::milliseconds(20);
  Restart(options);
  const v1::FitLoopsRequest request = FitRequest({Record(60, 2e-6, 20), Record(150, 2e-6, 20)});
  grpc::ClientContext no_deadline;
  const FitStream stream = Fit(request, &no_deadline);
  EXPECT_EQ(stream.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  for (const v1::FitLoopsResponse& response : stream.responses) {
    EXPECT_FALSE(response.has_result());
  }
  // A cheap call is answered as usual.
  v1::BackboneRequest cheap;
  *cheap.mutable_scene() = RigScene();
  cheap.set_normal_force(100);
  cheap.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_FORCE);
  cheap.add_amplitudes(10);
  v1::BackboneResponse answer;
  grpc::ClientContext also_no_deadline;
  EXPECT_TRUE(stub_->Backbone(&also_no_deadline, cheap, &answer).ok());
}

TEST_F(AnalysisServiceTest, FrettingMapAnswersTheLibrarysMap) {
  v1::FrettingMapRequest request;
  *request.mutable_scene() = RigScene();
  for (double force : {50.0, 100.0, 200.0}) request.add_normal_forces(force);
  for (double relative : {0.5, 0.9, 1.1, 2.0}) request.add_relative_amplitudes(relative);
  v1::FrettingMapResponse response;
  ASSERT_TRUE(stub_->FrettingMap(Context().get(), request, &response).ok());
  const auto expected =
      *analysis::FrettingMap(CoreOf(RigScene()), {50, 100, 200}, {0.5, 0.9, 1.1, 2.0});
  ASSERT_EQ(response.loads_size(), 3);
  for (int i = 0; i < 3; ++i) {
    const auto& load = response.loads(i);
    EXPECT_EQ(load.onset().normal_force(), expected[i].onset.normal_force);
    EXPECT_EQ(load.onset().actuator_amplitude(), expected[i].onset.actuator_amplitude);
    ASSERT_EQ(load.loops_size(), 4);
    ASSERT_EQ(load.regimes_size(), 4);
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(load.loops(k).dissipated_energy(), expected[i].loops[k].dissipated_energy);
    }
    EXPECT_EQ(load.regimes(1), v1::REGIME_PARTIAL_SLIP);
    EXPECT_EQ(load.regimes(2), v1::REGIME_GROSS_SLIP);
  }
  EXPECT_GT(response.compute_seconds(), 0);

  v1::FrettingMapRequest bad = request;
  bad.set_relative_amplitudes(2, 0);
  ExpectInvalidArgument(stub_->FrettingMap(Context().get(), bad, &response),
                        "relative_amplitudes[2]");
  bad = request;
  bad.set_normal_forces(1, -3);
  ExpectInvalidArgument(stub_->FrettingMap(Context().get(), bad, &response), "normal_forces[1]");
  bad = request;
  bad.clear_normal_forces();
  ExpectInvalidArgument(stub_->FrettingMap(Context().get(), bad, &response), "normal_forces");
  bad = request;
  for (int k = 0; k < 200; ++k) bad.add_relative_amplitudes(1);
  EXPECT_EQ(stub_->FrettingMap(Context().get(), bad, &response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  bad = request;
  bad.mutable_scene()->set_friction(0);
  const grpc::Status status = stub_->FrettingMap(Context().get(), bad, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::StartsWith("scene.friction: "));
}

TEST_F(AnalysisServiceTest, BackboneAnswersTheLibrarysLoops) {
  v1::BackboneRequest request;
  *request.mutable_scene() = RigScene();
  request.set_normal_force(100);
  request.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_FORCE);
  for (double q : {3.0, 15.0, 29.0}) request.add_amplitudes(q);
  v1::BackboneResponse response;
  ASSERT_TRUE(stub_->Backbone(Context().get(), request, &response).ok());
  const auto expected =
      *analysis::Backbone(CoreOf(RigScene()), 100, analysis::AmplitudeKind::kForce, {3, 15, 29});
  ASSERT_EQ(response.loops_size(), 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(response.loops(k).secant_stiffness(), expected[k].secant_stiffness);
    EXPECT_EQ(response.loops(k).damping_ratio(), expected[k].damping_ratio);
    EXPECT_EQ(response.loops(k).force_amplitude(), expected[k].force_amplitude);
  }
  // The secant stiffness falls and the damping ratio grows with the amplitude in partial slip.
  EXPECT_GT(response.loops(0).secant_stiffness(), response.loops(2).secant_stiffness());
  EXPECT_LT(response.loops(0).damping_ratio(), response.loops(2).damping_ratio());

  v1::BackboneRequest bad = request;
  bad.set_amplitudes(1, 31);  // above mu F_N = 30 N
  response.Clear();
  ExpectInvalidArgument(stub_->Backbone(Context().get(), bad, &response), "amplitudes[1]");
  EXPECT_EQ(response.loops_size(), 0);
  bad = request;
  bad.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_UNSPECIFIED);
  ExpectInvalidArgument(stub_->Backbone(Context().get(), bad, &response), "kind");
  bad = request;
  bad.set_normal_force(std::nan(""));
  ExpectInvalidArgument(stub_->Backbone(Context().get(), bad, &response), "normal_force");
  bad = request;
  bad.clear_amplitudes();
  ExpectInvalidArgument(stub_->Backbone(Context().get(), bad, &response), "amplitudes");
}

// ---- Torsional records (issue #49) --------------------------------------------------------------

v1::Scene TorsionalScene(double compliance = 0) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_torsion()->set_rig_compliance(compliance);
  return scene;
}

// A torsional record of the core's own steady loop through the shaft's compliance: twist
// triangles from 0, `per_cycle` samples a cycle.
v1::LoopSamples TorsionalRecord(double normal_force, double amplitude, double compliance,
                                int cycles = 3, int per_cycle = 200) {
  analysis::TorsionalScene scene = *bridge::ToTorsionalScene(
      TorsionalScene(compliance), CoreOf(TorsionalScene(compliance)));
  TorsionalContact contact = *analysis::PressTorsionalContact(scene, normal_force);
  v1::LoopSamples samples;
  for (int k = 0; k <= cycles * per_cycle; ++k) {
    const double phase = static_cast<double>(k % per_cycle) / per_cycle;
    const double wave = phase < 0.25 ? 4 * phase : phase < 0.75 ? 2 - 4 * phase : 4 * phase - 4;
    EXPECT_TRUE(contact.TwistThroughCompliance(amplitude * wave, compliance).ok());
    samples.add_twist(amplitude * wave);
    samples.add_twisting_moment(contact.memory().Moment());
  }
  return samples;
}

TEST_F(AnalysisServiceTest, TorsionalRecordsAreAnalysedAndClassifiedAgainstTheFullSlipMoment) {
  v1::AnalyzeLoopsRequest request;
  *request.mutable_samples() = TorsionalRecord(100, 6e-3, 0.5);
  request.mutable_options()->set_rig_compliance(0.5);
  request.mutable_options()->set_normal_force(100);
  *request.mutable_scene() = TorsionalScene();
  v1::AnalyzeLoopsResponse response;
  ASSERT_TRUE(stub_->AnalyzeLoops(Context().get(), request, &response).ok());
  ASSERT_EQ(response.cycles_size(), 2);
  const v1::CycleFigures& cycle = response.cycles(1);
  // The library's own figures of the same record, and the scene's full-slip moment.
  analysis::LoopSamples samples;
  samples.channel = analysis::LoopChannel::kTorsional;
  samples.displacement.assign(request.samples().twist().begin(), request.samples().twist().end());
  samples.tangential_force.assign(request.samples().twisting_moment().begin(),
                                  request.samples().twisting_moment().end());
  analysis::LoopOptions options;
  options.rig_compliance = 0.5;
  options.normal_force = 100;
  const analysis::LoopAnalysis expected = *analysis::AnalyzeLoops(samples, options);
  EXPECT_EQ(cycle.force_amplitude(), expected.cycles[1].force_amplitude);
  EXPECT_EQ(cycle.dissipated_energy(), expected.cycles[1].dissipated_energy);
  EXPECT_EQ(cycle.contact().displacement_amplitude(),
            expected.cycles[1].contact->displacement_amplitude);
  EXPECT_TRUE(std::isnan(cycle.friction_coefficient()));
  EXPECT_EQ(cycle.regime(), v1::REGIME_PARTIAL_SLIP);
  const double slip = *analysis::FullSlipMoment(
      *bridge::ToTorsionalScene(TorsionalScene(), CoreOf(TorsionalScene())), 100);
  EXPECT_EQ(cycle.full_slip_moment(), slip);
  EXPECT_LT(cycle.force_amplitude(), slip);

  // A record is one pair or the other; the scene must match the record; the columns are named.
  v1::AnalyzeLoopsRequest bad = request;
  bad.mutable_samples()->add_displacement(0);
  ExpectInvalidArgument(stub_->AnalyzeLoops(Context().get(), bad, &response), "samples.twist");
  bad = request;
  bad.mutable_scene()->clear_torsion();
  ExpectInvalidArgument(stub_->AnalyzeLoops(Context().get(), bad, &response), "scene.torsion");
  bad = request;
  bad.mutable_samples()->set_twist(7, 101);
  ExpectInvalidArgument(stub_->AnalyzeLoops(Context().get(), bad, &response), "samples.twist[7]");
  bad = request;
  bad.mutable_samples()->mutable_twisting_moment()->RemoveLast();
  ExpectInvalidArgument(stub_->AnalyzeLoops(Context().get(), bad, &response),
                        "samples.twisting_moment");
}

TEST_F(AnalysisServiceTest, TorsionalFitsGiveMuGtAndTheShaftBack) {
  v1::FitLoopsRequest request;
  *request.mutable_scene() = TorsionalScene(0.3);
  request.mutable_scene()->set_friction(0.4);
  request.mutable_scene()->mutable_torsion()->set_torsional_modulus(3e10);
  for (double load : {30.0, 100.0, 300.0}) {
    auto* set = request.add_sets();
    *set->mutable_samples() = TorsionalRecord(load, 6e-3, 0.5, 2, 120);
    set->set_normal_force(load);
  }
  const std::pair<v1::FitParameter, std::pair<double, double>> free[] = {
      {v1::FIT_PARAMETER_FRICTION, {0.05, 2}},
      {v1::FIT_PARAMETER_TORSIONAL_MODULUS, {1e9, 1e12}},
      {v1::FIT_PARAMETER_RIG_COMPLIANCE, {0, 10}}};
  for (const auto& [parameter, bounds] : free) {
    auto* f = request.add_free();
    f->set_parameter(parameter);
    f->set_lower(bounds.first);
    f->set_upper(bounds.second);
  }
  const FitStream fit = Fit(request);
  ASSERT_TRUE(fit.status.ok()) << fit.status.error_message();
  const v1::FitResult& result = fit.responses.back().result();
  const double g_t = *TorsionalModulusOfPair(210e9, 0.3, 210e9, 0.3);
  ExpectRelativelyNear(result.estimates(0).value(), 0.3, 1e-8);
  ExpectRelativelyNear(result.estimates(1).value(), g_t, 1e-8);
  ExpectRelativelyNear(result.estimates(2).value(), 0.5, 1e-8);
  EXPECT_TRUE(result.identified());
  // The fitted scene carries G_t and the shaft in scene.torsion.
  EXPECT_EQ(result.fitted_scene().torsion().torsional_modulus(), result.estimates(1).value());
  EXPECT_EQ(result.fitted_scene().torsion().rig_compliance(), result.estimates(2).value());
  EXPECT_FALSE(result.has_guessed_rig_compliance());

  // A tangential record in a torsional fit is named.
  v1::FitLoopsRequest bad = request;
  bad.mutable_sets(1)->clear_samples();
  bad.mutable_sets(1)->mutable_samples()->add_displacement(0);
  bad.mutable_sets(1)->mutable_samples()->add_tangential_force(0);
  const FitStream refused = Fit(bad);
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused.status.error_message().find("sets[1].samples"), std::string::npos)
      << refused.status.error_message();
}

TEST_F(AnalysisServiceTest, TheTorsionalBackboneThroughTheShaft) {
  v1::BackboneRequest request;
  *request.mutable_scene() = TorsionalScene(0.5);
  request.set_normal_force(100);
  request.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT);
  for (double phi : {1e-4, 2e-3, 6e-3}) request.add_amplitudes(phi);
  v1::BackboneResponse response;
  ASSERT_TRUE(stub_->Backbone(Context().get(), request, &response).ok());
  const auto expected = *analysis::TorsionalBackbone(
      *bridge::ToTorsionalScene(TorsionalScene(0.5), CoreOf(TorsionalScene(0.5))), 100,
      analysis::AmplitudeKind::kActuatorDisplacement, {1e-4, 2e-3, 6e-3});
  ASSERT_EQ(response.loops_size(), 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(response.loops(k).secant_stiffness(), expected[k].secant_stiffness);
    EXPECT_EQ(response.loops(k).damping_ratio(), expected[k].damping_ratio);
  }
  // The moment amplitude must stay below the full-slip moment; no map of a torsional scene.
  v1::BackboneRequest beyond = request;
  beyond.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_FORCE);
  beyond.set_amplitudes(2, 1);  // N m, far above 3 pi mu F_N a / 16 = 3.3e-3 N m
  ExpectInvalidArgument(stub_->Backbone(Context().get(), beyond, &response), "amplitudes[2]");
  v1::FrettingMapRequest map;
  *map.mutable_scene() = TorsionalScene();
  map.add_normal_forces(100);
  map.add_relative_amplitudes(0.5);
  v1::FrettingMapResponse map_response;
  ExpectInvalidArgument(stub_->FrettingMap(Context().get(), map, &map_response), "scene.torsion");
  // Sessions refuse the shaft they do not model.
  v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = TorsionalScene(0.5);
  v1::Session session;
  ExpectInvalidArgument(stub_->CreateSession(Context().get(), create, &session),
                        "session.scene.torsion.rig_compliance");
}

}  // namespace
}  // namespace mdr::service_testing
