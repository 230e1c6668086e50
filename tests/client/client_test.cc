// The client library: retries only of idempotent calls on UNAVAILABLE, TLS with a bearer token
// sent as "authorization: Bearer <token>", option errors as values, and StreamApply against the
// real service.
#include <gmock/gmock.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>
#include <grpcpp/server_builder.h>
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include "mdr/client/channel.h"
#include "mdr/client/contact_client.h"
#include "mdr/service/server.h"

namespace {

using mdr::client::ClientOptions;
using mdr::client::ContactClient;
using ::testing::HasSubstr;

// Fails the first `failures` calls of every method with UNAVAILABLE, then answers; GetSession
// echoes the authorization metadata as the session name.
class FlakyService final : public mdr::v1::ContactService::Service {
 public:
  explicit FlakyService(int failures) : failures_(failures) {}
  int calls() const { return calls_; }

  grpc::Status GetSession(grpc::ServerContext* context, const mdr::v1::GetSessionRequest*,
                          mdr::v1::Session* response) override {
    if (Fail()) return Unavailable();
    const auto& metadata = context->client_metadata();
    const auto found = metadata.find("authorization");
    response->set_name(
        found == metadata.end() ? "" : std::string(found->second.data(), found->second.size()));
    return grpc::Status::OK;
  }
  grpc::Status CreateSession(grpc::ServerContext*, const mdr::v1::CreateSessionRequest*,
                             mdr::v1::Session*) override {
    return Fail() ? Unavailable() : grpc::Status::OK;
  }
  grpc::Status Apply(grpc::ServerContext*, const mdr::v1::ApplyRequest*,
                     mdr::v1::ApplyResponse*) override {
    return Fail() ? Unavailable() : grpc::Status::OK;
  }
  grpc::Status AnalyzeLoops(grpc::ServerContext*, const mdr::v1::AnalyzeLoopsRequest*,
                            mdr::v1::AnalyzeLoopsResponse*) override {
    return Fail() ? Unavailable() : grpc::Status::OK;
  }
  // One progress message, then (from the second call on that does not fail) the result, unless
  // without_result: then the stream ends OK without one.
  grpc::Status FitLoops(grpc::ServerContext*, const mdr::v1::FitLoopsRequest*,
                        grpc::ServerWriter<mdr::v1::FitLoopsResponse>* writer) override {
    mdr::v1::FitLoopsResponse message;
    message.mutable_progress()->set_iteration(1);
    writer->Write(message);
    if (Fail()) return Unavailable();
    if (without_result) return grpc::Status::OK;
    message.mutable_result()->set_iterations(7);
    writer->Write(message);
    return grpc::Status::OK;
  }
  bool without_result = false;

 private:
  bool Fail() { return ++calls_ <= failures_; }
  static grpc::Status Unavailable() { return {grpc::StatusCode::UNAVAILABLE, "try again"}; }
  const int failures_;
  std::atomic<int> calls_{0};
};

class RetryTest : public ::testing::Test {
 protected:
  void Start(int failures) {
    service_ = std::make_unique<FlakyService>(failures);
    grpc::ServerBuilder builder;
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    client_ = std::make_unique<ContactClient>(
        server_->InProcessChannel({}),
        ClientOptions{.max_attempts = 3, .initial_backoff = std::chrono::milliseconds(1)});
  }
  std::unique_ptr<FlakyService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<ContactClient> client_;
};

TEST_F(RetryTest, IdempotentCallIsRetriedOnUnavailable) {
  Start(2);
  auto session = client_->GetSession("sessions/a");
  EXPECT_TRUE(session.ok()) << session.status().error_message();
  EXPECT_EQ(service_->calls(), 3);
}

TEST_F(RetryTest, RetriesStopAtMaxAttempts) {
  Start(5);
  auto session = client_->GetSession("sessions/a");
  ASSERT_FALSE(session.ok());
  EXPECT_EQ(session.status().error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(session.status().error_message(), "try again");
  EXPECT_EQ(service_->calls(), 3);
}

TEST_F(RetryTest, CreateIsNotRetried) {
  Start(1);
  EXPECT_EQ(client_->CreateSession(mdr::v1::Scene()).status().error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(service_->calls(), 1);
}

TEST_F(RetryTest, AnalysisCallsAreRetried) {
  Start(2);
  EXPECT_TRUE(client_->AnalyzeLoops({}).ok());
  EXPECT_EQ(service_->calls(), 3);
}

// A FitLoops stream that fails with UNAVAILABLE is started again; every attempt's progress is
// seen, and the result is the last attempt's.
TEST_F(RetryTest, FitLoopsStreamIsRetriedAndReturnsTheResult) {
  Start(1);
  int progress = 0;
  auto fit = client_->FitLoops({}, [&](const mdr::v1::FitProgress&) { ++progress; });
  ASSERT_TRUE(fit.ok()) << fit.status().error_message();
  EXPECT_EQ(fit->iterations(), 7);
  EXPECT_EQ(service_->calls(), 2);
  EXPECT_EQ(progress, 2);
}

TEST_F(RetryTest, FitLoopsStreamWithoutResultIsAnError) {
  Start(0);
  service_->without_result = true;
  auto fit = client_->FitLoops({});
  EXPECT_EQ(fit.status().error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_THAT(fit.status().error_message(), HasSubstr("without a result"));
}

TEST_F(RetryTest, ApplyIsRetriedOnlyWithRequestId) {
  Start(1);
  mdr::v1::Step step;
  step.set_normal_force(1);
  EXPECT_EQ(client_->Apply("sessions/a", step).status().error_code(),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(service_->calls(), 1);
  EXPECT_TRUE(client_->Apply("sessions/a", step, {}, "batch-1").ok());
  EXPECT_EQ(service_->calls(), 2);
}

std::string DataFile(const std::string& name) {
  return std::string(MDR_CLIENT_TEST_DATA) + "/" + name;
}

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(ChannelTest, TlsChannelSendsTheBearerToken) {
  FlakyService service(0);
  grpc::SslServerCredentialsOptions ssl;
  ssl.pem_key_cert_pairs.push_back(
      {Read(DataFile("localhost.key")), Read(DataFile("localhost.crt"))});
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("localhost:0", grpc::SslServerCredentials(ssl), &port);
  builder.RegisterService(&service);
  auto server = builder.BuildAndStart();
  ASSERT_NE(port, 0);
  auto channel = mdr::client::MakeChannel({.address = "localhost:" + std::to_string(port),
                                           .root_certificates_file = DataFile("localhost.crt"),
                                           .bearer_token = "s3cret"});
  ASSERT_TRUE(channel.ok()) << channel.status().error_message();
  ContactClient client(*channel, std::chrono::seconds(10));
  auto session = client.GetSession("sessions/a");
  ASSERT_TRUE(session.ok()) << session.status().error_message();
  EXPECT_EQ(session->name(), "Bearer s3cret");
  server->Shutdown();
}

// A service whose one session's name is as long as asked: a response larger than gRPC's default
// client limit (4 MiB).
class LargeResponseService final : public mdr::v1::ContactService::Service {
 public:
  explicit LargeResponseService(std::size_t bytes) : bytes_(bytes) {}
  grpc::Status GetSession(grpc::ServerContext*, const mdr::v1::GetSessionRequest*,
                          mdr::v1::Session* response) override {
    response->set_name(std::string(bytes_, 'n'));
    return grpc::Status::OK;
  }

 private:
  std::size_t bytes_;
};

TEST(ChannelTest, TakesResponsesAsLargeAsTheServerSends) {
  LargeResponseService service(std::size_t{6} << 20);
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("localhost:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  auto server = builder.BuildAndStart();
  ASSERT_NE(port, 0);
  auto channel = mdr::client::MakeChannel({.address = "localhost:" + std::to_string(port)});
  ASSERT_TRUE(channel.ok()) << channel.status().error_message();
  ContactClient client(*channel, std::chrono::seconds(10));
  auto session = client.GetSession("sessions/a");
  ASSERT_TRUE(session.ok()) << session.status().error_message();
  EXPECT_EQ(session->name().size(), std::size_t{6} << 20);
  server->Shutdown();
}

TEST(ChannelTest, OptionErrorsAreValuesNamingTheOption) {
  auto token = mdr::client::MakeChannel({.address = "localhost:1", .bearer_token = "t"});
  EXPECT_EQ(token.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(token.status().error_message(), HasSubstr("bearer_token: needs TLS"));
  auto missing = mdr::client::MakeChannel(
      {.address = "localhost:1", .root_certificates_file = "/no/such.pem"});
  EXPECT_THAT(missing.status().error_message(),
              HasSubstr("root_certificates_file: cannot open /no/such.pem"));
  auto half = mdr::client::MakeChannel(
      {.address = "localhost:1", .client_certificate_file = DataFile("localhost.crt")});
  EXPECT_THAT(half.status().error_message(),
              HasSubstr("client_certificate_file: a client certificate needs its key"));
  EXPECT_EQ(mdr::client::MakeChannel({}).status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST(StreamApplyTest, EachMessageHasItsOwnStatusInOrder) {
  auto server = mdr::service::ContactServer::Start({});
  ASSERT_TRUE(server.ok());
  ContactClient client((*server)->InProcessChannel());
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(0.01);
  scene.mutable_rigid_on_half_space()->set_shear_modulus(80e9);
  scene.mutable_rigid_on_half_space()->set_poisson_ratio(0.3);
  scene.set_friction(0.3);
  auto session = client.CreateSession(scene);
  ASSERT_TRUE(session.ok());
  std::vector<mdr::v1::ApplyRequest> requests(3);
  for (auto& request : requests) request.set_session(session->name());
  requests[0].add_steps()->set_normal_force(100);
  requests[1].add_steps()->set_tangential_force(31);  // above mu F_N = 30 N
  requests[2].add_steps()->set_tangential_force(15);
  std::vector<std::size_t> seen;
  auto responses =
      client.StreamApply(requests, [&](std::size_t i, const auto&) { seen.push_back(i); });
  ASSERT_TRUE(responses.ok()) << responses.status().error_message();
  ASSERT_EQ(responses->size(), 3u);
  EXPECT_EQ(seen, (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ((*responses)[0].status().code(), 0);
  EXPECT_EQ((*responses)[1].status().code(),
            static_cast<int>(grpc::StatusCode::FAILED_PRECONDITION));
  EXPECT_THAT((*responses)[1].status().message(), HasSubstr("steps[0].tangential_force"));
  EXPECT_EQ((*responses)[2].status().code(), 0);
  EXPECT_NEAR((*responses)[2].result().state().tangential_force(), 15, 1e-9);
}

}  // namespace
