// One contact session: the resource's immutable parts (name, owner, scene, limits, creation time),
// the contact behind the session's own mutex (calls on one session are serialised), the idle
// clock, the responses of its last successful batches by request_id (idempotent retries), and its
// place in the journal (every committed batch is journaled before the commit).
#pragma once

#include <google/protobuf/repeated_field.h>
#include <google/protobuf/timestamp.pb.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/bridge/interface_session.h"
#include "mdr/bridge/outputs.h"
#include "mdr/bridge/state_budget.h"
#include "mdr/core/contact.h"
#include "mdr/core/interface.h"
#include "mdr/core/torsion.h"
#include "mdr/service/completed_requests.h"
#include "mdr/service/principal.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

class Journal;

// Everything a session starts from (a fresh contact, an imported or a journaled one).
struct SessionOrigin {
  v1::Scene scene;
  v1::SessionLimits limits;  // effective
  // The scene's contact. An interface session steps `interface` instead and keeps this unloaded
  // contact for what the scene resolves (effective options, approximation errors).
  Contact contact;
  std::uint64_t applied_steps = 0;
  std::string owner{};
  // Unset: now.
  std::optional<google::protobuf::Timestamp> create_time{};
  // Batches journaled so far (the sequence number of the last one); the journal's snapshot
  // includes the first journal_snapshot_sequence of them.
  std::uint64_t journal_sequence = 0;
  std::uint64_t journal_snapshot_sequence = 0;
  // The responses remembered for request ids, oldest first.
  std::vector<CompletedRequest> completed{};
  // The contact's bytes, charged to the server's state budget; every commit resizes it.
  bridge::StateCharge charge{};
  // The message limit that every export of the session must fit (0: unchecked).
  int max_message_bytes = 0;
  // Set for an interface session (scene.interface).
  std::optional<Interface> interface {};
  // Set for a torsional session (scene.torsion); `contact` is then the unloaded contact of its
  // scene, as for an interface.
  std::optional<TorsionalContact> torsion{};
};

// The bytes a session's state holds and an upper bound of its export message.
std::size_t StateBytes(const SessionOrigin& state);
std::size_t ExportBytesBound(const SessionOrigin& state);

// A journaled session whose state could not be restored at start: kept (with its journal entry)
// so that it is listed with the reason and can be deleted, but without a state to use.
struct UnavailableSession {
  std::string owner;
  google::protobuf::Timestamp create_time;
  v1::Scene scene;
  v1::SessionLimits limits;  // as journaled
  std::string reason;
};

class Session {
 public:
  using Clock = std::chrono::steady_clock;
  // Called before every step of a batch; a non-OK status (deadline, cancellation) abandons the
  // batch, which then changes nothing.
  using StepGuard = std::function<Status(int step_index)>;

  Session(std::string name, SessionOrigin state);
  // An unavailable session: Apply, Query and Export fail with FAILED_PRECONDITION naming the
  // reason, it never expires, and the journal entry is never rewritten.
  Session(std::string name, UnavailableSession unavailable);

  const std::string& name() const { return name_; }
  const std::string& owner() const { return owner_; }
  const google::protobuf::Timestamp& create_time() const { return create_time_; }
  const v1::SessionLimits& limits() const { return limits_; }
  // Whether the caller may see and use this session: its owner, or anyone without
  // authentication.
  bool VisibleTo(const Principal& caller) const { return !caller || *caller == owner_; }
  bool available() const { return contact_.has_value(); }

  // From now on every committed batch is written to the journal before the commit (a batch the
  // journal refuses fails with UNAVAILABLE and changes nothing), and the session's snapshot is
  // rewritten every journal->options().snapshot_every batches. Null: not journaled.
  void AttachJournal(Journal* journal);
  // Writes a snapshot of the current state to the journal if batches were journaled since the
  // last one (a clean shutdown).
  Status CompactJournal();

  // Applies request.steps atomically: all succeed and are committed, or the first failure is
  // returned (field "steps[i]...") and the session is unchanged. A request_id seen among the
  // last successful batches returns the stored response (replayed) without applying anything.
  // The request must be validated (non-empty steps, request_id form); the batch size limit is
  // checked here.
  // A response above max_response_bytes fails with RESOURCE_EXHAUSTED, uncommitted; so does a
  // batch whose state would exceed the state budget or no longer fit one export message.
  // interrupt reaches inside long steps (curved force paths).
  Status Apply(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
               const StepGuard& guard, std::size_t max_response_bytes, v1::ApplyResponse* response,
               const Interrupt& interrupt = {});

  // Apply, if the batch's cost is bounded a priori and small (docs/operations.md, "Inline
  // steps"): one straight step (StraightStepLocked) on a single exact contact, not journaled, of
  // at most max_vertices memory vertices; nothing happens otherwise (nullopt).
  std::optional<Status> ApplyIfBounded(const v1::ApplyRequest& request,
                                       const bridge::BatchOutputs& outputs,
                                       std::size_t max_vertices, std::size_t max_response_bytes,
                                       v1::ApplyResponse* response);

  // The selected outputs of the current state; on error (an output this contact does not have)
  // the response is cleared. interface_query: contact_index and histogram bins of an interface
  // session (a single session refuses them).
  Status Query(const bridge::OutputSelection& selection, const bridge::RadialSampling& sampling,
               bridge::OutputCounters* counters, v1::QueryResponse* response,
               const bridge::InterfaceQuery& interface_query = {}) const;

  // Scene, limits, state, creation and expiry time, availability as the API resource. The state
  // is the one after the last committed batch: read without waiting for a batch that is running.
  void ReadResource(v1::Session* resource) const;
  // The exact, portable state; FAILED_PRECONDITION for an unavailable session.
  Status Export(v1::SessionSnapshot* snapshot) const;

  // Restarts the idle timer at `now`; IsExpired tells whether it ran out (never without an idle
  // timeout).
  void Touch(Clock::time_point now = Clock::now());
  bool IsExpired(Clock::time_point now) const;

  // How the SessionStore lets go of the session (deleted, expired, replaced), before it erases
  // it: under the session's mutex, so that no batch commits on it afterwards. A batch running now
  // commits (and is journaled) first; a later one fails with NOT_FOUND, so no batch is journaled
  // after the session's entry was deleted. remove_entry (the deletion of the journal entry; may
  // be empty) runs first: if it fails, its status is returned and nothing changes. NOT_FOUND
  // (field empty) if the session was removed already.
  Status Remove(const std::function<Status()>& remove_entry);
  // Remove, unless a call holds the session now (it is in use, so not idle): nullopt, nothing
  // done. Never waits: for the store's sweeps under its own lock.
  std::optional<Status> RemoveIfIdle(const std::function<Status()>& remove_entry);
  // Remove (without a journal entry to delete) if its cost is bounded a priori and small
  // (docs/operations.md, "Inline steps"): a single contact, not journaled, held by no call;
  // nullopt otherwise, nothing done.
  std::optional<Status> RemoveIfBounded();
  // A reference kept from an earlier lookup is no longer the session of its name once removed.
  bool removed() const { return removed_.load(std::memory_order_acquire); }

 private:
  Status RemoveLocked(const std::function<Status()>& remove_entry);
  Status RunBatch(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
                  const StepGuard& guard, std::size_t max_response_bytes,
                  v1::ApplyResponse* response, const Interrupt& interrupt);
  // A one-step batch in place when it can (RunInterfaceStepInPlace), else on a copy.
  Status RunInterfaceBatch(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
                           const StepGuard& guard, std::size_t max_response_bytes,
                           v1::ApplyResponse* response, const Interrupt& interrupt);
  // One step on interface_ itself: the core's step is atomic, and what could still refuse it
  // (the budget and the export limit, from bounds of the step's growth, and the journal) is done
  // in its commit gate, before it changes anything. Sets *fall_back (nothing changed) when the
  // bounds do not fit: the exact check of a batch copy decides then.
  Status RunInterfaceStepInPlace(const v1::ApplyRequest& request,
                                 const bridge::BatchOutputs& outputs, const StepGuard& guard,
                                 v1::ApplyResponse* response, const Interrupt& interrupt,
                                 bool* fall_back);
  // Every step of a torsional session on a copy (a few pieces), moved in at the commit.
  Status RunTorsionBatch(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
                         const StepGuard& guard, std::size_t max_response_bytes,
                         v1::ApplyResponse* response);
  // Every step on a copy of the interface, swapped in at the commit.
  Status RunInterfaceBatchOnCopy(const v1::ApplyRequest& request,
                                 const bridge::BatchOutputs& outputs, const StepGuard& guard,
                                 std::size_t max_response_bytes, v1::ApplyResponse* response,
                                 const Interrupt& interrupt);
  // The guard and the step counter's limit before step i.
  static Status CheckNextStep(const StepGuard& guard, int i, std::uint64_t applied);
  // Whether `step` is one exact linear step of this session's single exact contact whatever its
  // state (Contact::Apply): both channels displacements (an unset one holds) without a rig, or
  // at a held depth a tangential displacement or force (through a rig too). Its memory then
  // grows from n vertices to at most 3n + 1.
  bool StraightStepLocked(const v1::Step& step) const;
  // A one-step batch of a straight step on an exact contact without a journal, made in place
  // (Contact::Apply is atomic) once the bounds of the state after it are charged; *fall_back
  // when only those bounds did not fit (the exact state after the step may: RunBatch's copy).
  Status RunStepInPlace(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
                        const StepGuard& guard, v1::ApplyResponse* response,
                        const Interrupt& interrupt, bool* fall_back);
  // Apply's work with mutex_ held (the batch size checked).
  Status ApplyLocked(const v1::ApplyRequest& request, const bridge::BatchOutputs& outputs,
                     const StepGuard& guard, std::size_t max_response_bytes,
                     v1::ApplyResponse* response, const Interrupt& interrupt);
  // The end of a batch whose steps all succeeded: the response size and state checks, the
  // journal (AdmitBatchLocked), then commit() moves the new state in (FinishBatchLocked).
  Status CommitBatchLocked(const v1::ApplyRequest& request,
                           const bridge::OutputSelection& state_outputs, std::uint64_t applied,
                           double path_error, std::size_t max_response_bytes,
                           std::size_t state_bytes, std::size_t export_bytes,
                           const std::function<void()>& commit, v1::ApplyResponse* response);
  // Charges state_bytes (unless it exceeds the budget, or export_bytes the export limit), then
  // writes the batch to the journal; on an error nothing is charged or written.
  Status AdmitBatchLocked(const v1::ApplyRequest& request, std::size_t state_bytes,
                          std::size_t export_bytes);
  // After the state changed: counters, the committed state and the response's state (the
  // fields of state_outputs).
  void FinishBatchLocked(std::uint64_t applied, double path_error,
                         const bridge::OutputSelection& state_outputs, v1::ApplyResponse* response);
  // Keeps the state for ReadResource and, unless state is null, writes the selected fields
  // into *state, each computed once.
  void CommitStateLocked(const bridge::OutputSelection& selection, v1::ContactState* state);
  void WriteStateLocked(const bridge::OutputSelection& selection, v1::ContactState* state) const;
  void ExportLocked(v1::SessionSnapshot* snapshot) const;
  // Resizes charge_ to state_bytes, unless it exceeds the budget or export_bytes the export
  // limit.
  Status ChargeStateLocked(std::size_t state_bytes, std::size_t export_bytes);
  Status CompactJournalLocked();
  // FAILED_PRECONDITION naming the reason for an unavailable session; OK otherwise.
  Status RequireAvailable() const;
  Clock::time_point last_used() const;

  const std::string name_;
  const std::string owner_;
  const v1::Scene scene_;
  const v1::SessionLimits limits_;
  const std::chrono::nanoseconds idle_timeout_;  // 0: never expires
  const google::protobuf::Timestamp create_time_;
  const std::string unavailable_reason_;  // empty: available
  const int max_message_bytes_;
  const std::size_t scene_bytes_;
  std::atomic<Clock::rep> last_used_;
  std::atomic<bool> removed_{false};  // set under mutex_

  mutable std::mutex mutex_;
  std::optional<Contact> contact_;  // guarded by mutex_; unset: unavailable
  // The copy a batch of a single contact runs on (RunBatch), kept between batches so that its
  // vectors keep their capacity: a batch then allocates nothing. Holds the state before the last
  // committed batch (bounded like the state; not charged: a few vertices of a rig's contact).
  std::optional<Contact> batch_copy_;        // guarded by mutex_
  std::optional<Interface> interface_;       // guarded by mutex_; set: an interface session
  std::optional<TorsionalContact> torsion_;  // guarded by mutex_; set: a torsional session
  std::uint64_t applied_steps_;              // guarded by mutex_
  CompletedRequests completed_;              // guarded by mutex_
  Journal* journal_ = nullptr;               // guarded by mutex_
  std::uint64_t journal_sequence_;           // guarded by mutex_
  std::uint64_t journal_snapshot_sequence_;  // guarded by mutex_
  bridge::StateCharge charge_;               // guarded by mutex_

  // The state after the last commit, for ReadResource (GetSession, ListSessions are cheap calls
  // that must not wait for a running batch on mutex_). A single contact's session keeps only the
  // values of OutputSelection::KeptState (committed_kept_), so that a batch that answers one
  // field computes little more than that field; ReadResource derives the others from
  // kept_state_config_. Interface and torsional sessions keep the whole state.
  mutable std::mutex committed_mutex_;
  v1::ContactState committed_state_;  // guarded by committed_mutex_
  bridge::KeptState committed_kept_;  // guarded by committed_mutex_
  // A single contact's config (set once by the constructor, never changed: read without a lock);
  // unset for interface, torsional and unavailable sessions.
  std::optional<ContactConfig> kept_state_config_;
};

}  // namespace mdr::service
