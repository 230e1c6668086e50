#include "mdr/service/session_store.h"

#include <cstdio>
#include <mutex>
#include <utility>

#include "mdr/service/status.h"

namespace mdr::service {
namespace {

constexpr char kCollection[] = "sessions/";
constexpr std::size_t kMaxSessionIdLength = 63;

// RFC 1034 style, as the API design guide recommends: [a-z][a-z0-9-]{0,62}.
bool IsValidSessionId(const std::string& id) {
  if (id.empty() || id.size() > kMaxSessionIdLength) return false;
  if (id.front() < 'a' || id.front() > 'z') return false;
  for (char c : id) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
    if (!allowed) return false;
  }
  return true;
}

grpc::Status NotFound(const std::string& field, const std::string& name) {
  return GrpcError(grpc::StatusCode::NOT_FOUND, field, name + " does not exist (or expired)");
}

}  // namespace

bool SessionStore::IsSessionName(const std::string& name) {
  const std::string prefix = kCollection;
  return name.starts_with(prefix) && IsValidSessionId(name.substr(prefix.size()));
}

SessionStore::SessionStore(std::size_t max_sessions)
    : max_sessions_(max_sessions), id_generator_(std::random_device{}()) {}

grpc::Status SessionStore::Create(const std::string& id_field, const std::string& session_id,
                                  SessionState state, std::shared_ptr<Session>* session) {
  if (!session_id.empty() && !IsValidSessionId(session_id)) {
    return GrpcError(
        grpc::StatusCode::INVALID_ARGUMENT, id_field,
        "must be 1-63 characters of [a-z0-9-] starting with a letter, got \"" + session_id + "\"");
  }
  std::unique_lock lock(mutex_);
  if (sessions_.size() >= max_sessions_) {
    // Expired sessions the sweeper has not reached yet do not count.
    std::erase_if(sessions_, [now = Session::Clock::now()](const auto& entry) {
      return entry.second->IsExpired(now);
    });
  }
  if (sessions_.size() >= max_sessions_) {
    return GrpcError(grpc::StatusCode::RESOURCE_EXHAUSTED, "",
                     "the server holds its maximum of " + std::to_string(max_sessions_) +
                         " sessions (--max-sessions); delete unused ones");
  }
  std::string name = kCollection + session_id;
  if (session_id.empty()) {
    do {
      name = kCollection + GenerateSessionId();
    } while (sessions_.contains(name));
  }
  if (auto it = sessions_.find(name); it != sessions_.end()) {
    if (!it->second->IsExpired(Session::Clock::now())) {
      return GrpcError(grpc::StatusCode::ALREADY_EXISTS, id_field, name + " already exists");
    }
    sessions_.erase(it);
  }
  auto created = std::make_shared<Session>(name, std::move(state));
  sessions_.emplace(name, created);
  *session = std::move(created);
  return grpc::Status::OK;
}

grpc::Status SessionStore::Find(const std::string& field, const std::string& name,
                                std::shared_ptr<Session>* session) {
  if (!IsSessionName(name)) {
    return GrpcError(grpc::StatusCode::INVALID_ARGUMENT, field,
                     "must be a session name \"sessions/{session_id}\", got \"" + name + "\"");
  }
  {
    std::shared_lock lock(mutex_);
    auto it = sessions_.find(name);
    if (it == sessions_.end()) return NotFound(field, name);
    if (!it->second->IsExpired(Session::Clock::now())) {
      it->second->Touch();
      *session = it->second;
      return grpc::Status::OK;
    }
  }
  std::unique_lock lock(mutex_);
  if (auto it = sessions_.find(name);
      it != sessions_.end() && it->second->IsExpired(Session::Clock::now())) {
    sessions_.erase(it);
  }
  return NotFound(field, name);
}

grpc::Status SessionStore::Erase(const std::string& field, const std::string& name) {
  std::shared_ptr<Session> session;
  if (grpc::Status status = Find(field, name, &session); !status.ok()) return status;
  std::unique_lock lock(mutex_);
  // A concurrent delete may have won; deleting twice reports NOT_FOUND once.
  if (sessions_.erase(name) == 0) return NotFound(field, name);
  return grpc::Status::OK;
}

std::vector<std::shared_ptr<Session>> SessionStore::ListAfter(const std::string& after,
                                                              std::size_t page_size,
                                                              bool* more) const {
  std::vector<std::shared_ptr<Session>> page;
  const auto now = Session::Clock::now();
  std::shared_lock lock(mutex_);
  auto it = after.empty() ? sessions_.begin() : sessions_.upper_bound(after);
  for (; it != sessions_.end() && page.size() < page_size; ++it) {
    if (!it->second->IsExpired(now)) page.push_back(it->second);
  }
  while (it != sessions_.end() && it->second->IsExpired(now)) ++it;
  *more = it != sessions_.end();
  return page;
}

std::vector<std::string> SessionStore::EraseExpired() {
  std::vector<std::string> erased;
  const auto now = Session::Clock::now();
  std::unique_lock lock(mutex_);
  std::erase_if(sessions_, [&](const auto& entry) {
    if (!entry.second->IsExpired(now)) return false;
    erased.push_back(entry.first);
    return true;
  });
  return erased;
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
