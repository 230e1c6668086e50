// Why long work must stop before it is done: a deadline and cancellation flags that other threads
// set (the service fills them from the call's deadline and cancellation and from the server's
// drain). The long loops of the core (tabulated profile construction, grid steps, curved force
// paths, traction quadrature at many radii) check it at bounded intervals and then abandon their
// work without changing anything. No gRPC here.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>

#include "mdr/base/status.h"

namespace mdr {

class Interrupt {
 public:
  using Clock = std::chrono::steady_clock;

  // Never interrupts.
  Interrupt() = default;
  // Interrupts once `deadline` has passed or either flag (null: none) is set. The flags must
  // outlive every copy of this Interrupt.
  Interrupt(Clock::time_point deadline, const std::atomic<bool>* cancelled,
            const std::atomic<bool>* also_cancelled = nullptr)
      : deadline_(deadline), cancelled_{cancelled, also_cancelled} {}

  // OK to go on, else DeadlineExceeded or Cancelled (no field; the caller says what was
  // abandoned). Costs two atomic loads and a clock read.
  Status Check() const {
    for (const std::atomic<bool>* flag : cancelled_) {
      if (flag != nullptr && flag->load(std::memory_order_relaxed)) {
        return Cancelled(
            "", "the call was cancelled (by the client or a server shutdown); nothing was changed");
      }
    }
    if (deadline_ != Clock::time_point::max() && Clock::now() >= deadline_) {
      return DeadlineExceeded(
          "", "the call's deadline passed before the work was done; nothing was changed");
    }
    return OkStatus();
  }

  // Check() on every `period`-th call only, for loops whose iterations are cheap.
  Status CheckEvery(std::uint32_t period, std::uint64_t iteration) const {
    return iteration % period == 0 ? Check() : OkStatus();
  }

 private:
  Clock::time_point deadline_ = Clock::time_point::max();
  const std::atomic<bool>* cancelled_[2] = {nullptr, nullptr};
};

}  // namespace mdr
