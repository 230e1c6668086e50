// StreamApply: one atomic batch per request message, one response per message, in order
// (contract in contact_service.proto). Back-pressure: one write in flight and at most
// kMaxPendingResponses responses queued; reading pauses while the queue is full, so a client that
// stops reading stalls in HTTP/2 flow control instead of growing the server's memory. Each
// message is applied on the Executor (strand: its session); a message the full queue refuses is
// answered with UNAVAILABLE in its response status, unapplied, and the stream goes on.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include <atomic>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <set>

#include "mdr/service/auth.h"
#include "mdr/service/executor.h"
#include "mdr/service/operations.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

class StreamApplyReactor;

// The open streams, so that a shutdown can tell each to finish.
class StreamRegistry {
 public:
  // False once draining: the stream must end at once.
  bool Add(StreamApplyReactor* stream);
  void Remove(StreamApplyReactor* stream);
  // Every open stream (and every later one) finishes with UNAVAILABLE after answering the
  // message it is working on.
  void DrainAll();
  std::size_t size() const;

 private:
  mutable std::mutex mutex_;
  std::set<StreamApplyReactor*> streams_;  // guarded by mutex_
  bool draining_ = false;                  // guarded by mutex_
};

class StreamApplyReactor final
    : public grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse> {
 public:
  static constexpr std::size_t kMaxPendingResponses = 8;

  // An unauthenticated stream ends at once (UNAUTHENTICATED); an authenticated one applies
  // every message as its caller.
  StreamApplyReactor(grpc::CallbackServerContext* context, ContactOperations& operations,
                     const Authenticator* authenticator, StreamRegistry& registry,
                     Executor& executor, const std::atomic<bool>& server_stopping);

  // Stops reading; the stream ends with UNAVAILABLE once the responses already computed are
  // written. Messages read from now on are not applied.
  void Drain();

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnDone() override;
  void OnCancel() override { cancelled_.store(true, std::memory_order_relaxed); }

 private:
  // Applies the message in request_ and returns its response (errors in response.status).
  v1::StreamApplyResponse Answer();
  // On a worker: answers the message in request_ and queues its response.
  void Process();
  // Queues the response to the message just read and starts what follows.
  void Answered(v1::StreamApplyResponse response);
  // What to start after a state change, decided under mutex_ and started outside it (gRPC may
  // run reactions inline, so no Start* call is made while holding the lock).
  struct Actions {
    const v1::StreamApplyResponse* write = nullptr;
    bool read = false;
    std::optional<grpc::Status> finish;
  };
  Actions NextActionsLocked();
  void Start(const Actions& actions);

  grpc::CallbackServerContext* const context_;
  ContactOperations& operations_;
  StreamRegistry& registry_;
  Executor& executor_;
  std::atomic<bool> cancelled_{false};
  const Interrupt interrupt_;                           // after cancelled_, which it reads
  const ContactOperations::Interruption interruption_;  // interrupt_ between steps
  Principal caller_;                                    // set once by the constructor
  v1::StreamApplyRequest request_;                      // the read buffer; one read at a time

  std::mutex mutex_;
  std::deque<v1::StreamApplyResponse> pending_;  // front is being written when writing_
  bool reading_ = false;                         // a read is outstanding
  bool processing_ = false;                      // a message is being applied
  bool writing_ = false;                         // a write is outstanding
  bool reads_done_ = false;                      // the client half-closed (or the call ended)
  bool write_failed_ = false;                    // the client is gone
  bool draining_ = false;
  bool finished_ = false;
  std::size_t answered_ = 0;
};

}  // namespace mdr::service
