// The bounded worker pool that runs the computing calls (Apply, each StreamApply message, Query,
// ExportSession, Transform, CreateSession, ImportSession) off gRPC's threads, so that cheap calls
// (health, GetSession, ListSessions, DeleteSession) answered inline never wait behind them.
//
// Tasks carry a strand key (the session name): the tasks of one strand run one at a time and in
// the order they were submitted, so a session's calls stay serialised without a worker blocking on
// the session's mutex; different strands run in parallel. Admission control: at most max_queued
// tasks wait for a worker; Submit refuses more at once.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "mdr/base/status.h"

namespace mdr::service {

struct ExecutorOptions {
  static constexpr std::size_t kMaxWorkers = 1024;
  // Worker threads; 0: one per core (std::thread::hardware_concurrency).
  std::size_t workers = 0;
  // Tasks waiting for a worker at most (not counting the running ones), >= 1.
  std::size_t max_queued = 256;
};

// Field names are the mdrd flags: workers in [0, kMaxWorkers], max-queued-calls >= 1.
Status ValidateExecutorOptions(const ExecutorOptions& options);

class Executor {
 public:
  using Task = std::function<void()>;

  explicit Executor(const ExecutorOptions& options);
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;
  // Stop().
  ~Executor();

  // Queues task behind the earlier tasks of its strand (empty strand: ordered with nothing).
  // False, and the task is dropped unrun, when max_queued tasks are waiting or after Stop.
  bool Submit(const std::string& strand, Task task);
  // Refuses new tasks, runs every queued one, then joins the workers. Idempotent.
  void Stop();

  std::size_t workers() const { return workers_.size(); }
  std::size_t max_queued() const { return max_queued_; }
  // Tasks waiting for a worker now.
  std::size_t queued() const;

 private:
  void Work();

  const std::size_t max_queued_;
  mutable std::mutex mutex_;
  std::condition_variable wakeup_;
  // The strands with tasks not yet finished; a strand is in ready_ while it has a task waiting
  // and none running.
  std::unordered_map<std::string, std::deque<Task>> strands_;  // guarded by mutex_
  std::deque<std::string> ready_;                              // guarded by mutex_
  std::size_t queued_ = 0;                                     // guarded by mutex_
  std::uint64_t anonymous_strands_ = 0;                        // guarded by mutex_
  bool stopping_ = false;                                      // guarded by mutex_
  std::vector<std::thread> workers_;
};

}  // namespace mdr::service
