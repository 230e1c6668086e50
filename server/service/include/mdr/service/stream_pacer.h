// Paces the reading of one caller's StreamApply messages while other callers are active, so that
// a caller's streams cannot take the transport's threads and the CPU from the others (issue #27;
// docs/operations.md, "Fairness between callers").
//
// The executor bounds a caller's share of the workers, but each stream message also costs the
// transport (reading, parsing, writing the answer) on gRPC's threads, which serve every caller
// alike. A caller with hundreds of pipelined streams kept the CPU busy with that alone. So every
// message is charged to its caller: the transport's cost per message (measured continuously: the
// process's CPU time outside the worker threads per call answered) when it is read, and the
// measured time of its application when it is answered. While other callers are active, the charges
// drain at `contended_share` of one core, and a stream whose caller is in debt beyond `burst` stops
// reading until the debt would be repaid, then reads the one message it booked (a stream pauses
// max_pause at a time, so that a cancelled one ends soon). A caller alone is never paced. Pacing
// only delays reads: HTTP/2 flow control then holds the client back, and nothing is refused or
// dropped.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>

namespace mdr::service {

struct StreamPacing {
  // One core's fraction a caller's streams may use while other callers are active: its charges
  // drain at this rate (seconds of cost per second).
  double contended_share = 0.25;
  // What reading a message and writing its answer costs gRPC's threads, charged as the read is
  // booked: a first estimate, then measured (StreamBudget::Calibrate). On the 2-core development
  // machine: about 50 µs a message while 256 streams flow freely, about 250 µs while they are
  // paced one message at a time (docs/operations.md, "Fairness between callers").
  std::chrono::nanoseconds transport_cost{std::chrono::microseconds(50)};
  // Debt a caller may run up before its streams pause; also what a caller carries into
  // contention from a time alone.
  std::chrono::nanoseconds burst{std::chrono::milliseconds(5)};
  // The longest one pause: a stream whose booked read is later pauses again (so a cancelled
  // stream ends within it; each of a caller's paused streams wakes this often).
  std::chrono::nanoseconds max_pause{std::chrono::milliseconds(200)};
};

// A reading of the process's clocks: its CPU time, the part its worker threads used, and the
// calls and stream messages it answered so far.
struct TransportSample {
  std::chrono::nanoseconds process_cpu{0};
  std::chrono::nanoseconds worker_cpu{0};
  std::uint64_t calls = 0;
};

// The per-caller accounts (no threads; times are passed in, so it is tested deterministically).
class StreamBudget {
 public:
  using Clock = std::chrono::steady_clock;

  explicit StreamBudget(const StreamPacing& pacing)
      : pacing_(pacing),
        transport_seconds_(std::chrono::duration<double>(pacing.transport_cost).count()) {}

  const StreamPacing& pacing() const { return pacing_; }

  // Adds cost to the caller's debt (a message's application, once measured).
  void Charge(std::string_view caller, std::chrono::nanoseconds cost, Clock::time_point now);
  // Charges the reading of one message (its transport cost) and says when the read may start:
  // after the returned delay, which is zero when other_active_callers is 0 (alone, the debt is
  // first forgiven down to burst) or when the debt, drained at contended_share since it was last
  // looked at, is within burst; else the time to drain it down to burst.
  // Reads that wait are charged as they are booked, so the caller's streams are spaced out in
  // time instead of all waking at once.
  std::chrono::nanoseconds BookRead(std::string_view caller, std::size_t other_active_callers,
                                    Clock::time_point now);
  // Callers with a debt on record (the accounts of repaid callers are dropped).
  std::size_t callers() const;

  // Measures the transport's cost per call from two samples: the CPU time the process spent
  // outside its worker threads (gRPC's threads, this pacing) divided by the calls and messages
  // answered in between. The first sample only starts the measurement; an interval with fewer
  // than kMinCalls calls is extended. The estimate moves halfway to each measurement and stays
  // in [1 µs, 10 ms].
  static constexpr std::uint64_t kMinCalls = 50;
  void Calibrate(const TransportSample& sample);
  std::chrono::nanoseconds transport_cost() const;

 private:
  struct Account {
    double debt_seconds = 0;
    Clock::time_point drained_at;
  };
  Account& AccountLocked(std::string_view caller, Clock::time_point now);
  void DrainLocked(Account& account, Clock::time_point now) const;
  void ForgetRepaidLocked(Clock::time_point now);

  const StreamPacing pacing_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Account> accounts_;  // guarded by mutex_
  std::size_t forget_above_ = 64;                      // guarded by mutex_
  double transport_seconds_;                           // guarded by mutex_
  std::optional<TransportSample> calibrated_from_;     // guarded by mutex_
};

// Runs callbacks at their times on one thread (the paused streams' resumptions).
class DelayedCalls {
 public:
  using Clock = std::chrono::steady_clock;

  DelayedCalls();
  DelayedCalls(const DelayedCalls&) = delete;
  DelayedCalls& operator=(const DelayedCalls&) = delete;
  // Runs what is left at once, then joins the thread.
  ~DelayedCalls();

  void At(Clock::time_point when, std::function<void()> call);
  // Runs every scheduled call now (a drain must not wait for paused streams).
  void RunAllNow();
  std::size_t scheduled() const;

 private:
  void Run();

  mutable std::mutex mutex_;
  std::condition_variable wakeup_;
  std::multimap<Clock::time_point, std::function<void()>> calls_;  // guarded by mutex_
  bool all_now_ = false;                                           // guarded by mutex_
  bool stopping_ = false;                                          // guarded by mutex_
  std::thread thread_;
};

}  // namespace mdr::service
