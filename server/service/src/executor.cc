#include "mdr/service/executor.h"

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <limits>
#include <string>
#include <utility>

#include "mdr/service/metrics.h"

namespace mdr::service {
namespace {

std::size_t WorkerCount(std::size_t requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

thread_local std::string current_caller;

// The executor's lock for the inline path, taken after a short spin: its critical sections are
// a few hash lookups, and on a contended lock a futex sleep and wake-up cost far more than that.
std::unique_lock<std::mutex> LockSpinningFirst(std::mutex& mutex) {
  constexpr int kSpins = 64;
  for (int i = 0; i < kSpins; ++i) {
    if (mutex.try_lock()) return std::unique_lock(mutex, std::adopt_lock);
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
  return std::unique_lock(mutex);
}

}  // namespace

Status ValidateExecutorOptions(const ExecutorOptions& options) {
  if (options.workers > ExecutorOptions::kMaxWorkers) {
    return InvalidArgument("workers",
                           "must be in [0, " + std::to_string(ExecutorOptions::kMaxWorkers) +
                               "] (0: one per core), got " + std::to_string(options.workers));
  }
  if (options.max_queued < 1) return InvalidArgument("max-queued-calls", "must be >= 1, got 0");
  if (options.max_queued_per_caller < 1) {
    return InvalidArgument("max-queued-calls-per-caller", "must be >= 1, got 0");
  }
  if (options.reserve_workers < -1 ||
      options.reserve_workers > static_cast<int>(ExecutorOptions::kMaxWorkers)) {
    return InvalidArgument("reserve-workers", "must be in [-1, " +
                                                  std::to_string(ExecutorOptions::kMaxWorkers) +
                                                  "] (-1: as many as the workers), got " +
                                                  std::to_string(options.reserve_workers));
  }
  return OkStatus();
}

Executor::Executor(const ExecutorOptions& options) : options_(options) {
  const std::size_t count = WorkerCount(options.workers);
  workers_.reserve(count);
  for (std::size_t i = 0; i < count; ++i) workers_.emplace_back([this] { Work(false); });
  const std::size_t reserve =
      options.reserve_workers < 0 ? count : static_cast<std::size_t>(options.reserve_workers);
  reserve_.reserve(reserve);
  for (std::size_t i = 0; i < reserve; ++i) reserve_.emplace_back([this] { Work(true); });
}

Executor::~Executor() { Stop(); }

const std::string& Executor::CurrentCaller() { return current_caller; }

Executor::Admission Executor::Submit(std::string_view caller, std::string_view strand, Task task) {
  // Nothing of the caller's runs and every worker is busy: the reserve may take it. While a
  // worker is free no reserve thread is woken (a rig's sequential calls would wake one each).
  bool newcomer = false;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return Admission::kStopped;
    const Clock::time_point now = Clock::now();
    auto it = callers_.find(caller);
    const bool new_caller = it == callers_.end();
    if (new_caller) it = callers_.try_emplace(std::string(caller)).first;
    CallerQueue& queue = it->second;
    Admission refusal = Admission::kQueued;
    if (queue.queued >= options_.max_queued_per_caller) {
      refusal = Admission::kCallerQueueFull;
    } else if (queued_ >= options_.max_queued) {
      // Its fair share of the full queue: the active callers, itself included.
      const std::string_view self = it->first;
      const std::size_t others = ActiveCallersLocked(now, &self);
      const std::size_t share = std::max<std::size_t>(options_.max_queued / (others + 1), 1);
      if (queue.queued >= share || queued_ >= 2 * options_.max_queued) refusal = Admission::kBusy;
    }
    if (refusal != Admission::kQueued) {
      ProcessMetrics().work_rejected.Increment();
      if (new_caller) callers_.erase(it);
      return refusal;
    }
    // Session names never start with a control character, so anonymous strands cannot collide.
    std::string key(strand);
    if (key.empty()) {
      key = '\x01';  // (not "\x01" + ...: GCC 12 warns falsely on that form)
      key += std::to_string(queue.anonymous_strands++);
    }
    queue.last_active = now;
    ++queue.queued;
    ++queued_;
    auto [strand_it, new_strand] = queue.strands.try_emplace(key);
    strand_it->second.push_back(std::move(task));
    // It runs after the strand's earlier tasks, or once an inline task on it released it.
    if (!new_strand || ClaimedLocked(queue, key)) return Admission::kQueued;
    queue.ready.push_back(std::move(key));
    if (queue.ready.size() == 1) ready_callers_.push_back(it->first);
    newcomer = queue.running == 0 && workers_running_ >= workers_.size();
  }
  wakeup_.notify_one();
  if (newcomer) reserve_wakeup_.notify_one();
  return Admission::kQueued;
}

bool Executor::ClaimedLocked(const CallerQueue& queue, std::string_view strand) {
  return std::find(queue.claimed.begin(), queue.claimed.begin() + queue.claims, strand) !=
         queue.claimed.begin() + queue.claims;
}

bool Executor::TryRunInline(std::string_view caller, std::string_view strand,
                            const std::function<bool()>& task) {
  {
    const auto lock = LockSpinningFirst(mutex_);
    if (stopping_ || strand.empty()) return false;
    auto it = callers_.find(caller);
    if (it == callers_.end()) it = callers_.try_emplace(std::string(caller)).first;
    CallerQueue& queue = it->second;
    // A strand is in the map while it has a task queued or running: then this one waits its
    // turn, as it does behind another thread's inline task. Otherwise the strand is claimed:
    // Submit queues behind the claim, and no worker takes the strand until it is released.
    if (queue.strands.find(strand) != queue.strands.end() || ClaimedLocked(queue, strand)) {
      return false;
    }
    if (queue.claims < queue.claimed.size()) {
      queue.claimed[queue.claims].assign(strand);
    } else {
      queue.claimed.emplace_back(strand);
    }
    ++queue.claims;
    queue.last_active = Clock::now();  // not read again at the release: the task is bounded
  }
  const bool ran = task();  // bounded: it spreads nothing over the pool (CurrentCaller unset)
  bool newcomer = false;
  {
    const auto lock = LockSpinningFirst(mutex_);
    auto it = callers_.find(caller);  // active while it ran: not forgotten
    CallerQueue& queue = it->second;
    const auto claim =
        std::find(queue.claimed.begin(), queue.claimed.begin() + queue.claims, strand);
    std::swap(*claim, queue.claimed[--queue.claims]);
    if (queue.strands.find(strand) == queue.strands.end()) return ran;
    // Submitted while it ran: the strand's tasks go to the workers now.
    queue.ready.emplace_back(strand);
    if (queue.ready.size() == 1) ready_callers_.push_back(it->first);
    newcomer = queue.running == 0 && workers_running_ >= workers_.size();
  }
  wakeup_.notify_one();
  if (newcomer) reserve_wakeup_.notify_one();
  return ran;
}

void Executor::Stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty() && reserve_.empty()) return;
    stopping_ = true;
  }
  wakeup_.notify_all();
  reserve_wakeup_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
  for (std::thread& worker : reserve_) {
    if (worker.joinable()) worker.join();
  }
  workers_.clear();
  reserve_.clear();
}

std::size_t Executor::queued() const {
  std::lock_guard lock(mutex_);
  return queued_;
}

std::size_t Executor::busy() const {
  std::lock_guard lock(mutex_);
  return queued_ + running_;
}

bool Executor::ActiveLocked(const CallerQueue& queue, Clock::time_point now) const {
  return queue.queued > 0 || queue.running > 0 || queue.claims > 0 ||
         now - queue.last_active <= options_.recent_window;
}

std::chrono::nanoseconds Executor::worker_cpu_time() const {
  std::lock_guard lock(mutex_);
  // Workers return only once stopping_ is set: until then every clock is a live thread's.
  if (stopping_) return stopped_worker_cpu_;
  std::chrono::nanoseconds total{0};
  for (const clockid_t clock : worker_clocks_) {
    timespec used{};
    if (clock_gettime(clock, &used) == 0) {
      total += std::chrono::seconds(used.tv_sec) + std::chrono::nanoseconds(used.tv_nsec);
    }
  }
  stopped_worker_cpu_ = total;
  return total;
}

std::size_t Executor::OtherActiveCallers(std::string_view caller) const {
  std::lock_guard lock(mutex_);
  return ActiveCallersLocked(Clock::now(), &caller);
}

std::size_t Executor::ActiveCallersLocked(Clock::time_point now,
                                          const std::string_view* except) const {
  return std::count_if(callers_.begin(), callers_.end(), [&](const Callers::value_type& entry) {
    return (except == nullptr || entry.first != *except) && ActiveLocked(entry.second, now);
  });
}

void Executor::ForgetIdleCallersLocked(Clock::time_point now) {
  std::erase_if(callers_,
                [&](const Callers::value_type& entry) { return !ActiveLocked(entry.second, now); });
}

std::size_t Executor::RunningCapLocked(std::size_t active) const {
  if (stopping_) return std::numeric_limits<std::size_t>::max();  // drain at full speed
  const std::size_t reserved = active > 0 ? active - 1 : 0;       // one worker per other caller
  return workers_.size() > reserved ? workers_.size() - reserved : 1;
}

Executor::Callers::iterator Executor::NextRunnableLocked(Clock::time_point now) {
  ForgetIdleCallersLocked(now);
  if (ready_callers_.empty()) return callers_.end();
  const std::size_t cap = RunningCapLocked(ActiveCallersLocked(now, nullptr));
  for (auto name = ready_callers_.begin(); name != ready_callers_.end(); ++name) {
    auto it = callers_.find(*name);
    if (it->second.running >= cap) continue;
    ready_callers_.erase(name);
    return it;
  }
  return callers_.end();
}

Executor::Callers::iterator Executor::NextNewcomerLocked() {
  if (workers_running_ < workers_.size()) return callers_.end();  // a worker takes it
  for (auto name = ready_callers_.begin(); name != ready_callers_.end(); ++name) {
    auto it = callers_.find(*name);
    if (it->second.running > 0) continue;
    ready_callers_.erase(name);
    return it;
  }
  return callers_.end();
}

void Executor::Work(bool reserve) {
  // Tells them apart in top -H, perf and gdb.
  pthread_setname_np(pthread_self(), reserve ? "mdr-reserve" : "mdr-worker");
  clockid_t clock{};
  const bool has_clock = pthread_getcpuclockid(pthread_self(), &clock) == 0;
  std::unique_lock lock(mutex_);
  if (has_clock) worker_clocks_.push_back(clock);
  for (;;) {
    auto it = reserve ? NextNewcomerLocked() : NextRunnableLocked(Clock::now());
    if (it == callers_.end()) {
      if (stopping_ && queued_ == 0) return;  // every task has run or runs on another worker
      if (reserve) {
        reserve_wakeup_.wait(lock);  // a newcomer's task, or the stop
      } else if (ready_callers_.empty()) {
        wakeup_.wait(lock);
      } else {
        // Capped while others are active: look again when their activity may have expired.
        wakeup_.wait_for(lock, options_.recent_window);
      }
      continue;
    }
    const std::string caller = it->first;
    CallerQueue& queue = it->second;
    std::string strand = std::move(queue.ready.front());
    queue.ready.pop_front();
    if (!queue.ready.empty()) ready_callers_.push_back(caller);  // behind the others: its turn
    std::deque<Task>& tasks = queue.strands.at(strand);
    Task task = std::move(tasks.front());
    tasks.pop_front();
    --queue.queued;
    --queued_;
    ++queue.running;
    ++running_;
    // The last free worker taken while tasks wait: a newcomer among them is the reserve's now.
    const bool saturated =
        !reserve && ++workers_running_ == workers_.size() && !ready_callers_.empty();
    lock.unlock();
    if (saturated) reserve_wakeup_.notify_one();
    current_caller = caller;
    task();
    task = nullptr;  // destroyed outside the lock
    current_caller.clear();
    lock.lock();
    CallerQueue& after = callers_.at(caller);  // rehashing may have moved it
    --after.running;
    --running_;
    if (!reserve) --workers_running_;
    after.last_active = Clock::now();
    std::deque<Task>& rest = after.strands.at(strand);
    if (rest.empty()) {
      after.strands.erase(strand);
      if (stopping_ && queued_ == 0) {
        wakeup_.notify_all();
        reserve_wakeup_.notify_all();
      }
    } else {
      after.ready.push_back(std::move(strand));  // behind its other strands: fair between them
      if (after.ready.size() == 1) ready_callers_.push_back(caller);
      wakeup_.notify_one();
    }
  }
}

}  // namespace mdr::service
