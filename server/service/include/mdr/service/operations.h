// The operations of ContactService independent of the transport: validate a request, find the
// session, run the core, encode the reply, all errors as Status. The unary handlers and the
// StreamApply reactor are thin wrappers around this class. Every session operation is made by a
// caller (Principal) and sees only the caller's sessions. With a journal (OpenJournal), every
// change is journaled before it is answered.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/bridge/outputs.h"
#include "mdr/bridge/state_budget.h"
#include "mdr/core/interface.h"
#include "mdr/core/interrupt.h"
#include "mdr/service/journal.h"
#include "mdr/service/limits.h"
#include "mdr/service/session_store.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// Hooks for tests; all default to off.
struct TestHooks {
  // Counts every Query output computed.
  bridge::OutputCounters* output_counters = nullptr;
  // Called before every step of every batch (e.g. to make a batch outlast a deadline).
  std::function<void(int step_index)> before_step;
  // Called by CreateSession and ImportSession after the state is built, before the call's
  // interrupt is checked a last time and the session is added.
  std::function<void()> before_add_session;
};

class ContactOperations {
 public:
  // Why a running batch must stop (deadline passed, call cancelled); OK to go on.
  using Interruption = std::function<Status()>;

  ContactOperations(const ServiceLimits& limits, TestHooks hooks);

  // Opens the journal, restores every session in it (snapshot, then its later batches replayed
  // through Session::Apply) and journals every change from now on. Call before serving. A
  // session that cannot be restored is kept as unavailable (logged at error level with the
  // reason; its journal entry is kept); every other one is restored. Errors (the journal cannot
  // be opened, or is damaged and options.recover is off) name the journal and what is wrong.
  Status OpenJournal(const JournalOptions& options);
  // Interface sessions created, imported or restored from now on run their per-contact passes
  // on `parallel` (the server's worker pool: PoolParallelFor); null: on the calling worker. Set
  // before OpenJournal.
  void set_parallel(std::shared_ptr<ParallelFor> parallel) { parallel_ = std::move(parallel); }
  // Writes a snapshot of every session with batches since its last one (a clean shutdown).
  void CompactJournal();

  // interrupt abandons a long construction (a tabulated profile) and is checked once more just
  // before the session is added: nothing is created after the caller gave up.
  Status CreateSession(const Principal& caller, const v1::CreateSessionRequest& request,
                       v1::Session* response, const Interrupt& interrupt = {});
  Status GetSession(const Principal& caller, const v1::GetSessionRequest& request,
                    v1::Session* response);
  Status ListSessions(const Principal& caller, const v1::ListSessionsRequest& request,
                      v1::ListSessionsResponse* response);
  Status DeleteSession(const Principal& caller, const v1::DeleteSessionRequest& request);
  // DeleteSession if its cost is bounded a priori and small (SessionStore::EraseIfBounded), for
  // a transport thread; nullopt otherwise, nothing done.
  std::optional<Status> DeleteSessionIfBounded(const Principal& caller,
                                               const v1::DeleteSessionRequest& request);
  Status ExportSession(const Principal& caller, const v1::ExportSessionRequest& request,
                       v1::SessionSnapshot* response);
  // interrupt: as for CreateSession.
  Status ImportSession(const Principal& caller, const v1::ImportSessionRequest& request,
                       v1::Session* response, const Interrupt& interrupt = {});
  // interruption is checked before every step, interrupt inside long steps (curved force
  // paths). recent (optional; a stream's): the sessions this caller's stream found before, reused
  // without a lookup while the store holds them (SessionStore::FindAgain).
  Status Apply(const Principal& caller, const v1::ApplyRequest& request,
               const Interruption& interruption, v1::ApplyResponse* response,
               const Interrupt& interrupt = {}, RecentSessions* recent = nullptr);
  // Apply, if its cost is bounded a priori and small: one step of a straight kind (displacement
  // channels, or a tangential force at a held depth) on a single exact contact of at most
  // limits().max_inline_vertices vertices, without a journal or a test hook (docs/operations.md,
  // "Inline steps"). Otherwise, and for a request that Apply would refuse, nothing happens
  // (nullopt): the caller queues the request for Apply. For a transport thread.
  std::optional<Status> ApplyIfBounded(const Principal& caller, const v1::ApplyRequest& request,
                                       v1::ApplyResponse* response,
                                       RecentSessions* recent = nullptr);
  // interrupt is checked before every radius of a traction or pressure profile.
  Status Query(const Principal& caller, const v1::QueryRequest& request,
               v1::QueryResponse* response, const Interrupt& interrupt = {});
  // Stateless: no session is read or changed.
  Status Transform(const v1::TransformRequest& request, v1::TransformResponse* response);

  // Deletes the sessions whose idle timeout ran out; returns their names.
  std::vector<std::string> EraseExpiredSessions() { return sessions_.EraseExpired(); }
  std::size_t session_count() const { return sessions_.size(); }
  const ServiceLimits& limits() const { return limits_; }

 private:
  void LogDeleted(const std::string& name) const;
  // SessionStore::Find, or FindAgain with recent when given.
  Status FindSession(const Principal& caller, const std::string& name, RecentSessions* recent,
                     std::shared_ptr<Session>* session);
  // The largest per-step results of a batch: the message limit less room for the final state
  // and the other fields of the response.
  std::size_t MaxResponseBytes() const {
    constexpr std::size_t kResponseOverheadBytes = 512;
    return static_cast<std::size_t>(limits_.max_message_bytes) - kResponseOverheadBytes;
  }
  // The budget a caller's sessions are charged to: its own quota inside the server's
  // (--max-state-bytes-per-token), or the server's for callers without a token or without
  // quotas. Created on first use, kept for the process.
  bridge::StateBudget* BudgetOf(const std::string& owner) const;
  // What the caller's budget and the server's have left, and which is the tighter; for checks
  // made before a state is built.
  bridge::StateRoom StateRoomOf(const Principal& caller) const {
    return BudgetOf(caller.value_or(""))->Room();
  }
  // Builds the contact of a new session from a scene; errors prefixed with scene_path's parent.
  Result<ContactConfig> SessionConfig(const v1::Scene& scene, const std::string& prefix,
                                      const Interrupt& interrupt) const;
  // The state a snapshot describes (ImportSession and the journal); errors name
  // "snapshot.<field>".
  Status StateOf(const v1::SessionSnapshot& snapshot, const Principal& owner,
                 std::optional<SessionOrigin>* state, const Interrupt& interrupt = {}) const;
  // Adds the session unless the interrupt fired, its export would not fit a message or its
  // state the budget (errors name state_field).
  Status AddSession(const Principal& caller, const std::string& id_field,
                    const std::string& session_id, SessionOrigin state, v1::Session* response,
                    const char* verb, const std::string& state_field, const Interrupt& interrupt);
  // A journaled session: its snapshot imported, its later batches replayed.
  Status Restore(const JournaledSession& journaled, std::shared_ptr<Session>* session) const;
  // What is kept of a journaled session that Restore refused (`why`).
  static UnavailableSession Unavailable(JournaledSession entry, const Status& why);

  const ServiceLimits limits_;
  const TestHooks hooks_;
  std::shared_ptr<ParallelFor> parallel_;  // for interface sessions
  // Thread-safe; mutable for Restore, which charges the restored sessions.
  mutable bridge::StateBudget budget_;  // before sessions_, whose charges it holds
  mutable std::mutex owner_budgets_mutex_;
  // Per token, inside budget_ (before sessions_ too).
  mutable std::map<std::string, std::unique_ptr<bridge::StateBudget>> owner_budgets_;
  std::unique_ptr<Journal> journal_;  // before sessions_: they write to it until destroyed
  SessionStore sessions_;
};

}  // namespace mdr::service
