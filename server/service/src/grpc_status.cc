#include "mdr/service/grpc_status.h"

#include <grpcpp/support/error_details.h>

#include <cstddef>
#include <iterator>

#include "google/rpc/error_details.pb.h"

namespace mdr::service {
namespace {

grpc::StatusCode ToGrpcCode(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return grpc::StatusCode::OK;
    case StatusCode::kInvalidArgument:
      return grpc::StatusCode::INVALID_ARGUMENT;
    case StatusCode::kFailedPrecondition:
      return grpc::StatusCode::FAILED_PRECONDITION;
    case StatusCode::kResourceExhausted:
      return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case StatusCode::kNotFound:
      return grpc::StatusCode::NOT_FOUND;
    case StatusCode::kDeadlineExceeded:
      return grpc::StatusCode::DEADLINE_EXCEEDED;
    case StatusCode::kCancelled:
      return grpc::StatusCode::CANCELLED;
    case StatusCode::kAlreadyExists:
      return grpc::StatusCode::ALREADY_EXISTS;
    case StatusCode::kUnauthenticated:
      return grpc::StatusCode::UNAUTHENTICATED;
    case StatusCode::kPermissionDenied:
      return grpc::StatusCode::PERMISSION_DENIED;
    case StatusCode::kUnavailable:
      return grpc::StatusCode::UNAVAILABLE;
    case StatusCode::kDataLoss:
      return grpc::StatusCode::DATA_LOSS;
    case StatusCode::kInternal:
      return grpc::StatusCode::INTERNAL;
  }
  return grpc::StatusCode::INTERNAL;  // a code added to the core but not mapped here
}

// The error's gRPC form: "field: message" with its details (see ToGrpcStatus).
grpc::Status GrpcError(grpc::StatusCode code, const std::string& field,
                       const std::string& message) {
  const std::string text = field.empty() ? message : field + ": " + message;
  if (code == grpc::StatusCode::OK) return grpc::Status::OK;
  google::rpc::Status rich;
  rich.set_code(code);
  rich.set_message(text);
  if (code == grpc::StatusCode::INVALID_ARGUMENT && !field.empty()) {  // first, as before
    google::rpc::BadRequest bad_request;
    google::rpc::BadRequest::FieldViolation* violation = bad_request.add_field_violations();
    violation->set_field(field);
    violation->set_description(message);
    rich.add_details()->PackFrom(bad_request);
  }
  google::rpc::ErrorInfo info;
  info.set_reason(CodeName(code));
  info.set_domain(kErrorDomain);
  if (!field.empty()) (*info.mutable_metadata())[kFieldKey] = field;
  rich.add_details()->PackFrom(info);
  grpc::Status status;
  grpc::SetErrorDetails(rich, &status);
  return status;
}

}  // namespace

const char* CodeName(grpc::StatusCode code) {
  static constexpr const char* kNames[] = {"OK",
                                           "CANCELLED",
                                           "UNKNOWN",
                                           "INVALID_ARGUMENT",
                                           "DEADLINE_EXCEEDED",
                                           "NOT_FOUND",
                                           "ALREADY_EXISTS",
                                           "PERMISSION_DENIED",
                                           "RESOURCE_EXHAUSTED",
                                           "FAILED_PRECONDITION",
                                           "ABORTED",
                                           "OUT_OF_RANGE",
                                           "UNIMPLEMENTED",
                                           "INTERNAL",
                                           "UNAVAILABLE",
                                           "DATA_LOSS",
                                           "UNAUTHENTICATED"};
  const auto index = static_cast<std::size_t>(code);
  return index < std::size(kNames) ? kNames[index] : "UNKNOWN";
}

grpc::Status ToGrpcStatus(const Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return GrpcError(ToGrpcCode(status.code()), status.field(), status.message());
}

void ToRpcStatus(const grpc::Status& status, google::rpc::Status* rpc_status) {
  if (!status.error_details().empty() && rpc_status->ParseFromString(status.error_details())) {
    return;
  }
  rpc_status->Clear();
  rpc_status->set_code(status.error_code());
  rpc_status->set_message(status.error_message());
}

}  // namespace mdr::service
