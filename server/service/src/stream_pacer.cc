#include "mdr/service/stream_pacer.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>
#include <vector>

namespace mdr::service {

namespace {

double Seconds(std::chrono::nanoseconds duration) {
  return std::chrono::duration<double>(duration).count();
}

}  // namespace

void StreamBudget::Charge(std::string_view caller, std::chrono::nanoseconds cost,
                          Clock::time_point now) {
  std::lock_guard lock(mutex_);
  AccountLocked(caller, now).debt_seconds += Seconds(cost);
}

std::chrono::nanoseconds StreamBudget::BookRead(std::string_view caller,
                                                std::size_t other_active_callers,
                                                Clock::time_point now) {
  std::lock_guard lock(mutex_);
  Account& account = AccountLocked(caller, now);
  const double burst = Seconds(pacing_.burst);
  DrainLocked(account, now);
  if (other_active_callers == 0) account.debt_seconds = std::min(account.debt_seconds, burst);
  const double wait = (account.debt_seconds - burst) / pacing_.contended_share;
  account.debt_seconds += transport_seconds_;
  if (wait <= 0) return std::chrono::nanoseconds(0);
  // At least 1 µs, so that a positive wait never rounds to "read now"; at most an hour, so that
  // the time point cannot overflow.
  return std::chrono::nanoseconds(
      static_cast<std::int64_t>(std::ceil(std::clamp(wait, 1e-6, 3600.0) * 1e9)));
}

void StreamBudget::Calibrate(const TransportSample& sample) {
  std::lock_guard lock(mutex_);
  if (!calibrated_from_) {
    calibrated_from_ = sample;
    return;
  }
  const std::uint64_t calls = sample.calls - calibrated_from_->calls;
  if (calls < kMinCalls) return;
  const double outside_tasks = Seconds((sample.process_cpu - calibrated_from_->process_cpu) -
                                       (sample.worker_cpu - calibrated_from_->worker_cpu));
  const double measured = std::clamp(outside_tasks / static_cast<double>(calls), 1e-6, 1e-2);
  transport_seconds_ = 0.5 * (transport_seconds_ + measured);
  calibrated_from_ = sample;
}

std::chrono::nanoseconds StreamBudget::transport_cost() const {
  std::lock_guard lock(mutex_);
  return std::chrono::nanoseconds(static_cast<std::int64_t>(transport_seconds_ * 1e9));
}

std::size_t StreamBudget::callers() const {
  std::lock_guard lock(mutex_);
  return accounts_.size();
}

StreamBudget::Account& StreamBudget::AccountLocked(std::string_view caller, Clock::time_point now) {
  auto it = accounts_.find(std::string(caller));
  if (it == accounts_.end()) {
    ForgetRepaidLocked(now);
    it = accounts_.emplace(std::string(caller), Account{0, now}).first;
  }
  return it->second;
}

// Debts drain at the contended rate whether or not others are active: alone, BookRead caps the
// debt at burst anyway.
void StreamBudget::DrainLocked(Account& account, Clock::time_point now) const {
  if (now > account.drained_at) {
    account.debt_seconds = std::max(
        0.0, account.debt_seconds - pacing_.contended_share * Seconds(now - account.drained_at));
    account.drained_at = now;
  }
}

// Amortised: accounts are dropped once their number doubles since the last sweep.
void StreamBudget::ForgetRepaidLocked(Clock::time_point now) {
  if (accounts_.size() < forget_above_) return;
  for (auto it = accounts_.begin(); it != accounts_.end();) {
    DrainLocked(it->second, now);
    it = it->second.debt_seconds == 0 ? accounts_.erase(it) : std::next(it);
  }
  forget_above_ = std::max<std::size_t>(64, 2 * accounts_.size());
}

DelayedCalls::DelayedCalls() : thread_([this] { Run(); }) {}

DelayedCalls::~DelayedCalls() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wakeup_.notify_all();
  thread_.join();
}

void DelayedCalls::At(Clock::time_point when, std::function<void()> call) {
  {
    std::lock_guard lock(mutex_);
    calls_.emplace(when, std::move(call));
  }
  wakeup_.notify_all();
}

void DelayedCalls::RunAllNow() {
  {
    std::lock_guard lock(mutex_);
    all_now_ = true;
  }
  wakeup_.notify_all();
}

std::size_t DelayedCalls::scheduled() const {
  std::lock_guard lock(mutex_);
  return calls_.size();
}

void DelayedCalls::Run() {
  pthread_setname_np(pthread_self(), "mdr-pacer");
  std::unique_lock lock(mutex_);
  for (;;) {
    if (calls_.empty()) {
      all_now_ = false;
      if (stopping_) return;
      wakeup_.wait(lock);
      continue;
    }
    const bool run_all = all_now_ || stopping_;
    const auto due = run_all ? calls_.end() : calls_.upper_bound(Clock::now());
    if (due == calls_.begin()) {
      wakeup_.wait_until(lock, calls_.begin()->first);
      continue;
    }
    std::vector<std::function<void()>> ready;
    for (auto it = calls_.begin(); it != due; ++it) ready.push_back(std::move(it->second));
    calls_.erase(calls_.begin(), due);
    lock.unlock();  // a call may schedule another
    for (auto& call : ready) call();
    lock.lock();
  }
}

}  // namespace mdr::service
