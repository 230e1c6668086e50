#include "mdr/service/session.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>
#include <utility>

#include "mdr/base/log_value.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/service/journal.h"
#include "mdr/service/limits.h"
#include "mdr/service/metrics.h"

namespace mdr::service {

using bridge::ApplyInterfaceStep;
using bridge::ApplyTorsionStep;
using bridge::BatchOutputs;
using bridge::BoundsAfterOneStraightStep;
using bridge::BoundsAtCommit;
using bridge::CheckExportable;
using bridge::CheckSingleContactQuery;
using bridge::CheckSingleContactStep;
using bridge::CopyStateFields;
using bridge::ExportBytesBound;
using bridge::ExportedSceneBytes;
using bridge::InterfaceQuery;
using bridge::KeepState;
using bridge::KeptState;
using bridge::kMaxAppliedSteps;
using bridge::kSnapshotVersion;
using bridge::MovesEveryContactOnce;
using bridge::OutputCounters;
using bridge::OutputSelection;
using bridge::RadialSampling;
using bridge::RefuseTwist;
using bridge::StateBytes;
using bridge::StepBounds;
using bridge::ToCoreStep;
using bridge::ToProtoInterfaceSnapshot;
using bridge::ToProtoSnapshot;
using bridge::ToProtoTorsionSnapshot;
using bridge::WithEffectiveOptions;
using bridge::WriteApproximationErrors;
using bridge::WriteCompleteState;
using bridge::WriteInterfaceQueryOutputs;
using bridge::WriteInterfaceState;
using bridge::WriteInterfaceStepResult;
using bridge::WriteKeptState;
using bridge::WriteQueryOutputs;
using bridge::WriteState;
using bridge::WriteStepResult;
using bridge::WriteTorsionQueryOutputs;
using bridge::WriteTorsionState;
using bridge::WriteTorsionStepResult;
namespace {

using google::protobuf::util::TimeUtil;

class Stopwatch {
 public:
  // Seconds from the start to `end`.
  double Seconds(
      std::chrono::steady_clock::time_point end = std::chrono::steady_clock::now()) const {
    return std::chrono::duration<double>(end - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// Identifies what a request asked for, so a request_id reused for other steps is caught. Kept in
// the journal: libstdc++'s string hash is the same in every process.
std::uint64_t Fingerprint(const v1::ApplyRequest& request) {
  v1::ApplyRequest content;
  *content.mutable_steps() = request.steps();
  *content.mutable_step_mask() = request.step_mask();
  *content.mutable_state_mask() = request.state_mask();  // absent: the bytes of before
  return std::hash<std::string>{}(content.SerializeAsString());
}

}  // namespace

std::size_t StateBytes(const SessionOrigin& state) {
  if (state.interface) return StateBytes(*state.interface);
  // A torsional session holds its scene's contact too (its profile: a tabulated one's tables).
  if (state.torsion) return StateBytes(state.contact) + StateBytes(*state.torsion);
  return StateBytes(state.contact);
}

std::size_t ExportBytesBound(const SessionOrigin& state) {
  const std::size_t scene_bytes = ExportedSceneBytes(state.scene, state.contact);
  if (state.interface) return ExportBytesBound(*state.interface, scene_bytes);
  if (state.torsion) return ExportBytesBound(*state.torsion, scene_bytes);
  return ExportBytesBound(state.contact, scene_bytes);
}

Session::Session(std::string name, SessionOrigin state)
    : name_(std::move(name)),
      owner_(std::move(state.owner)),
      scene_(std::move(state.scene)),
      limits_(std::move(state.limits)),
      idle_timeout_(IdleTimeout(limits_)),
      create_time_(state.create_time.value_or(TimeUtil::GetCurrentTime())),
      max_message_bytes_(state.max_message_bytes),
      scene_bytes_(ExportedSceneBytes(scene_, state.contact)),
      last_used_(Clock::now().time_since_epoch().count()),
      contact_(std::move(state.contact)),
      interface_(std::move(state.interface)),
      torsion_(std::move(state.torsion)),
      applied_steps_(state.applied_steps),
      journal_sequence_(state.journal_sequence),
      journal_snapshot_sequence_(state.journal_snapshot_sequence),
      charge_(std::move(state.charge)) {
  for (CompletedRequest& completed : state.completed) completed_.Add(std::move(completed));
  if (!interface_ && !torsion_) kept_state_config_.emplace(contact_->config());
  CommitStateLocked(OutputSelection::FullState(), nullptr);
}

Session::Session(std::string name, UnavailableSession unavailable)
    : name_(std::move(name)),
      owner_(std::move(unavailable.owner)),
      scene_(std::move(unavailable.scene)),
      limits_(std::move(unavailable.limits)),
      idle_timeout_(0),
      create_time_(std::move(unavailable.create_time)),
      unavailable_reason_(std::move(unavailable.reason)),
      max_message_bytes_(0),
      scene_bytes_(0),
      last_used_(Clock::now().time_since_epoch().count()),
      applied_steps_(0),
      journal_sequence_(0),
      journal_snapshot_sequence_(0) {}

Status Session::RequireAvailable() const {
  if (available()) return OkStatus();
  return FailedPrecondition("", name_ +
                                    " is unavailable: it could not be restored from the journal (" +
                                    unavailable_reason_ + "); DeleteSession removes it");
}

void Session::AttachJournal(Journal* journal) {
  std::lock_guard lock(mutex_);
  journal_ = journal;
}

Status Session::Remove(const std::function<Status()>& remove_entry) {
  std::lock_guard lock(mutex_);
  return RemoveLocked(remove_entry);
}

std::optional<Status> Session::RemoveIfIdle(const std::function<Status()>& remove_entry) {
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) return std::nullopt;
  return RemoveLocked(remove_entry);
}

std::optional<Status> Session::RemoveIfBounded() {
  if (scene_.has_interface()) return std::nullopt;  // its memory takes long to free
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || journal_ != nullptr) return std::nullopt;
  return RemoveLocked(nullptr);
}

Status Session::RemoveLocked(const std::function<Status()>& remove_entry) {
  if (removed()) return NotFound("", name_ + " does not exist (deleted or expired)");
  if (remove_entry) {
    if (Status status = remove_entry(); !status.ok()) return status;
  }
  removed_.store(true, std::memory_order_release);
  return OkStatus();
}

Status Session::CompactJournal() {
  std::lock_guard lock(mutex_);
  if (journal_ == nullptr || !available() || removed() ||
      journal_snapshot_sequence_ == journal_sequence_) {
    return OkStatus();
  }
  return CompactJournalLocked();
}

Status Session::CompactJournalLocked() {
  v1::SessionSnapshot snapshot;
  ExportLocked(&snapshot);
  const std::vector<CompletedRequest> completed(completed_.entries().begin(),
                                                completed_.entries().end());
  Status status = journal_->Compact(name_, journal_sequence_, snapshot, completed);
  if (status.ok()) journal_snapshot_sequence_ = journal_sequence_;
  return status;
}

Status Session::Apply(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                      const StepGuard& guard, std::size_t max_response_bytes,
                      v1::ApplyResponse* response, const Interrupt& interrupt) {
  if (static_cast<std::uint32_t>(request.steps_size()) > limits_.max_steps_per_batch()) {
    return ResourceExhausted(
        "steps", std::to_string(request.steps_size()) + " steps exceed the session's limit of " +
                     std::to_string(limits_.max_steps_per_batch()) + " per batch; split the batch");
  }
  if (Status status = RequireAvailable(); !status.ok()) return status;
  std::lock_guard lock(mutex_);
  return ApplyLocked(request, outputs, guard, max_response_bytes, response, interrupt);
}

std::optional<Status> Session::ApplyIfBounded(const v1::ApplyRequest& request,
                                              const BatchOutputs& outputs, std::size_t max_vertices,
                                              std::size_t max_response_bytes,
                                              v1::ApplyResponse* response) {
  if (!available() || interface_ || torsion_ || request.steps_size() != 1) return std::nullopt;
  // Never waits: the session may be held by a batch of another caller's strand (the executor
  // orders a caller's calls; two callers may share a session without authentication).
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) return std::nullopt;
  if (journal_ != nullptr) return std::nullopt;  // a write whose time the disk decides
  if (contact_->config().method != Method::kExact ||
      contact_->memory().vertex_count() > max_vertices || !StraightStepLocked(request.steps(0))) {
    return std::nullopt;
  }
  return ApplyLocked(request, outputs, {}, max_response_bytes, response, {});
}

bool Session::StraightStepLocked(const v1::Step& step) const {
  if (!step.contact_normal_values().empty() || !step.contact_tangential_values().empty() ||
      step.torsional_case() != v1::Step::TORSIONAL_NOT_SET) {
    return false;  // refused by the batch's checks
  }
  const bool holds_depth =
      step.normal_case() == v1::Step::NORMAL_NOT_SET ||
      (step.normal_case() == v1::Step::kDepthIncrement && step.depth_increment() == 0);
  if (holds_depth) return true;  // a displacement or force target at a held depth
  const RigCompliance& rig = contact_->config().rig;
  return step.normal_case() != v1::Step::kNormalForce &&
         step.tangential_case() != v1::Step::kTangentialForce && !(rig.normal > 0) &&
         !(rig.tangential > 0);
}

Status Session::ApplyLocked(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                            const StepGuard& guard, std::size_t max_response_bytes,
                            v1::ApplyResponse* response, const Interrupt& interrupt) {
  // Removed while the batch waited for the session: its journal entry may be gone already.
  if (removed()) return NotFound("session", name_ + " does not exist (deleted or expired)");
  const bool deduplicated = !request.request_id().empty();
  const std::uint64_t fingerprint = deduplicated ? Fingerprint(request) : 0;
  const Stopwatch stopwatch;
  if (deduplicated) {
    if (const CompletedRequest* done = completed_.Find(request.request_id())) {
      if (done->fingerprint != fingerprint) {
        return InvalidArgument(
            "request_id", "\"" + request.request_id() +
                              "\" was used for a different batch on this session; use a new id");
      }
      *response = done->response;
      response->set_replayed(true);
      return OkStatus();
    }
  }
  if (Status status = RunBatch(request, outputs, guard, max_response_bytes, response, interrupt);
      !status.ok()) {
    response->Clear();
    return status;
  }
  const Clock::time_point end = Clock::now();  // one clock read for both
  response->set_compute_seconds(stopwatch.Seconds(end));
  if (deduplicated) completed_.Add({request.request_id(), fingerprint, *response});
  if (journal_ != nullptr &&
      journal_sequence_ - journal_snapshot_sequence_ >= journal_->options().snapshot_every) {
    // The batch is journaled either way; a failed compaction only leaves more to replay.
    if (Status status = CompactJournalLocked(); !status.ok()) {
      spdlog::error("event=journal_compaction_failed session={} error={}", LogValue(name_),
                    Quoted(status.ToString(), kMaxLoggedErrorBytes));
    }
  }
  Touch(end);  // a long batch counts as use until its end
  return OkStatus();
}

Status Session::RunBatch(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                         const StepGuard& guard, std::size_t max_response_bytes,
                         v1::ApplyResponse* response, const Interrupt& interrupt) {
  if (interface_) {
    return RunInterfaceBatch(request, outputs, guard, max_response_bytes, response, interrupt);
  }
  if (torsion_) return RunTorsionBatch(request, outputs, guard, max_response_bytes, response);
  // A single step is atomic in the core; a longer batch (or any batch that the journal must
  // accept before it counts, or that may grow the state past its budget: an exact memory) runs
  // on a copy that is committed at the end, so a failing step, an expired deadline, an exceeded
  // budget or a failed journal write leaves the session as it was. A grid never changes size.
  if (request.steps_size() == 1 && journal_ == nullptr && contact_->grid_memory() == nullptr &&
      StraightStepLocked(request.steps(0))) {
    bool fall_back = false;
    Status status = RunStepInPlace(request, outputs, guard, response, interrupt, &fall_back);
    if (!fall_back) return status;
    response->Clear();
  }
  const bool on_copy =
      request.steps_size() > 1 || journal_ != nullptr || contact_->grid_memory() == nullptr;
  if (on_copy) {
    if (batch_copy_) {
      *batch_copy_ = *contact_;  // into the vectors it already has
    } else {
      batch_copy_.emplace(*contact_);
    }
  }
  Contact& target = on_copy ? *batch_copy_ : *contact_;
  std::uint64_t applied = applied_steps_;
  double path_error = 0;
  for (int i = 0; i < request.steps_size(); ++i) {
    if (Status status = CheckNextStep(guard, i, applied); !status.ok()) return status;
    Status checked = CheckSingleContactStep(request.steps(i));
    if (checked.ok()) checked = RefuseTwist(request.steps(i));
    if (!checked.ok()) return checked.WithFieldPrefix("steps[" + std::to_string(i) + "]");
    StepReport report;
    // A failed batch drops its copy (the next one overwrites it).
    if (Status status =
            target.Apply(ToCoreStep(request.steps(i)), &report, interrupt,
                         on_copy ? Contact::OnFailure::kDiscarded : Contact::OnFailure::kUnchanged);
        !status.ok()) {
      return status.WithFieldPrefix("steps[" + std::to_string(i) + "]");
    }
    ++applied;
    path_error = std::max(path_error, report.path_error);
    if (!outputs.steps.empty()) {
      WriteStepResult(target, applied, report, outputs.steps, response->add_step_results());
    }
  }
  return CommitBatchLocked(
      request, outputs.state, applied, path_error, max_response_bytes, StateBytes(target),
      ExportBytesBound(target, scene_bytes_),
      [&] {
        if (!on_copy) return;
        // An exact memory is a few vertices: copied into the vectors the state already has
        // (a swap would leave both contacts without their step scratch). A grid is swapped.
        if (contact_->grid_memory() != nullptr) {
          std::swap(*contact_, *batch_copy_);
        } else {
          *contact_ = *batch_copy_;
        }
      },
      response);
}

Status Session::RunStepInPlace(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                               const StepGuard& guard, v1::ApplyResponse* response,
                               const Interrupt& interrupt, bool* fall_back) {
  // A one-step response (one small StepResult) is far below any allowed message limit.
  if (Status status = CheckNextStep(guard, 0, applied_steps_); !status.ok()) return status;
  const std::size_t charged = charge_.bytes();
  const StepBounds bounds = BoundsAfterOneStraightStep(*contact_, scene_bytes_);
  if (Status status = ChargeStateLocked(charged + bounds.growth_bytes, bounds.export_bytes);
      !status.ok()) {
    *fall_back = status.code() == StatusCode::kResourceExhausted;
    return status;
  }
  StepReport report;
  if (Status status = contact_->Apply(ToCoreStep(request.steps(0)), &report, interrupt);
      !status.ok()) {
    charge_.ForceResize(charged);  // a release
    return status.WithFieldPrefix("steps[0]");
  }
  charge_.ForceResize(StateBytes(*contact_));
  const std::uint64_t applied = applied_steps_ + 1;
  if (!outputs.steps.empty()) {
    WriteStepResult(*contact_, applied, report, outputs.steps, response->add_step_results());
  }
  FinishBatchLocked(applied, report.path_error, outputs.state, response);
  return OkStatus();
}

Status Session::RunTorsionBatch(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                                const StepGuard& guard, std::size_t max_response_bytes,
                                v1::ApplyResponse* response) {
  TorsionalContact copy = *torsion_;
  const ContactConfig& config = contact_->config();
  std::uint64_t applied = applied_steps_;
  for (int i = 0; i < request.steps_size(); ++i) {
    if (Status status = CheckNextStep(guard, i, applied); !status.ok()) return status;
    if (Status status = ApplyTorsionStep(copy, request.steps(i), config.max_memory_vertices);
        !status.ok()) {
      return status.WithFieldPrefix("steps[" + std::to_string(i) + "]");
    }
    ++applied;
    if (!outputs.steps.empty()) {
      WriteTorsionStepResult(copy, config.friction, applied, outputs.steps,
                             response->add_step_results());
    }
  }
  return CommitBatchLocked(
      request, outputs.state, applied, 0.0, max_response_bytes,
      StateBytes(*contact_) + StateBytes(copy), ExportBytesBound(copy, scene_bytes_),
      [&] { *torsion_ = std::move(copy); }, response);
}

Status Session::RunInterfaceBatch(const v1::ApplyRequest& request, const BatchOutputs& outputs,
                                  const StepGuard& guard, std::size_t max_response_bytes,
                                  v1::ApplyResponse* response, const Interrupt& interrupt) {
  if (request.steps_size() == 1 && MovesEveryContactOnce(*interface_, request.steps(0))) {
    bool fall_back = false;
    Status status =
        RunInterfaceStepInPlace(request, outputs, guard, response, interrupt, &fall_back);
    if (!fall_back) return status;
    response->Clear();
  }
  return RunInterfaceBatchOnCopy(request, outputs, guard, max_response_bytes, response, interrupt);
}

Status Session::RunInterfaceStepInPlace(const v1::ApplyRequest& request,
                                        const BatchOutputs& outputs, const StepGuard& guard,
                                        v1::ApplyResponse* response, const Interrupt& interrupt,
                                        bool* fall_back) {
  // A one-step response (one small StepResult) is far below any allowed message limit, so the
  // response size needs no check here.
  if (Status status = CheckNextStep(guard, 0, applied_steps_); !status.ok()) return status;
  const std::size_t charged = charge_.bytes();
  Status refused;  // by the gate: the batch's, not the step's, so not under steps[0]
  const Interface::CommitGate gate = [&](const Interface::StepCommit& commit) {
    const StepBounds bounds = BoundsAtCommit(*interface_, commit, scene_bytes_);
    refused = AdmitBatchLocked(request, charged + bounds.growth_bytes, bounds.export_bytes);
    // What the step holds while it commits did not fit (or, in place, its bound): the state
    // after it may still fit, as the batch path on a copy checks.
    *fall_back = refused.code() == StatusCode::kResourceExhausted;
    return refused;
  };
  if (Status status = ApplyInterfaceStep(*interface_, request.steps(0), interrupt, gate);
      !status.ok()) {
    return refused.ok() ? status.WithFieldPrefix("steps[0]") : refused;
  }
  // What the step allocated was charged above as a bound; now the bytes really held.
  charge_.ForceResize(StateBytes(*interface_));
  const std::uint64_t applied = applied_steps_ + 1;
  if (!outputs.steps.empty()) {
    WriteInterfaceStepResult(*interface_, applied, outputs.steps, response->add_step_results());
  }
  FinishBatchLocked(applied, 0.0, outputs.state, response);
  return OkStatus();
}

Status Session::RunInterfaceBatchOnCopy(const v1::ApplyRequest& request,
                                        const BatchOutputs& outputs, const StepGuard& guard,
                                        std::size_t max_response_bytes, v1::ApplyResponse* response,
                                        const Interrupt& interrupt) {
  Interface copy = *interface_;
  std::uint64_t applied = applied_steps_;
  for (int i = 0; i < request.steps_size(); ++i) {
    if (Status status = CheckNextStep(guard, i, applied); !status.ok()) return status;
    if (Status status = ApplyInterfaceStep(copy, request.steps(i), interrupt); !status.ok()) {
      return status.WithFieldPrefix("steps[" + std::to_string(i) + "]");
    }
    ++applied;
    if (!outputs.steps.empty()) {
      WriteInterfaceStepResult(copy, applied, outputs.steps, response->add_step_results());
    }
  }
  return CommitBatchLocked(
      request, outputs.state, applied, 0.0, max_response_bytes, StateBytes(copy),
      ExportBytesBound(copy, scene_bytes_), [&] { std::swap(*interface_, copy); }, response);
}

Status Session::CheckNextStep(const StepGuard& guard, int i, std::uint64_t applied) {
  if (guard) {
    if (Status status = guard(i); !status.ok()) return status;
  }
  if (applied >= kMaxAppliedSteps) {
    return FailedPrecondition("steps[" + std::to_string(i) + "]",
                              "the session has applied its maximum of 2^53 steps");
  }
  return OkStatus();
}

Status Session::CommitBatchLocked(const v1::ApplyRequest& request,
                                  const OutputSelection& state_outputs, std::uint64_t applied,
                                  double path_error, std::size_t max_response_bytes,
                                  std::size_t state_bytes, std::size_t export_bytes,
                                  const std::function<void()>& commit,
                                  v1::ApplyResponse* response) {
  // Checked before the commit (a single step, applied in place, has a response far below any
  // allowed limit).
  if (const std::size_t bytes = response->ByteSizeLong(); bytes > max_response_bytes) {
    return ResourceExhausted("step_mask",
                             "the per-step results would take " + std::to_string(bytes) +
                                 " bytes, above the message limit of " +
                                 std::to_string(max_response_bytes) +
                                 "; select fewer fields or split the batch (nothing was applied)");
  }
  if (Status status = AdmitBatchLocked(request, state_bytes, export_bytes); !status.ok()) {
    return status;
  }
  commit();
  FinishBatchLocked(applied, path_error, state_outputs, response);
  return OkStatus();
}

Status Session::AdmitBatchLocked(const v1::ApplyRequest& request, std::size_t state_bytes,
                                 std::size_t export_bytes) {
  const std::size_t charged = charge_.bytes();
  if (Status status = ChargeStateLocked(state_bytes, export_bytes); !status.ok()) return status;
  if (journal_ != nullptr) {
    if (Status status = journal_->AddBatch(name_, journal_sequence_ + 1, request); !status.ok()) {
      (void)charge_.Resize(charged);  // a release: cannot fail
      return status;
    }
  }
  return OkStatus();
}

void Session::FinishBatchLocked(std::uint64_t applied, double path_error,
                                const OutputSelection& state_outputs, v1::ApplyResponse* response) {
  ++journal_sequence_;
  ProcessMetrics().steps_applied.Increment(applied - applied_steps_);
  applied_steps_ = applied;
  CommitStateLocked(state_outputs, response->mutable_state());
  response->mutable_error_estimate()->set_path_error(path_error);
  WriteApproximationErrors(*contact_, response->mutable_error_estimate());
}

void Session::CommitStateLocked(const OutputSelection& selection, v1::ContactState* state) {
  if (kept_state_config_) {
    // Only what needs the contact is computed here, each field once; GetSession derives the
    // rest (WriteCompleteState).
    const KeptState kept = KeepState(*contact_, applied_steps_);
    if (state != nullptr) {
      const OutputSelection derived = selection.Without(OutputSelection::KeptState());
      if (!derived.empty()) WriteStateLocked(derived, state);
      WriteKeptState(kept, selection, state);
    }
    std::lock_guard committed_lock(committed_mutex_);
    committed_kept_ = kept;
    return;
  }
  // An interface's forces are sums over its contacts: computed once, the answer copied.
  v1::ContactState committed;
  WriteStateLocked(OutputSelection::FullState(), &committed);
  if (state != nullptr) CopyStateFields(committed, selection, state);
  std::lock_guard committed_lock(committed_mutex_);
  committed_state_.Swap(&committed);  // the previous state is freed after the lock
}

Status Session::ChargeStateLocked(std::size_t state_bytes, std::size_t export_bytes) {
  if (max_message_bytes_ > 0) {
    if (Status status = CheckExportable(export_bytes, max_message_bytes_, "steps"); !status.ok()) {
      return status;
    }
  }
  return charge_.Resize(state_bytes);
}

void Session::WriteStateLocked(const OutputSelection& selection, v1::ContactState* state) const {
  if (interface_) {
    WriteInterfaceState(*interface_, applied_steps_, selection, state);
  } else if (torsion_) {
    WriteTorsionState(*torsion_, contact_->config().friction, applied_steps_, selection, state);
  } else {
    WriteState(*contact_, applied_steps_, selection, state);
  }
}

Status Session::Query(const OutputSelection& selection, const RadialSampling& sampling,
                      OutputCounters* counters, v1::QueryResponse* response,
                      const InterfaceQuery& interface_query) const {
  if (Status status = RequireAvailable(); !status.ok()) return status;
  std::lock_guard lock(mutex_);
  const Stopwatch stopwatch;
  Status status = interface_
                      ? WriteInterfaceQueryOutputs(*interface_, applied_steps_, selection, sampling,
                                                   interface_query, response, counters)
                      : CheckSingleContactQuery(selection, interface_query);
  if (status.ok() && torsion_) {
    status = WriteTorsionQueryOutputs(*torsion_, contact_->config(), applied_steps_, selection,
                                      sampling, response, counters);
  } else if (status.ok() && !interface_) {
    status = WriteQueryOutputs(*contact_, applied_steps_, selection, sampling, response, counters);
  }
  if (!status.ok()) {
    response->Clear();
    return status;
  }
  response->set_compute_seconds(stopwatch.Seconds());
  return OkStatus();
}

void Session::ReadResource(v1::Session* resource) const {
  resource->set_name(name_);
  *resource->mutable_scene() = scene_;
  *resource->mutable_limits() = limits_;
  *resource->mutable_create_time() = create_time_;
  if (idle_timeout_.count() > 0) {
    const auto remaining = last_used() + idle_timeout_ - Clock::now();
    *resource->mutable_expire_time() =
        TimeUtil::GetCurrentTime() +
        TimeUtil::NanosecondsToDuration(std::chrono::nanoseconds(remaining).count());
  }
  if (!available()) {
    resource->set_availability(v1::Session::AVAILABILITY_UNAVAILABLE);
    resource->set_unavailable_reason(unavailable_reason_);
    return;
  }
  resource->set_availability(v1::Session::AVAILABILITY_ACTIVE);
  if (kept_state_config_) {
    KeptState kept;
    {
      std::lock_guard lock(committed_mutex_);
      kept = committed_kept_;
    }
    WriteCompleteState(*kept_state_config_, kept, resource->mutable_state());
    return;
  }
  std::lock_guard lock(committed_mutex_);
  *resource->mutable_state() = committed_state_;
}

Status Session::Export(v1::SessionSnapshot* snapshot) const {
  if (Status status = RequireAvailable(); !status.ok()) return status;
  std::lock_guard lock(mutex_);
  ExportLocked(snapshot);
  return OkStatus();
}

void Session::ExportLocked(v1::SessionSnapshot* snapshot) const {
  snapshot->set_version(kSnapshotVersion);
  snapshot->set_source_name(name_);
  *snapshot->mutable_limits() = limits_;
  *snapshot->mutable_scene() = WithEffectiveOptions(scene_, contact_->config());
  if (interface_) {
    ToProtoInterfaceSnapshot(*interface_, snapshot->mutable_interface());
  } else if (torsion_) {
    ToProtoTorsionSnapshot(*torsion_, snapshot->mutable_torsion());
  } else {
    ToProtoSnapshot(contact_->Snapshot(), snapshot->mutable_contact());
  }
  snapshot->set_applied_steps(applied_steps_);
}

void Session::Touch(Clock::time_point now) {
  last_used_.store(now.time_since_epoch().count(), std::memory_order_relaxed);
}

bool Session::IsExpired(Clock::time_point now) const {
  return idle_timeout_.count() > 0 && now - last_used() > idle_timeout_;
}

Session::Clock::time_point Session::last_used() const {
  return Clock::time_point(Clock::duration(last_used_.load(std::memory_order_relaxed)));
}

}  // namespace mdr::service
