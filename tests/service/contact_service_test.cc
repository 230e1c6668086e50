// Integration tests: a real server on a free port, driven through the generated stub.
#include <gmock/gmock.h>
#include <google/protobuf/util/message_differencer.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace {

using google::protobuf::util::MessageDifferencer;
using ::testing::HasSubstr;

// Reference vector H1 (reference-values.md): steel sphere on steel flat.
constexpr double kYoungsModulus = 210e9;
constexpr double kPoissonRatio = 0.3;
constexpr double kRadius = 0.01;
constexpr double kFriction = 0.3;
constexpr double kDepth = 3.4829098839e-6;              // gives F_N = 100 N
constexpr double kDisplacementAt15N = 4.6949658143e-7;  // gives F_x = 15 N

// Closed forms (physics.md) for two equal elastic bodies.
double EffectiveYoungsModulus() {
  return 1 / (2 * (1 - kPoissonRatio * kPoissonRatio) / kYoungsModulus);
}
double EffectiveShearModulus() {
  const double shear_modulus = kYoungsModulus / (2 * (1 + kPoissonRatio));
  return 1 / (2 * (2 - kPoissonRatio) / (4 * shear_modulus));
}
double HertzNormalForce(double depth) {
  return 4.0 / 3.0 * EffectiveYoungsModulus() * std::sqrt(kRadius) * std::pow(depth, 1.5);
}
// Cattaneo-Mindlin at constant depth: ux = mu kappa d [1 - (1-s)^(2/3)], F_x = s mu F_N.
double CattaneoMindlinTangentialForce(double depth, double displacement) {
  const double kappa = EffectiveYoungsModulus() / EffectiveShearModulus();
  const double full_slip = kFriction * kappa * depth;
  const double s = 1 - std::pow(1 - displacement / full_slip, 1.5);
  return s * kFriction * HertzNormalForce(depth);
}

mdr::v1::Scene SteelSphereOnSteelFlat() {
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(kRadius);
  mdr::v1::ElasticPair* pair = scene.mutable_elastic_pair();
  pair->set_youngs_modulus_1(kYoungsModulus);
  pair->set_poisson_ratio_1(kPoissonRatio);
  pair->set_youngs_modulus_2(kYoungsModulus);
  pair->set_poisson_ratio_2(kPoissonRatio);
  scene.set_friction(kFriction);
  return scene;
}

mdr::v1::Step DepthStep(double depth) {
  mdr::v1::Step step;
  step.set_depth(depth);
  return step;
}
mdr::v1::Step DisplacementStep(double displacement) {
  mdr::v1::Step step;
  step.set_displacement(displacement);
  return step;
}
mdr::v1::Step TangentialForceStep(double force) {
  mdr::v1::Step step;
  step.set_tangential_force(force);
  return step;
}

void ExpectRelativelyNear(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected));
}

class ContactServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto server = mdr::service::ContactServer::Start({.listen_address = "127.0.0.1:0"});
    ASSERT_TRUE(server.ok()) << server.status().ToString();
    server_ = std::move(server).value();
    ASSERT_GT(server_->port(), 0);
    stub_ = mdr::v1::ContactService::NewStub(grpc::CreateChannel(
        "127.0.0.1:" + std::to_string(server_->port()), grpc::InsecureChannelCredentials()));
  }

  std::unique_ptr<grpc::ClientContext> Context() {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    return context;
  }

  grpc::Status Create(const mdr::v1::Scene& scene, mdr::v1::Session* session,
                      const std::string& session_id = "") {
    mdr::v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = scene;
    request.set_session_id(session_id);
    return stub_->CreateSession(Context().get(), request, session);
  }

  std::string CreateOrDie() {
    mdr::v1::Session session;
    grpc::Status status = Create(SteelSphereOnSteelFlat(), &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }

  grpc::Status Apply(const std::string& session, const std::vector<mdr::v1::Step>& steps,
                     mdr::v1::ApplyResponse* response) {
    mdr::v1::ApplyRequest request;
    request.set_session(session);
    for (const mdr::v1::Step& step : steps) *request.add_steps() = step;
    request.set_include_step_results(true);
    return stub_->Apply(Context().get(), request, response);
  }

  grpc::Status Query(const std::string& session, mdr::v1::QueryResponse* response,
                     const std::vector<std::string>& read_mask = {}) {
    mdr::v1::QueryRequest request;
    request.set_session(session);
    for (const std::string& path : read_mask) request.mutable_read_mask()->add_paths(path);
    return stub_->Query(Context().get(), request, response);
  }

  void ExpectInvalidScene(const mdr::v1::Scene& scene, const std::string& field) {
    mdr::v1::Session session;
    grpc::Status status = Create(scene, &session);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field;
    EXPECT_THAT(status.error_message(), HasSubstr(field + ": "));
  }

  std::unique_ptr<mdr::service::ContactServer> server_;
  std::unique_ptr<mdr::v1::ContactService::Stub> stub_;
};

TEST_F(ContactServiceTest, CreateSessionReturnsUnloadedSessionResource) {
  mdr::v1::Session session;
  grpc::Status status = Create(SteelSphereOnSteelFlat(), &session);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(session.name().starts_with("sessions/")) << session.name();
  EXPECT_TRUE(MessageDifferencer::Equals(session.scene(), SteelSphereOnSteelFlat()));
  EXPECT_EQ(session.state().depth(), 0);
  EXPECT_EQ(session.state().normal_force(), 0);
  EXPECT_EQ(session.state().applied_steps(), 0u);
  EXPECT_GT(session.create_time().seconds(), 0);

  mdr::v1::GetSessionRequest get;
  get.set_name(session.name());
  mdr::v1::Session fetched;
  ASSERT_TRUE(stub_->GetSession(Context().get(), get, &fetched).ok());
  EXPECT_TRUE(MessageDifferencer::Equals(fetched, session));
}

TEST_F(ContactServiceTest, CreateSessionRejectsInvalidSceneNamingTheField) {
  mdr::v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(-1);
  ExpectInvalidScene(scene, "session.scene.sphere.radius");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_elastic_pair()->set_poisson_ratio_2(0.7);
  ExpectInvalidScene(scene, "session.scene.elastic_pair.poisson_ratio_2");

  scene = SteelSphereOnSteelFlat();
  scene.set_friction(-0.1);
  ExpectInvalidScene(scene, "session.scene.friction");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_power_law()->set_coefficient(1);
  scene.mutable_power_law()->set_exponent(20);
  ExpectInvalidScene(scene, "session.scene.power_law.exponent");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_force_path_tolerance(0.5);
  ExpectInvalidScene(scene, "session.scene.options.force_path_tolerance");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_max_memory_vertices(0);
  ExpectInvalidScene(scene, "session.scene.options.max_memory_vertices");

  scene = SteelSphereOnSteelFlat();
  scene.clear_sphere();
  ExpectInvalidScene(scene, "session.scene.profile");

  scene = SteelSphereOnSteelFlat();
  scene.clear_elastic_pair();
  ExpectInvalidScene(scene, "session.scene.material");
}

TEST_F(ContactServiceTest, CreateSessionWithChosenIdRejectsDuplicatesAndBadIds) {
  mdr::v1::Session session;
  ASSERT_TRUE(Create(SteelSphereOnSteelFlat(), &session, "rig-1").ok());
  EXPECT_EQ(session.name(), "sessions/rig-1");
  EXPECT_EQ(Create(SteelSphereOnSteelFlat(), &session, "rig-1").error_code(),
            grpc::StatusCode::ALREADY_EXISTS);
  grpc::Status status = Create(SteelSphereOnSteelFlat(), &session, "Rig/1");
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("session_id: "));
}

TEST_F(ContactServiceTest, HertzDisplacementStepsMatchCattaneoMindlin) {
  const std::string session = CreateOrDie();
  std::vector<mdr::v1::Step> steps = {DepthStep(kDepth)};
  for (int k = 1; k <= 3; ++k) steps.push_back(DisplacementStep(kDisplacementAt15N * k / 3));
  mdr::v1::ApplyResponse response;
  grpc::Status status = Apply(session, steps, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.step_results_size(), 4);

  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE("step " + std::to_string(i));
    const mdr::v1::ContactState& state = response.step_results(i).state();
    EXPECT_EQ(state.depth(), kDepth);
    ExpectRelativelyNear(state.normal_force(), HertzNormalForce(kDepth), 1e-10);
    ExpectRelativelyNear(state.contact_radius(), std::sqrt(kRadius * kDepth), 1e-10);
    const double displacement = i == 0 ? 0 : steps[i].displacement();
    EXPECT_EQ(state.tangential_displacement(), displacement);
    if (i == 0) {
      EXPECT_EQ(state.tangential_force(), 0);
    } else {
      ExpectRelativelyNear(state.tangential_force(),
                           CattaneoMindlinTangentialForce(kDepth, displacement), 1e-10);
    }
    EXPECT_EQ(state.applied_steps(), static_cast<std::uint64_t>(i + 1));
  }
  // The tabulated H1 values themselves (rounded to 11 digits there).
  ExpectRelativelyNear(response.state().normal_force(), 100, 1e-9);
  ExpectRelativelyNear(response.state().tangential_force(), 15, 1e-9);
  ExpectRelativelyNear(response.state().contact_radius(), 1.8662555784e-4, 1e-9);
  EXPECT_TRUE(MessageDifferencer::Equals(response.state(), response.step_results(3).state()));
}

TEST_F(ContactServiceTest, ForceControlledStepsReachTheirTargets) {
  const std::string session = CreateOrDie();
  mdr::v1::Step load;
  load.set_normal_force(100);
  mdr::v1::ApplyResponse response;
  ASSERT_TRUE(
      Apply(session, {load, TangentialForceStep(5), TangentialForceStep(15)}, &response).ok());
  ExpectRelativelyNear(response.state().normal_force(), 100, 1e-9);
  ExpectRelativelyNear(response.state().tangential_force(), 15, 1e-9);
  ExpectRelativelyNear(response.state().depth(), 3.4829098839e-6, 1e-9);
  ExpectRelativelyNear(response.state().tangential_displacement(), kDisplacementAt15N, 1e-9);
}

TEST_F(ContactServiceTest, FailingBatchLeavesSessionUnchanged) {
  const std::string session = CreateOrDie();
  mdr::v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
  mdr::v1::QueryResponse before;
  ASSERT_TRUE(Query(session, &before).ok());

  mdr::v1::Step invalid;
  invalid.set_normal_force(-1);
  grpc::Status status = Apply(session, {DisplacementStep(2e-7), invalid}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("steps[1]"));

  // |F_x| = 40 N > mu F_N = 30 N cannot be reached.
  status = Apply(session, {DisplacementStep(2e-7), TangentialForceStep(40)}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("steps[1]"));

  mdr::v1::QueryResponse after;
  ASSERT_TRUE(Query(session, &after).ok());
  EXPECT_TRUE(MessageDifferencer::Equals(before, after))
      << before.DebugString() << " vs " << after.DebugString();
}

TEST_F(ContactServiceTest, ApplyRejectsEmptyBatchAndRequestId) {
  const std::string session = CreateOrDie();
  mdr::v1::ApplyResponse response;
  grpc::Status status = Apply(session, {}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("steps: "));

  mdr::v1::ApplyRequest request;
  request.set_session(session);
  *request.add_steps() = DepthStep(kDepth);
  request.set_request_id("retry-1");
  status = stub_->Apply(Context().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED);
}

TEST_F(ContactServiceTest, QueryReadMaskSelectsFields) {
  const std::string session = CreateOrDie();
  mdr::v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(1e-7)}, &applied).ok());

  mdr::v1::QueryResponse response;
  ASSERT_TRUE(Query(session, &response, {"state.normal_force"}).ok());
  EXPECT_EQ(response.state().normal_force(), applied.state().normal_force());
  EXPECT_EQ(response.state().tangential_force(), 0);
  EXPECT_EQ(response.state().depth(), 0);

  ASSERT_TRUE(Query(session, &response).ok());
  EXPECT_TRUE(MessageDifferencer::Equals(response.state(), applied.state()));

  grpc::Status status = Query(session, &response, {"state", "state.no_such_field"});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("read_mask.paths[1]: "));
}

TEST_F(ContactServiceTest, UnknownSessionIsNotFoundAndMalformedNameInvalid) {
  mdr::v1::ApplyResponse applied;
  EXPECT_EQ(Apply("sessions/unknown", {DepthStep(kDepth)}, &applied).error_code(),
            grpc::StatusCode::NOT_FOUND);
  mdr::v1::QueryResponse queried;
  EXPECT_EQ(Query("sessions/unknown", &queried).error_code(), grpc::StatusCode::NOT_FOUND);
  mdr::v1::GetSessionRequest get;
  get.set_name("sessions/unknown");
  mdr::v1::Session session;
  EXPECT_EQ(stub_->GetSession(Context().get(), get, &session).error_code(),
            grpc::StatusCode::NOT_FOUND);

  grpc::Status status = Query("unknown", &queried);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("session: "));
}

TEST_F(ContactServiceTest, DeleteRemovesSessionOnce) {
  const std::string session = CreateOrDie();
  mdr::v1::DeleteSessionRequest request;
  request.set_name(session);
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), request, &empty).ok());
  EXPECT_EQ(stub_->DeleteSession(Context().get(), request, &empty).error_code(),
            grpc::StatusCode::NOT_FOUND);
  mdr::v1::QueryResponse response;
  EXPECT_EQ(Query(session, &response).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(ContactServiceTest, ConcurrentBatchesOnOneSessionAreSerialised) {
  const std::string session = CreateOrDie();
  mdr::v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  constexpr int kThreads = 4;
  constexpr int kBatchesPerThread = 25;
  mdr::v1::Step increment;
  increment.set_displacement_increment(1e-9);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&] {
      for (int b = 0; b < kBatchesPerThread; ++b) {
        mdr::v1::ApplyResponse ignored;
        EXPECT_TRUE(Apply(session, {increment, increment}, &ignored).ok());
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  mdr::v1::QueryResponse state;
  ASSERT_TRUE(Query(session, &state).ok());
  EXPECT_EQ(state.state().applied_steps(), 1u + 2u * kThreads * kBatchesPerThread);
  ExpectRelativelyNear(state.state().tangential_displacement(),
                       2 * kThreads * kBatchesPerThread * 1e-9, 1e-12);
}

}  // namespace
