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

google::protobuf::FieldMask RecordedFields(bool torsional) {
  google::protobuf::FieldMask mask;
  mask.add_paths(torsional ? "state.twist" : "state.actuator_displacement");
  mask.add_paths(torsional ? "state.twisting_moment" : "state.tangential_force");
  return mask;
}

// Applies `steps` in batches and appends the state after each step to *run: the actuator's
// displacement and F_x, or a torsional session's twist and moment.
grpc::Status ApplyRecorded(ContactClient& client, const std::string& session,
                           std::uint32_t batch_limit,
                           const google::protobuf::RepeatedPtrField<mdr::v1::Step>& steps,
                           bool torsional, RecordedRun* run) {
  const google::protobuf::FieldMask mask = RecordedFields(torsional);
  const int batch = static_cast<int>(std::clamp<std::uint32_t>(batch_limit, 1, kBatch));
  for (int first = 0; first < steps.size(); first += batch) {
    const int last = std::min(steps.size(), first + batch);
    google::protobuf::RepeatedPtrField<mdr::v1::Step> part(steps.begin() + first,
                                                           steps.begin() + last);
    auto applied = client.Apply(session, part, mask);
    if (!applied.ok()) return applied.status();
    for (const auto& result : applied->step_results()) {
      const mdr::v1::ContactState& state = result.state();
      run->displacement.push_back(torsional ? state.twist() : state.actuator_displacement());
      run->force.push_back(torsional ? state.twisting_moment() : state.tangential_force());
    }
  }
  return grpc::Status::OK;
}

std::uint32_t BatchLimit(const mdr::v1::Session& session) {
  const std::uint32_t limit = session.limits().max_steps_per_batch();
  return limit == 0 ? kBatch : limit;
}

// The twist and moment after each of `steps` (the first presses at twist 0) of a session of the
// torsional scene's contact: its shaft left out, which sessions refuse.
RpcResult<RecordedRun> RecordTwists(
    ContactClient& client, const mdr::v1::Scene& scene,
    const google::protobuf::RepeatedPtrField<mdr::v1::Step>& steps) {
  mdr::v1::Scene contact = scene;
  contact.mutable_torsion()->clear_rig_compliance();
  auto created = client.CreateSession(contact);
  if (!created.ok()) return created.status();
  const ScopedSession session(client, created->name());
  RecordedRun run;
  const grpc::Status applied =
      ApplyRecorded(client, session.name(), BatchLimit(*created), steps, true, &run);
  if (!applied.ok()) return applied;
  return run;
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
      ApplyRecorded(client, session.name(), BatchLimit(*created), steps, false, &run);
  if (!applied.ok()) return applied;
  return run;
}

RpcResult<RecordedRun> RecordSineTwistRun(ContactClient& client, const mdr::v1::Scene& scene,
                                          double normal_force, double amplitude, int cycles,
                                          int samples_per_cycle) {
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(normal_force);  // a step moves one channel: the twist stays 0
  for (int k = 1; k <= cycles * samples_per_cycle; ++k) {
    const double phase = 2 * std::numbers::pi * (k % samples_per_cycle) / samples_per_cycle;
    steps.Add()->set_twist(amplitude * std::sin(phase));
  }
  auto run = RecordTwists(client, scene, steps);
  if (!run.ok()) return run;
  const double compliance = scene.torsion().rig_compliance();
  for (std::size_t k = 0; k < run->displacement.size(); ++k) {
    run->displacement[k] += compliance * run->force[k];
  }
  return run;
}

RpcResult<std::vector<double>> ReplayTwists(ContactClient& client, const mdr::v1::Scene& scene,
                                            double normal_force,
                                            const std::vector<double>& twists) {
  google::protobuf::RepeatedPtrField<mdr::v1::Step> steps;
  steps.Add()->set_normal_force(normal_force);
  for (double twist : twists) steps.Add()->set_twist(twist);
  auto run = RecordTwists(client, scene, steps);
  if (!run.ok()) return run.status();
  return std::vector<double>(run->force.begin() + 1, run->force.end());
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
      ApplyRecorded(client, session.name(), BatchLimit(*created), steps, false, &run);
  if (!applied.ok()) return applied;
  return std::vector<double>(run.force.begin() + 1, run.force.end());
}

}  // namespace mdrctl
