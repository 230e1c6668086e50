#include "mdr/service/stream_apply.h"

#include <spdlog/spdlog.h>

#include <utility>

#include "mdr/service/call.h"
#include "mdr/service/status.h"

namespace mdr::service {

bool StreamRegistry::Add(StreamApplyReactor* stream) {
  std::lock_guard lock(mutex_);
  if (draining_) return false;
  streams_.insert(stream);
  return true;
}

void StreamRegistry::Remove(StreamApplyReactor* stream) {
  std::lock_guard lock(mutex_);
  streams_.erase(stream);
}

void StreamRegistry::DrainAll() {
  // Held throughout: a stream removes itself (in OnDone, never inline in Finish) before it is
  // deleted, so every pointer here is alive.
  std::lock_guard lock(mutex_);
  draining_ = true;
  for (StreamApplyReactor* stream : streams_) stream->Drain();
}

std::size_t StreamRegistry::size() const {
  std::lock_guard lock(mutex_);
  return streams_.size();
}

StreamApplyReactor::StreamApplyReactor(grpc::CallbackServerContext* context,
                                       ContactOperations& operations,
                                       const Authenticator* authenticator, StreamRegistry& registry,
                                       Executor& executor, const std::atomic<bool>& server_stopping)
    : context_(context),
      operations_(operations),
      registry_(registry),
      executor_(executor),
      interrupt_(InterruptOf(context, &cancelled_, &server_stopping)),
      interruption_(InterruptionOf(interrupt_)) {
  // No reaction runs before the handler returns this reactor, so the flags need no lock yet.
  if (Status status = CallerOf(context, authenticator, &caller_); !status.ok()) {
    const grpc::Status sent = ToGrpcStatus(status);
    LogCall("StreamApply", "", RequestIdOf(context), sent, 0);
    finished_ = true;
    Finish(sent);
    return;
  }
  reading_ = true;
  StartRead(&request_);
  if (!registry_.Add(this)) Drain();
}

void StreamApplyReactor::Drain() {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    draining_ = true;
    actions = NextActionsLocked();
  }
  Start(actions);
}

void StreamApplyReactor::OnReadDone(bool ok) {
  Actions actions;
  bool apply = false;
  {
    std::lock_guard lock(mutex_);
    reading_ = false;
    if (!ok) reads_done_ = true;
    // Once a drain started (or the client is gone) nothing more is applied.
    apply = ok && !draining_ && !finished_ && !write_failed_;
    if (apply) {
      processing_ = true;
    } else {
      actions = NextActionsLocked();
    }
  }
  if (!apply) {
    Start(actions);
    return;
  }
  // No further read starts while processing_, so request_ stays as read until Process is done.
  if (executor_.Submit(request_.apply().session(), [this] { Process(); })) return;
  v1::StreamApplyResponse busy;
  const grpc::Status refused = ToGrpcStatus(BusyStatus(executor_));
  ToRpcStatus(refused, busy.mutable_status());
  LogCall("StreamApply", request_.apply().session(),
          RequestIdOf(context_, request_.apply().request_id()), refused, 0);
  Answered(std::move(busy));
}

void StreamApplyReactor::Process() { Answered(Answer()); }

void StreamApplyReactor::Answered(v1::StreamApplyResponse response) {
  Actions actions;
  {
    std::lock_guard lock(mutex_);
    processing_ = false;
    pending_.push_back(std::move(response));
    ++answered_;
    actions = NextActionsLocked();
  }
  Start(actions);
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

v1::StreamApplyResponse StreamApplyReactor::Answer() {
  const auto start = std::chrono::steady_clock::now();
  v1::StreamApplyResponse response;
  const v1::ApplyRequest& apply = request_.apply();
  const grpc::Status status = ToGrpcStatus(
      operations_.Apply(caller_, apply, interruption_, response.mutable_result(), interrupt_));
  if (status.ok()) {
    response.mutable_status();  // present, code OK
  } else {
    response.clear_result();
    ToRpcStatus(status, response.mutable_status());
  }
  LogCall("StreamApply", apply.session(), RequestIdOf(context_, apply.request_id()), status,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return response;
}

StreamApplyReactor::Actions StreamApplyReactor::NextActionsLocked() {
  Actions actions;
  if (finished_) return actions;
  if (!writing_ && !write_failed_ && !pending_.empty()) {
    writing_ = true;
    actions.write = &pending_.front();  // deque::push_back keeps it valid
  }
  const bool more_wanted = !reads_done_ && !draining_ && !write_failed_;
  if (more_wanted && !reading_ && !processing_ && pending_.size() < kMaxPendingResponses) {
    reading_ = true;
    actions.read = true;
  }
  if (writing_ || processing_) return actions;
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

void StreamApplyReactor::Start(const Actions& actions) {
  if (actions.write != nullptr) StartWrite(actions.write);
  if (actions.read) StartRead(&request_);
  if (actions.finish) Finish(*actions.finish);
}

}  // namespace mdr::service
