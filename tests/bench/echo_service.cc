#include "echo_service.h"

#include <mutex>
#include <utility>

namespace mdr::bench {
namespace {

using v1::ApplyResponse;
using v1::StreamApplyRequest;
using v1::StreamApplyResponse;

class EchoStreamReactor final
    : public grpc::ServerBidiReactor<StreamApplyRequest, StreamApplyResponse> {
 public:
  // step (optional) runs on every message before its answer is queued.
  EchoStreamReactor(const StreamApplyResponse& canned, const EchoService::StepFunction* step)
      : canned_(canned), step_(step) {
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    bool write = false, read = false, finish = false;
    if (ok && step_ != nullptr) (*step_)(request_.apply());  // request_ is not read into now
    {
      std::lock_guard lock(mutex_);
      if (!ok) {
        reads_done_ = true;
        finish = !writing_ && pending_ == 0;
      } else {
        ++pending_;
        write = !writing_;
        writing_ = true;
        read = pending_ < kMaxPending;
        reading_ = read;
      }
    }
    Continue(write, read, finish);
  }

  void OnWriteDone(bool ok) override {
    bool write = false, read = false, finish = false;
    {
      std::lock_guard lock(mutex_);
      --pending_;
      writing_ = ok && pending_ > 0;
      write = writing_;
      read = ok && !reads_done_ && !reading_ && pending_ < kMaxPending;
      if (read) reading_ = true;
      finish = !writing_ && (!ok || (reads_done_ && pending_ == 0));
    }
    Continue(write, read, finish);
  }

  void OnDone() override { delete this; }

 private:
  void Continue(bool write, bool read, bool finish) {
    if (write) StartWrite(&canned_);
    if (read) StartRead(&request_);
    if (finish) Finish(grpc::Status::OK);
  }

  static constexpr int kMaxPending = 8;
  const StreamApplyResponse& canned_;
  const EchoService::StepFunction* const step_;
  StreamApplyRequest request_;
  std::mutex mutex_;
  int pending_ = 0;
  bool writing_ = false, reading_ = true, reads_done_ = false;
};

}  // namespace

EchoService::EchoService(const ApplyResponse& canned, StepFunction engine_step)
    : canned_apply_(canned), engine_step_(std::move(engine_step)) {
  canned_stream_.mutable_status();
  *canned_stream_.mutable_result() = canned;
}

grpc::ServerUnaryReactor* EchoService::EchoApply(grpc::CallbackServerContext* context,
                                                 const v1::ApplyRequest*, ApplyResponse* response) {
  *response = canned_apply_;
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerBidiReactor<StreamApplyRequest, StreamApplyResponse>* EchoService::EchoStream(
    grpc::CallbackServerContext*) {
  return new EchoStreamReactor(canned_stream_, nullptr);
}

grpc::ServerBidiReactor<StreamApplyRequest, StreamApplyResponse>* EchoService::EngineStream(
    grpc::CallbackServerContext* context) {
  if (!engine_step_) return Echo::CallbackService::EngineStream(context);
  return new EchoStreamReactor(canned_stream_, &engine_step_);
}

}  // namespace mdr::bench
