// Many sessions in parallel: 16 sessions, each driven by 4 threads of unary batches, while 8
// streams drive 8 further sessions, all at once. Every session must end in exactly the state of
// the same steps applied serially.
#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using ConcurrencyTest = ServiceTest;

TEST_F(ConcurrencyTest, SessionsRunInParallelAndEachStaysSerial) {
  constexpr int kUnarySessions = 16, kThreadsPerSession = 4, kBatchesPerThread = 10;
  constexpr int kStepsPerBatch = 5;
  constexpr int kStreams = 8, kMessagesPerStream = 300;
  // Identical steps commute in their effect on the count, and are identical, so the final state
  // does not depend on the interleaving.
  const v1::Step unary_step = DisplacementIncrementStep(2e-10);
  const v1::Step stream_step = DisplacementIncrementStep(3e-10);

  std::vector<std::string> unary_sessions, stream_sessions;
  v1::ApplyResponse response;
  for (int i = 0; i < kUnarySessions + kStreams; ++i) {
    const std::string session = CreateOrDie();
    ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
    (i < kUnarySessions ? unary_sessions : stream_sessions).push_back(session);
  }

  std::vector<std::thread> threads;
  for (const std::string& session : unary_sessions) {
    for (int t = 0; t < kThreadsPerSession; ++t) {
      threads.emplace_back([&, session] {
        for (int b = 0; b < kBatchesPerThread; ++b) {
          v1::ApplyResponse ignored;
          const grpc::Status status =
              Apply(session, std::vector<v1::Step>(kStepsPerBatch, unary_step), &ignored);
          EXPECT_TRUE(status.ok()) << status.error_message();
        }
      });
    }
  }
  for (const std::string& session : stream_sessions) {
    threads.emplace_back([&, session] {
      auto context = Context(std::chrono::seconds(60));
      auto stream = stub_->StreamApply(context.get());
      v1::StreamApplyRequest message;
      *message.mutable_apply() = ApplyRequestFor(session, {stream_step});
      std::thread writer([&] {
        for (int m = 0; m < kMessagesPerStream; ++m) {
          if (!stream->Write(message)) break;
        }
        stream->WritesDone();
      });
      v1::StreamApplyResponse answer;
      int answered = 0;
      while (stream->Read(&answer)) answered += answer.status().code() == 0 ? 1 : 0;
      writer.join();
      EXPECT_TRUE(stream->Finish().ok());
      EXPECT_EQ(answered, kMessagesPerStream);
    });
  }
  for (std::thread& thread : threads) thread.join();

  const auto reference_contact = [&](const v1::Step& step, int count) {
    const std::string reference = CreateOrDie();
    std::vector<v1::Step> steps = {DepthStep(kDepth)};
    steps.insert(steps.end(), count, step);
    v1::ApplyResponse ignored;
    EXPECT_TRUE(Apply(reference, steps, &ignored).ok());
    return ExportOrDie(reference).contact().SerializeAsString();
  };
  const std::string unary_reference =
      reference_contact(unary_step, kThreadsPerSession * kBatchesPerThread * kStepsPerBatch);
  const std::string stream_reference = reference_contact(stream_step, kMessagesPerStream);
  for (const std::string& session : unary_sessions) {
    EXPECT_EQ(ExportOrDie(session).contact().SerializeAsString(), unary_reference) << session;
    EXPECT_EQ(StateOf(session).applied_steps(),
              1u + kThreadsPerSession * kBatchesPerThread * kStepsPerBatch);
  }
  for (const std::string& session : stream_sessions) {
    EXPECT_EQ(ExportOrDie(session).contact().SerializeAsString(), stream_reference) << session;
  }
}

}  // namespace
}  // namespace mdr::service_testing
