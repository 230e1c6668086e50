// The typed client over an in-process channel (mdrctl's embedded mode).
#include "mdr/client/contact_client.h"

#include <gmock/gmock.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>

#include "fixtures/reference_scenes.h"
#include "mdr/client/error_details.h"
#include "mdr/service/server.h"

namespace {

using ::testing::HasSubstr;
using ::testing::Not;

class ContactClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto server = mdr::service::ContactServer::Start({});
    ASSERT_TRUE(server.ok()) << server.status().ToString();
    server_ = std::move(server).value();
    client_ = std::make_unique<mdr::client::ContactClient>(server_->InProcessChannel());
  }

  std::unique_ptr<mdr::service::ContactServer> server_;
  std::unique_ptr<mdr::client::ContactClient> client_;
};

using C1 = mdr::reference::C1;
using H1 = mdr::reference::H1;

mdr::v1::Scene RigidConeOnPolymer() { return mdr::reference::C1Scene<mdr::v1::Scene>(); }

TEST(ContactClientStandaloneTest, UnreachableServerIsUnavailableAfterDeadline) {
  mdr::client::ContactClient client(
      grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials()),
      std::chrono::milliseconds(200));
  auto session = client.CreateSession(RigidConeOnPolymer());
  ASSERT_FALSE(session.ok());
  EXPECT_THAT(session.status().error_code(),
              ::testing::AnyOf(grpc::StatusCode::UNAVAILABLE, grpc::StatusCode::DEADLINE_EXCEEDED));
}

TEST_F(ContactClientTest, RoundTripCreateApplyQueryDelete) {
  auto session = client_->CreateSession(RigidConeOnPolymer(), "cone");
  ASSERT_TRUE(session.ok()) << session.status().error_message();
  EXPECT_EQ(session->name(), "sessions/cone");

  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(C1::kNormalForce);
  steps.Add()->set_tangential_force(0.25);
  google::protobuf::FieldMask every_state;
  every_state.add_paths("state");
  auto applied = client_->Apply(session->name(), steps, every_state);
  ASSERT_TRUE(applied.ok()) << applied.status().error_message();
  EXPECT_EQ(applied->step_results_size(), 2);
  // C1 (docs/reference-values.md): F_N = 1 N gives d = 9.0008237835e-6 m, a = 3.2497025499e-5 m.
  EXPECT_NEAR(applied->state().depth(), C1::kDepth, 1e-9 * C1::kDepth);
  EXPECT_NEAR(applied->state().contact_radius(), C1::kContactRadius, 1e-9 * C1::kContactRadius);
  EXPECT_NEAR(applied->state().tangential_force(), 0.25, 1e-10);

  auto queried = client_->Query(session->name());
  ASSERT_TRUE(queried.ok());
  EXPECT_EQ(queried->state().normal_force(), applied->state().normal_force());

  auto fetched = client_->GetSession(session->name());
  ASSERT_TRUE(fetched.ok());
  EXPECT_EQ(fetched->state().applied_steps(), 2u);

  EXPECT_TRUE(client_->DeleteSession(session->name()).ok());
  auto gone = client_->Query(session->name());
  ASSERT_FALSE(gone.ok());
  EXPECT_EQ(gone.status().error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(gone.status().error_message(), HasSubstr("sessions/cone"));
}

TEST_F(ContactClientTest, ListExportImportAndQueryOutputs) {
  auto session = client_->CreateSession(RigidConeOnPolymer(), "cone");
  ASSERT_TRUE(session.ok());
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(1);
  steps.Add()->set_displacement_increment(1e-6);
  ASSERT_TRUE(client_->Apply(session->name(), steps, {}, "first").ok());

  auto snapshot = client_->ExportSession(session->name());
  ASSERT_TRUE(snapshot.ok());
  auto imported = client_->ImportSession(*snapshot, "cone-copy");
  ASSERT_TRUE(imported.ok()) << imported.status().error_message();
  auto page = client_->ListSessions(1);
  ASSERT_TRUE(page.ok());
  ASSERT_EQ(page->sessions_size(), 1);
  EXPECT_EQ(page->sessions(0).name(), "sessions/cone");
  page = client_->ListSessions(1, page->next_page_token());
  ASSERT_TRUE(page.ok());
  ASSERT_EQ(page->sessions_size(), 1);
  EXPECT_EQ(page->sessions(0).name(), "sessions/cone-copy");
  EXPECT_EQ(page->sessions(0).state().tangential_force(), imported->state().tangential_force());

  google::protobuf::FieldMask springs;
  springs.add_paths("springs.normal_displacement");
  auto queried = client_->Query("sessions/cone-copy", springs, {0.0});
  ASSERT_TRUE(queried.ok()) << queried.status().error_message();
  ASSERT_EQ(queried->springs().normal_displacement_size(), 1);
  EXPECT_EQ(queried->springs().normal_displacement(0), imported->state().depth());  // w(0) = d
}

TEST_F(ContactClientTest, ErrorsCarryCodeAndFieldMessage) {
  mdr::v1::Scene scene = RigidConeOnPolymer();
  scene.mutable_cone()->set_slope_angle(2);
  auto session = client_->CreateSession(scene);
  ASSERT_FALSE(session.ok());
  EXPECT_EQ(session.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(session.status().error_message(), HasSubstr("session.scene.cone.slope_angle: "));
  const mdr::client::ErrorDetails details = mdr::client::ReadErrorDetails(session.status());
  EXPECT_EQ(details.field, "session.scene.cone.slope_angle");
  EXPECT_THAT(details.description, Not(HasSubstr("slope_angle: ")));
}

// Every code carries its field in the details (ErrorInfo), not only INVALID_ARGUMENT.
TEST_F(ContactClientTest, ErrorDetailsNameTheFieldForEveryCode) {
  auto session = client_->CreateSession(RigidConeOnPolymer());
  ASSERT_TRUE(session.ok());
  mdr::v1::Step load;
  load.set_normal_force(1);
  ASSERT_TRUE(client_->Apply(session->name(), load).ok());
  mdr::v1::Step too_far;
  too_far.set_tangential_force(10);  // above mu F_N = 0.5 N
  auto applied = client_->Apply(session->name(), too_far);
  ASSERT_EQ(applied.status().error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  mdr::client::ErrorDetails details = mdr::client::ReadErrorDetails(applied.status());
  EXPECT_EQ(details.field, "steps[0].tangential_force");
  EXPECT_THAT(details.description, HasSubstr("friction limit"));

  auto missing = client_->GetSession("sessions/none-such");
  ASSERT_EQ(missing.status().error_code(), grpc::StatusCode::NOT_FOUND);
  details = mdr::client::ReadErrorDetails(missing.status());
  EXPECT_EQ(details.field, "name");
  EXPECT_FALSE(details.description.empty());
}

// H1 behind a rig of 2e-8 m/N (examples/fretting_rig.yaml).
mdr::v1::Scene H1WithRig() {
  mdr::v1::Scene scene = mdr::reference::H1Scene<mdr::v1::Scene>();
  scene.mutable_rig()->set_tangential_compliance(2e-8);
  return scene;
}

// What a rig records: pressed to P with the actuator at 0, then u = U sin(2 pi k / n) for
// `cycles` cycles of n samples; the actuator's displacement and F_x after each step.
mdr::v1::LoopSamples SineRun(mdr::client::ContactClient& client, const mdr::v1::Scene& scene,
                             double normal_force, double amplitude, int cycles, int n) {
  auto session = client.CreateSession(scene);
  EXPECT_TRUE(session.ok()) << session.status().error_message();
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(normal_force);
  for (int k = 1; k <= cycles * n; ++k) {
    steps.Add()->set_displacement(amplitude * std::sin(2 * std::numbers::pi * (k % n) / n));
  }
  google::protobuf::FieldMask mask;
  mask.add_paths("state");
  auto applied = client.Apply(session->name(), steps, mask);
  EXPECT_TRUE(applied.ok()) << applied.status().error_message();
  mdr::v1::LoopSamples samples;
  for (const auto& result : applied->step_results()) {
    samples.add_displacement(result.state().actuator_displacement());
    samples.add_tangential_force(result.state().tangential_force());
  }
  return samples;
}

TEST_F(ContactClientTest, AnalyzeLoopsLabelsTheFiguresAndClassifiesTheCycles) {
  mdr::v1::AnalyzeLoopsRequest request;
  // Gross slip: the onset lies at mu kappa delta + C_t mu P = 1.87e-6 m of the actuator.
  *request.mutable_samples() = SineRun(*client_, H1WithRig(), H1::kNormalForce, 3e-6, 3, 200);
  request.mutable_options()->set_normal_force(H1::kNormalForce);
  request.mutable_options()->set_rig_compliance(2e-8);
  *request.mutable_scene() = H1WithRig();
  auto analysis = client_->AnalyzeLoops(request);
  ASSERT_TRUE(analysis.ok()) << analysis.status().error_message();
  ASSERT_EQ(analysis->cycles_size(), 2);
  for (const auto& cycle : analysis->cycles()) {
    EXPECT_NEAR(cycle.force_amplitude(), H1::kFriction * H1::kNormalForce, 1e-9);
    EXPECT_NEAR(cycle.friction_coefficient(), H1::kFriction, 1e-11);
    EXPECT_NEAR(cycle.displacement_amplitude(), 3e-6, 1e-15);
    EXPECT_NEAR(cycle.contact().displacement_amplitude(), 3e-6 - 2e-8 * 30, 1e-15);
    EXPECT_EQ(cycle.regime(), mdr::v1::REGIME_GROSS_SLIP);
  }
  EXPECT_EQ(analysis->measures().at("dissipated_energy"), mdr::v1::MEASURES_CONTACT);
  EXPECT_EQ(analysis->measures().at("energy_ratio"), mdr::v1::MEASURES_CONTACT_AND_RIG);
  EXPECT_EQ(analysis->measures().at("contact.energy_ratio"), mdr::v1::MEASURES_CONTACT);
}

TEST_F(ContactClientTest, AnalyzeLoopsNamesTheBadSample) {
  mdr::v1::AnalyzeLoopsRequest request;
  for (double u : {0.0, 1e-6, 2e-6, std::nan(""), 1e-6}) {
    request.mutable_samples()->add_displacement(u);
    request.mutable_samples()->add_tangential_force(0);
  }
  auto analysis = client_->AnalyzeLoops(request);
  ASSERT_EQ(analysis.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(mdr::client::ReadErrorDetails(analysis.status()).field, "samples.displacement[3]");
}

TEST_F(ContactClientTest, FitLoopsStreamsProgressAndRecoversTheScene) {
  mdr::v1::FitLoopsRequest request;
  mdr::v1::Scene start = H1WithRig();
  start.set_friction(0.2);
  start.mutable_rig()->set_tangential_compliance(3e-8);
  *request.mutable_scene() = start;
  for (double load : {50.0, 200.0}) {
    for (double amplitude : {1e-6, 4e-6}) {
      auto* set = request.add_sets();
      set->set_normal_force(load);
      *set->mutable_samples() = SineRun(*client_, H1WithRig(), load, amplitude, 3, 60);
    }
  }
  auto* friction = request.add_free();
  friction->set_parameter(mdr::v1::FIT_PARAMETER_FRICTION);
  friction->set_lower(0.05);
  friction->set_upper(1);
  auto* rig = request.add_free();
  rig->set_parameter(mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE);
  rig->set_lower(1e-10);
  rig->set_upper(1e-6);
  std::vector<int> iterations;
  auto fit = client_->FitLoops(
      request, [&](const mdr::v1::FitProgress& p) { iterations.push_back(p.iteration()); });
  ASSERT_TRUE(fit.ok()) << fit.status().error_message();
  ASSERT_FALSE(iterations.empty());
  EXPECT_TRUE(std::is_sorted(iterations.begin(), iterations.end()));
  EXPECT_LE(iterations.back(), fit->iterations());
  ASSERT_EQ(fit->estimates_size(), 2);
  EXPECT_NEAR(fit->estimates(0).value(), H1::kFriction, 1e-8 * H1::kFriction);
  EXPECT_NEAR(fit->estimates(1).value(), 2e-8, 1e-8 * 2e-8);
  EXPECT_TRUE(fit->identified());
  EXPECT_NEAR(fit->fitted_scene().friction(), fit->estimates(0).value(), 1e-15);
  EXPECT_TRUE(fit->has_guessed_rig_compliance());
}

TEST_F(ContactClientTest, FitLoopsErrorIsTheResultsStatus) {
  mdr::v1::FitLoopsRequest request;
  *request.mutable_scene() = H1WithRig();
  int progress = 0;
  auto fit = client_->FitLoops(request, [&](const mdr::v1::FitProgress&) { ++progress; });
  ASSERT_EQ(fit.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(mdr::client::ReadErrorDetails(fit.status()).field, "sets");
  EXPECT_EQ(progress, 0);
}

TEST_F(ContactClientTest, FrettingMapAndBackboneOfTheScene) {
  mdr::v1::FrettingMapRequest map_request;
  *map_request.mutable_scene() = H1WithRig();
  map_request.add_normal_forces(H1::kNormalForce);
  map_request.add_relative_amplitudes(0.5);
  map_request.add_relative_amplitudes(2);
  auto map = client_->FrettingMap(map_request);
  ASSERT_TRUE(map.ok()) << map.status().error_message();
  ASSERT_EQ(map->loads_size(), 1);
  const auto& load = map->loads(0);
  // At the onset Q* = mu P, and the actuator moves the contact's amplitude plus C_t Q*.
  EXPECT_NEAR(load.onset().force_amplitude(), 30, 1e-9);
  EXPECT_NEAR(load.onset().actuator_amplitude(), load.onset().contact_amplitude() + 2e-8 * 30,
              1e-15);
  ASSERT_EQ(load.regimes_size(), 2);
  EXPECT_EQ(load.regimes(0), mdr::v1::REGIME_PARTIAL_SLIP);
  EXPECT_EQ(load.regimes(1), mdr::v1::REGIME_GROSS_SLIP);

  mdr::v1::BackboneRequest backbone_request;
  *backbone_request.mutable_scene() = H1WithRig();
  backbone_request.set_normal_force(H1::kNormalForce);
  backbone_request.set_kind(mdr::v1::BackboneRequest::AMPLITUDE_KIND_FORCE);
  for (double q : {5.0, 15.0, 30.0}) backbone_request.add_amplitudes(q);
  auto backbone = client_->Backbone(backbone_request);
  ASSERT_TRUE(backbone.ok()) << backbone.status().error_message();
  ASSERT_EQ(backbone->loops_size(), 3);
  // The secant stiffness falls and the damping ratio grows toward gross slip.
  EXPECT_GT(backbone->loops(0).secant_stiffness(), backbone->loops(1).secant_stiffness());
  EXPECT_GT(backbone->loops(1).secant_stiffness(), backbone->loops(2).secant_stiffness());
  EXPECT_LT(backbone->loops(0).damping_ratio(), backbone->loops(1).damping_ratio());
  EXPECT_NEAR(backbone->loops(2).force_amplitude(), 30, 1e-9);
}

}  // namespace
