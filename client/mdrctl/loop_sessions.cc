#include "loop_sessions.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mdrctl {
namespace {

using mdr::client::ContactClient;
using mdr::client::RpcResult;

// Steps per Apply: many, for speed, within the session's limit and the message size.
constexpr std::uint32_t kBatch = 4096;

// A session deleted when this goes out of scope (also on errors).
class ScopedSession {
 public:
  ScopedSession(ContactClient& client, std::string name)
      : client_(client), name_(std::move(name)) {}
  ~ScopedSession() { (void)client_.DeleteSession(name_); }
  const std::string& name() const { return name_; }

 private:
  ContactClient& client_;
  std::string name_;
};

google::protobuf::FieldMask RecordedFields() {
  google::protobuf::FieldMask mask;
  mask.add_paths("state.actuator_displacement");
  mask.add_paths("state.tangential_force");
  return mask;
}

// Applies `steps` in batches and appends the state after each step to *run.
grpc::Status ApplyRecorded(ContactClient& client, const std::string& session,
                           std::uint32_t batch_limit,
                           const google::protobuf::RepeatedPtrField<mdr::v1::Step>& steps,
                           RecordedRun* run) {
  const google::protobuf::FieldMask mask = RecordedFields();
  const int batch = static_cast<int>(std::clamp<std::uint32_t>(batch_limit, 1, kBatch));
  for (int first = 0; first < steps.size(); first += batch) {
    const int last = std::min(steps.size(), first + batch);
    google::protobuf::RepeatedPtrField<mdr::v1::Step> part(steps.begin() + first,
                                                           steps.begin() + last);
    auto applied = client.Apply(session, part, mask);
    if (!applied.ok()) return applied.status();
    for (const auto& result : applied->step_results()) {
      run->displacement.push_back(result.state().actuator_displacement());
      run->force.push_back(result.state().tangential_force());
    }
  }
  return grpc::Status::OK;
}

std::uint32_t BatchLimit(const mdr::v1::Session& session) {
  const std::uint32_t limit = session.limits().max_steps_per_batch();
  return limit == 0 ? kBatch : limit;
}

}  // namespace

RpcResult<RecordedRun> RecordSineRun(ContactClient& client, const mdr::v1::Scene& scene,
                                     double normal_force, double amplitude, int cycles,
                                     int samples_per_cycle) {
  auto created = client.CreateSession(scene);
  if (!created.ok()) return created.status();
  const ScopedSession session(client, created->name());
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(normal_force);
  for (int k = 1; k <= cycles * samples_per_cycle; ++k) {
    // The phase from k mod N: every cycle gets the same displacements, exactly.
    const double phase = 2 * std::numbers::pi * (k % samples_per_cycle) / samples_per_cycle;
    steps.Add()->set_displacement(amplitude * std::sin(phase));
  }
  RecordedRun run;
  const grpc::Status applied =
      ApplyRecorded(client, session.name(), BatchLimit(*created), steps, &run);
  if (!applied.ok()) return applied;
  return run;
}

RpcResult<std::vector<double>> ReplayForces(ContactClient& client, const mdr::v1::Scene& scene,
                                            double normal_force, const std::vector<double>& normal,
                                            const std::vector<double>& displacement) {
  auto created = client.CreateSession(scene);
  if (!created.ok()) return created.status();
  const ScopedSession session(client, created->name());
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  mdr::v1::Step* press = steps.Add();
  press->set_normal_force(normal.empty() ? normal_force : normal.front());
  press->set_displacement(0);
  for (std::size_t i = 0; i < displacement.size(); ++i) {
    mdr::v1::Step* step = steps.Add();
    step->set_displacement(displacement[i]);
    if (!normal.empty()) step->set_normal_force(normal[i]);
  }
  RecordedRun run;
  const grpc::Status applied =
      ApplyRecorded(client, session.name(), BatchLimit(*created), steps, &run);
  if (!applied.ok()) return applied;
  return std::vector<double>(run.force.begin() + 1, run.force.end());
}

}  // namespace mdrctl
