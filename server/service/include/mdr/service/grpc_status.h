// Errors of the service layer as grpc::Status, in the form "field: message". The one place where
// an error becomes a gRPC status. Every error carries, in its binary error details
// (grpc::ExtractErrorDetails into a google::rpc::Status), a google.rpc.ErrorInfo (reason: the
// code's name, domain "mdr.v1", metadata "field": the offending field when there is one);
// INVALID_ARGUMENT errors naming a field also carry a google.rpc.BadRequest.
#pragma once

#include <grpcpp/support/status.h>

#include <string>

#include "google/rpc/status.pb.h"
#include "mdr/base/status.h"

namespace mdr::service {

// ErrorInfo.domain of this API's errors and the metadata key of the offending field.
inline constexpr char kErrorDomain[] = "mdr.v1";
inline constexpr char kFieldKey[] = "field";

// An error of the core or of the service mapped to its gRPC code (kInvalidArgument ->
// INVALID_ARGUMENT, ...): message "field: message" (just "message" when field is empty), the
// ErrorInfo and, for INVALID_ARGUMENT with a field, a BadRequest detail. Called once per call at
// the transport edge (the unary handlers, StreamApply, start-up); every layer below returns Status.
grpc::Status ToGrpcStatus(const Status& status);

// The google.rpc.Code name of a code ("OK", "INVALID_ARGUMENT", ...): ErrorInfo.reason, the logs'
// code= and the metrics' code label.
const char* CodeName(grpc::StatusCode code);

// The status as a google.rpc.Status message (StreamApply's per-message status), details included.
void ToRpcStatus(const grpc::Status& status, google::rpc::Status* rpc_status);

}  // namespace mdr::service
