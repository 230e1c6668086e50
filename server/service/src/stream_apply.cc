#include "mdr/service/stream_apply.h"

#include <spdlog/spdlog.h>
#include <time.h>

#include <algorithm>
#include <utility>

#include "mdr/service/call_context.h"
#include "mdr/service/grpc_status.h"
#include "mdr/service/metrics.h"

namespace mdr::service {

StreamRegistry::Admission StreamRegistry::Add(StreamApplyReactor* stream,
                                              const std::string& caller) {
  std::lock_guard lock(mutex_);
  if (draining_) return Admission::kDraining;
  std::size_t& open = per_caller_[caller];
  if (open >= max_per_caller_) {
    if (open == 0) per_caller_.erase(caller);
    return Admission::kCallerFull;
  }
  ++open;
  streams_.emplace(stream, caller);
  return Admission::kAdded;
}

void StreamRegistry::Remove(StreamApplyReactor* stream) {
  std::lock_guard lock(mutex_);
  auto it = streams_.find(stream);
  if (it == streams_.end()) return;
  if (auto open = per_caller_.find(it->second); --open->second == 0) per_caller_.erase(open);
  streams_.erase(it);
}

void StreamRegistry::DrainAll() {
  {
    // Held throughout: a stream removes itself (in OnDone, never inline in Finish) before it is
    // deleted, so every pointer here is alive.
    std::lock_guard lock(mutex_);
    draining_ = true;
    for (const auto& [stream, caller] : streams_) stream->Drain();
  }
  resumptions_.RunAllNow();
}

void StreamRegistry::MaybeCalibrate(StreamBudget::Clock::time_point now) {
  StreamBudget::Clock::rep due = next_calibration_.load(std::memory_order_relaxed);
  const StreamBudget::Clock::rep ticks = now.time_since_epoch().count();
  if (ticks < due ||
      !next_calibration_.compare_exchange_strong(
          due, ticks + StreamBudget::Clock::duration(kCalibrationInterval).count())) {
    return;  // not yet, or another thread samples
  }
  timespec process{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &process);
  budget_.Calibrate(
      {std::chrono::seconds(process.tv_sec) + std::chrono::nanoseconds(process.tv_nsec),
       executor_.worker_cpu_time(), RecordedCalls()});
}

std::size_t StreamRegistry::size() const {
  std::lock_guard lock(mutex_);
  return streams_.size();
}

StreamApplyReactor::StreamApplyReactor(grpc::CallbackServerContext* context,
                                       ContactOperations& operations,
                                       const Authenticator* authenticator, StreamRegistry& registry,
                                       Executor& executor, const std::atomic<bool>& server_stopping)
    : operations_(operations),
      registry_(registry),
      executor_(executor),
      interrupt_(InterruptOf(context, &cancelled_, &server_stopping)),
      interruption_(InterruptionOf(interrupt_)),
      metadata_request_id_(RequestIdOf(context)) {
  // No reaction runs before the handler returns this reactor, so the flags need no lock yet.
  if (Status status = CallerOf(context, authenticator, &caller_); !status.ok()) {
    const grpc::Status sent = ToGrpcStatus(status);
    LogCall("StreamApply", "", metadata_request_id_, sent, 0);
    finished_ = true;
    Finish(sent);
    return;
  }
  caller_key_ = CallerKeyOf(context, caller_);
  const StreamRegistry::Admission admission = registry_.Add(this, caller_key_);
  if (admission == StreamRegistry::Admission::kCallerFull) {
    const grpc::Status sent = ToGrpcStatus(ResourceExhausted(
        "max-streams-per-caller",
        "this caller already holds " + std::to_string(registry_.max_per_caller()) +
            " open StreamApply streams (mdrd --max-streams-per-caller); close one first"));
    LogCall("StreamApply", "", metadata_request_id_, sent, 0);
    finished_ = true;
    Finish(sent);
    return;
  }
  reading_ = true;
  read_buffer_ = std::make_unique<Message>();
  StartRead(read_buffer_.get());
  if (admission == StreamRegistry::Admission::kDraining) Drain();
}

void StreamApplyReactor::Drain() {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    draining_ = true;  // the owner of applying_ drops the unapplied messages
    actions = NextActionsLocked();
  }
  Start(actions);
}

void StreamApplyReactor::Resume() {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    const auto now = StreamBudget::Clock::now();
    if (now < read_booked_at_ && !StoppedLocked() && !cancelled_.load(std::memory_order_relaxed)) {
      actions.resume_at = std::min(read_booked_at_, now + registry_.budget().pacing().max_pause);
    } else {
      paused_ = false;
      read_booked_ = true;
      actions = NextActionsLocked();
    }
  }
  Start(actions);
}

void StreamApplyReactor::OnReadDone(bool ok) {
  Actions actions;
  bool submit = false;
  {
    std::lock_guard lock(mutex_);
    reading_ = false;
    if (!ok) reads_done_ = true;
    // Once a drain started (or the client is gone) nothing more is applied.
    if (ok && !StoppedLocked()) {
      unapplied_.push_back(std::move(read_buffer_));
      submit = !applying_;
      applying_ = true;
    } else {
      RecycleLocked(std::move(read_buffer_));
    }
    // The thread that applies holds the next read until the answer's write is started (or the
    // message is queued for a worker), as an echo does: more messages per second than reading
    // first (docs/operations.md, "Streams").
    actions = NextActionsLocked(submit ? ReadBooking::kHeld : ReadBooking::kAllowed);
  }
  Start(actions);  // never a finish while applying_
  if (submit) SubmitNext();
}

void StreamApplyReactor::SubmitNext() {
  const Message* next = nullptr;
  {
    std::lock_guard lock(mutex_);
    next = unapplied_.front().get();  // stays until this owner removes it
  }
  int inline_run = 0;
  while (next != nullptr) {
    const std::string& session = next->apply().session();
    // A message whose cost is bounded a priori and small, for a session with nothing queued, is
    // answered on this thread (docs/operations.md, "Inline steps"): at most kMaxRunLength in a
    // row, then the rest go to the workers in turn with the other strands.
    bool stopped = false;
    {
      std::lock_guard lock(mutex_);
      stopped = StoppedLocked();  // then ApplyRun drops what is left, on a worker
    }
    if (inline_run < kMaxRunLength && !stopped) {
      std::optional<v1::StreamApplyResponse> answer;
      if (executor_.TryRunInline(caller_key_, session, [&] {
            answer = Answer(next->apply(), /*bounded_only=*/true);
            return answer.has_value();
          })) {
        ++inline_run;
        bool same_session = false;
        next = Answered(std::move(*answer), &same_session);
        continue;
      }
    }
    StartHeldRead();  // before the task can run: once it is queued, `this` may be gone
    // The strand is copied before the task can run.
    const Executor::Admission admission =
        executor_.Submit(caller_key_, session, [this] { ApplyRun(); });
    if (admission == Executor::Admission::kQueued) return;
    v1::StreamApplyResponse busy;
    const grpc::Status refused = ToGrpcStatus(RefusalStatus(executor_, admission));
    ToRpcStatus(refused, busy.mutable_status());
    LogCall("StreamApply", session, metadata_request_id_, refused, 0);
    bool same_session = false;
    next = Answered(std::move(busy), &same_session);
  }
}

void StreamApplyReactor::StartHeldRead() {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    actions = NextActionsLocked();
  }
  Start(actions);  // never a finish while applying_
}

void StreamApplyReactor::ApplyRun() {
  const Message* message = nullptr;
  {
    std::lock_guard lock(mutex_);
    if (!StoppedLocked()) message = unapplied_.front().get();
  }
  if (message == nullptr) {  // stopped before applying anything: drop what is left
    Actions actions;
    {
      std::lock_guard lock(mutex_);
      DropUnappliedLocked();
      actions = NextActionsLocked();
    }
    Start(actions);
    return;
  }
  for (int applied = 1;; ++applied) {
    bool same_session = false;
    message = Answered(*Answer(message->apply(), /*bounded_only=*/false), &same_session);
    if (message == nullptr) return;
    if (!same_session || applied == kMaxRunLength) {
      SubmitNext();  // another strand, or a fair turn for the other strands
      return;
    }
  }
}

const StreamApplyReactor::Message* StreamApplyReactor::Answered(v1::StreamApplyResponse response,
                                                                bool* same_session) {
  Actions actions;
  const Message* next = nullptr;
  {
    std::lock_guard lock(mutex_);
    pending_.push_back(std::move(response));
    ++answered_;
    std::unique_ptr<Message> done = std::move(unapplied_.front());
    unapplied_.pop_front();
    if (StoppedLocked()) {
      DropUnappliedLocked();
    } else if (unapplied_.empty()) {
      applying_ = false;
    } else {
      next = unapplied_.front().get();
      *same_session = next->apply().session() == done->apply().session();
    }
    RecycleLocked(std::move(done));  // a read may reuse it as soon as the lock is released
    actions = NextActionsLocked();
  }
  Start(actions);  // a finish only when nothing more is applied: `this` is not used after it
  return next;
}

void StreamApplyReactor::DropUnappliedLocked() {
  while (!unapplied_.empty()) {
    RecycleLocked(std::move(unapplied_.front()));
    unapplied_.pop_front();
  }
  applying_ = false;
}

void StreamApplyReactor::RecycleLocked(std::unique_ptr<Message> message) {
  if (message != nullptr) spare_.push_back(std::move(message));
}

void StreamApplyReactor::OnWriteDone(bool ok) {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (ok) {
      pending_.pop_front();
    } else {
      write_failed_ = true;
      pending_.clear();
    }
    actions = NextActionsLocked();
  }
  Start(actions);
}

void StreamApplyReactor::OnDone() {
  spdlog::debug("rpc=StreamApply event=closed answered={}", answered_);
  registry_.Remove(this);
  delete this;
}

std::optional<v1::StreamApplyResponse> StreamApplyReactor::Answer(const v1::ApplyRequest& apply,
                                                                  bool bounded_only) {
  const auto start = std::chrono::steady_clock::now();
  v1::StreamApplyResponse response;
  std::optional<Status> applied;
  if (bounded_only) {
    applied =
        operations_.ApplyIfBounded(caller_, apply, response.mutable_result(), &recent_sessions_);
    if (!applied) return std::nullopt;
  } else {
    applied = operations_.Apply(caller_, apply, interruption_, response.mutable_result(),
                                interrupt_, &recent_sessions_);
  }
  const grpc::Status status = ToGrpcStatus(*applied);
  if (status.ok()) {
    response.mutable_status();  // present, code OK
  } else {
    response.clear_result();
    ToRpcStatus(status, response.mutable_status());
  }
  const auto end = std::chrono::steady_clock::now();
  registry_.budget().Charge(caller_key_, end - start, end);
  LogCall("StreamApply", apply.session(),
          apply.request_id().empty() ? metadata_request_id_ : apply.request_id(), status,
          std::chrono::duration<double>(end - start).count());
  return response;
}

StreamApplyReactor::Actions StreamApplyReactor::NextActionsLocked(ReadBooking reads) {
  Actions actions;
  if (finished_) return actions;
  if (!writing_ && !write_failed_ && !pending_.empty()) {
    writing_ = true;
    actions.write = &pending_.front();  // deque::push_back keeps it valid
  }
  const bool more_wanted =
      reads == ReadBooking::kAllowed && !reads_done_ && !draining_ && !write_failed_;
  if (more_wanted && !reading_ && !paused_ &&
      unapplied_.size() + pending_.size() < kMaxPendingResponses) {
    if (!std::exchange(read_booked_, false)) {
      const auto now = StreamBudget::Clock::now();
      registry_.MaybeCalibrate(now);
      const auto delay =
          registry_.budget().BookRead(caller_key_, OtherActiveCallersLocked(now), now);
      if (delay.count() > 0) {
        paused_ = true;
        read_booked_at_ = now + delay;
        actions.resume_at = std::min(read_booked_at_, now + registry_.budget().pacing().max_pause);
        ProcessMetrics().stream_read_pauses.Increment();
        return actions;  // a write started above goes on; nothing finishes while paused
      }
    }
    reading_ = true;
    if (spare_.empty()) {
      read_buffer_ = std::make_unique<Message>();
    } else {
      read_buffer_ = std::move(spare_.back());
      spare_.pop_back();
    }
    actions.read = read_buffer_.get();
  }
  if (writing_ || applying_ || paused_) return actions;
  if (write_failed_) {
    actions.finish = ToGrpcStatus(Cancelled("", "the client stopped reading"));
  } else if (draining_) {
    actions.finish = ToGrpcStatus(Unavailable("",
                                              "the server is shutting down; every message without "
                                              "a response was not applied: send it to another "
                                              "server"));
  } else if (reads_done_ && !reading_) {
    actions.finish = grpc::Status::OK;
  }
  if (actions.finish) finished_ = true;
  return actions;
}

std::size_t StreamApplyReactor::OtherActiveCallersLocked(StreamBudget::Clock::time_point now) {
  if (now >= other_callers_at_ + kOtherCallersRefresh) {
    other_callers_ = executor_.OtherActiveCallers(caller_key_);
    other_callers_at_ = now;
  }
  return other_callers_;
}

void StreamApplyReactor::Start(const Actions& actions) {
  if (actions.resume_at) registry_.ResumeAt(*actions.resume_at, [this] { Resume(); });
  if (actions.write != nullptr) StartWrite(actions.write);
  if (actions.read != nullptr) StartRead(actions.read);
  if (actions.finish) Finish(*actions.finish);
}

}  // namespace mdr::service
