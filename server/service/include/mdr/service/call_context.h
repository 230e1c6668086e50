// Per-call helpers shared by the unary handlers and the StreamApply reactor: the caller's
// principal, the batch interruption check from the call's deadline and cancellation, the request
// id for logs, and the structured (key=value) call log.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include <atomic>
#include <string>
#include <string_view>

#include "mdr/base/status.h"
#include "mdr/core/interrupt.h"
#include "mdr/service/auth.h"
#include "mdr/service/executor.h"
#include "mdr/service/operations.h"

namespace mdr::service {

// The caller of a call: nullopt without an authenticator (authentication off), else the
// principal of its bearer token (UNAUTHENTICATED without a valid one).
Status CallerOf(const grpc::CallbackServerContext* context, const Authenticator* authenticator,
                Principal* caller);

// The core's Interrupt of a call: its deadline (the client's, or now + max_duration if that is
// sooner: the server's bound on a call, ServiceLimits::max_call_duration), its own cancellation
// flag (set by the reactor's OnCancel) and the server's (set when a drain's grace period ends).
// Both flags must outlive it.
Interrupt InterruptOf(const grpc::CallbackServerContext* context,
                      const std::atomic<bool>* call_cancelled,
                      const std::atomic<bool>* server_stopping,
                      std::chrono::milliseconds max_duration = std::chrono::milliseconds::max());

// A batch's interruption check: DEADLINE_EXCEEDED or CANCELLED when interrupt fires.
ContactOperations::Interruption InterruptionOf(const Interrupt& interrupt);

// Whom the executor's fairness and quotas count a call against: "token:<principal>" when
// authenticated, else "peer:<address>" (the client's IP address without its port, or the unix
// socket), so the connections of one host share one queue.
std::string CallerKeyOf(const grpc::CallbackServerContext* context, const Principal& caller);
// The same for a peer string as gRPC gives it ("ipv4:1.2.3.4:5", "ipv6:[::1]:5", "unix:/p").
std::string PeerCallerKey(std::string_view peer);

// Why the executor did not take a call (or stream message), which was not run:
// RESOURCE_EXHAUSTED naming max-queued-calls-per-caller when the caller's own queue is full,
// else UNAVAILABLE with a retry hint.
Status RefusalStatus(const Executor& executor, Executor::Admission admission);

// explicit_id if set, else the client's "x-request-id" metadata, else "-"; raw client text,
// for LogCall only.
std::string RequestIdOf(const grpc::CallbackServerContext* context,
                        const std::string& explicit_id = "");

// One log line per call, with the status as sent (ToGrpcStatus): debug when it succeeded, info when
// it failed. The session and request id are client values, shown through LogValue (bounded, quoted
// and escaped when needed), so the line always starts "rpc=... session=... request_id=... code=..."
// and never spans two lines.
void LogCall(const char* method, const std::string& session, const std::string& request_id,
             const grpc::Status& status, double seconds);

}  // namespace mdr::service
