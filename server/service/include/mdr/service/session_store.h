// The thread-safe set of sessions, ordered by name (stable pages for ListSessions). Sessions
// whose idle timeout ran out are invisible at once and erased by EraseExpired (the server's
// sweeper) or on the next lookup.
#pragma once

#include <grpcpp/support/status.h>

#include <cstddef>
#include <map>
#include <memory>
#include <random>
#include <shared_mutex>
#include <string>
#include <vector>

#include "mdr/service/session.h"

namespace mdr::service {

class SessionStore {
 public:
  explicit SessionStore(std::size_t max_sessions);

  // Creates "sessions/{session_id}"; an empty session_id gets a generated one. Errors:
  // INVALID_ARGUMENT (session_id, named by id_field), ALREADY_EXISTS, RESOURCE_EXHAUSTED.
  grpc::Status Create(const std::string& id_field, const std::string& session_id,
                      SessionState state, std::shared_ptr<Session>* session);
  // Finds a live session and restarts its idle timer. NOT_FOUND for an unknown or expired name,
  // INVALID_ARGUMENT for one not of the form "sessions/{id}"; field names the request field.
  grpc::Status Find(const std::string& field, const std::string& name,
                    std::shared_ptr<Session>* session);
  grpc::Status Erase(const std::string& field, const std::string& name);

  // Up to page_size live sessions with names after `after` (empty: from the first), in name
  // order; *more tells whether further sessions follow.
  std::vector<std::shared_ptr<Session>> ListAfter(const std::string& after, std::size_t page_size,
                                                  bool* more) const;

  // Erases the sessions whose idle timeout ran out; returns their names.
  std::vector<std::string> EraseExpired();

  std::size_t size() const;

  // Whether name has the form "sessions/{session_id}" with a valid id.
  static bool IsSessionName(const std::string& name);

 private:
  std::string GenerateSessionId();

  const std::size_t max_sessions_;
  mutable std::shared_mutex mutex_;
  std::map<std::string, std::shared_ptr<Session>> sessions_;  // guarded by mutex_
  std::mt19937_64 id_generator_;                              // guarded by mutex_
};

}  // namespace mdr::service
