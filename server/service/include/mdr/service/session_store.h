// The thread-safe set of sessions, ordered by name (stable pages for ListSessions). Sessions
// whose idle timeout ran out are invisible at once and erased by EraseExpired (the server's
// sweeper, or a creation that needs their room). A session is visible only to its owner
// (Session::VisibleTo): to anyone else it does not exist. With a journal, every session added or
// erased is journaled (an added one before it becomes visible).
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <shared_mutex>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/service/session.h"

namespace mdr::service {

// The sessions a stream found lately (SessionStore::FindAgain): its next messages for them need
// no lookup under the store's lock, which every call of every caller shares. Holds none of them
// alive. A rig's stream drives one session; a simulation code may cycle through many.
class RecentSessions {
 public:
  static constexpr std::size_t kCapacity = 16;

  // The session remembered under name, if it is still alive; null otherwise.
  std::shared_ptr<Session> Lookup(const std::string& name) const;
  // Remembers a session found in the store under its (valid, so short) name, in the entry of
  // that name or else in the oldest.
  void Remember(const std::string& name, const std::shared_ptr<Session>& session);

 private:
  // The entry of that name, kCapacity if none.
  std::size_t IndexOf(const std::string& name) const;

  struct Entry {
    std::string name;  // compared before the weak pointer is locked (an atomic operation)
    std::weak_ptr<Session> session;
  };
  std::array<Entry, kCapacity> entries_;
  std::size_t used_ = 0;
  std::size_t next_ = 0;  // the entry replaced next once all are used
};

class SessionStore {
 public:
  // max_sessions_per_owner: sessions one principal may hold at most (0: no such limit; it applies
  // only with authentication).
  SessionStore(std::size_t max_sessions, std::size_t max_sessions_per_owner);

  // Creates "sessions/{session_id}" owned by the caller (see Principal); an empty session_id gets
  // a generated one. Errors: INVALID_ARGUMENT (session_id, named by id_field), ALREADY_EXISTS,
  // RESOURCE_EXHAUSTED, UNAVAILABLE (the journal failed; nothing was created).
  Status Create(const std::string& id_field, const std::string& session_id, const Principal& caller,
                SessionOrigin state, std::shared_ptr<Session>* session);
  // Finds a live session visible to the caller and restarts its idle timer. NOT_FOUND for an
  // unknown, expired or someone else's session, INVALID_ARGUMENT for a name not of the form
  // "sessions/{id}"; field names the request field.
  Status Find(const std::string& field, const std::string& name, const Principal& caller,
              std::shared_ptr<Session>* session);
  // As Find, but first tries the session of that name in *recent (found earlier by this caller's
  // stream): while the store still holds it, it is found without the store's lock. Otherwise as
  // Find, and what it finds is remembered in *recent.
  Status FindAgain(const std::string& field, const std::string& name, const Principal& caller,
                   RecentSessions* recent, std::shared_ptr<Session>* session);
  // As Find, then deletes it (UNAVAILABLE if the journal fails: then it is kept). Waits for a
  // batch running on the session (Session::Remove): for a worker, on the session's strand.
  Status Erase(const std::string& field, const std::string& name, const Principal& caller);
  // Erase if its cost is bounded a priori and small (Session::RemoveIfBounded), for a transport
  // thread; nullopt otherwise, nothing done.
  std::optional<Status> EraseIfBounded(const std::string& field, const std::string& name,
                                       const Principal& caller);

  // Up to page_size live sessions visible to the caller with names after `after` (empty: from
  // the first), in name order; *more tells whether further ones follow.
  std::vector<std::shared_ptr<Session>> ListAfter(const std::string& after, std::size_t page_size,
                                                  const Principal& caller, bool* more) const;

  // Erases the sessions whose idle timeout ran out (those `which` selects; empty: all), but one
  // that a call holds now (it is in use); returns their names. The journal's deletions run
  // outside the store's lock.
  std::vector<std::string> EraseExpired(const std::function<bool(const Session&)>& which = {});

  // Adds a session restored from the journal (not journaled again); false if the name is taken.
  bool AddRestored(std::shared_ptr<Session> session);
  // From now on sessions are journaled (the restored ones included); see Session::AttachJournal.
  void AttachJournal(Journal* journal);
  // Every session, for a final compaction.
  std::vector<std::shared_ptr<Session>> All() const;

  std::size_t size() const;

  // Whether name has the form "sessions/{session_id}" with a valid id.
  static bool IsSessionName(const std::string& name);
  // INVALID_ARGUMENT naming `field` unless session_id is empty (Create generates one) or a valid
  // id; the message quotes a bounded prefix of it. Create checks it too; callers check it before
  // any other work on the request.
  static Status CheckSessionId(const std::string& field, const std::string& session_id);

 private:
  using Map = std::map<std::string, std::shared_ptr<Session>>;
  std::string GenerateSessionId();
  // Checks the limits for a new session of the caller (sessions being created count); the
  // caller holds mutex_.
  Status CheckRoomLocked(const Principal& caller) const;
  // After Session::Remove (or RemoveIfBounded) returned `removal`: erases the session from the
  // map if it succeeded; the status to answer.
  Status FinishErase(const std::string& field, const std::shared_ptr<Session>& session,
                     const Status& removal);

  const std::size_t max_sessions_;
  const std::size_t max_sessions_per_owner_;
  mutable std::shared_mutex mutex_;
  Map sessions_;  // guarded by mutex_
  // Sessions being journaled by Create, not yet in sessions_: name -> owner. Their names are
  // taken, and they count toward the limits.
  std::map<std::string, std::string> creating_;  // guarded by mutex_
  std::mt19937_64 id_generator_;                 // guarded by mutex_
  Journal* journal_ = nullptr;                   // guarded by mutex_
};

}  // namespace mdr::service
