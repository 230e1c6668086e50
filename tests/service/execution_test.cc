// The execution model (contact_service.h): computing calls run on a bounded worker pool, cheap
// calls answer inline while every worker is busy, a full queue refuses at once, a call whose
// deadline passed while it waited is not run, nothing is created after the client gave up, and a
// drain interrupts running work. Workers are held by a gate in a test hook, not by sleeps.
#include <condition_variable>
#include <mutex>
#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

// Closes on Close(); Pass() blocks while it is closed. Counts the callers that arrived.
class Gate {
 public:
  void Pass() {
    std::unique_lock lock(mutex_);
    ++arrived_;
    changed_.notify_all();
    changed_.wait(lock, [this] { return open_; });
  }
  void Close() {
    std::lock_guard lock(mutex_);
    open_ = false;
  }
  void Open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  int arrived() {
    std::lock_guard lock(mutex_);
    return arrived_;
  }
  void AwaitArrivals(int count) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return arrived_ >= count; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = true;
  int arrived_ = 0;
};

class ExecutionTest : public ServiceTest {
 protected:
  // One worker and one queue slot; every batch step and every session addition passes the gate.
  void SetUp() override {
    service::ServerOptions options = LocalServerOptions();
    options.execution = {.workers = 1, .max_queued = 1};
    options.test_hooks.before_step = [this](int) { gate_.Pass(); };
    options.test_hooks.before_add_session = [this] { gate_.Pass(); };
    Restart(options);
    busy_session_ = CreateOrDie();
    other_session_ = CreateOrDie();
    v1::ApplyResponse response;
    ASSERT_TRUE(Apply(other_session_, {DepthStep(kDepth)}, &response).ok());
    gate_.Close();
  }
  void TearDown() override {
    gate_.Open();
    for (std::thread& thread : threads_) thread.join();
  }

  // Holds the only worker: a batch on busy_session_ that waits at the gate.
  void OccupyTheWorker() {
    const int arrived = gate_.arrived();
    threads_.emplace_back([this] {
      v1::ApplyResponse response;
      EXPECT_TRUE(Apply(busy_session_, {DepthStep(kDepth)}, &response).ok());
    });
    gate_.AwaitArrivals(arrived + 1);  // this batch's first step
  }
  // Waits until `count` calls wait for the worker (a failure after 30 s).
  void AwaitQueued(std::size_t count) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (server_->queued_calls() != count) {
      if (std::chrono::steady_clock::now() > deadline) {
        ADD_FAILURE() << "never " << count << " queued calls";
        return;
      }
      std::this_thread::yield();
    }
  }

  Gate gate_;
  std::vector<std::thread> threads_;
  std::string busy_session_, other_session_;
};

TEST_F(ExecutionTest, CheapCallsAnswerWhileEveryWorkerIsBusy) {
  OccupyTheWorker();
  // Without inline execution these would wait for the gate and miss their deadline.
  const auto deadline = std::chrono::seconds(5);
  v1::GetSessionRequest get;
  get.set_name(busy_session_);
  v1::Session session;
  EXPECT_TRUE(stub_->GetSession(Context(deadline).get(), get, &session).ok());
  EXPECT_EQ(session.state().applied_steps(), 0u) << "the state of the last commit";
  v1::ListSessionsResponse list;
  EXPECT_TRUE(stub_->ListSessions(Context(deadline).get(), {}, &list).ok());
  EXPECT_EQ(list.sessions_size(), 2);
  v1::DeleteSessionRequest erase;
  erase.set_name(other_session_);
  google::protobuf::Empty empty;
  EXPECT_TRUE(stub_->DeleteSession(Context(deadline).get(), erase, &empty).ok());
}

TEST_F(ExecutionTest, FullQueueRefusesAtOnceWithUnavailable) {
  OccupyTheWorker();
  threads_.emplace_back([this] {
    v1::ApplyResponse response;
    EXPECT_TRUE(Apply(other_session_, {DisplacementStep(1e-8)}, &response).ok());
  });
  AwaitQueued(1);
  v1::QueryResponse answer;
  const grpc::Status status = Query(other_session_, &answer);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(status.error_message(), testing::HasSubstr("busy"));
  EXPECT_THAT(status.error_message(), testing::HasSubstr("retry"));
  gate_.Open();
  for (std::thread& thread : threads_) thread.join();
  threads_.clear();
  EXPECT_EQ(StateOf(other_session_).applied_steps(), 2u) << "the queued batch ran";
}

TEST_F(ExecutionTest, StreamMessageRefusedByAFullQueueIsAnsweredUnapplied) {
  OccupyTheWorker();
  threads_.emplace_back([this] {
    v1::ApplyResponse response;
    EXPECT_TRUE(Apply(other_session_, {DisplacementStep(1e-8)}, &response).ok());
  });
  AwaitQueued(1);
  auto context = Context();
  auto stream = stub_->StreamApply(context.get());
  v1::StreamApplyRequest message;
  *message.mutable_apply() = ApplyRequestFor(other_session_, {DisplacementStep(2e-8)});
  ASSERT_TRUE(stream->Write(message));
  v1::StreamApplyResponse answer;
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(answer.status().message(), testing::HasSubstr("busy"));
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
  gate_.Open();
  for (std::thread& thread : threads_) thread.join();
  threads_.clear();
  EXPECT_EQ(StateOf(other_session_).applied_steps(), 2u) << "only the queued unary batch ran";
}

// A deletion never overtakes a batch on its session: with the batch running, DeleteSession waits
// on the session's strand (it cannot run inline), the batch commits, then the session goes, and
// a batch that arrives after the deletion finds no session.
TEST_F(ExecutionTest, DeleteSessionRunsAfterTheBatchRunningOnItsSession) {
  OccupyTheWorker();
  grpc::Status deleted;
  threads_.emplace_back([this, &deleted] {
    v1::DeleteSessionRequest erase;
    erase.set_name(busy_session_);
    google::protobuf::Empty empty;
    deleted = stub_->DeleteSession(Context().get(), erase, &empty);
  });
  AwaitQueued(1);
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), {}, &list).ok());
  EXPECT_EQ(list.sessions_size(), 2) << "deleted while its batch ran";
  gate_.Open();
  for (std::thread& thread : threads_) thread.join();
  threads_.clear();
  EXPECT_TRUE(deleted.ok()) << deleted.error_message();
  v1::ApplyResponse response;
  EXPECT_EQ(Apply(busy_session_, {DepthStep(kDepth)}, &response).error_code(),
            grpc::StatusCode::NOT_FOUND);
}

TEST_F(ExecutionTest, CallWhoseDeadlinePassedWhileQueuedIsNotRun) {
  OccupyTheWorker();
  v1::ApplyResponse response;
  const grpc::Status status =
      stub_->Apply(Context(std::chrono::milliseconds(200)).get(),
                   ApplyRequestFor(other_session_, {DisplacementStep(1e-8)}), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  // The server's deadline is the client's timeout counted from when the call arrived, so it
  // passes up to the transit time later: a wide margin, not a measurement.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  gate_.Open();
  AwaitQueued(0);
  // Query runs on the session's strand after the expired batch was taken from the queue.
  EXPECT_EQ(StateOf(other_session_).applied_steps(), 1u);
}

TEST_F(ExecutionTest, NothingIsCreatedAfterTheClientGaveUp) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  v1::Session created;
  // The session is built, then waits at the gate until the client's deadline has passed.
  const grpc::Status status =
      stub_->CreateSession(Context(std::chrono::milliseconds(200)).get(), request, &created);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // as above: the server's deadline
  gate_.Open();
  // ListSessions is inline; the worker is done once a queued call (Query) has answered.
  v1::QueryResponse answer;
  ASSERT_TRUE(Query(other_session_, &answer).ok());
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), {}, &list).ok());
  EXPECT_EQ(list.sessions_size(), 2) << "no third session";
}

TEST_F(ExecutionTest, DrainInterruptsRunningWorkAfterTheGracePeriod) {
  gate_.Open();
  std::atomic<int> steps{0};
  service::ServerOptions options = LocalServerOptions();
  options.execution = {.workers = 1, .max_queued = 1};
  options.test_hooks.before_step = [&](int) {
    ++steps;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  };
  Restart(options);
  const std::string session = CreateOrDie();
  // 10000 steps of 5 ms: close to a minute unless interrupted.
  threads_.emplace_back([&] {
    v1::ApplyResponse response;
    const grpc::Status status = stub_->Apply(
        Context(std::chrono::seconds(120)).get(),
        ApplyRequestFor(session, std::vector<v1::Step>(10000, DepthStep(kDepth))), &response);
    EXPECT_FALSE(status.ok());
  });
  while (steps == 0) std::this_thread::yield();
  const auto start = std::chrono::steady_clock::now();
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(100));
  // A behavioural bound with a wide margin: without the interrupt this takes ~50 s.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  for (std::thread& thread : threads_) thread.join();
  threads_.clear();
}

}  // namespace
}  // namespace mdr::service_testing
