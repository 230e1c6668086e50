// The gRPC adapter: each handler authenticates the caller (with an Authenticator), hands its
// request to ContactOperations and finishes the call with the result; StreamApply runs a
// StreamApplyReactor. No physics and no validation rules here.
//
// Execution model (docs/operations.md): the cheap calls (GetSession, ListSessions) run inline on
// gRPC's thread. The computing calls (CreateSession, ImportSession, ExportSession, Apply, Query,
// Transform, every StreamApply message) and DeleteSession (a journal write, and it waits for a
// batch running on its session) are authenticated inline and then queued on the Executor, on
// their session's strand; the worker finishes the reactor. A full queue
// answers UNAVAILABLE at once; a call whose deadline passed (or that was cancelled) while queued
// is not run.
#pragma once

#include <grpcpp/support/message_allocator.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "mdr/service/auth.h"
#include "mdr/service/executor.h"
#include "mdr/service/operations.h"
#include "mdr/service/stream_apply.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace mdr::service {

// Apply's request and response messages, reused from call to call: a message cleared by
// protobuf keeps its repeated elements for the next parse, so a batch of N steps costs no N
// allocations and frees per call. Keeps at most kMaxKept pairs, and none whose request had more
// than kMaxKeptSteps steps (so the pool holds a bounded amount of memory). Thread-safe.
class ApplyMessagePool final : public grpc::MessageAllocator<v1::ApplyRequest, v1::ApplyResponse> {
 public:
  static constexpr std::size_t kMaxKept = 64;
  static constexpr int kMaxKeptSteps = 10000;

  // Defined where Messages is complete.
  ApplyMessagePool();
  ~ApplyMessagePool() override;

  grpc::MessageHolder<v1::ApplyRequest, v1::ApplyResponse>* AllocateMessages() override;
  // Pairs kept for reuse now.
  std::size_t kept() const;

 private:
  class Messages;
  // Called by Messages::Release when gRPC is done with the call.
  void Return(Messages* messages);

  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<Messages>> kept_;  // guarded by mutex_
};

class ContactServiceImpl final : public v1::ContactService::CallbackService {
 public:
  // authenticator: null when authentication is off (every caller is anonymous).
  // server_stopping: set when a drain's grace period ends; interrupts every running call.
  ContactServiceImpl(ContactOperations& operations, const Authenticator* authenticator,
                     Executor& executor, const std::atomic<bool>& server_stopping)
      : operations_(operations),
        authenticator_(authenticator),
        executor_(executor),
        server_stopping_(server_stopping),
        streams_(operations.limits().max_streams_per_caller, operations.limits().stream_pacing,
                 executor) {
    SetMessageAllocatorFor_Apply(&apply_messages_);
  }

  grpc::ServerUnaryReactor* CreateSession(grpc::CallbackServerContext* context,
                                          const v1::CreateSessionRequest* request,
                                          v1::Session* response) override;
  grpc::ServerUnaryReactor* GetSession(grpc::CallbackServerContext* context,
                                       const v1::GetSessionRequest* request,
                                       v1::Session* response) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* context,
                                         const v1::ListSessionsRequest* request,
                                         v1::ListSessionsResponse* response) override;
  grpc::ServerUnaryReactor* DeleteSession(grpc::CallbackServerContext* context,
                                          const v1::DeleteSessionRequest* request,
                                          google::protobuf::Empty* response) override;
  grpc::ServerUnaryReactor* ExportSession(grpc::CallbackServerContext* context,
                                          const v1::ExportSessionRequest* request,
                                          v1::SessionSnapshot* response) override;
  grpc::ServerUnaryReactor* ImportSession(grpc::CallbackServerContext* context,
                                          const v1::ImportSessionRequest* request,
                                          v1::Session* response) override;
  grpc::ServerUnaryReactor* Apply(grpc::CallbackServerContext* context,
                                  const v1::ApplyRequest* request,
                                  v1::ApplyResponse* response) override;
  grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse>* StreamApply(
      grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* Query(grpc::CallbackServerContext* context,
                                  const v1::QueryRequest* request,
                                  v1::QueryResponse* response) override;
  grpc::ServerUnaryReactor* Transform(grpc::CallbackServerContext* context,
                                      const v1::TransformRequest* request,
                                      v1::TransformResponse* response) override;
  // The analysis of measured loops (analysis_ops.h), stateless, on the workers.
  grpc::ServerUnaryReactor* AnalyzeLoops(grpc::CallbackServerContext* context,
                                         const v1::AnalyzeLoopsRequest* request,
                                         v1::AnalyzeLoopsResponse* response) override;
  grpc::ServerWriteReactor<v1::FitLoopsResponse>* FitLoops(
      grpc::CallbackServerContext* context, const v1::FitLoopsRequest* request) override;
  grpc::ServerUnaryReactor* FrettingMap(grpc::CallbackServerContext* context,
                                        const v1::FrettingMapRequest* request,
                                        v1::FrettingMapResponse* response) override;
  grpc::ServerUnaryReactor* Backbone(grpc::CallbackServerContext* context,
                                     const v1::BackboneRequest* request,
                                     v1::BackboneResponse* response) override;

  // Open streams answer what they are working on and end with UNAVAILABLE; new ones end at once.
  void DrainStreams() { streams_.DrainAll(); }
  std::size_t open_streams() const { return streams_.size(); }

 private:
  // Authenticates inline, then runs operation(caller, interrupt) on the executor (strand: the
  // session name, empty for none) and finishes the call from the worker.
  template <typename Operation>
  grpc::ServerUnaryReactor* Queue(grpc::CallbackServerContext* context, const char* method,
                                  const std::string& strand, const std::string& request_id,
                                  Operation operation);
  // A call whose cost is bounded a priori and small, on a strand with nothing queued, answered
  // here on the transport's thread (docs/operations.md, "Inline steps"): bounded(caller) returns
  // its status, or nullopt to decline, having done nothing. Any other call goes to Queue (an
  // unauthenticated one is refused there).
  template <typename Bounded, typename Operation>
  grpc::ServerUnaryReactor* InlineOrQueue(grpc::CallbackServerContext* context, const char* method,
                                          const std::string& strand, const std::string& request_id,
                                          Bounded bounded, Operation operation);

  ContactOperations& operations_;
  const Authenticator* const authenticator_;
  Executor& executor_;
  const std::atomic<bool>& server_stopping_;
  StreamRegistry streams_;
  ApplyMessagePool apply_messages_;  // outlives the server that allocates from it
};

}  // namespace mdr::service
