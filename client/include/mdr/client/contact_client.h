// A typed client for mdr.v1.ContactService: one method per RPC, a deadline on every call, retries
// of idempotent calls on UNAVAILABLE, and errors returned as values (the gRPC code and the
// server's "field: message").
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/support/status.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mdr/client/rpc_result.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace mdr::client {

struct ClientOptions {
  // Deadline of every call (of a whole stream for StreamApply), from the moment it starts.
  std::chrono::milliseconds timeout = std::chrono::seconds(30);
  // Attempts of an idempotent call that fails with UNAVAILABLE (GetSession, ListSessions,
  // ExportSession, Query, Transform, the analysis calls, and Apply with a request_id), >= 1. mdrd
  // answers UNAVAILABLE when it shuts down and when it is busy (its queue of computing calls is
  // full, nothing was run): both are worth a retry after the backoff.
  int max_attempts = 3;
  // Wait before the second attempt; doubled for every further one.
  std::chrono::milliseconds initial_backoff = std::chrono::milliseconds(100);
};

// Metadata key carrying the id of the session a call names, so that a router can pin every call
// on a session, its creation included, to one server (consistent hashing; deploy/haproxy).
inline constexpr char kSessionRoutingKey[] = "x-session-id";

// A fresh session id of the API's form [a-z][a-z0-9-]{0,62}: the client chooses the ids of the
// sessions it creates or imports, so that a router can route the creation.
std::string NewSessionId();

class ContactClient {
 public:
  explicit ContactClient(std::shared_ptr<grpc::ChannelInterface> channel,
                         ClientOptions options = {});
  ContactClient(std::shared_ptr<grpc::ChannelInterface> channel, std::chrono::milliseconds timeout);

  const ClientOptions& options() const { return options_; }

  // Empty session_id: the client picks one (NewSessionId). Unset limits take the server's.
  RpcResult<v1::Session> CreateSession(const v1::Scene& scene, const std::string& session_id = "",
                                       const v1::SessionLimits& limits = {});
  RpcResult<v1::Session> GetSession(const std::string& name);
  // One page of sessions in name order; pass the previous page's next_page_token.
  RpcResult<v1::ListSessionsResponse> ListSessions(int page_size = 0,
                                                   const std::string& page_token = "");
  // Every session, following the pages.
  RpcResult<std::vector<v1::Session>> ListAllSessions();
  grpc::Status DeleteSession(const std::string& name);
  RpcResult<v1::SessionSnapshot> ExportSession(const std::string& name);
  RpcResult<v1::Session> ImportSession(const v1::SessionSnapshot& snapshot,
                                       const std::string& session_id = "");

  // Applies the steps as one atomic batch; step_mask selects the per-step results (empty: none).
  // A non-empty request_id makes the call idempotent, so it is retried on UNAVAILABLE.
  RpcResult<v1::ApplyResponse> Apply(const std::string& session,
                                     const google::protobuf::RepeatedPtrField<v1::Step>& steps,
                                     const google::protobuf::FieldMask& step_mask = {},
                                     const std::string& request_id = "");
  // One step.
  RpcResult<v1::ApplyResponse> Apply(const std::string& session, const v1::Step& step,
                                     const google::protobuf::FieldMask& step_mask = {},
                                     const std::string& request_id = "");
  // The request as given (session, steps, step_mask, state_mask, request_id).
  RpcResult<v1::ApplyResponse> Apply(const v1::ApplyRequest& request);

  // Sends every request as one message of a StreamApply stream (pipelined: a second thread
  // writes while this one reads) and returns the responses in order; each has its own status.
  // on_response, if set, sees each response as it arrives. The stream's own error (deadline,
  // UNAVAILABLE on shutdown) is the result's status.
  using StreamObserver = std::function<void(std::size_t index, const v1::StreamApplyResponse&)>;
  RpcResult<std::vector<v1::StreamApplyResponse>> StreamApply(
      const std::vector<v1::ApplyRequest>& requests, const StreamObserver& on_response = {});

  // The outputs selected by read_mask (empty: the state); radii for "springs" and tractions.
  RpcResult<v1::QueryResponse> Query(const std::string& session,
                                     const google::protobuf::FieldMask& read_mask = {},
                                     const std::vector<double>& radii = {});
  RpcResult<v1::QueryResponse> Query(const v1::QueryRequest& request);

  // Stateless MDR <-> Jäger transformation.
  RpcResult<v1::TransformResponse> Transform(const v1::TransformRequest& request);

  // The analysis of measured loops (docs/analysis.md). Stateless, so retried on UNAVAILABLE.
  // The figures of every cycle of a run's samples.
  RpcResult<v1::AnalyzeLoopsResponse> AnalyzeLoops(const v1::AnalyzeLoopsRequest& request);
  // Fits scene parameters to loop sets: on_progress, if set, sees each FitProgress as it
  // arrives (the server may skip some when the client reads slowly; a retried call starts again
  // from iteration 1); the result is the stream's last message, and the stream's error (or
  // INTERNAL if it ended without a result) is the returned status. The deadline covers the whole
  // stream.
  using FitProgressObserver = std::function<void(const v1::FitProgress&)>;
  RpcResult<v1::FitResult> FitLoops(const v1::FitLoopsRequest& request,
                                    const FitProgressObserver& on_progress = {});
  // The exact loops of a scene across normal forces and relative actuator amplitudes.
  RpcResult<v1::FrettingMapResponse> FrettingMap(const v1::FrettingMapRequest& request);
  // Secant stiffness and damping ratio against amplitude at one normal force.
  RpcResult<v1::BackboneResponse> Backbone(const v1::BackboneRequest& request);

 private:
  // A context whose deadline is now + timeout (deadlines are system_clock time points), carrying
  // the routing metadata of the session it names ("sessions/{id}" or a bare id; empty: none).
  std::unique_ptr<grpc::ClientContext> NewContext(const std::string& session = "") const;
  // Calls rpc(context, request, response) once, or up to max_attempts times on UNAVAILABLE when
  // idempotent.
  template <typename Request, typename Response, typename Rpc>
  RpcResult<Response> Call(Rpc rpc, const Request& request, bool idempotent,
                           const std::string& session = "");
  // One FitLoops stream: its result, or its status.
  RpcResult<v1::FitResult> FitLoopsOnce(const v1::FitLoopsRequest& request,
                                        const FitProgressObserver& on_progress);

  std::unique_ptr<v1::ContactService::Stub> stub_;
  ClientOptions options_;
};

}  // namespace mdr::client
