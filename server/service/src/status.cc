#include "mdr/service/status.h"

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
  }
  return grpc::StatusCode::INTERNAL;  // a code added to the core but not mapped here
}

}  // namespace

grpc::Status ToGrpcStatus(const Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(ToGrpcCode(status.code()), status.ToString());
}

grpc::Status GrpcError(grpc::StatusCode code, const std::string& field,
                       const std::string& message) {
  return grpc::Status(code, field.empty() ? message : field + ": " + message);
}

}  // namespace mdr::service
