// The core's ParallelFor (interface.h) on the service's worker pool (executor.h), so that an
// interface session's per-contact passes spread over the workers that also run the calls
// (issue #17, docs/interfaces.md "Threads"). Run splits [0, n) into shares that are claimed one at
// a time: the calling worker claims shares itself, and helper tasks submitted to the pool (empty
// strand) claim the rest when a worker is free. A share is run by whoever claims it first, so a
// full queue, a refused Submit or a busy pool only lose parallelism: the caller then runs every
// share itself and never waits for a task that has not started. A helper that starts after all
// shares were claimed returns at once. Results do not depend on who ran which share (the core
// steps every contact on its own and sums in index order).
#pragma once

#include <cstddef>

#include "mdr/core/interface.h"
#include "mdr/service/executor.h"

namespace mdr::service {

class PoolParallelFor final : public ParallelFor {
 public:
  // executor must outlive every Run (it may be stopped: then the caller runs everything).
  explicit PoolParallelFor(Executor& executor) : executor_(executor) {}

  // The pool's workers (the caller being one of them).
  int workers() const override;
  void Run(std::size_t n, const Body& body) override;

  // Shares per worker: finer than one range per worker, so that a worker that starts late or is
  // slowed by other calls leaves its part to the others.
  static constexpr std::size_t kSharesPerWorker = 4;

 private:
  Executor& executor_;
};

}  // namespace mdr::service
