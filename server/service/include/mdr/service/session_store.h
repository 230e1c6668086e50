// Contact sessions and the thread-safe store that owns them. Calls on one session are
// serialised by the session's own mutex; calls on different sessions run in parallel.
#pragma once

#include <google/protobuf/repeated_field.h>
#include <google/protobuf/timestamp.pb.h>
#include <grpcpp/support/status.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <random>
#include <shared_mutex>
#include <string>
#include <unordered_map>

#include "mdr/core/contact.h"
#include "mdr/core/status.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

class Session {
 public:
  Session(std::string name, v1::Scene scene, Contact contact);

  const std::string& name() const { return name_; }

  // Applies the steps atomically: all succeed and are committed, or the first failure is
  // returned (field prefixed "steps[i]") and the session is unchanged.
  Status Apply(const google::protobuf::RepeatedPtrField<v1::Step>& steps, bool include_step_results,
               v1::ApplyResponse* response);

  void ReadState(v1::ContactState* state) const;
  // Scene, state and creation time as the API resource.
  void ReadResource(v1::Session* resource) const;

 private:
  const std::string name_;
  const v1::Scene scene_;
  const google::protobuf::Timestamp create_time_;

  mutable std::mutex mutex_;
  Contact contact_;                  // guarded by mutex_
  std::uint64_t applied_steps_ = 0;  // guarded by mutex_
};

class SessionStore {
 public:
  explicit SessionStore(std::size_t max_sessions);

  // Creates a session "sessions/{session_id}" for a validated scene; an empty session_id gets a
  // generated one. Errors: ALREADY_EXISTS, RESOURCE_EXHAUSTED, INVALID_ARGUMENT (session_id).
  grpc::Status Create(const std::string& session_id, const v1::Scene& scene, Contact contact,
                      std::shared_ptr<Session>* session);
  // NOT_FOUND for an unknown name, INVALID_ARGUMENT for one not of the form "sessions/{id}";
  // field names the request field that held the name.
  grpc::Status Find(const std::string& field, const std::string& name,
                    std::shared_ptr<Session>* session) const;
  grpc::Status Erase(const std::string& field, const std::string& name);

  std::size_t size() const;

 private:
  std::string GenerateSessionId();

  const std::size_t max_sessions_;
  mutable std::shared_mutex mutex_;
  std::unordered_map<std::string, std::shared_ptr<Session>> sessions_;  // guarded by mutex_
  std::mt19937_64 id_generator_;                                        // guarded by mutex_
};

}  // namespace mdr::service
