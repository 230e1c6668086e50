#include "mdr/service/call.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "mdr/service/log_value.h"
#include "mdr/service/status.h"

namespace mdr::service {

grpc::Status CallerOf(const grpc::CallbackServerContext* context,
                      const Authenticator* authenticator, Principal* caller) {
  caller->reset();
  if (authenticator == nullptr) return grpc::Status::OK;
  return authenticator->Authenticate(context->client_metadata(), caller);
}

ContactOperations::Interruption InterruptionOf(grpc::CallbackServerContext* context) {
  return [context]() -> grpc::Status {
    if (std::chrono::system_clock::now() > context->deadline()) {
      return GrpcError(grpc::StatusCode::DEADLINE_EXCEEDED, "",
                       "the deadline passed during the batch; nothing was applied");
    }
    if (context->IsCancelled()) {
      return GrpcError(grpc::StatusCode::CANCELLED, "",
                       "the call was cancelled during the batch; nothing was applied");
    }
    return grpc::Status::OK;
  };
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

const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    default:
      return "UNKNOWN";
  }
}

void LogCall(const char* method, const std::string& session, const std::string& request_id,
             const grpc::Status& status, double seconds) {
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
