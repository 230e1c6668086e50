#include "mdr/service/session_store.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <mutex>
#include <optional>
#include <string_view>
#include <utility>

#include "mdr/base/log_value.h"
#include "mdr/base/status.h"
#include "mdr/service/journal.h"

namespace mdr::service {
namespace {

constexpr char kCollection[] = "sessions/";
constexpr std::size_t kMaxSessionIdLength = 63;
constexpr char kSessionIdForm[] = "1-63 characters of [a-z0-9-] starting with a letter";

// RFC 1034 style, as the API design guide recommends: [a-z][a-z0-9-]{0,62}.
bool IsValidSessionId(std::string_view id) {
  if (id.empty() || id.size() > kMaxSessionIdLength) return false;
  if (id.front() < 'a' || id.front() > 'z') return false;
  for (char c : id) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
    if (!allowed) return false;
  }
  return true;
}

Status NotFound(const std::string& field, const std::string& name) {
  return mdr::NotFound(field, name + " does not exist (or expired)");
}

// Hands out a session found for a lookup unless its idle timeout ran out, and restarts its timer.
bool TakeIfUnexpired(std::shared_ptr<Session> found, std::shared_ptr<Session>* session) {
  const auto now = Session::Clock::now();
  if (found->IsExpired(now)) return false;
  found->Touch(now);
  *session = std::move(found);
  return true;
}

}  // namespace

Status SessionStore::CheckSessionId(const std::string& field, const std::string& session_id) {
  if (session_id.empty() || IsValidSessionId(session_id)) return OkStatus();
  return InvalidArgument(field, std::string("must be empty (a generated id) or ") + kSessionIdForm +
                                    ", got " + Quoted(session_id));
}

bool SessionStore::IsSessionName(const std::string& name) {
  const std::string_view prefix = kCollection;
  return name.starts_with(prefix) && IsValidSessionId(std::string_view(name).substr(prefix.size()));
}

SessionStore::SessionStore(std::size_t max_sessions, std::size_t max_sessions_per_owner)
    : max_sessions_(max_sessions),
      max_sessions_per_owner_(max_sessions_per_owner),
      id_generator_(std::random_device{}()) {}

std::vector<std::string> SessionStore::EraseExpired(
    const std::function<bool(const Session&)>& which) {
  std::vector<std::shared_ptr<Session>> expired;
  Journal* journal = nullptr;
  {
    const auto now = Session::Clock::now();
    std::shared_lock lock(mutex_);
    journal = journal_;
    for (const auto& [name, session] : sessions_) {
      if ((!which || which(*session)) && session->IsExpired(now)) expired.push_back(session);
    }
  }
  // Each under its own mutex, not the store's: other lookups go on during the journal's writes.
  std::vector<std::string> erased;
  for (const std::shared_ptr<Session>& session : expired) {
    // A session a call holds now is in use, not idle: it stays.
    const std::optional<Status> removal = session->RemoveIfIdle([&] {
      if (journal != nullptr) {
        // Gone from memory either way; a session the journal keeps comes back at the next start
        // and expires again.
        if (Status status = journal->RemoveSession(session->name()); !status.ok()) {
          spdlog::error("event=journal_error session={} error={}", LogValue(session->name()),
                        Quoted(status.ToString(), kMaxLoggedErrorBytes));
        }
      }
      return OkStatus();
    });
    if (!removal || !removal->ok()) continue;  // in use, or a deletion removed it already
    (void)FinishErase("", session, *removal);
    erased.push_back(session->name());
  }
  return erased;
}

Status SessionStore::CheckRoomLocked(const Principal& caller) const {
  // Sessions being created count.
  if (sessions_.size() + creating_.size() >= max_sessions_) {
    return ResourceExhausted("", "the server holds its maximum of " +
                                     std::to_string(max_sessions_) +
                                     " sessions (--max-sessions); delete unused ones");
  }
  if (!caller || max_sessions_per_owner_ == 0) return OkStatus();
  auto owned = [&] {
    return static_cast<std::size_t>(
        std::count_if(
            sessions_.begin(), sessions_.end(),
            [&](const Map::value_type& entry) { return entry.second->owner() == *caller; }) +
        std::count_if(creating_.begin(), creating_.end(),
                      [&](const auto& entry) { return entry.second == *caller; }));
  };
  if (owned() >= max_sessions_per_owner_) {
    return ResourceExhausted("", "your token holds its maximum of " +
                                     std::to_string(max_sessions_per_owner_) +
                                     " sessions (--max-sessions-per-token); delete unused ones");
  }
  return OkStatus();
}

Status SessionStore::Create(const std::string& id_field, const std::string& session_id,
                            const Principal& caller, SessionOrigin state,
                            std::shared_ptr<Session>* session) {
  if (Status status = CheckSessionId(id_field, session_id); !status.ok()) return status;
  state.owner = caller.value_or("");
  std::unique_lock lock(mutex_);
  if (Status status = CheckRoomLocked(caller); !status.ok()) {
    // Expired sessions the sweeper has not reached yet do not count: erased (outside the lock;
    // every one if the server is full, else the caller's), then the limits checked again.
    const bool server_full = sessions_.size() + creating_.size() >= max_sessions_;
    lock.unlock();
    EraseExpired([&](const Session& session) {
      return server_full || session.owner() == caller.value_or("");
    });
    lock.lock();
    if (status = CheckRoomLocked(caller); !status.ok()) return status;
  }
  std::string name = kCollection + session_id;
  if (session_id.empty()) {
    do {
      name = kCollection + GenerateSessionId();
    } while (sessions_.contains(name) || creating_.contains(name));
  }
  if (creating_.contains(name)) return AlreadyExists(id_field, name + " already exists");
  if (auto it = sessions_.find(name); it != sessions_.end()) {
    // Names are global: a name taken by someone else's session is taken for the caller too. An
    // expired session that a call holds is in use: still there. The journal entry of a replaced
    // one is replaced below.
    const bool replaceable =
        it->second->removed() || (it->second->IsExpired(Session::Clock::now()) &&
                                  it->second->RemoveIfIdle(nullptr).has_value());
    if (!replaceable) return AlreadyExists(id_field, name + " already exists");
    sessions_.erase(it);
  }
  auto created = std::make_shared<Session>(name, std::move(state));
  if (Journal* journal = journal_; journal != nullptr) {
    // The name is held meanwhile, and the store's lock is not: every other lookup goes on while
    // the snapshot (of up to --max-message-bytes) is written.
    creating_.emplace(name, created->owner());
    lock.unlock();
    v1::SessionSnapshot snapshot;
    created->Export(&snapshot);
    Status status = journal->AddSession(name, created->owner(), created->create_time(), snapshot);
    if (status.ok()) created->AttachJournal(journal);
    lock.lock();
    creating_.erase(name);
    if (!status.ok()) return status;
  }
  sessions_.emplace(name, created);
  *session = std::move(created);
  return OkStatus();
}

Status SessionStore::Find(const std::string& field, const std::string& name,
                          const Principal& caller, std::shared_ptr<Session>* session) {
  if (!IsSessionName(name)) {
    return InvalidArgument(field,
                           std::string("must be a session name \"sessions/{session_id}\" whose "
                                       "session_id is ") +
                               kSessionIdForm + ", got " + Quoted(name));
  }
  {
    std::shared_lock lock(mutex_);
    auto it = sessions_.find(name);
    if (it == sessions_.end() || it->second->removed() || !it->second->VisibleTo(caller)) {
      return NotFound(field, name);
    }
    if (TakeIfUnexpired(it->second, session)) return OkStatus();
  }
  // Expired: erased by the sweeper (or a creation that needs the room), not on this thread.
  return NotFound(field, name);
}

std::size_t RecentSessions::IndexOf(const std::string& name) const {
  for (std::size_t i = 0; i < used_; ++i) {
    if (entries_[i].name == name) return i;
  }
  return kCapacity;
}

std::shared_ptr<Session> RecentSessions::Lookup(const std::string& name) const {
  const std::size_t i = IndexOf(name);
  return i < kCapacity ? entries_[i].session.lock() : nullptr;
}

void RecentSessions::Remember(const std::string& name, const std::shared_ptr<Session>& session) {
  std::size_t i = IndexOf(name);
  if (i == kCapacity) {
    i = used_ < kCapacity ? used_++ : next_++ % kCapacity;
    entries_[i].name.assign(name);  // reuses the entry's buffer
  }
  entries_[i].session = session;
}

Status SessionStore::FindAgain(const std::string& field, const std::string& name,
                               const Principal& caller, RecentSessions* recent,
                               std::shared_ptr<Session>* session) {
  // Removal is marked under the store's exclusive lock before the erase, so a session seen here
  // as not removed was in the store at this moment: as if Find had run now.
  if (std::shared_ptr<Session> kept = recent->Lookup(name);
      kept != nullptr && !kept->removed() && kept->VisibleTo(caller) &&
      TakeIfUnexpired(std::move(kept), session)) {
    return OkStatus();
  }
  Status status = Find(field, name, caller, session);
  if (status.ok()) recent->Remember(name, *session);
  return status;
}

Status SessionStore::Erase(const std::string& field, const std::string& name,
                           const Principal& caller) {
  std::shared_ptr<Session> session;
  if (Status status = Find(field, name, caller, &session); !status.ok()) return status;
  Journal* journal = nullptr;
  {
    std::shared_lock lock(mutex_);
    journal = journal_;
  }
  // Under the session's mutex, not the store's: the journal's write (and a batch running on the
  // session, which commits first) keeps no other session's lookup waiting. A concurrent delete
  // may have won; deleting twice reports NOT_FOUND once.
  return FinishErase(field, session, session->Remove([&] {
    return journal != nullptr ? journal->RemoveSession(name) : OkStatus();
  }));
}

std::optional<Status> SessionStore::EraseIfBounded(const std::string& field,
                                                   const std::string& name,
                                                   const Principal& caller) {
  std::shared_ptr<Session> session;
  if (Status status = Find(field, name, caller, &session); !status.ok()) return status;
  std::optional<Status> removal = session->RemoveIfBounded();
  if (!removal) return std::nullopt;
  return FinishErase(field, session, *removal);
}

Status SessionStore::FinishErase(const std::string& field, const std::shared_ptr<Session>& session,
                                 const Status& removal) {
  if (removal.code() == StatusCode::kNotFound) return NotFound(field, session->name());
  if (!removal.ok()) return removal;
  std::unique_lock lock(mutex_);
  if (auto it = sessions_.find(session->name()); it != sessions_.end() && it->second == session) {
    sessions_.erase(it);
  }
  return OkStatus();
}

std::vector<std::shared_ptr<Session>> SessionStore::ListAfter(const std::string& after,
                                                              std::size_t page_size,
                                                              const Principal& caller,
                                                              bool* more) const {
  std::vector<std::shared_ptr<Session>> page;
  const auto now = Session::Clock::now();
  auto listed = [&](const Session& session) {
    return session.VisibleTo(caller) && !session.removed() && !session.IsExpired(now);
  };
  std::shared_lock lock(mutex_);
  auto it = after.empty() ? sessions_.begin() : sessions_.upper_bound(after);
  for (; it != sessions_.end() && page.size() < page_size; ++it) {
    if (listed(*it->second)) page.push_back(it->second);
  }
  while (it != sessions_.end() && !listed(*it->second)) ++it;
  *more = it != sessions_.end();
  return page;
}

bool SessionStore::AddRestored(std::shared_ptr<Session> session) {
  std::unique_lock lock(mutex_);
  const std::string name = session->name();
  return sessions_.emplace(name, std::move(session)).second;
}

void SessionStore::AttachJournal(Journal* journal) {
  std::unique_lock lock(mutex_);
  journal_ = journal;
  for (const auto& [name, session] : sessions_) session->AttachJournal(journal);
}

std::vector<std::shared_ptr<Session>> SessionStore::All() const {
  std::vector<std::shared_ptr<Session>> all;
  std::shared_lock lock(mutex_);
  for (const auto& [name, session] : sessions_) all.push_back(session);
  return all;
}

std::size_t SessionStore::size() const {
  std::shared_lock lock(mutex_);
  return sessions_.size();
}

// Random, so ids do not repeat across restarts; the caller holds mutex_ and checks uniqueness.
std::string SessionStore::GenerateSessionId() {
  char id[20];
  std::snprintf(id, sizeof id, "s%016llx", static_cast<unsigned long long>(id_generator_()));
  return id;
}

}  // namespace mdr::service
