// StreamApply: one response per message, in order; per-message errors; idempotent retries;
// back-pressure; the drain on shutdown.
#include <grpcpp/support/channel_arguments.h>

#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using ::testing::HasSubstr;

using Stream = grpc::ClientReaderWriter<v1::StreamApplyRequest, v1::StreamApplyResponse>;

v1::StreamApplyRequest Message(const std::string& session, const std::vector<v1::Step>& steps,
                               const std::vector<std::string>& step_mask = {},
                               const std::string& request_id = "") {
  v1::StreamApplyRequest message;
  *message.mutable_apply() = ApplyRequestFor(session, steps, step_mask, request_id);
  return message;
}

using StreamApplyTest = ServiceTest;

TEST_F(StreamApplyTest, AnswersThousandsOfPipelinedMessagesInOrder) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  constexpr int kMessages = 3000;
  constexpr double kIncrement = 1e-10;
  auto context = Context(std::chrono::seconds(30));
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  std::thread writer([&] {
    const v1::StreamApplyRequest message =
        Message(session, {DisplacementIncrementStep(kIncrement)});
    for (int i = 0; i < kMessages; ++i) ASSERT_TRUE(stream->Write(message));
    stream->WritesDone();
  });
  v1::StreamApplyResponse answer;
  int answered = 0;
  while (stream->Read(&answer)) {
    ++answered;
    ASSERT_EQ(answer.status().code(), 0) << answer.status().message();
    ASSERT_EQ(answer.result().state().applied_steps(), 1u + answered);
  }
  writer.join();
  const grpc::Status status = stream->Finish();
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(answered, kMessages);
  const v1::ContactState state = StateOf(session);
  EXPECT_EQ(state.applied_steps(), 1u + kMessages);
  ExpectRelativelyNear(state.tangential_displacement(), kMessages * kIncrement, 1e-9);
  // Same state as one unary batch of the same steps, bit for bit.
  const std::string reference = CreateOrDie();
  std::vector<v1::Step> steps = {DepthStep(kDepth)};
  steps.insert(steps.end(), kMessages, DisplacementIncrementStep(kIncrement));
  ASSERT_TRUE(Apply(reference, steps, &response).ok());
  EXPECT_EQ(ExportOrDie(reference).contact().SerializeAsString(),
            ExportOrDie(session).contact().SerializeAsString());
}

TEST_F(StreamApplyTest, ReportsErrorsPerMessageAndStaysOpen) {
  const std::string session = CreateOrDie();
  auto context = Context();
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  v1::StreamApplyResponse answer;

  ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth)}, {"state.normal_force"})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_TRUE(answer.has_status());
  EXPECT_EQ(answer.status().code(), 0);
  ASSERT_EQ(answer.result().step_results_size(), 1);
  ExpectRelativelyNear(answer.result().step_results(0).state().normal_force(), 100, 1e-9);
  EXPECT_GT(answer.result().compute_seconds(), 0);

  ASSERT_TRUE(stream->Write(Message(session, {DisplacementStep(1e-7), DepthStep(std::nan(""))})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(answer.status().message(), ::testing::StartsWith("steps[1].depth: "));
  const google::rpc::BadRequest bad_request = BadRequestOf(answer.status());
  ASSERT_EQ(bad_request.field_violations_size(), 1);
  EXPECT_EQ(bad_request.field_violations(0).field(), "steps[1].depth");
  EXPECT_FALSE(answer.has_result());

  ASSERT_TRUE(stream->Write(Message("sessions/nobody", {DepthStep(kDepth)})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::NOT_FOUND);

  ASSERT_TRUE(stream->Write(Message(session, {TangentialForceStep(40)})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(answer.status().message(), HasSubstr("mu F_N = 30"));

  ASSERT_TRUE(stream->Write(Message(session, {DisplacementStep(1e-7)})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), 0);
  EXPECT_EQ(answer.result().state().applied_steps(), 2u);  // the failed batches applied nothing

  stream->WritesDone();
  EXPECT_FALSE(stream->Read(&answer));
  EXPECT_TRUE(stream->Finish().ok());
}

// A stream keeps the sessions its messages found (SessionStore::FindAgain); a session
// deleted between two messages is not found by the next one, and one created again under the
// same name is the one the next message applies to.
TEST_F(StreamApplyTest, FollowsASessionDeletedAndCreatedAgainBetweenMessages) {
  const std::string session = CreateOrDie("rig-1");
  auto context = Context();
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  v1::StreamApplyResponse answer;
  for (int i = 1; i <= 2; ++i) {
    ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth)})));
    ASSERT_TRUE(stream->Read(&answer));
    ASSERT_EQ(answer.status().code(), 0) << answer.status().message();
    EXPECT_EQ(answer.result().state().applied_steps(), static_cast<std::uint64_t>(i));
  }
  v1::DeleteSessionRequest request;
  request.set_name(session);
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), request, &empty).ok());
  ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth)})));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::NOT_FOUND);

  ASSERT_EQ(CreateOrDie("rig-1"), session);
  ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth)})));
  ASSERT_TRUE(stream->Read(&answer));
  ASSERT_EQ(answer.status().code(), 0) << answer.status().message();
  EXPECT_EQ(answer.result().state().applied_steps(), 1u);
  EXPECT_EQ(StateOf(session).applied_steps(), 1u);
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
}

TEST_F(StreamApplyTest, RequestIdsDeduplicateAcrossStreamAndUnaryCalls) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse unary;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &unary, {}, "load").ok());
  auto context = Context();
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  v1::StreamApplyResponse answer;
  ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth)}, {}, "load")));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_TRUE(answer.result().replayed());
  for (int i = 0; i < 2; ++i) {  // a rig resending after a reconnect
    ASSERT_TRUE(stream->Write(Message(session, {DisplacementIncrementStep(1e-8)}, {}, "shift-1")));
    ASSERT_TRUE(stream->Read(&answer));
    EXPECT_EQ(answer.result().replayed(), i == 1);
    EXPECT_EQ(answer.result().state().applied_steps(), 2u);
  }
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_EQ(StateOf(session).applied_steps(), 2u);
}

TEST_F(StreamApplyTest, ServerStopsReadingWhileTheClientDoesNotRead) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  // A client channel with a fixed 64 KiB receive window (no BDP growth), so the responses it
  // does not read soon fill it; its own connection, so the Query below is not stuck behind them.
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  arguments.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 65535);
  arguments.SetInt("mdr.test.own_connection", 1);
  auto stream_stub = v1::ContactService::NewStub(
      grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(server_->port()),
                                grpc::InsecureChannelCredentials(), arguments));
  constexpr int kMessages = 400;
  constexpr int kStepsPerMessage = 50;  // ~5 KB of per-step states per response
  const v1::StreamApplyRequest message =
      Message(session, std::vector<v1::Step>(kStepsPerMessage, DisplacementIncrementStep(1e-11)),
              {"state"});
  auto context = Context(std::chrono::seconds(30));
  std::unique_ptr<Stream> stream = stream_stub->StreamApply(context.get());
  std::thread writer([&] {
    for (int i = 0; i < kMessages; ++i) {
      if (!stream->Write(message)) break;
    }
    stream->WritesDone();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const std::uint64_t applied_while_stalled = StateOf(session).applied_steps() - 1;
  EXPECT_LT(applied_while_stalled, kMessages / 2 * kStepsPerMessage)
      << "the server kept applying messages whose responses nobody read";

  v1::StreamApplyResponse answer;
  int answered = 0;
  while (stream->Read(&answer)) {
    ASSERT_EQ(answer.status().code(), 0);
    ++answered;
  }
  writer.join();
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_EQ(answered, kMessages);
  EXPECT_EQ(StateOf(session).applied_steps(), 1u + kMessages * kStepsPerMessage);
}

TEST_F(StreamApplyTest, ShutdownTellsOpenStreamsToFinish) {
  const std::string session = CreateOrDie();
  auto context = Context();
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  v1::StreamApplyResponse answer;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(stream->Write(Message(session, {DepthStep(kDepth * (i + 1) / 3)})));
    ASSERT_TRUE(stream->Read(&answer));
    ASSERT_EQ(answer.status().code(), 0);
  }
  ASSERT_EQ(server_->open_streams(), 1u);

  const auto start = std::chrono::steady_clock::now();
  std::thread shutdown(
      [&] { server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(10)); });
  EXPECT_FALSE(stream->Read(&answer));
  const grpc::Status status = stream->Finish();
  shutdown.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(status.error_message(), HasSubstr("shutting down"));
  // Ended by the drain, not by Shutdown's deadline.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

}  // namespace
}  // namespace mdr::service_testing
