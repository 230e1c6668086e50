// Shared helpers for the service tests: those of the bridge's tests (bridge_test_util.h), and
// a fixture with a real server on a free port driven through the stub.
#pragma once

#include <gmock/gmock.h>
#include <grpcpp/client_context.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/error_details.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bridge/bridge_test_util.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace mdr::service_testing {

// The scenes, steps, closed forms and masks of bridge_test_util.h.
using bridge_testing::CattaneoMindlinTangentialForce;
using bridge_testing::DepthStep;
using bridge_testing::DisplacementIncrementStep;
using bridge_testing::DisplacementStep;
using bridge_testing::EffectiveShearModulus;
using bridge_testing::EffectiveYoungsModulus;
using bridge_testing::ExpectRelativelyNear;
using bridge_testing::HertzNormalForce;
using bridge_testing::Kappa;
using bridge_testing::kDepth;
using bridge_testing::kDisplacementAt15N;
using bridge_testing::kFriction;
using bridge_testing::kPoissonRatio;
using bridge_testing::kRadius;
using bridge_testing::kYoungsModulus;
using bridge_testing::Mask;
using bridge_testing::NormalForceStep;
using bridge_testing::SteelSphereOnSteelFlat;
using bridge_testing::TangentialForceStep;

inline v1::ApplyRequest ApplyRequestFor(const std::string& session,
                                        const std::vector<v1::Step>& steps,
                                        const std::vector<std::string>& step_mask = {},
                                        const std::string& request_id = "") {
  v1::ApplyRequest request;
  request.set_session(session);
  for (const v1::Step& step : steps) *request.add_steps() = step;
  *request.mutable_step_mask() = Mask(step_mask);
  request.set_request_id(request_id);
  return request;
}

inline std::unique_ptr<grpc::ClientContext> Context(
    std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + timeout);
  return context;
}

// The BadRequest in a status' binary details (empty if there is none).
inline google::rpc::BadRequest BadRequestOf(const google::rpc::Status& rich) {
  google::rpc::BadRequest bad_request;
  for (const auto& detail : rich.details()) {
    if (detail.Is<google::rpc::BadRequest>()) detail.UnpackTo(&bad_request);
  }
  return bad_request;
}
inline google::rpc::BadRequest BadRequestOf(const grpc::Status& status) {
  google::rpc::Status rich;
  if (!grpc::ExtractErrorDetails(status, &rich).ok()) return {};
  return BadRequestOf(rich);
}

// INVALID_ARGUMENT whose message starts "field: " and whose details name the same field.
inline void ExpectInvalidArgument(const grpc::Status& status, const std::string& field) {
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
      << field << ": " << status.error_message();
  EXPECT_THAT(status.error_message(), ::testing::StartsWith(field + ": "));
  const google::rpc::BadRequest bad_request = BadRequestOf(status);
  ASSERT_EQ(bad_request.field_violations_size(), 1) << status.error_message();
  EXPECT_EQ(bad_request.field_violations(0).field(), field);
  EXPECT_FALSE(bad_request.field_violations(0).description().empty());
}

inline service::ServerOptions LocalServerOptions() {
  service::ServerOptions options;
  options.listen_address = "127.0.0.1:0";
  return options;
}

// A server on a free loopback port, its stub, and shorthands for the common calls. Tests that
// need other limits or hooks call Restart.
class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override { Restart(LocalServerOptions()); }

  void Restart(service::ServerOptions options) {
    stub_.reset();
    server_.reset();
    if (options.test_hooks.output_counters == nullptr) {
      options.test_hooks.output_counters = &counters_;
    }
    auto server = service::ContactServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status().ToString();
    server_ = std::move(server).value();
    ASSERT_GT(server_->port(), 0);
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(server_->port()),
                                   grpc::InsecureChannelCredentials());
    stub_ = v1::ContactService::NewStub(channel_);
  }

  grpc::Status Create(const v1::Scene& scene, v1::Session* session,
                      const std::string& session_id = "") {
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = scene;
    request.set_session_id(session_id);
    return stub_->CreateSession(Context().get(), request, session);
  }

  // A session of `scene`; its name, or "" after a failed expectation.
  std::string CreateScene(const v1::Scene& scene) {
    v1::Session session;
    grpc::Status status = Create(scene, &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }

  std::string CreateOrDie(const std::string& session_id = "") {
    v1::Session session;
    grpc::Status status = Create(SteelSphereOnSteelFlat(), &session, session_id);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }

  grpc::Status Apply(const std::string& session, const std::vector<v1::Step>& steps,
                     v1::ApplyResponse* response, const std::vector<std::string>& step_mask = {},
                     const std::string& request_id = "") {
    return stub_->Apply(Context().get(), ApplyRequestFor(session, steps, step_mask, request_id),
                        response);
  }

  grpc::Status Query(const std::string& session, v1::QueryResponse* response,
                     const std::vector<std::string>& read_mask = {},
                     const std::vector<double>& radii = {}) {
    v1::QueryRequest request;
    request.set_session(session);
    *request.mutable_read_mask() = Mask(read_mask);
    request.mutable_radii()->Add(radii.begin(), radii.end());
    return stub_->Query(Context().get(), request, response);
  }

  v1::ContactState StateOf(const std::string& session) {
    v1::QueryResponse response;
    EXPECT_TRUE(Query(session, &response).ok());
    return response.state();
  }

  v1::SessionSnapshot ExportOrDie(const std::string& session) {
    v1::ExportSessionRequest request;
    request.set_name(session);
    v1::SessionSnapshot snapshot;
    grpc::Status status = stub_->ExportSession(Context().get(), request, &snapshot);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return snapshot;
  }

  bridge::OutputCounters counters_;
  std::unique_ptr<service::ContactServer> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::ContactService::Stub> stub_;
};

}  // namespace mdr::service_testing
