// Errors of the service layer as grpc::Status, in the form "field: message".
#pragma once

#include <grpcpp/support/status.h>

#include <string>

#include "mdr/core/status.h"

namespace mdr::service {

// The one mapping of core errors to gRPC: kInvalidArgument -> INVALID_ARGUMENT, etc.
grpc::Status ToGrpcStatus(const Status& status);

// An error of the service itself (a code the core has no name for, e.g. ALREADY_EXISTS), in the
// same "field: message" form.
grpc::Status GrpcError(grpc::StatusCode code, const std::string& field, const std::string& message);

}  // namespace mdr::service
