#include "mdr/service/operations.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "mdr/base/log_value.h"
#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/service/journal.h"
#include "mdr/service/metrics.h"
#include "mdr/service/transform.h"

namespace mdr::service {

using bridge::CheckExportable;
using bridge::CheckInterfaceSize;
using bridge::CheckRadiiCount;
using bridge::CheckSnapshotHeader;
using bridge::CheckTorsionScene;
using bridge::CreateInterface;
using bridge::CreateTorsionalContact;
using bridge::ExportBytesBound;
using bridge::InterfaceQuery;
using bridge::OutputSelection;
using bridge::RadialSampling;
using bridge::RestoreInterface;
using bridge::RestoreTorsionalContact;
using bridge::SelectBatchOutputs;
using bridge::SelectQueryOutputs;
using bridge::StateBudget;
using bridge::StateBytes;
using bridge::StateCharge;
using bridge::ToContactConfig;
using bridge::ToCoreContact;
using bridge::ToRadialSampling;
namespace {

constexpr int kDefaultPageSize = 100;
constexpr int kMaxPageSize = 1000;
constexpr std::size_t kMaxRequestIdLength = 128;

Status ValidateRequestId(const std::string& request_id) {
  const bool printable = std::all_of(request_id.begin(), request_id.end(),
                                     [](char c) { return c >= 0x20 && c <= 0x7E; });
  if (request_id.size() <= kMaxRequestIdLength && printable) return OkStatus();
  return InvalidArgument("request_id", "must be at most " + std::to_string(kMaxRequestIdLength) +
                                           " printable ASCII characters (empty: none), got " +
                                           std::to_string(request_id.size()) + " characters");
}

Result<RadialSampling> QuerySampling(const v1::QueryRequest& request,
                                     const OutputSelection& selection, int max_message_bytes) {
  if (selection.any_radial() && request.radii().empty()) {
    return InvalidArgument("radii",
                           "required (at least one radius) when read_mask selects springs, "
                           "tractions or pressure");
  }
  if (Status s = CheckRadiiCount(request.radii_size(), selection, max_message_bytes); !s.ok()) {
    return s;
  }
  return ToRadialSampling(request.radii(), request.traction_route());
}

}  // namespace

ContactOperations::ContactOperations(const ServiceLimits& limits, TestHooks hooks)
    : limits_(limits),
      hooks_(std::move(hooks)),
      budget_(limits.max_state_bytes),
      sessions_(limits.max_sessions, limits.max_sessions_per_token) {}

Status ContactOperations::OpenJournal(const JournalOptions& options) {
  std::unique_ptr<Journal> journal;
  if (Status status = Journal::Open(options, &journal); !status.ok()) return status;
  for (const std::string& dropped : journal->recovery_drops()) {
    spdlog::warn("event=journal_recovery_dropped path={} dropped={}", Quoted(options.path),
                 Quoted(dropped, kMaxLoggedErrorBytes));
  }
  std::vector<JournaledSession> journaled;
  if (Status status = journal->Load(&journaled); !status.ok()) return status;
  std::size_t restored = 0, unavailable = 0, batches = 0;
  for (JournaledSession& entry : journaled) {
    std::shared_ptr<Session> session;
    if (Status status = Restore(entry, &session); status.ok()) {
      ++restored;
      batches += entry.batches.size();
    } else {
      // One session that cannot be restored must not keep the others away: it is kept aside,
      // journal entry untouched, until it is deleted or a fixed mdrd restores it.
      spdlog::error("event=session_unavailable session={} path={} reason={}", LogValue(entry.name),
                    Quoted(options.path), Quoted(status.ToString(), kMaxLoggedErrorBytes));
      const std::string name = entry.name;
      session = std::make_shared<Session>(name, Unavailable(std::move(entry), status));
      ++unavailable;
    }
    sessions_.AddRestored(std::move(session));  // names are unique: the journal's primary key
  }
  journal_ = std::move(journal);
  sessions_.AttachJournal(journal_.get());
  spdlog::info(
      "event=journal_restored path={} sync={} restored={} unavailable={} replayed_batches={} "
      "recovered={}",
      Quoted(options.path), JournalSyncName(options.sync), restored, unavailable, batches,
      !journal_->recovery_drops().empty());
  return OkStatus();
}

UnavailableSession ContactOperations::Unavailable(JournaledSession entry, const Status& why) {
  return UnavailableSession{.owner = std::move(entry.owner),
                            .create_time = std::move(entry.create_time),
                            .scene = std::move(*entry.snapshot.mutable_scene()),
                            .limits = std::move(*entry.snapshot.mutable_limits()),
                            .reason = why.ToString()};
}

Status ContactOperations::Restore(const JournaledSession& journaled,
                                  std::shared_ptr<Session>* session) const {
  std::optional<SessionOrigin> state;
  const Principal owner = journaled.owner.empty() ? Principal() : Principal(journaled.owner);
  if (Status status = StateOf(journaled.snapshot, owner, &state); !status.ok()) return status;
  state->owner = journaled.owner;
  state->create_time = journaled.create_time;
  state->journal_sequence = journaled.snapshot_sequence;
  state->journal_snapshot_sequence = journaled.snapshot_sequence;
  state->completed = journaled.completed;
  state->charge = StateCharge::Force(BudgetOf(journaled.owner), StateBytes(*state));
  state->max_message_bytes = limits_.max_message_bytes;
  auto restored = std::make_shared<Session>(journaled.name, std::move(*state));
  // Replayed exactly as first applied: same steps, same step mask (so the responses remembered
  // for request ids are the same), no deadline and no response limit. Journal::Load checked that
  // the batches are numbered without gaps.
  for (const JournaledBatch& batch : journaled.batches) {
    Result<bridge::BatchOutputs> outputs = SelectBatchOutputs(batch.request);
    v1::ApplyResponse response;
    Status status = outputs.status();
    if (status.ok()) {
      status = restored->Apply(batch.request, *outputs, nullptr,
                               std::numeric_limits<std::size_t>::max(), &response);
    }
    if (status.ok() && response.replayed()) {
      status = DataLoss("", "its request_id was already applied");
    }
    if (!status.ok()) {
      return Status(status.code(), "",
                    "batch " + std::to_string(batch.sequence) + ": " + status.ToString());
    }
  }
  *session = std::move(restored);
  return OkStatus();
}

StateBudget* ContactOperations::BudgetOf(const std::string& owner) const {
  if (owner.empty() || limits_.max_state_bytes_per_token == 0) return &budget_;
  std::lock_guard lock(owner_budgets_mutex_);
  std::unique_ptr<StateBudget>& budget = owner_budgets_[owner];
  if (budget == nullptr) {
    budget = std::make_unique<StateBudget>(limits_.max_state_bytes_per_token, &budget_,
                                           "this caller's session state quota",
                                           "--max-state-bytes-per-token");
  }
  return budget.get();
}

void ContactOperations::CompactJournal() {
  if (journal_ == nullptr) return;
  for (const std::shared_ptr<Session>& session : sessions_.All()) {
    if (Status status = session->CompactJournal(); !status.ok()) {
      spdlog::error("event=journal_compaction_failed session={} error={}",
                    LogValue(session->name()), Quoted(status.ToString(), kMaxLoggedErrorBytes));
    }
  }
}

Result<ContactConfig> ContactOperations::SessionConfig(const v1::Scene& scene,
                                                       const std::string& prefix,
                                                       const Interrupt& interrupt) const {
  Result<ContactConfig> config = ToContactConfig(scene, limits_.max_memory_vertices, interrupt);
  if (!config.ok()) return config.status().WithFieldPrefix(prefix);
  return config;
}

Status ContactOperations::AddSession(const Principal& caller, const std::string& id_field,
                                     const std::string& session_id, SessionOrigin state,
                                     v1::Session* response, const char* verb,
                                     const std::string& state_field, const Interrupt& interrupt) {
  if (hooks_.before_add_session) hooks_.before_add_session();
  if (Status s = interrupt.Check(); !s.ok()) return s;
  if (Status status =
          CheckExportable(ExportBytesBound(state), limits_.max_message_bytes, state_field);
      !status.ok()) {
    return status;
  }
  if (Status status =
          StateCharge::Take(BudgetOf(caller.value_or("")), StateBytes(state), &state.charge);
      !status.ok()) {
    return status.WithFieldPrefix(state_field);
  }
  state.max_message_bytes = limits_.max_message_bytes;
  std::shared_ptr<Session> session;
  Status status = sessions_.Create(id_field, session_id, caller, std::move(state), &session);
  if (!status.ok()) return status;
  session->ReadResource(response);
  spdlog::info("event=session_{} session={} sessions={}", verb, LogValue(session->name()),
               sessions_.size());
  return OkStatus();
}

Status ContactOperations::CreateSession(const Principal& caller,
                                        const v1::CreateSessionRequest& request,
                                        v1::Session* response, const Interrupt& interrupt) {
  if (Status status = SessionStore::CheckSessionId("session_id", request.session_id());
      !status.ok()) {
    return status;
  }
  const v1::Session& resource = request.session();
  Result<v1::SessionLimits> limits = ResolveSessionLimits(resource.limits(), limits_);
  if (!limits.ok()) return limits.status().WithFieldPrefix("session.limits");
  Result<ContactConfig> config = SessionConfig(resource.scene(), "session", interrupt);
  if (!config.ok()) return config.status();
  Result<Contact> contact = Contact::Create(std::move(config).value());
  if (!contact.ok()) return contact.status().WithFieldPrefix("session.scene");
  SessionOrigin state{
      .scene = resource.scene(), .limits = *limits, .contact = std::move(contact).value()};
  if (Status s = CheckTorsionScene(resource.scene()); !s.ok()) {
    return s.WithFieldPrefix("session");
  }
  if (resource.scene().has_torsion()) {
    Result<TorsionalContact> torsion =
        CreateTorsionalContact(resource.scene(), state.contact.config());
    if (!torsion.ok()) return torsion.status().WithFieldPrefix("session");
    state.torsion.emplace(std::move(torsion).value());
  }
  if (resource.scene().has_interface()) {
    if (Status s = CheckInterfaceSize(resource.scene(), state.contact.config(), StateRoomOf(caller),
                                      limits_.max_message_bytes);
        !s.ok()) {
      return s.WithFieldPrefix("session");
    }
    Result<Interface> interface = CreateInterface(resource.scene(), state.contact.config());
    if (!interface.ok()) return interface.status().WithFieldPrefix("session");
    interface->set_parallel(parallel_);
    state.interface.emplace(std::move(interface).value());
  }
  return AddSession(caller, "session_id", request.session_id(), std::move(state), response,
                    "created", "session.scene", interrupt);
}

Status ContactOperations::GetSession(const Principal& caller, const v1::GetSessionRequest& request,
                                     v1::Session* response) {
  std::shared_ptr<Session> session;
  Status status = sessions_.Find("name", request.name(), caller, &session);
  if (status.ok()) session->ReadResource(response);
  return status;
}

Status ContactOperations::ListSessions(const Principal& caller,
                                       const v1::ListSessionsRequest& request,
                                       v1::ListSessionsResponse* response) {
  if (Status s = RequireNonNegative("page_size", request.page_size()); !s.ok()) {
    return s;
  }
  if (!request.page_token().empty() && !SessionStore::IsSessionName(request.page_token())) {
    return InvalidArgument("page_token",
                           "must be empty or a next_page_token returned by ListSessions");
  }
  const int page_size =
      request.page_size() == 0 ? kDefaultPageSize : std::min(request.page_size(), kMaxPageSize);
  bool more = false;
  const auto page =
      sessions_.ListAfter(request.page_token(), static_cast<std::size_t>(page_size), caller, &more);
  // A page also ends before the session that would take it past the message limit (a tabulated
  // profile of 10^5 points makes a session of 1.6 MB), holding at least one: every page can be
  // sent, and the copying this inline call does is bounded by the limit.
  constexpr std::size_t kFieldOverheadBytes = 6;  // a repeated field's tag and length
  std::size_t bytes = 0;
  std::size_t listed = 0;
  for (; listed < page.size(); ++listed) {
    v1::Session* resource = response->add_sessions();
    page[listed]->ReadResource(resource);
    bytes += resource->ByteSizeLong() + kFieldOverheadBytes;
    if (bytes > MaxResponseBytes() && listed > 0) {
      response->mutable_sessions()->RemoveLast();
      more = true;
      break;
    }
  }
  if (more && listed > 0) response->set_next_page_token(page[listed - 1]->name());
  return OkStatus();
}

Status ContactOperations::DeleteSession(const Principal& caller,
                                        const v1::DeleteSessionRequest& request) {
  Status status = sessions_.Erase("name", request.name(), caller);
  if (status.ok()) LogDeleted(request.name());
  return status;
}

std::optional<Status> ContactOperations::DeleteSessionIfBounded(
    const Principal& caller, const v1::DeleteSessionRequest& request) {
  std::optional<Status> status = sessions_.EraseIfBounded("name", request.name(), caller);
  if (status && status->ok()) LogDeleted(request.name());
  return status;
}

void ContactOperations::LogDeleted(const std::string& name) const {
  spdlog::info("event=session_deleted session={} sessions={}", LogValue(name), sessions_.size());
}

Status ContactOperations::ExportSession(const Principal& caller,
                                        const v1::ExportSessionRequest& request,
                                        v1::SessionSnapshot* response) {
  std::shared_ptr<Session> session;
  Status status = sessions_.Find("name", request.name(), caller, &session);
  if (status.ok()) status = session->Export(response);
  return status;
}

Status ContactOperations::StateOf(const v1::SessionSnapshot& snapshot, const Principal& caller,
                                  std::optional<SessionOrigin>* state,
                                  const Interrupt& interrupt) const {
  if (Status s = CheckSnapshotHeader(snapshot); !s.ok()) return s;
  if (!snapshot.source_name().empty() && !SessionStore::IsSessionName(snapshot.source_name())) {
    return InvalidArgument("snapshot.source_name",
                           "must be empty or a session name \"sessions/{session_id}\" (session_id: "
                           "1-63 characters of [a-z0-9-] starting with a letter)");
  }
  Result<v1::SessionLimits> limits = ResolveSessionLimits(snapshot.limits(), limits_);
  if (!limits.ok()) return limits.status().WithFieldPrefix("snapshot.limits");
  Result<Contact> contact = ToCoreContact(snapshot, limits_.max_memory_vertices, interrupt);
  if (!contact.ok()) return contact.status();
  if (Status s = CheckTorsionScene(snapshot.scene()); !s.ok()) {
    return s.WithFieldPrefix("snapshot");
  }
  std::optional<TorsionalContact> torsion;
  if (snapshot.scene().has_torsion()) {
    Result<TorsionalContact> restored =
        RestoreTorsionalContact(snapshot.scene(), contact->config(), snapshot.torsion());
    if (!restored.ok()) {
      // The scene's errors are named from the scene, the state's from the snapshot.
      return restored.status().WithFieldPrefix("snapshot");
    }
    torsion.emplace(std::move(restored).value());
  }
  std::optional<Interface> interface;
  if (snapshot.scene().has_interface()) {
    if (Status s = CheckInterfaceSize(snapshot.scene(), contact->config(), StateRoomOf(caller),
                                      limits_.max_message_bytes);
        !s.ok()) {
      return s.WithFieldPrefix("snapshot");
    }
    Result<Interface> restored =
        RestoreInterface(snapshot.scene(), contact->config(), snapshot.interface());
    if (!restored.ok()) return restored.status().WithFieldPrefix("snapshot");
    restored->set_parallel(parallel_);
    interface.emplace(std::move(restored).value());
  }
  state->emplace(SessionOrigin{.scene = snapshot.scene(),
                               .limits = *limits,
                               .contact = std::move(contact).value(),
                               .applied_steps = snapshot.applied_steps(),
                               .interface = std::move(interface),
                               .torsion = std::move(torsion)});
  return OkStatus();
}

Status ContactOperations::ImportSession(const Principal& caller,
                                        const v1::ImportSessionRequest& request,
                                        v1::Session* response, const Interrupt& interrupt) {
  if (Status status = SessionStore::CheckSessionId("session_id", request.session_id());
      !status.ok()) {
    return status;
  }
  std::optional<SessionOrigin> state;
  if (Status status = StateOf(request.snapshot(), caller, &state, interrupt); !status.ok()) {
    return status;
  }
  const v1::Scene& scene = request.snapshot().scene();
  const char* state_field = scene.has_interface() ? "snapshot.interface"
                            : scene.has_torsion() ? "snapshot.torsion"
                                                  : "snapshot.contact";
  return AddSession(caller, "session_id", request.session_id(), std::move(*state), response,
                    "imported", state_field, interrupt);
}

Status ContactOperations::Apply(const Principal& caller, const v1::ApplyRequest& request,
                                const Interruption& interruption, v1::ApplyResponse* response,
                                const Interrupt& interrupt, RecentSessions* recent) {
  if (request.steps().empty()) {
    return InvalidArgument("steps", "must contain at least one step");
  }
  if (Status s = ValidateRequestId(request.request_id()); !s.ok()) return s;
  Result<bridge::BatchOutputs> outputs = SelectBatchOutputs(request);
  if (!outputs.ok()) return outputs.status();
  std::shared_ptr<Session> session;
  if (Status status = FindSession(caller, request.session(), recent, &session); !status.ok()) {
    return status;
  }
  const Session::StepGuard guard = [&](int step_index) {
    if (hooks_.before_step) hooks_.before_step(step_index);
    return interruption ? interruption() : OkStatus();
  };
  return session->Apply(request, *outputs, guard, MaxResponseBytes(), response, interrupt);
}

Status ContactOperations::FindSession(const Principal& caller, const std::string& name,
                                      RecentSessions* recent, std::shared_ptr<Session>* session) {
  static const std::string kField = "session";  // not a string built per message
  return recent == nullptr ? sessions_.Find(kField, name, caller, session)
                           : sessions_.FindAgain(kField, name, caller, recent, session);
}

std::optional<Status> ContactOperations::ApplyIfBounded(const Principal& caller,
                                                        const v1::ApplyRequest& request,
                                                        v1::ApplyResponse* response,
                                                        RecentSessions* recent) {
  if (limits_.max_inline_vertices == 0 || hooks_.before_step || request.steps_size() != 1) {
    return std::nullopt;
  }
  if (!ValidateRequestId(request.request_id()).ok()) return std::nullopt;
  Result<bridge::BatchOutputs> outputs = SelectBatchOutputs(request);
  if (!outputs.ok()) return std::nullopt;
  std::shared_ptr<Session> session;
  if (!FindSession(caller, request.session(), recent, &session).ok()) return std::nullopt;
  std::optional<Status> applied = session->ApplyIfBounded(
      request, *outputs, limits_.max_inline_vertices, MaxResponseBytes(), response);
  if (applied) ProcessMetrics().inline_batches.Increment();
  return applied;
}

Status ContactOperations::Query(const Principal& caller, const v1::QueryRequest& request,
                                v1::QueryResponse* response, const Interrupt& interrupt) {
  Result<OutputSelection> selection = SelectQueryOutputs(request.read_mask());
  if (!selection.ok()) return selection.status();
  Result<RadialSampling> sampling = QuerySampling(request, *selection, limits_.max_message_bytes);
  if (!sampling.ok()) return sampling.status();
  sampling->traction_options.interrupt = interrupt;
  std::shared_ptr<Session> session;
  if (Status status = sessions_.Find("session", request.session(), caller, &session);
      !status.ok()) {
    return status;
  }
  InterfaceQuery interface_query;
  interface_query.slip_histogram_bins = request.slip_histogram_bins();
  if (request.has_contact_index()) interface_query.contact_index = request.contact_index();
  return session->Query(*selection, *sampling, hooks_.output_counters, response, interface_query);
}

Status ContactOperations::Transform(const v1::TransformRequest& request,
                                    v1::TransformResponse* response) {
  const auto start = std::chrono::steady_clock::now();
  if (Status status = RunTransform(request, limits_, response); !status.ok()) {
    response->Clear();
    return status;
  }
  response->set_compute_seconds(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return OkStatus();
}

}  // namespace mdr::service
