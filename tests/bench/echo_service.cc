#include "echo_service.h"

#include <mutex>

namespace mdr::bench {
namespace {

using v1::ApplyResponse;
using v1::StreamApplyRequest;
using v1::StreamApplyResponse;

class EchoStreamReactor final
    : public grpc::ServerBidiReactor<StreamApplyRequest, StreamApplyResponse> {
 public:
  explicit EchoStreamReactor(const StreamApplyResponse& canned) : canned_(canned) {
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    bool write = false, read = false, finish = false;
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
  StreamApplyRequest request_;
  std::mutex mutex_;
  int pending_ = 0;
  bool writing_ = false, reading_ = true, reads_done_ = false;
};

}  // namespace

EchoService::EchoService(const ApplyResponse& canned) : canned_apply_(canned) {
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
  return new EchoStreamReactor(canned_stream_);
}

}  // namespace mdr::bench
