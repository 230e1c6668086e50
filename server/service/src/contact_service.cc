#include "mdr/service/contact_service.h"

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "mdr/bridge/analysis_ops.h"
#include "mdr/service/call_context.h"
#include "mdr/service/grpc_status.h"

namespace mdr::service {

using bridge::RunAnalyzeLoops;
using bridge::RunBackbone;
using bridge::RunFitLoops;
using bridge::RunFrettingMap;
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A cheap call: runs to completion on gRPC's thread and finishes its reactor before returning
// it, after one structured log line.
class InlineCall {
 public:
  InlineCall(grpc::CallbackServerContext* context, const char* method, std::string session)
      : context_(context),
        method_(method),
        session_(std::move(session)),
        request_id_(RequestIdOf(context)) {}

  // Authenticates the caller and, if that succeeds, finishes with operation(caller), mapped to
  // gRPC here.
  template <typename Operation>
  grpc::ServerUnaryReactor* Run(const Authenticator* authenticator, Operation operation) const {
    Principal caller;
    Status status = CallerOf(context_, authenticator, &caller);
    if (status.ok()) status = operation(caller);
    const grpc::Status sent = ToGrpcStatus(status);
    LogCall(method_, session_, request_id_, sent, SecondsSince(start_));
    grpc::ServerUnaryReactor* reactor = context_->DefaultReactor();
    reactor->Finish(sent);
    return reactor;
  }

 private:
  grpc::CallbackServerContext* const context_;
  const char* const method_;
  const std::string session_;
  const std::string request_id_;
  const Clock::time_point start_ = Clock::now();
};

// A computing call: its reactor outlives the handler, runs the operation on a worker and is
// deleted by gRPC's OnDone once finished. OnCancel (client gone, deadline, server shutdown) sets
// the flag the core's Interrupt reads.
class QueuedCall final : public grpc::ServerUnaryReactor {
 public:
  using Operation = std::function<Status(const Principal&, const Interrupt&)>;

  QueuedCall(grpc::CallbackServerContext* context, const char* method, std::string session,
             const std::string& request_id, const std::atomic<bool>& server_stopping,
             std::chrono::milliseconds max_duration)
      : method_(method),
        session_(std::move(session)),
        request_id_(RequestIdOf(context, request_id)),
        interrupt_(InterruptOf(context, &cancelled_, &server_stopping, max_duration)) {}

  void OnCancel() override { cancelled_.store(true, std::memory_order_relaxed); }
  void OnDone() override { delete this; }

  // On a worker: the operation, unless the call was given up while it waited.
  void Run(const Principal& caller, const Operation& operation) {
    if (Status waited = interrupt_.Check(); !waited.ok()) {
      const bool late = waited.code() == StatusCode::kDeadlineExceeded;
      Complete(late ? DeadlineExceeded(
                          "",
                          "the deadline passed while the call waited for a worker; it was not "
                          "run")
                    : Cancelled("",
                                "the call was cancelled while it waited for a worker; it was not "
                                "run"));
      return;
    }
    Complete(operation(caller, interrupt_));
  }

  // Maps the status to gRPC (the one place for this call), logs and finishes the call.
  void Complete(const Status& status) {
    const grpc::Status sent = ToGrpcStatus(status);
    LogCall(method_, session_, request_id_, sent, SecondsSince(start_));
    Finish(sent);
  }

 private:
  const char* const method_;
  const std::string session_;
  const std::string request_id_;
  const Clock::time_point start_ = Clock::now();
  std::atomic<bool> cancelled_{false};
  const Interrupt interrupt_;  // after cancelled_, which it points to
};

// Runs `run(response)` and records its time in response->compute_seconds (the analysis calls).
template <typename Response, typename Run>
Status Timed(Response* response, Run run) {
  const Clock::time_point start = Clock::now();
  Status status = run(response);
  if (!status.ok()) {
    response->Clear();
    return status;
  }
  response->set_compute_seconds(SecondsSince(start));
  return status;
}

// FitLoops: a server stream computed on a worker. gRPC allows one write in flight: a progress
// message produced while one is being written replaces the one waiting (the latest matters); the
// result is written last, with the status, after every progress message sent. Nothing touches
// the call after Finish (gRPC then deletes it in OnDone), and gRPC calls happen outside the lock.
class FitLoopsCall final : public grpc::ServerWriteReactor<v1::FitLoopsResponse> {
 public:
  FitLoopsCall(grpc::CallbackServerContext* context, const std::atomic<bool>& server_stopping,
               std::chrono::milliseconds max_duration)
      : request_id_(RequestIdOf(context)),
        interrupt_(InterruptOf(context, &cancelled_, &server_stopping, max_duration)) {}

  void OnCancel() override { cancelled_.store(true, std::memory_order_relaxed); }
  void OnDone() override { delete this; }
  void OnWriteDone(bool ok) override {
    std::unique_lock lock(mutex_);
    writing_ = false;
    write_failed_ = write_failed_ || !ok;  // the client is gone: the interrupt stops the fit
    Next(lock);
  }

  const Interrupt& interrupt() const { return interrupt_; }

  // On the worker, during the fit.
  void Progress(const v1::FitProgress& progress) {
    std::unique_lock lock(mutex_);
    *waiting_.mutable_progress() = progress;
    has_waiting_ = true;
    Next(lock);
  }

  // On the worker: the fit's outcome; the last call the worker makes on this object.
  void Complete(const Status& status, v1::FitResult result) {
    std::unique_lock lock(mutex_);
    final_ = status;
    *result_.mutable_result() = std::move(result);
    done_ = true;
    Next(lock);
  }

 private:
  // With the lock held: start the next write or the finish if none is in flight.
  void Next(std::unique_lock<std::mutex>& lock) {
    if (writing_ || finishing_) return;
    if (has_waiting_ && !write_failed_) {
      writing_ = true;
      has_waiting_ = false;
      out_.Swap(&waiting_);
      lock.unlock();
      StartWrite(&out_);
      return;
    }
    if (!done_) return;
    finishing_ = true;
    const grpc::Status sent = ToGrpcStatus(final_);
    LogCall("FitLoops", "", request_id_, sent, SecondsSince(start_));
    const bool with_result = final_.ok() && !write_failed_;
    if (with_result) out_.Swap(&result_);
    lock.unlock();
    if (with_result) {
      StartWriteAndFinish(&out_, grpc::WriteOptions(), sent);
    } else {
      Finish(sent);
    }
  }

  const std::string request_id_;
  const Clock::time_point start_ = Clock::now();
  std::atomic<bool> cancelled_{false};
  const Interrupt interrupt_;  // after cancelled_, which it points to
  std::mutex mutex_;
  v1::FitLoopsResponse out_, waiting_, result_;  // out_: the message being written
  bool has_waiting_ = false, writing_ = false, write_failed_ = false;
  bool done_ = false, finishing_ = false;
  Status final_;
};

}  // namespace

class ApplyMessagePool::Messages final
    : public grpc::MessageHolder<v1::ApplyRequest, v1::ApplyResponse> {
 public:
  explicit Messages(ApplyMessagePool* pool) : pool_(pool) {
    set_request(&request_);
    set_response(&response_);
  }
  void Release() override { pool_->Return(this); }
  // Whether the messages are worth keeping, and then cleared for the next call.
  bool Recycle() {
    if (request_.steps_size() > kMaxKeptSteps) return false;
    request_.Clear();
    response_.Clear();
    return true;
  }

 private:
  ApplyMessagePool* const pool_;
  v1::ApplyRequest request_;
  v1::ApplyResponse response_;
};

ApplyMessagePool::ApplyMessagePool() = default;
ApplyMessagePool::~ApplyMessagePool() = default;

grpc::MessageHolder<v1::ApplyRequest, v1::ApplyResponse>* ApplyMessagePool::AllocateMessages() {
  {
    std::lock_guard lock(mutex_);
    if (!kept_.empty()) {
      Messages* messages = kept_.back().release();
      kept_.pop_back();
      return messages;
    }
  }
  return new Messages(this);
}

void ApplyMessagePool::Return(Messages* returned) {
  std::unique_ptr<Messages> messages(returned);
  if (!messages->Recycle()) return;  // cleared outside the lock
  std::lock_guard lock(mutex_);
  if (kept_.size() < kMaxKept) kept_.push_back(std::move(messages));
}

std::size_t ApplyMessagePool::kept() const {
  std::lock_guard lock(mutex_);
  return kept_.size();
}

template <typename Operation>
grpc::ServerUnaryReactor* ContactServiceImpl::Queue(grpc::CallbackServerContext* context,
                                                    const char* method, const std::string& strand,
                                                    const std::string& request_id,
                                                    Operation operation) {
  auto* call = new QueuedCall(context, method, strand, request_id, server_stopping_,
                              operations_.limits().max_call_duration);
  Principal caller;
  if (Status status = CallerOf(context, authenticator_, &caller); !status.ok()) {
    call->Complete(status);
    return call;
  }
  const Executor::Admission admission = executor_.Submit(
      CallerKeyOf(context, caller), strand,
      [call, caller, operation = std::move(operation)] { call->Run(caller, operation); });
  if (admission != Executor::Admission::kQueued) {
    call->Complete(RefusalStatus(executor_, admission));
  }
  return call;
}

template <typename Bounded, typename Operation>
grpc::ServerUnaryReactor* ContactServiceImpl::InlineOrQueue(grpc::CallbackServerContext* context,
                                                            const char* method,
                                                            const std::string& strand,
                                                            const std::string& request_id,
                                                            Bounded bounded, Operation operation) {
  const Clock::time_point start = Clock::now();
  Principal caller;
  if (CallerOf(context, authenticator_, &caller).ok()) {
    std::optional<Status> status;
    if (executor_.TryRunInline(CallerKeyOf(context, caller), strand, [&] {
          status = bounded(caller);
          return status.has_value();
        })) {
      const grpc::Status sent = ToGrpcStatus(*status);
      LogCall(method, strand, RequestIdOf(context, request_id), sent, SecondsSince(start));
      grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
      reactor->Finish(sent);
      return reactor;
    }
  }
  return Queue(context, method, strand, request_id, std::move(operation));
}

grpc::ServerUnaryReactor* ContactServiceImpl::CreateSession(grpc::CallbackServerContext* context,
                                                            const v1::CreateSessionRequest* request,
                                                            v1::Session* response) {
  return Queue(context, "CreateSession", "", "",
               [this, request, response](const Principal& caller, const Interrupt& interrupt) {
                 return operations_.CreateSession(caller, *request, response, interrupt);
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::GetSession(grpc::CallbackServerContext* context,
                                                         const v1::GetSessionRequest* request,
                                                         v1::Session* response) {
  const InlineCall call(context, "GetSession", request->name());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.GetSession(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ListSessions(grpc::CallbackServerContext* context,
                                                           const v1::ListSessionsRequest* request,
                                                           v1::ListSessionsResponse* response) {
  const InlineCall call(context, "ListSessions", "");
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.ListSessions(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::DeleteSession(grpc::CallbackServerContext* context,
                                                            const v1::DeleteSessionRequest* request,
                                                            google::protobuf::Empty* /*response*/) {
  // Else on the session's strand: after the calls queued on it, and a journal write off the
  // transport's threads.
  return InlineOrQueue(
      context, "DeleteSession", request->name(), "",
      [this, request](const Principal& caller) {
        return operations_.DeleteSessionIfBounded(caller, *request);
      },
      [this, request](const Principal& caller, const Interrupt&) {
        return operations_.DeleteSession(caller, *request);
      });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ExportSession(grpc::CallbackServerContext* context,
                                                            const v1::ExportSessionRequest* request,
                                                            v1::SessionSnapshot* response) {
  return Queue(context, "ExportSession", request->name(), "",
               [this, request, response](const Principal& caller, const Interrupt&) {
                 return operations_.ExportSession(caller, *request, response);
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ImportSession(grpc::CallbackServerContext* context,
                                                            const v1::ImportSessionRequest* request,
                                                            v1::Session* response) {
  return Queue(context, "ImportSession", "", "",
               [this, request, response](const Principal& caller, const Interrupt& interrupt) {
                 return operations_.ImportSession(caller, *request, response, interrupt);
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::Apply(grpc::CallbackServerContext* context,
                                                    const v1::ApplyRequest* request,
                                                    v1::ApplyResponse* response) {
  return InlineOrQueue(
      context, "Apply", request->session(), request->request_id(),
      [this, request, response](const Principal& caller) {
        return operations_.ApplyIfBounded(caller, *request, response);
      },
      [this, request, response](const Principal& caller, const Interrupt& interrupt) {
        return operations_.Apply(caller, *request, InterruptionOf(interrupt), response, interrupt);
      });
}

grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse>*
ContactServiceImpl::StreamApply(grpc::CallbackServerContext* context) {
  return new StreamApplyReactor(context, operations_, authenticator_, streams_, executor_,
                                server_stopping_);
}

grpc::ServerUnaryReactor* ContactServiceImpl::Query(grpc::CallbackServerContext* context,
                                                    const v1::QueryRequest* request,
                                                    v1::QueryResponse* response) {
  return Queue(context, "Query", request->session(), "",
               [this, request, response](const Principal& caller, const Interrupt& interrupt) {
                 return operations_.Query(caller, *request, response, interrupt);
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::Transform(grpc::CallbackServerContext* context,
                                                        const v1::TransformRequest* request,
                                                        v1::TransformResponse* response) {
  return Queue(context, "Transform", "", "",
               [this, request, response](const Principal&, const Interrupt&) {
                 return operations_.Transform(*request, response);
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::AnalyzeLoops(grpc::CallbackServerContext* context,
                                                           const v1::AnalyzeLoopsRequest* request,
                                                           v1::AnalyzeLoopsResponse* response) {
  return Queue(context, "AnalyzeLoops", "", "",
               [this, request, response](const Principal&, const Interrupt& interrupt) {
                 return Timed(response, [&](v1::AnalyzeLoopsResponse* r) {
                   return RunAnalyzeLoops(*request, operations_.limits().max_memory_vertices,
                                          interrupt, r);
                 });
               });
}

grpc::ServerWriteReactor<v1::FitLoopsResponse>* ContactServiceImpl::FitLoops(
    grpc::CallbackServerContext* context, const v1::FitLoopsRequest* request) {
  auto* call = new FitLoopsCall(context, server_stopping_, operations_.limits().max_call_duration);
  Principal caller;
  if (Status status = CallerOf(context, authenticator_, &caller); !status.ok()) {
    call->Complete(status, {});
    return call;
  }
  const Executor::Admission admission =
      executor_.Submit(CallerKeyOf(context, caller), "", [this, call, request] {
        v1::FitResult result;
        const Clock::time_point start = Clock::now();
        Status status = call->interrupt().Check();
        if (status.ok()) {
          status = RunFitLoops(
              *request, operations_.limits().max_memory_vertices, call->interrupt(),
              [call](const v1::FitProgress& progress) { call->Progress(progress); }, &result);
        }
        if (status.ok()) {
          result.set_compute_seconds(SecondsSince(start));
        } else {
          result.Clear();
        }
        call->Complete(status, std::move(result));
      });
  if (admission != Executor::Admission::kQueued) {
    call->Complete(RefusalStatus(executor_, admission), {});
  }
  return call;
}

grpc::ServerUnaryReactor* ContactServiceImpl::FrettingMap(grpc::CallbackServerContext* context,
                                                          const v1::FrettingMapRequest* request,
                                                          v1::FrettingMapResponse* response) {
  return Queue(context, "FrettingMap", "", "",
               [this, request, response](const Principal&, const Interrupt& interrupt) {
                 return Timed(response, [&](v1::FrettingMapResponse* r) {
                   return RunFrettingMap(*request, operations_.limits().max_memory_vertices,
                                         interrupt, r);
                 });
               });
}

grpc::ServerUnaryReactor* ContactServiceImpl::Backbone(grpc::CallbackServerContext* context,
                                                       const v1::BackboneRequest* request,
                                                       v1::BackboneResponse* response) {
  return Queue(context, "Backbone", "", "",
               [this, request, response](const Principal&, const Interrupt& interrupt) {
                 return Timed(response, [&](v1::BackboneResponse* r) {
                   return RunBackbone(*request, operations_.limits().max_memory_vertices, interrupt,
                                      r);
                 });
               });
}

}  // namespace mdr::service
