// Limits, deadlines and cancellation: RESOURCE_EXHAUSTED for every configured limit, and a
// batch stopped by its deadline or a cancellation changes nothing.
#include <atomic>
#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using ::testing::HasSubstr;

using LimitsTest = ServiceTest;

TEST_F(LimitsTest, MaxSessionsIsResourceExhausted) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_sessions = 2;
  Restart(options);
  const std::string first = CreateOrDie();
  CreateOrDie();
  v1::Session session;
  grpc::Status status = Create(SteelSphereOnSteelFlat(), &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("maximum of 2 sessions"));

  v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = ExportOrDie(first);
  EXPECT_EQ(stub_->ImportSession(Context().get(), import_request, &session).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);

  v1::DeleteSessionRequest delete_request;
  delete_request.set_name(first);
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), delete_request, &empty).ok());
  EXPECT_TRUE(Create(SteelSphereOnSteelFlat(), &session).ok());
}

TEST_F(LimitsTest, MemoryVertexLimitFailsTheStepAndKeepsTheState) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_max_memory_vertices(8);
  v1::Session session;
  ASSERT_TRUE(Create(scene, &session).ok());
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session.name(), {DepthStep(kDepth)}, &response).ok());
  // Nested load reversals of decreasing amplitude each leave a slip front in the memory.
  grpc::Status status;
  double amplitude = kDisplacementAt15N;
  int step = 0;
  for (; step < 20 && status.ok(); ++step, amplitude *= -0.8) {
    const v1::SessionSnapshot before = ExportOrDie(session.name());
    status = Apply(session.name(), {DisplacementStep(amplitude)}, &response);
    if (!status.ok()) {
      EXPECT_EQ(before.SerializeAsString(), ExportOrDie(session.name()).SerializeAsString());
    }
  }
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << "after " << step;
  EXPECT_THAT(status.error_message(), HasSubstr("steps[0].max_memory_vertices: "));
  EXPECT_THAT(status.error_message(), HasSubstr("limit of 8"));
}

TEST_F(LimitsTest, MessageSizeLimitAppliesToRequestsAndResponses) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_message_bytes = 4096;
  Restart(options);
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  // About 11 bytes per step: 1000 steps exceed 4 KiB.
  grpc::Status status =
      Apply(session, std::vector<v1::Step>(1000, DisplacementIncrementStep(1e-9)), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();

  // 100 small steps fit, but their full states would not: refused before anything is applied.
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  status = Apply(session, std::vector<v1::Step>(100, DisplacementIncrementStep(1e-9)), &response,
                 {"state"});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("step_mask: "));
  EXPECT_EQ(StateOf(session).applied_steps(), 1u);
  EXPECT_TRUE(Apply(session, std::vector<v1::Step>(100, DisplacementIncrementStep(1e-9)), &response,
                    {"state.tangential_force"})
                  .ok());
  EXPECT_EQ(StateOf(session).applied_steps(), 101u);
}

// A server whose batches take 2 ms per step while `slow` is set.
class SlowBatchTest : public ServiceTest {
 protected:
  void SetUp() override {
    service::ServerOptions options = LocalServerOptions();
    options.test_hooks.before_step = [this](int) {
      steps_started_.fetch_add(1);
      if (slow_.load()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    };
    Restart(options);
    session_ = CreateOrDie();
    v1::ApplyResponse response;
    ASSERT_TRUE(Apply(session_, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
    before_ = ExportOrDie(session_);
    slow_ = true;
    steps_started_ = 0;
  }

  // 500 steps of 2 ms: a second, far beyond the deadlines used here.
  static v1::ApplyRequest LongBatch(const std::string& session) {
    return ApplyRequestFor(session, std::vector<v1::Step>(500, DisplacementIncrementStep(1e-10)));
  }

  void ExpectAbandonedEarlyAndUnchanged() {
    // Query waits for the session, i.e. for the abandoned batch to return.
    EXPECT_EQ(StateOf(session_).applied_steps(), 2u);
    EXPECT_LT(steps_started_.load(), 400) << "the batch was not stopped between steps";
    EXPECT_EQ(before_.SerializeAsString(), ExportOrDie(session_).SerializeAsString());
  }

  std::atomic<bool> slow_{false};
  std::atomic<int> steps_started_{0};
  std::string session_;
  v1::SessionSnapshot before_;
};

TEST_F(SlowBatchTest, DeadlineAbortsTheBatchAtomically) {
  v1::ApplyResponse response;
  grpc::Status status =
      stub_->Apply(Context(std::chrono::milliseconds(100)).get(), LongBatch(session_), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  ExpectAbandonedEarlyAndUnchanged();
}

TEST_F(SlowBatchTest, CancellationAbortsTheBatchAtomically) {
  auto context = Context();
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    context->TryCancel();
  });
  v1::ApplyResponse response;
  grpc::Status status = stub_->Apply(context.get(), LongBatch(session_), &response);
  canceller.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED);
  ExpectAbandonedEarlyAndUnchanged();
}

// The limits themselves, without a server.
TEST(LimitsUnitTest, ServerLimitsNameTheirFlag) {
  service::ServiceLimits limits;
  EXPECT_TRUE(service::ValidateServiceLimits(limits).ok());
  limits.max_message_bytes = 100;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-message-bytes");
  limits = {};
  limits.max_memory_vertices = 4;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-memory-vertices");
  limits = {};
  limits.max_sessions = 0;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-sessions");
}

TEST(LimitsUnitTest, SessionLimitsTakeTheServersUnlessSetWithinThem) {
  service::ServiceLimits server;
  server.max_steps_per_batch = 500;
  server.session_idle_timeout = std::chrono::minutes(10);
  const v1::SessionLimits defaults = *service::ResolveSessionLimits({}, server);
  EXPECT_EQ(defaults.max_steps_per_batch(), 500u);
  EXPECT_EQ(service::IdleTimeout(defaults), std::chrono::minutes(10));

  v1::SessionLimits requested;
  requested.set_max_steps_per_batch(20);
  requested.mutable_idle_timeout()->set_seconds(30);
  const v1::SessionLimits own = *service::ResolveSessionLimits(requested, server);
  EXPECT_EQ(own.max_steps_per_batch(), 20u);
  EXPECT_EQ(service::IdleTimeout(own), std::chrono::seconds(30));

  requested.set_max_steps_per_batch(501);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(),
            "max_steps_per_batch");
  requested.set_max_steps_per_batch(20);
  requested.mutable_idle_timeout()->set_seconds(601);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(), "idle_timeout");
  requested.mutable_idle_timeout()->set_seconds(1);
  requested.mutable_idle_timeout()->set_nanos(-5);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(),
            "idle_timeout.nanos");
}

}  // namespace
}  // namespace mdr::service_testing
