// The typed client over an in-process channel (mdrctl's embedded mode).
#include "mdr/client/contact_client.h"

#include <gmock/gmock.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include <memory>

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

}  // namespace
