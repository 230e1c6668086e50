// The bounded worker pool that runs the computing calls (Apply, each StreamApply message, Query,
// ExportSession, Transform, CreateSession, ImportSession, DeleteSession, the analyses) off gRPC's
// threads, so that cheap calls (health, GetSession, ListSessions) answered inline never wait
// behind them.
//
// Every task belongs to a caller (a token's principal, or a peer's address without
// authentication) and to a strand of that caller (the session name): the tasks of one strand run
// one at a time and in the order they were submitted, so a session's calls stay serialised
// without a worker blocking on the session's mutex; different strands run in parallel.
//
// Fairness between callers (docs/operations.md, "Fairness between callers"):
// - Workers take the callers in turn (round robin), and each caller's strands in turn, so a
//   caller with many sessions or streams gets no more turns than one with a single session.
// - A caller runs on at most workers - (other active callers) workers, at least one: while
//   others are active (a task queued or running, or one submitted or finished within
//   recent_window), a worker stays free for them, so one caller's long tasks cannot hold every
//   worker. A caller alone has every worker.
// - A newcomer never waits behind the others' work: a caller with nothing running whose task
//   finds every worker busy gets one of reserve_workers threads kept for that case (by default
//   as many as the workers; each serves one such caller at a time, so the reserve never takes a
//   second task of a caller already running one, nor the work a task spreads over the pool).
//   The worker reservation above keeps a worker only for callers active within recent_window;
//   the reserve holds for a caller arriving at any time. While it runs, the cores are shared by
//   more threads than there are workers.
// - Admission: a caller may have at most max_queued_per_caller tasks waiting (beyond:
//   kCallerQueueFull). While max_queued tasks wait in total, a caller is still admitted below
//   its fair share (max_queued / active callers, at least one), up to a hard total of
//   2 max_queued (beyond: kBusy), so a busy caller cannot fill the queue for the others.
#pragma once

#include <time.h>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include "mdr/base/status.h"

namespace mdr::service {

struct ExecutorOptions {
  static constexpr std::size_t kMaxWorkers = 1024;
  // Worker threads; 0: one per core (std::thread::hardware_concurrency).
  std::size_t workers = 0;
  // Tasks waiting for a worker in total (not counting the running ones), >= 1; see admission.
  std::size_t max_queued = 256;
  // Tasks one caller may have waiting, >= 1. By default a caller alone may fill the queue
  // (clients on one host are one caller without authentication); the fair share still admits the
  // others.
  std::size_t max_queued_per_caller = 256;
  // How long a caller counts as active after its last task was submitted or finished: the
  // workers kept free for it while it works call after call.
  std::chrono::milliseconds recent_window{1000};
  // Threads for callers with nothing running while every worker is busy (see above); -1: as many
  // as the workers, 0: none.
  int reserve_workers = -1;
};

// Field names are the mdrd flags: workers in [0, kMaxWorkers], max-queued-calls >= 1,
// max-queued-calls-per-caller >= 1, reserve-workers in [-1, kMaxWorkers].
Status ValidateExecutorOptions(const ExecutorOptions& options);

class Executor {
 public:
  using Task = std::function<void()>;
  using Clock = std::chrono::steady_clock;

  enum class Admission {
    kQueued,
    kCallerQueueFull,  // the caller has max_queued_per_caller tasks waiting
    kBusy,             // the queue is full and the caller has its share of it
    kStopped,
  };

  explicit Executor(const ExecutorOptions& options);
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;
  // Stop().
  ~Executor();

  // Queues task behind the earlier tasks of the caller's strand (empty strand: ordered with
  // nothing). Anything but kQueued: the task is dropped unrun.
  Admission Submit(std::string_view caller, std::string_view strand, Task task);
  // Runs task on the calling thread at once if the strand (not empty) has no task queued or
  // running, holding the strand meanwhile, so that tasks submitted to it in between run after
  // it, in order. For work whose cost is bounded a priori and small (docs/operations.md, "Inline
  // steps"): it runs on a transport thread and counts as no worker's. task returns whether it
  // did the work (it may decline, e.g. when the state it finds is beyond the bound). Returns
  // false, without running task, when the strand is busy or the executor stops.
  bool TryRunInline(std::string_view caller, std::string_view strand,
                    const std::function<bool()>& task);
  // Refuses new tasks, runs every queued one, then joins the workers. Idempotent.
  void Stop();

  // The caller of the task running on this thread ("" outside a task): work a task spreads over
  // the pool (PoolParallelFor) stays its caller's.
  static const std::string& CurrentCaller();

  std::size_t workers() const { return workers_.size(); }
  std::size_t reserve_workers() const { return reserve_.size(); }
  std::size_t max_queued() const { return options_.max_queued; }
  std::size_t max_queued_per_caller() const { return options_.max_queued_per_caller; }
  // Tasks waiting for a worker now.
  std::size_t queued() const;
  // Tasks waiting or running now (0: every strand free for an inline task).
  std::size_t busy() const;
  // The active callers other than `caller` (see above): whether it competes with anyone now.
  std::size_t OtherActiveCallers(std::string_view caller) const;
  // CPU time the worker threads used so far (their tasks and the dispatch between them), read
  // from their CPU clocks, so that the rest of the process's CPU time can be told apart: gRPC's
  // transport (stream_pacer.h). Two system calls per worker: for a sampler, not per task.
  std::chrono::nanoseconds worker_cpu_time() const;

 private:
  // Lookups by string_view without building a std::string.
  struct StringHash {
    using is_transparent = void;
    std::size_t operator()(std::string_view s) const { return std::hash<std::string_view>{}(s); }
  };
  struct CallerQueue {
    // The strands with tasks not yet finished; a strand is in ready while it has a task waiting
    // and none running.
    std::unordered_map<std::string, std::deque<Task>, StringHash, std::equal_to<>> strands;
    std::deque<std::string> ready;
    std::size_t queued = 0;
    std::size_t running = 0;
    // The strands TryRunInline runs now: claimed[0, claims). The strings are reused (no
    // allocation per inline task once they have grown).
    std::vector<std::string> claimed;
    std::size_t claims = 0;
    Clock::time_point last_active;
    std::uint64_t anonymous_strands = 0;
  };
  using Callers = std::unordered_map<std::string, CallerQueue, StringHash, std::equal_to<>>;

  // A worker's loop; a reserve thread's when `reserve`.
  void Work(bool reserve);
  // The first caller in turn with a ready strand and nothing running, while every worker is
  // busy (taken out of ready_callers_); callers_.end() otherwise.
  Callers::iterator NextNewcomerLocked();
  static bool ClaimedLocked(const CallerQueue& queue, std::string_view strand);
  // Whether a caller is active: a task waiting or running, or one submitted or finished within
  // recent_window.
  bool ActiveLocked(const CallerQueue& queue, Clock::time_point now) const;
  // The active callers, but `except` (if not null).
  std::size_t ActiveCallersLocked(Clock::time_point now, const std::string_view* except) const;
  // How many workers a caller may hold while `active` callers (itself included) are active.
  std::size_t RunningCapLocked(std::size_t active) const;
  // The next caller in turn that may start a task now (taken out of ready_callers_);
  // callers_.end() if none.
  Callers::iterator NextRunnableLocked(Clock::time_point now);
  void ForgetIdleCallersLocked(Clock::time_point now);

  const ExecutorOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wakeup_;          // the workers'
  std::condition_variable reserve_wakeup_;  // the reserve's
  Callers callers_;                         // guarded by mutex_
  std::deque<std::string> ready_callers_;   // guarded by mutex_; callers with a ready strand
  std::size_t queued_ = 0;                  // guarded by mutex_
  std::size_t running_ = 0;                 // guarded by mutex_; tasks running, reserve's included
  std::size_t workers_running_ = 0;         // guarded by mutex_; tasks running on the workers
  bool stopping_ = false;                   // guarded by mutex_
  std::vector<clockid_t> worker_clocks_;    // guarded by mutex_; read while !stopping_
  mutable std::chrono::nanoseconds stopped_worker_cpu_{0};  // guarded by mutex_; last reading
  std::vector<std::thread> workers_;
  std::vector<std::thread> reserve_;
};

}  // namespace mdr::service
