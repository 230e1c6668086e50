// Test-only echo of ContactService's message shapes (echo.proto): answers every call with a
// canned response of a real Apply. Its stream reads ahead like StreamApplyReactor (one write in
// flight, at most 8 answers queued), so a benchmark can measure the framework's own cost beside
// the real service in the same run (service-notes: compare as a ratio).
#pragma once

#include <functional>

#include "echo.grpc.pb.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::bench {

class EchoService final : public Echo::CallbackService {
 public:
  // Applies a message's steps in EngineStream (called on the transport's thread; streams never
  // share a session, so it is called concurrently only for different sessions).
  using StepFunction = std::function<void(const v1::ApplyRequest&)>;

  explicit EchoService(const v1::ApplyResponse& canned, StepFunction engine_step = {});

  grpc::ServerUnaryReactor* EchoApply(grpc::CallbackServerContext* context, const v1::ApplyRequest*,
                                      v1::ApplyResponse* response) override;
  grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse>* EchoStream(
      grpc::CallbackServerContext*) override;
  // UNIMPLEMENTED without a step function.
  grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse>* EngineStream(
      grpc::CallbackServerContext* context) override;

 private:
  const v1::ApplyResponse canned_apply_;
  const StepFunction engine_step_;
  v1::StreamApplyResponse canned_stream_;
};

}  // namespace mdr::bench
