#include "mdr/service/executor.h"

#include <pthread.h>

#include <algorithm>
#include <string>
#include <utility>

#include "mdr/service/metrics.h"

namespace mdr::service {
namespace {

std::size_t WorkerCount(std::size_t requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

Status ValidateExecutorOptions(const ExecutorOptions& options) {
  if (options.workers > ExecutorOptions::kMaxWorkers) {
    return InvalidArgument("workers",
                           "must be in [0, " + std::to_string(ExecutorOptions::kMaxWorkers) +
                               "] (0: one per core), got " + std::to_string(options.workers));
  }
  if (options.max_queued < 1) return InvalidArgument("max-queued-calls", "must be >= 1, got 0");
  return OkStatus();
}

Executor::Executor(const ExecutorOptions& options)
    : max_queued_(std::max<std::size_t>(options.max_queued, 1)) {
  const std::size_t count = WorkerCount(options.workers);
  workers_.reserve(count);
  for (std::size_t i = 0; i < count; ++i) workers_.emplace_back([this] { Work(); });
}

Executor::~Executor() { Stop(); }

bool Executor::Submit(const std::string& strand, Task task) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    if (queued_ >= max_queued_) {
      ProcessMetrics().work_rejected.Increment();
      return false;
    }
    // Session names never start with a control character, so anonymous strands cannot collide.
    std::string key = strand;
    if (key.empty()) {
      key = '\x01';  // (not "\x01" + ...: GCC 12 warns falsely on that form)
      key += std::to_string(anonymous_strands_++);
    }
    auto [it, created] = strands_.try_emplace(key);
    it->second.push_back(std::move(task));
    ++queued_;
    if (!created) return true;  // already ready or running: it runs after the earlier ones
    ready_.push_back(key);
  }
  wakeup_.notify_one();
  return true;
}

void Executor::Stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
  }
  wakeup_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
  workers_.clear();
}

std::size_t Executor::queued() const {
  std::lock_guard lock(mutex_);
  return queued_;
}

void Executor::Work() {
  pthread_setname_np(pthread_self(), "mdr-worker");  // tells them apart in top -H, perf and gdb
  std::unique_lock lock(mutex_);
  for (;;) {
    wakeup_.wait(lock, [this] { return !ready_.empty() || (stopping_ && strands_.empty()); });
    if (ready_.empty()) return;  // stopping, and every task has run
    std::string key = std::move(ready_.front());
    ready_.pop_front();
    std::deque<Task>& tasks = strands_.at(key);
    Task task = std::move(tasks.front());
    tasks.pop_front();
    --queued_;
    lock.unlock();
    task();
    task = nullptr;  // destroyed outside the lock
    lock.lock();
    std::deque<Task>& rest = strands_.at(key);  // rehashing may have moved it
    if (rest.empty()) {
      strands_.erase(key);
      if (stopping_ && strands_.empty()) wakeup_.notify_all();
    } else {
      ready_.push_back(std::move(key));  // behind the other strands: fair between sessions
      wakeup_.notify_one();
    }
  }
}

}  // namespace mdr::service
