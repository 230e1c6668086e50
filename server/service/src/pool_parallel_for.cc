#include "mdr/service/pool_parallel_for.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>

namespace mdr::service {
namespace {

// One Run: the shares, who claims the next one, and how many are done. Shared with the helper
// tasks, which may start (and find nothing left) after Run has returned.
struct Shares {
  Shares(std::size_t n, std::size_t count, const ParallelFor::Body& body)
      : n(n), count(count), body(&body) {}

  // Claims and runs shares until none is left. body is only touched for a claimed share, and Run
  // does not return before every claimed share is done, so it is still valid then.
  void RunUnclaimed() {
    for (;;) {
      const std::size_t share = next.fetch_add(1);
      if (share >= count) return;
      const std::size_t begin = n * share / count, end = n * (share + 1) / count;
      if (begin < end) (*body)(begin, end);
      std::lock_guard lock(mutex);
      if (++done == count) all_done.notify_all();
    }
  }

  void WaitUntilDone() {
    std::unique_lock lock(mutex);
    all_done.wait(lock, [this] { return done == count; });
  }

  const std::size_t n, count;
  const ParallelFor::Body* body;
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  std::condition_variable all_done;
  std::size_t done = 0;  // guarded by mutex
};

}  // namespace

int PoolParallelFor::workers() const { return static_cast<int>(executor_.workers()); }

void PoolParallelFor::Run(std::size_t n, const Body& body) {
  const auto pool_workers = static_cast<std::size_t>(std::max(workers(), 1));
  const std::size_t count = std::max<std::size_t>(std::min(n, pool_workers * kSharesPerWorker), 1);
  auto shares = std::make_shared<Shares>(n, count, body);
  for (std::size_t helper = 1; helper < std::min(pool_workers, count); ++helper) {
    // A full queue refuses the helper: skip it, the caller's share loop covers its part. The
    // helper is the running task's caller's work, under its quotas and turns.
    if (executor_.queued() >= executor_.max_queued()) break;
    if (executor_.Submit(Executor::CurrentCaller(), "", [shares] { shares->RunUnclaimed(); }) !=
        Executor::Admission::kQueued) {
      break;
    }
  }
  shares->RunUnclaimed();
  shares->WaitUntilDone();  // only shares already running on other workers remain
}

}  // namespace mdr::service
