// Per-call helpers shared by the unary handlers and the StreamApply reactor: the caller's
// principal, the batch interruption check from the call's deadline and cancellation, the request
// id for logs, and the structured (key=value) call log.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include <string>

#include "mdr/service/auth.h"
#include "mdr/service/operations.h"

namespace mdr::service {

// The caller of a call: nullopt without an authenticator (authentication off), else the
// principal of its bearer token (UNAUTHENTICATED without a valid one).
grpc::Status CallerOf(const grpc::CallbackServerContext* context,
                      const Authenticator* authenticator, Principal* caller);

// DEADLINE_EXCEEDED once the call's deadline has passed, CANCELLED once the client cancelled.
ContactOperations::Interruption InterruptionOf(grpc::CallbackServerContext* context);

// explicit_id if set, else the client's "x-request-id" metadata, else "-"; raw client text,
// for LogCall only.
std::string RequestIdOf(const grpc::CallbackServerContext* context,
                        const std::string& explicit_id = "");

// "OK", "INVALID_ARGUMENT", ...
const char* CodeName(grpc::StatusCode code);

// One log line per call: debug when it succeeded, info when it failed. The session and request
// id are client values, shown through LogValue (bounded, quoted and escaped when needed), so the
// line always starts "rpc=... session=... request_id=... code=..." and never spans two lines.
void LogCall(const char* method, const std::string& session, const std::string& request_id,
             const grpc::Status& status, double seconds);

}  // namespace mdr::service
