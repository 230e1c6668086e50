#include "mdr/service/call_context.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "mdr/base/log_value.h"
#include "mdr/service/grpc_status.h"
#include "mdr/service/metrics.h"

namespace mdr::service {

Status CallerOf(const grpc::CallbackServerContext* context, const Authenticator* authenticator,
                Principal* caller) {
  caller->reset();
  if (authenticator == nullptr) return OkStatus();
  return authenticator->Authenticate(context->client_metadata(), caller);
}

Interrupt InterruptOf(const grpc::CallbackServerContext* context,
                      const std::atomic<bool>* call_cancelled,
                      const std::atomic<bool>* server_stopping,
                      std::chrono::milliseconds max_duration) {
  // gRPC's deadline is on the system clock (infinite: far in the future); the core's is steady.
  // Both bounds are compared in milliseconds below a year, so nothing overflows.
  constexpr auto kNoDeadline = std::chrono::hours(24 * 365);
  const auto remaining = std::min<std::chrono::system_clock::duration>(
      context->deadline() - std::chrono::system_clock::now(), kNoDeadline + std::chrono::hours(1));
  const auto bound = std::min<std::chrono::system_clock::duration>(
      remaining,
      std::min<std::chrono::milliseconds>(max_duration, kNoDeadline + std::chrono::hours(1)));
  const Interrupt::Clock::time_point deadline =
      bound > kNoDeadline
          ? Interrupt::Clock::time_point::max()
          : Interrupt::Clock::now() + std::chrono::duration_cast<Interrupt::Clock::duration>(bound);
  return Interrupt(deadline, call_cancelled, server_stopping);
}

ContactOperations::Interruption InterruptionOf(const Interrupt& interrupt) {
  return [interrupt]() -> Status {
    const Status status = interrupt.Check();
    if (status.ok()) return status;
    return status.code() == StatusCode::kDeadlineExceeded
               ? DeadlineExceeded("", "the deadline passed during the batch; nothing was applied")
               : Cancelled("",
                           "the call was cancelled (by the client or a server shutdown) during "
                           "the batch; nothing was applied");
  };
}

std::string PeerCallerKey(std::string_view peer) {
  std::string_view address = peer;
  if (peer.starts_with("ipv4:") || peer.starts_with("ipv6:")) {
    address.remove_prefix(5);
    // The port follows the last ':' ("[::1]:5" keeps its brackets, "1.2.3.4:5").
    if (const std::size_t colon = address.rfind(':');
        colon != std::string_view::npos && address.find(']', colon) == std::string_view::npos) {
      address = address.substr(0, colon);
    }
  }
  return "peer:" + std::string(address);
}

std::string CallerKeyOf(const grpc::CallbackServerContext* context, const Principal& caller) {
  if (caller) return "token:" + *caller;
  return PeerCallerKey(context->peer());
}

Status RefusalStatus(const Executor& executor, Executor::Admission admission) {
  switch (admission) {
    case Executor::Admission::kCallerQueueFull:
      return ResourceExhausted(
          "max-queued-calls-per-caller",
          "this caller already has " + std::to_string(executor.max_queued_per_caller()) +
              " calls waiting for a worker (mdrd --max-queued-calls-per-caller); nothing was "
              "run: wait for their answers before sending more");
    case Executor::Admission::kStopped:
      return Unavailable("", "the server is shutting down; nothing was run: retry elsewhere");
    case Executor::Admission::kQueued:
    case Executor::Admission::kBusy:
      break;
  }
  return Unavailable("", "the server is busy: " + std::to_string(executor.max_queued()) +
                             " calls already wait for its " + std::to_string(executor.workers()) +
                             " workers (mdrd --max-queued-calls) and this caller has its share of "
                             "them; nothing was run: retry with backoff");
}

std::string RequestIdOf(const grpc::CallbackServerContext* context,
                        const std::string& explicit_id) {
  if (!explicit_id.empty()) return explicit_id;
  const auto& metadata = context->client_metadata();
  if (auto it = metadata.find("x-request-id"); it != metadata.end()) {
    return std::string(it->second.data(), it->second.size());
  }
  return "-";
}

void LogCall(const char* method, const std::string& session, const std::string& request_id,
             const grpc::Status& status, double seconds) {
  RecordCall(method, CodeName(status.error_code()), seconds);
  const auto level = status.ok() ? spdlog::level::debug : spdlog::level::info;
  if (!spdlog::should_log(level)) return;
  const std::string shown_session = session.empty() ? "-" : LogValue(session);
  if (status.ok()) {
    spdlog::log(level, "rpc={} session={} request_id={} code=OK seconds={:.6f}", method,
                shown_session, LogValue(request_id), seconds);
  } else {
    spdlog::log(level, "rpc={} session={} request_id={} code={} seconds={:.6f} error={}", method,
                shown_session, LogValue(request_id), CodeName(status.error_code()), seconds,
                Quoted(status.error_message(), kMaxLoggedErrorBytes));
  }
}

}  // namespace mdr::service
