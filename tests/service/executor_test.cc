// The executor's fairness between callers (executor.h): callers served in turn, a caller's
// strands in turn, a caller's own queue bound, its fair share of a full queue, and a worker kept
// free for the other active callers. Tasks are held by latches, not sleeps; a wait that would
// hang without the property under test fails after kPatience instead.
#include "mdr/service/executor.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <pthread.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mdr/service/call_context.h"

namespace mdr::service {
namespace {

using Admission = Executor::Admission;
constexpr auto kPatience = std::chrono::seconds(30);

// A task that reports it started and then waits until released.
class Held {
 public:
  Executor::Task Task() {
    return [this] {
      started_.set_value();
      release_future_.wait();
    };
  }
  bool AwaitStart() { return started_future_.wait_for(kPatience) == std::future_status::ready; }
  bool Started() {
    return started_future_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }
  void Release() { release_.set_value(); }

 private:
  std::promise<void> started_, release_;
  std::future<void> started_future_ = started_.get_future();
  std::shared_future<void> release_future_ = release_.get_future().share();
};

// Records the order in which tasks ran.
class Order {
 public:
  Executor::Task Record(std::string label) {
    return [this, label = std::move(label)] {
      std::lock_guard lock(mutex_);
      ran_.push_back(label);
    };
  }
  std::vector<std::string> ran() {
    std::lock_guard lock(mutex_);
    return ran_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> ran_;
};

TEST(ExecutorTest, CallersAreServedInTurnWhateverTheirNumberOfStrands) {
  Executor executor({.workers = 1, .reserve_workers = 0});
  Held gate;
  ASSERT_EQ(executor.Submit("alice", "s0", gate.Task()), Admission::kQueued);
  ASSERT_TRUE(gate.AwaitStart());
  Order order;
  for (int i = 1; i <= 10; ++i) {
    const std::string label = "alice" + std::to_string(i);
    ASSERT_EQ(executor.Submit("alice", "s" + std::to_string(i), order.Record(label)),
              Admission::kQueued);
  }
  ASSERT_EQ(executor.Submit("bob", "b", order.Record("bob")), Admission::kQueued);
  gate.Release();
  executor.Stop();  // runs every queued task
  const std::vector<std::string> ran = order.ran();
  ASSERT_EQ(ran.size(), 11u);
  // Bob waited for one of alice's ten, not for all of them.
  EXPECT_EQ(ran[0], "alice1");
  EXPECT_EQ(ran[1], "bob");
}

TEST(ExecutorTest, StrandsKeepTheirOrderAndTakeTurnsWithinACaller) {
  Executor executor({.workers = 1});
  Held gate;
  ASSERT_EQ(executor.Submit("alice", "g", gate.Task()), Admission::kQueued);
  ASSERT_TRUE(gate.AwaitStart());
  Order order;
  for (int i = 1; i <= 3; ++i) {
    ASSERT_EQ(executor.Submit("alice", "long", order.Record("long" + std::to_string(i))),
              Admission::kQueued);
  }
  ASSERT_EQ(executor.Submit("alice", "short", order.Record("short")), Admission::kQueued);
  gate.Release();
  executor.Stop();
  EXPECT_THAT(order.ran(), ::testing::ElementsAre("long1", "short", "long2", "long3"));
}

TEST(ExecutorTest, ACallersOwnQueueIsBoundedWithoutTouchingTheOthers) {
  Executor executor(
      {.workers = 1, .max_queued = 100, .max_queued_per_caller = 2, .reserve_workers = 0});
  Held gate;
  ASSERT_EQ(executor.Submit("alice", "", gate.Task()), Admission::kQueued);
  ASSERT_TRUE(gate.AwaitStart());  // running: not waiting
  EXPECT_EQ(executor.Submit("alice", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.Submit("alice", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.Submit("alice", "", [] {}), Admission::kCallerQueueFull);
  EXPECT_EQ(executor.Submit("bob", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.queued(), 3u);
  gate.Release();
}

TEST(ExecutorTest, ACallerUnderItsShareIsAdmittedToAFullQueue) {
  Executor executor({.workers = 1, .max_queued = 4, .reserve_workers = 0});
  Held gate;
  ASSERT_EQ(executor.Submit("alice", "", gate.Task()), Admission::kQueued);
  ASSERT_TRUE(gate.AwaitStart());
  for (int i = 0; i < 4; ++i) ASSERT_EQ(executor.Submit("alice", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.Submit("alice", "", [] {}), Admission::kBusy);
  // Two active callers: a share of 4 / 2 each.
  EXPECT_EQ(executor.Submit("bob", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.Submit("bob", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.Submit("bob", "", [] {}), Admission::kBusy);
  // New callers still get one each, but never beyond twice the queue.
  EXPECT_EQ(executor.Submit("carol", "", [] {}), Admission::kQueued);  // shares 4 / 3 and 4 / 4
  EXPECT_EQ(executor.Submit("dave", "", [] {}), Admission::kQueued);
  EXPECT_EQ(executor.queued(), 8u);
  EXPECT_EQ(executor.Submit("erin", "", [] {}), Admission::kBusy);
  gate.Release();
}

TEST(ExecutorTest, ACallerAloneHasEveryWorker) {
  Executor executor({.workers = 2});
  Held first, second;
  ASSERT_EQ(executor.Submit("alice", "a", first.Task()), Admission::kQueued);
  ASSERT_EQ(executor.Submit("alice", "b", second.Task()), Admission::kQueued);
  EXPECT_TRUE(first.AwaitStart());
  EXPECT_TRUE(second.AwaitStart());
  first.Release();
  second.Release();
}

TEST(ExecutorTest, AWorkerStaysFreeForAnotherActiveCaller) {
  Executor executor({.workers = 2, .recent_window = std::chrono::minutes(10)});
  // Bob made a call a moment ago: he is active for the window.
  std::promise<void> bob_done;
  ASSERT_EQ(executor.Submit("bob", "", [&] { bob_done.set_value(); }), Admission::kQueued);
  ASSERT_EQ(bob_done.get_future().wait_for(kPatience), std::future_status::ready);
  // Alice's two long tasks: one runs, the other waits, so bob's next call finds a worker.
  Held first, second;
  ASSERT_EQ(executor.Submit("alice", "a", first.Task()), Admission::kQueued);
  ASSERT_EQ(executor.Submit("alice", "b", second.Task()), Admission::kQueued);
  ASSERT_TRUE(first.AwaitStart());
  std::promise<void> bob_again;
  ASSERT_EQ(executor.Submit("bob", "", [&] { bob_again.set_value(); }), Admission::kQueued);
  EXPECT_EQ(bob_again.get_future().wait_for(kPatience), std::future_status::ready);
  EXPECT_FALSE(second.Started());
  first.Release();
  EXPECT_TRUE(second.AwaitStart());  // alice's turn once her first is done
  second.Release();
}

// The thread a task runs on: "mdr-worker" or "mdr-reserve".
std::string ThreadName() {
  char name[16] = {};
  pthread_getname_np(pthread_self(), name, sizeof name);
  return name;
}

// Bob was idle (no recent window to keep a worker for him) while alice's tasks hold every worker
// and more of hers wait: his task starts at once on the reserve, and hers stay queued.
TEST(ExecutorTest, ANewcomerNeverWaitsBehindAnothersWork) {
  Executor executor({.workers = 1, .recent_window = std::chrono::milliseconds(0)});
  ASSERT_EQ(executor.reserve_workers(), 1u);
  Held first, second;
  ASSERT_EQ(executor.Submit("alice", "a", first.Task()), Admission::kQueued);
  ASSERT_TRUE(first.AwaitStart());
  ASSERT_EQ(executor.Submit("alice", "b", second.Task()), Admission::kQueued);
  std::promise<std::string> bob;
  ASSERT_EQ(executor.Submit("bob", "", [&] { bob.set_value(ThreadName()); }), Admission::kQueued);
  auto ran_on = bob.get_future();
  ASSERT_EQ(ran_on.wait_for(kPatience), std::future_status::ready);
  EXPECT_EQ(ran_on.get(), "mdr-reserve");
  EXPECT_FALSE(second.Started()) << "the reserve took a task of a caller already running one";
  first.Release();
  EXPECT_TRUE(second.AwaitStart());
  second.Release();
}

// Each reserve thread serves a caller with nothing running: a newcomer's second task waits for
// its first (its turn on the workers comes as before), another newcomer gets the next thread.
TEST(ExecutorTest, TheReserveServesEachNewcomerOneTaskAtATime) {
  Executor executor(
      {.workers = 1, .recent_window = std::chrono::milliseconds(0), .reserve_workers = 2});
  Held alice, bob_first, bob_second, carol;
  ASSERT_EQ(executor.Submit("alice", "a", alice.Task()), Admission::kQueued);
  ASSERT_TRUE(alice.AwaitStart());
  ASSERT_EQ(executor.Submit("bob", "1", bob_first.Task()), Admission::kQueued);
  ASSERT_TRUE(bob_first.AwaitStart());
  ASSERT_EQ(executor.Submit("bob", "2", bob_second.Task()), Admission::kQueued);
  ASSERT_EQ(executor.Submit("carol", "", carol.Task()), Admission::kQueued);
  EXPECT_TRUE(carol.AwaitStart());
  EXPECT_FALSE(bob_second.Started());
  bob_first.Release();
  EXPECT_TRUE(bob_second.AwaitStart());  // bob has nothing running again: the reserve takes it
  alice.Release();
  bob_second.Release();
  carol.Release();
}

// While a worker is free, the reserve takes nothing.
TEST(ExecutorTest, TheReserveWaitsWhileAWorkerIsFree) {
  Executor executor({.workers = 2, .recent_window = std::chrono::milliseconds(0)});
  Held alice;
  ASSERT_EQ(executor.Submit("alice", "a", alice.Task()), Admission::kQueued);
  ASSERT_TRUE(alice.AwaitStart());
  for (int i = 0; i < 20; ++i) {
    std::promise<std::string> bob;
    ASSERT_EQ(executor.Submit("bob", "", [&] { bob.set_value(ThreadName()); }), Admission::kQueued);
    auto ran_on = bob.get_future();
    ASSERT_EQ(ran_on.wait_for(kPatience), std::future_status::ready);
    EXPECT_EQ(ran_on.get(), "mdr-worker");
  }
  alice.Release();
}

TEST(ExecutorTest, ReserveWorkersAreValidated) {
  EXPECT_TRUE(ValidateExecutorOptions({.reserve_workers = -1}).ok());
  EXPECT_TRUE(ValidateExecutorOptions({.reserve_workers = 0}).ok());
  const Status refused = ValidateExecutorOptions({.reserve_workers = -2});
  EXPECT_FALSE(refused.ok());
  EXPECT_THAT(refused.ToString(), ::testing::HasSubstr("reserve-workers"));
  EXPECT_THAT(refused.ToString(), ::testing::HasSubstr("[-1, 1024]"));
}

TEST(ExecutorTest, WorkSpreadByATaskStaysItsCallers) {
  Executor executor({.workers = 1});
  std::promise<std::string> seen;
  ASSERT_EQ(executor.Submit("alice", "", [&] { seen.set_value(Executor::CurrentCaller()); }),
            Admission::kQueued);
  EXPECT_EQ(seen.get_future().get(), "alice");
  EXPECT_EQ(Executor::CurrentCaller(), "");
}

TEST(ExecutorTest, StopRunsEveryQueuedTaskAndRefusesNewOnes) {
  Executor executor({.workers = 2, .recent_window = std::chrono::minutes(10)});
  std::atomic<int> ran{0};
  for (int i = 0; i < 50; ++i) {
    ASSERT_EQ(executor.Submit(i % 2 ? "alice" : "bob", std::to_string(i % 7), [&] { ++ran; }),
              Admission::kQueued);
  }
  executor.Stop();
  EXPECT_EQ(ran.load(), 50);
  EXPECT_EQ(executor.Submit("alice", "", [] {}), Admission::kStopped);
}

TEST(ExecutorTest, AnIdleStrandRunsInlineOnTheCallingThread) {
  Executor executor({.workers = 1});
  std::thread::id ran_on;
  EXPECT_TRUE(executor.TryRunInline("alice", "s", [&] {
    ran_on = std::this_thread::get_id();
    return true;
  }));
  EXPECT_EQ(ran_on, std::this_thread::get_id());
  // A task that declines (its work was beyond the bound) leaves the strand free.
  EXPECT_FALSE(executor.TryRunInline("alice", "s", [] { return false; }));
  EXPECT_TRUE(executor.TryRunInline("alice", "s", [] { return true; }));
  EXPECT_FALSE(executor.TryRunInline("alice", "", [] { return true; })) << "no strand: no order";
}

TEST(ExecutorTest, ABusyStrandIsNeverRunInline) {
  Executor executor({.workers = 1});
  Held running;
  ASSERT_EQ(executor.Submit("alice", "s", running.Task()), Admission::kQueued);
  ASSERT_TRUE(running.AwaitStart());
  bool ran = false;
  EXPECT_FALSE(executor.TryRunInline("alice", "s", [&] { return ran = true; }));
  ASSERT_EQ(executor.Submit("alice", "s", [] {}), Admission::kQueued);  // now one is queued too
  EXPECT_FALSE(executor.TryRunInline("alice", "s", [&] { return ran = true; }));
  EXPECT_FALSE(ran);
  EXPECT_TRUE(executor.TryRunInline("alice", "t", [] { return true; })) << "another strand";
  running.Release();
  executor.Stop();
  EXPECT_FALSE(executor.TryRunInline("alice", "s", [&] { return ran = true; }));
  EXPECT_FALSE(ran);
}

TEST(ExecutorTest, TasksSubmittedDuringAnInlineTaskRunAfterIt) {
  Executor executor({.workers = 2});
  Order order;
  std::promise<void> inline_started;
  std::promise<void> submitted;
  std::thread transport([&] {
    EXPECT_TRUE(executor.TryRunInline("alice", "s", [&] {
      inline_started.set_value();
      submitted.get_future().wait();
      order.Record("inline")();
      return true;
    }));
  });
  inline_started.get_future().wait();
  // Queued behind the claim: no worker takes the strand while the inline task runs, nor does
  // another inline attempt.
  ASSERT_EQ(executor.Submit("alice", "s", order.Record("queued")), Admission::kQueued);
  EXPECT_FALSE(executor.TryRunInline("alice", "s", [] { return true; }));
  submitted.set_value();
  transport.join();
  executor.Stop();
  EXPECT_THAT(order.ran(), ::testing::ElementsAre("inline", "queued"));
}

TEST(CallerKeyTest, PeersAreKeyedByHostNotByConnection) {
  EXPECT_EQ(PeerCallerKey("ipv4:127.0.0.1:45678"), "peer:127.0.0.1");
  EXPECT_EQ(PeerCallerKey("ipv4:127.0.0.1:1"), PeerCallerKey("ipv4:127.0.0.1:2"));
  EXPECT_EQ(PeerCallerKey("ipv6:[::1]:45678"), "peer:[::1]");
  EXPECT_EQ(PeerCallerKey("ipv6:[fe80::1%25eth0]:80"), "peer:[fe80::1%25eth0]");
  EXPECT_EQ(PeerCallerKey("unix:/run/mdr.sock"), "peer:unix:/run/mdr.sock");
  EXPECT_NE(PeerCallerKey("ipv4:10.0.0.1:5"), PeerCallerKey("ipv4:10.0.0.2:5"));
}

}  // namespace
}  // namespace mdr::service
