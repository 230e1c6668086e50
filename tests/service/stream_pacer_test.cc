// The pacing of a caller's StreamApply reads (stream_pacer.h): the accounts with explicit times,
// and the thread that resumes paused streams.
#include "mdr/service/stream_pacer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <mutex>
#include <vector>

namespace mdr::service {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;
using std::chrono::nanoseconds;
using Clock = StreamBudget::Clock;

// Waits are rounded up to whole nanoseconds from a double.
void ExpectAbout(nanoseconds actual, nanoseconds expected) {
  EXPECT_NEAR(static_cast<double>(actual.count()), static_cast<double>(expected.count()), 2.0);
}

StreamPacing Pacing() {
  StreamPacing pacing;
  pacing.contended_share = 0.25;
  pacing.transport_cost = microseconds(10);
  pacing.burst = milliseconds(1);
  return pacing;
}

TEST(StreamBudgetTest, ACallerAloneIsNeverPacedAndCarriesAtMostBurstIntoContention) {
  StreamBudget budget(Pacing());
  const Clock::time_point t0;
  budget.Charge("alice", milliseconds(100), t0);
  EXPECT_EQ(budget.BookRead("alice", 0, t0), nanoseconds(0));
  // Forgiven down to burst (1 ms), then charged the booked read (10 µs): 10 µs beyond burst,
  // drained at a quarter of a core.
  ExpectAbout(budget.BookRead("alice", 1, t0), microseconds(40));
}

TEST(StreamBudgetTest, DebtBeyondBurstWaitsUntilDrainedAtTheShare) {
  StreamBudget budget(Pacing());
  const Clock::time_point t0;
  budget.Charge("alice", milliseconds(3), t0);
  // 2 ms beyond burst at 0.25 of a core: 8 ms.
  ExpectAbout(budget.BookRead("alice", 1, t0), milliseconds(8));
  // Each booked read adds its transport cost, so the next stream waits 40 µs longer.
  ExpectAbout(budget.BookRead("alice", 1, t0), milliseconds(8) + microseconds(40));
  // 8 ms later 2 ms of debt were repaid: 20 µs of booked reads are left beyond burst.
  ExpectAbout(budget.BookRead("alice", 1, t0 + milliseconds(8)), microseconds(80));
  // Within burst: read at once.
  EXPECT_EQ(budget.BookRead("alice", 1, t0 + milliseconds(20)), nanoseconds(0));
}

TEST(StreamBudgetTest, CallersHaveTheirOwnAccounts) {
  StreamBudget budget(Pacing());
  const Clock::time_point t0;
  budget.Charge("alice", milliseconds(50), t0);
  EXPECT_GT(budget.BookRead("alice", 1, t0), milliseconds(100));
  EXPECT_EQ(budget.BookRead("bob", 1, t0), nanoseconds(0));
}

TEST(StreamBudgetTest, WaitsAreBoundedSoTimePointsCannotOverflow) {
  StreamBudget budget(Pacing());
  const Clock::time_point t0;
  budget.Charge("alice", std::chrono::hours(1000000), t0);
  EXPECT_EQ(budget.BookRead("alice", 1, t0), std::chrono::hours(1));
}

TEST(StreamBudgetTest, RepaidAccountsAreForgotten) {
  StreamBudget budget(Pacing());
  const Clock::time_point t0;
  // Accounts are swept when a new one arrives and their number reached a power of two >= 64.
  for (int i = 0; i < 1024; ++i) budget.Charge("caller" + std::to_string(i), microseconds(1), t0);
  EXPECT_EQ(budget.callers(), 1024u);
  budget.Charge("late", microseconds(1), t0 + std::chrono::seconds(1));
  EXPECT_EQ(budget.callers(), 1u);
}

TEST(StreamBudgetTest, TransportCostIsMeasuredOutsideTheWorkers) {
  StreamBudget budget(Pacing());
  EXPECT_EQ(budget.transport_cost(), microseconds(10));
  budget.Calibrate({milliseconds(100), milliseconds(60), 1000});  // starts the measurement
  EXPECT_EQ(budget.transport_cost(), microseconds(10));
  // Too few calls: the interval goes on.
  budget.Calibrate({milliseconds(101), milliseconds(60), 1000 + StreamBudget::kMinCalls - 1});
  EXPECT_EQ(budget.transport_cost(), microseconds(10));
  // 1000 more calls; 140 ms more process CPU, 40 ms of it on the workers: 100 µs each outside,
  // and the estimate moves halfway: 55 µs.
  budget.Calibrate({milliseconds(240), milliseconds(100), 2000});
  ExpectAbout(budget.transport_cost(), microseconds(55));
  // A read booked while contended is charged at the estimate: 55 µs beyond a 1 ms burst.
  budget.Charge("alice", milliseconds(1), Clock::time_point());
  EXPECT_EQ(budget.BookRead("alice", 1, Clock::time_point()), nanoseconds(0));
  ExpectAbout(budget.BookRead("alice", 1, Clock::time_point()), microseconds(220));
}

TEST(DelayedCallsTest, RunsCallsInTheOrderOfTheirTimes) {
  std::mutex mutex;
  std::vector<int> order;
  std::promise<void> done;
  {
    DelayedCalls calls;
    const auto now = Clock::now();
    calls.At(now + milliseconds(30), [&] {
      std::lock_guard lock(mutex);
      order.push_back(3);
      done.set_value();
    });
    calls.At(now + milliseconds(10), [&] {
      std::lock_guard lock(mutex);
      order.push_back(2);
    });
    calls.At(now, [&] {
      std::lock_guard lock(mutex);
      order.push_back(1);
    });
    ASSERT_EQ(done.get_future().wait_for(std::chrono::seconds(30)), std::future_status::ready);
  }
  EXPECT_EQ(order, (std::vector<int>{1, 2, 3}));
}

TEST(DelayedCallsTest, RunAllNowDoesNotWaitForTheirTimes) {
  DelayedCalls calls;
  std::promise<void> ran;
  calls.At(Clock::now() + std::chrono::hours(1), [&] { ran.set_value(); });
  EXPECT_EQ(calls.scheduled(), 1u);
  calls.RunAllNow();
  EXPECT_EQ(ran.get_future().wait_for(std::chrono::seconds(30)), std::future_status::ready);
}

TEST(DelayedCallsTest, DestructionRunsWhatIsLeft) {
  bool ran = false;
  {
    DelayedCalls calls;
    calls.At(Clock::now() + std::chrono::hours(1), [&] { ran = true; });
  }
  EXPECT_TRUE(ran);
}

}  // namespace
}  // namespace mdr::service
