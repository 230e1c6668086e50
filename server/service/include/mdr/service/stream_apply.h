// StreamApply: one atomic batch per request message, one response per message, in order
// (contract in contact_service.proto). Back-pressure: one write in flight and at most
// kMaxPendingResponses messages read and not yet written (applied or waiting to be); reading
// pauses while that many are held, so a client that stops reading stalls in HTTP/2 flow control
// instead of growing the server's memory. Reading goes on while a message is applied on a worker,
// so the next ones are at hand when it is done: the messages are applied one at a time and in
// order on the Executor (strand: the message's session), a run of consecutive messages for one
// session in one task (at most kMaxRunLength, then the task queues behind the others). A message
// whose cost is bounded a priori and small, for a session with nothing queued, is applied on the
// thread that read it instead (Executor::TryRunInline; docs/operations.md, "Inline steps"), which
// starts the answer's write before the next read, as an echo does. A message the full queue
// refuses is answered with UNAVAILABLE in its response status, unapplied, and the stream goes on.
// While other callers are active, the caller's streams read at the pace its StreamBudget allows
// (stream_pacer.h): a paused stream resumes from the pacer's thread.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include <atomic>
#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "mdr/service/auth.h"
#include "mdr/service/executor.h"
#include "mdr/service/operations.h"
#include "mdr/service/stream_pacer.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

class StreamApplyReactor;

// The open streams, so that a shutdown can tell each to finish, counted per caller (executor.h's
// caller keys) against ServiceLimits::max_streams_per_caller; and the pacing of their reads
// (stream_pacer.h), whose thread resumes paused streams.
class StreamRegistry {
 public:
  enum class Admission { kAdded, kDraining, kCallerFull };

  // executor: whose workers' CPU time the transport's measurement leaves out.
  StreamRegistry(std::size_t max_per_caller, const StreamPacing& pacing, const Executor& executor)
      : max_per_caller_(max_per_caller), budget_(pacing), executor_(executor) {}

  // kDraining: the stream must end at once; kCallerFull: the caller holds max_per_caller open
  // streams, this one is not added and must end at once.
  Admission Add(StreamApplyReactor* stream, const std::string& caller);
  // Removes an added stream (nothing for one that was not).
  void Remove(StreamApplyReactor* stream);
  // Every open stream (and every later one) finishes with UNAVAILABLE after answering the
  // message it is working on; paused streams resume at once to do so.
  void DrainAll();
  std::size_t size() const;
  std::size_t max_per_caller() const { return max_per_caller_; }

  StreamBudget& budget() { return budget_; }
  // Feeds the budget a sample of the process's clocks at most every kCalibrationInterval.
  static constexpr std::chrono::milliseconds kCalibrationInterval{100};
  void MaybeCalibrate(StreamBudget::Clock::time_point now);
  // Runs resume at `when` on the pacer's thread.
  void ResumeAt(StreamBudget::Clock::time_point when, std::function<void()> resume) {
    resumptions_.At(when, std::move(resume));
  }

 private:
  const std::size_t max_per_caller_;
  StreamBudget budget_;
  const Executor& executor_;
  std::atomic<StreamBudget::Clock::rep> next_calibration_{0};
  DelayedCalls resumptions_;  // its thread outlives every stream (the registry outlives the server)
  mutable std::mutex mutex_;
  std::map<StreamApplyReactor*, std::string> streams_;       // guarded by mutex_; their callers
  std::unordered_map<std::string, std::size_t> per_caller_;  // guarded by mutex_
  bool draining_ = false;                                    // guarded by mutex_
};

class StreamApplyReactor final
    : public grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse> {
 public:
  static constexpr std::size_t kMaxPendingResponses = 8;
  // Messages one executor task applies at most before it yields the worker to other strands.
  static constexpr int kMaxRunLength = 8;

  // An unauthenticated stream ends at once (UNAUTHENTICATED); an authenticated one applies
  // every message as its caller.
  StreamApplyReactor(grpc::CallbackServerContext* context, ContactOperations& operations,
                     const Authenticator* authenticator, StreamRegistry& registry,
                     Executor& executor, const std::atomic<bool>& server_stopping);

  // Stops reading; the stream ends with UNAVAILABLE once the responses already computed are
  // written. Messages read from now on are not applied.
  void Drain();
  // Ends a pause (on the pacer's thread): reads the booked message once its time has come (else
  // pauses again, up to max_pause), or finishes.
  void Resume();

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnDone() override;
  void OnCancel() override { cancelled_.store(true, std::memory_order_relaxed); }

 private:
  using Message = v1::StreamApplyRequest;

  // Applies one message's batch and returns its response (errors in response.status);
  // bounded_only: only if its cost is bounded (ContactOperations::ApplyIfBounded), else nothing.
  std::optional<v1::StreamApplyResponse> Answer(const v1::ApplyRequest& apply, bool bounded_only);
  // On a worker: applies the oldest unapplied messages while they are for the session of the
  // first (the task's strand), at most kMaxRunLength, then hands the rest to SubmitNext.
  void ApplyRun();
  // Queues a task for the oldest unapplied message; while the executor refuses, answers it
  // UNAVAILABLE (unapplied) and tries the next.
  void SubmitNext();
  // Queues the response to the oldest unapplied message and starts what follows. Returns the
  // next unapplied message for the caller (the owner of applying_) to go on with, and whether
  // it is for the same session; null when there is none (applying_ is cleared).
  const Message* Answered(v1::StreamApplyResponse response, bool* same_session);
  // What to start after a state change, decided under mutex_ and started outside it (gRPC may
  // run reactions inline, so no Start* call is made while holding the lock).
  struct Actions {
    const v1::StreamApplyResponse* write = nullptr;
    Message* read = nullptr;
    std::optional<StreamBudget::Clock::time_point> resume_at;  // paused until then
    std::optional<grpc::Status> finish;
  };
  // kHeld: no read is booked now (the caller applies the message just read and books the next
  // read once its answer is being written, or StartHeldRead does before queueing it).
  enum class ReadBooking { kAllowed, kHeld };
  Actions NextActionsLocked(ReadBooking reads = ReadBooking::kAllowed);
  // Books the read that OnReadDone held, if it is still due (the owner of applying_ only).
  void StartHeldRead();
  void Start(const Actions& actions);
  // The executor's count of other active callers (a caller stays active for a second after its
  // last task), asked at most every kOtherCallersRefresh: reads of every stream would otherwise
  // queue on the executor's lock.
  std::size_t OtherActiveCallersLocked(StreamBudget::Clock::time_point now);
  static constexpr auto kOtherCallersRefresh = std::chrono::milliseconds(1);
  // Once draining, the client gone or the stream finished: no message is applied any more.
  bool StoppedLocked() const { return draining_ || write_failed_ || finished_; }
  // Gives up the unapplied messages (they get no response: the contract says they were not
  // applied) and clears applying_.
  void DropUnappliedLocked();
  void RecycleLocked(std::unique_ptr<Message> message);

  ContactOperations& operations_;
  StreamRegistry& registry_;
  Executor& executor_;
  std::atomic<bool> cancelled_{false};
  const Interrupt interrupt_;                           // after cancelled_, which it reads
  const ContactOperations::Interruption interruption_;  // interrupt_ between steps
  Principal caller_;                                    // set once by the constructor
  std::string caller_key_;                              // the executor's key of caller_
  std::string metadata_request_id_;  // the stream's x-request-id (or "-"), for the call logs
  // The sessions earlier messages found: the next messages for them need no lookup in the
  // store. Used by the owner of applying_ only (one thread at a time, ordered by mutex_).
  RecentSessions recent_sessions_;

  std::mutex mutex_;
  std::unique_ptr<Message> read_buffer_;  // the outstanding read's target while reading_
  // Read and not yet answered, oldest first; the front is being applied while applying_. Only
  // the owner of applying_ removes messages.
  std::deque<std::unique_ptr<Message>> unapplied_;
  // Answered messages, kept for the next reads (their parsed fields are reused).
  std::vector<std::unique_ptr<Message>> spare_;
  std::deque<v1::StreamApplyResponse> pending_;  // front is being written when writing_
  bool reading_ = false;                         // a read is outstanding
  // A task is queued or running for unapplied_ (or the thread that queues one owns it): set
  // exactly while unapplied_ is not empty.
  bool applying_ = false;
  bool writing_ = false;       // a write is outstanding
  bool reads_done_ = false;    // the client half-closed (or the call ended)
  bool write_failed_ = false;  // the client is gone
  bool draining_ = false;
  bool finished_ = false;
  // Reading waits for the caller's budget; nothing finishes the stream while paused, so the
  // pacer's resumption always finds it alive.
  bool paused_ = false;
  StreamBudget::Clock::time_point read_booked_at_;  // while paused: when the booked read may start
  bool read_booked_ = false;  // resumed: the next read was charged when the pause began
  // guarded by mutex_: the executor's last answer to OtherActiveCallers, and when it was asked
  std::size_t other_callers_ = 0;
  StreamBudget::Clock::time_point other_callers_at_{};
  std::size_t answered_ = 0;
};

}  // namespace mdr::service
