#include "mdr/service/session_store.h"

#include <google/protobuf/util/time_util.h>

#include <cstdio>
#include <random>
#include <utility>

#include "mdr/service/conversion.h"
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

bool IsSessionName(const std::string& name) {
  const std::string prefix = kCollection;
  return name.starts_with(prefix) && IsValidSessionId(name.substr(prefix.size()));
}

}  // namespace

Session::Session(std::string name, v1::Scene scene, Contact contact)
    : name_(std::move(name)),
      scene_(std::move(scene)),
      create_time_(google::protobuf::util::TimeUtil::GetCurrentTime()),
      contact_(std::move(contact)) {}

Status Session::Apply(const google::protobuf::RepeatedPtrField<v1::Step>& steps,
                      bool include_step_results, v1::ApplyResponse* response) {
  std::lock_guard lock(mutex_);
  // Work on a copy so that a failing step leaves the session as it was.
  Contact trial = contact_;
  std::uint64_t applied = applied_steps_;
  for (int i = 0; i < steps.size(); ++i) {
    StepReport report;
    if (Status status = trial.Apply(ToCoreStep(steps[i]), &report); !status.ok()) {
      response->Clear();
      return status.WithFieldPrefix("steps[" + std::to_string(i) + "]");
    }
    ++applied;
    if (include_step_results) {
      ToProtoStepResult(trial, applied, report, response->add_step_results());
    }
  }
  contact_ = std::move(trial);
  applied_steps_ = applied;
  ToProtoState(contact_, applied_steps_, response->mutable_state());
  return OkStatus();
}

void Session::ReadState(v1::ContactState* state) const {
  std::lock_guard lock(mutex_);
  ToProtoState(contact_, applied_steps_, state);
}

void Session::ReadResource(v1::Session* resource) const {
  resource->set_name(name_);
  *resource->mutable_scene() = scene_;
  *resource->mutable_create_time() = create_time_;
  ReadState(resource->mutable_state());
}

SessionStore::SessionStore(std::size_t max_sessions)
    : max_sessions_(max_sessions), id_generator_(std::random_device{}()) {}

grpc::Status SessionStore::Create(const std::string& session_id, const v1::Scene& scene,
                                  Contact contact, std::shared_ptr<Session>* session) {
  if (!session_id.empty() && !IsValidSessionId(session_id)) {
    return GrpcError(
        grpc::StatusCode::INVALID_ARGUMENT, "session_id",
        "must be 1-63 characters of [a-z0-9-] starting with a letter, got \"" + session_id + "\"");
  }
  std::unique_lock lock(mutex_);
  if (sessions_.size() >= max_sessions_) {
    return GrpcError(grpc::StatusCode::RESOURCE_EXHAUSTED, "",
                     "the server holds its maximum of " + std::to_string(max_sessions_) +
                         " sessions; delete unused ones");
  }
  std::string name = kCollection + session_id;
  if (session_id.empty()) {
    do {
      name = kCollection + GenerateSessionId();
    } while (sessions_.contains(name));
  }
  if (sessions_.contains(name)) {
    return GrpcError(grpc::StatusCode::ALREADY_EXISTS, "session_id", name + " already exists");
  }
  auto created = std::make_shared<Session>(name, scene, std::move(contact));
  sessions_.emplace(name, created);
  *session = std::move(created);
  return grpc::Status::OK;
}

grpc::Status SessionStore::Find(const std::string& field, const std::string& name,
                                std::shared_ptr<Session>* session) const {
  if (!IsSessionName(name)) {
    return GrpcError(grpc::StatusCode::INVALID_ARGUMENT, field,
                     "must be a session name \"sessions/{session_id}\", got \"" + name + "\"");
  }
  std::shared_lock lock(mutex_);
  auto it = sessions_.find(name);
  if (it == sessions_.end()) {
    return GrpcError(grpc::StatusCode::NOT_FOUND, field, name + " does not exist");
  }
  *session = it->second;
  return grpc::Status::OK;
}

grpc::Status SessionStore::Erase(const std::string& field, const std::string& name) {
  std::shared_ptr<Session> session;
  if (grpc::Status status = Find(field, name, &session); !status.ok()) return status;
  std::unique_lock lock(mutex_);
  // A concurrent delete may have won; deleting twice reports NOT_FOUND once.
  if (sessions_.erase(name) == 0) {
    return GrpcError(grpc::StatusCode::NOT_FOUND, field, name + " does not exist");
  }
  return grpc::Status::OK;
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
