// libFuzzer target for the service's request validation: bytes -> a CreateSessionRequest,
// ApplyRequest, QueryRequest or ImportSessionRequest (ParseFromArray), run by ContactOperations
// (no network, a journal in a temporary directory) on fresh copies of five sessions: an exact and
// a grid contact, a shared-motion interface, a contact list and a torsional contact. Checks: nothing crashes (ASan +
// UBSan); every error has a message, and INVALID_ARGUMENT names its field in the message and in a
// BadRequest detail; a failed request changes no session and creates none; a successful Apply
// leaves finite forces; and every state a request creates (Create, Import, Apply) round-trips:
// ExportSession -> ImportSession gives the same snapshot, the process "crashes" (no compaction)
// and the journal restores it bit for bit, and after an Apply the imported copy and the restored
// session take the same batch again to the same state. (The physical invariants over realistic
// scales are engine_fuzz's: here values up to 1e308 m reach the core, where force control loses
// its precision.) Build and run: tests/fuzz/run.sh.
//
// Input: byte 0 chooses the request (mod 4: create, apply, query, import), byte 1 the session an
// Apply or Query goes to (mod 5: exact, grid, shared motion, contact list, torsion; its `session`
// field is replaced), the rest is the serialized message.
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/support/error_details.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fixtures/slip_state_check.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "mdr/bridge/conversion.h"
#include "mdr/service/grpc_status.h"
#include "mdr/service/operations.h"

namespace {

using mdr::service::ContactOperations;
using mdr::service::ToGrpcStatus;

// The sessions every input starts from, in the order byte 1 picks them.
const std::vector<std::string> kSessionIds = {"exact", "grid", "shared", "list", "torsion"};
// Where a new session's round trip imports its copy.
constexpr char kCopyId[] = "round-trip";

void Check(bool ok, const char* what, const grpc::Status& status = grpc::Status::OK) {
  if (ok) return;
  std::fprintf(stderr, "invariant violated: %s (status %d \"%s\")\n", what,
               static_cast<int>(status.error_code()), status.error_message().c_str());
  std::abort();
}

// Small limits keep every input cheap under the sanitizers.
mdr::service::ServiceLimits FuzzLimits() {
  mdr::service::ServiceLimits limits;
  limits.max_sessions = 8;
  limits.max_steps_per_batch = 16;
  limits.max_memory_vertices = 512;
  limits.max_message_bytes = 1 << 16;
  return limits;
}

mdr::v1::Scene SteelSphere() {
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(0.01);
  mdr::v1::ElasticPair* pair = scene.mutable_elastic_pair();
  pair->set_youngs_modulus_1(210e9);
  pair->set_poisson_ratio_1(0.3);
  pair->set_youngs_modulus_2(210e9);
  pair->set_poisson_ratio_2(0.3);
  scene.set_friction(0.3);
  // Keeps curved force paths cheap under the sanitizers (as engine_fuzz.cc does): at the default
  // 1e-8 a press from zero that slides takes some 9 000 exact sub-steps, 20 s here.
  scene.mutable_options()->set_force_path_tolerance(1e-4);
  return scene;
}

mdr::v1::Scene InterfaceScene(mdr::v1::Interface::Kind kind) {
  mdr::v1::Scene scene = SteelSphere();
  scene.mutable_interface()->set_kind(kind);
  return scene;
}

// A session of `scene` after the steps of `load`, exported and deleted.
mdr::v1::SessionSnapshot Loaded(ContactOperations& operations, const mdr::v1::Scene& scene,
                                const std::string& id, mdr::v1::ApplyRequest load) {
  mdr::v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = scene;
  create.set_session_id(id);
  mdr::v1::Session session;
  Check(operations.CreateSession(std::nullopt, create, &session).ok(), "baseline created");
  load.set_session(session.name());
  mdr::v1::ApplyResponse response;
  Check(operations.Apply(std::nullopt, load, nullptr, &response).ok(), "baseline loaded");
  mdr::v1::ExportSessionRequest request;
  request.set_name(session.name());
  mdr::v1::SessionSnapshot snapshot;
  Check(operations.ExportSession(std::nullopt, request, &snapshot).ok(), "baseline exported");
  mdr::v1::DeleteSessionRequest erase;
  erase.set_name(session.name());
  Check(operations.DeleteSession(std::nullopt, erase).ok(), "baseline deleted");
  return snapshot;
}

// The sessions every input starts from, loaded and partly slipping: single contacts at
// F_N = 100 N, a shared-motion interface of 4 generated summits at a total of 100 N, and a
// contact list of 3 spheres pressed and sheared each its own way.
std::vector<mdr::v1::SessionSnapshot> MakeBaselines(ContactOperations& operations) {
  mdr::v1::ApplyRequest single;
  single.add_steps()->set_normal_force(100);
  single.add_steps()->set_tangential_force(15);
  single.add_steps()->set_tangential_force(-5);

  mdr::v1::Scene grid = SteelSphere();
  grid.set_method(mdr::v1::METHOD_GRID);
  grid.mutable_grid()->set_size(64);
  grid.mutable_grid()->set_max_radius(1e-3);

  mdr::v1::Scene shared = InterfaceScene(mdr::v1::Interface::KIND_SHARED_MOTION);
  mdr::v1::GeneratedPopulation* population = shared.mutable_interface()->mutable_generated();
  population->set_count(4);
  population->set_height_scale(1e-6);
  population->set_radius_distribution(mdr::v1::GeneratedPopulation::RADIUS_DISTRIBUTION_LOGNORMAL);
  population->set_log_sigma(0.3);
  population->set_seed(3);

  mdr::v1::Scene list = InterfaceScene(mdr::v1::Interface::KIND_CONTACT_LIST);
  mdr::v1::ExplicitPopulation* summits = list.mutable_interface()->mutable_explicit_list();
  for (double radius : {0.01, 0.005, 0.02}) {
    summits->add_heights(0);
    summits->add_radii(radius);
  }
  mdr::v1::ApplyRequest each;
  mdr::v1::Step* press = each.add_steps();
  press->set_depth_increment(0);
  for (double depth : {3.5e-6, 1.7e-6, 4.2e-6}) press->add_contact_normal_values(depth);
  mdr::v1::Step* pull = each.add_steps();
  pull->set_tangential_force(0);
  for (double force : {5.0, -2.0, 3.0}) pull->add_contact_tangential_values(force);
  mdr::v1::Step* shift = each.add_steps();
  shift->set_displacement_increment(0);
  for (double increment : {1e-7, -1e-7, 0.0}) shift->add_contact_tangential_values(increment);

  mdr::v1::Scene twisted = SteelSphere();
  twisted.mutable_torsion();
  mdr::v1::ApplyRequest twist;
  twist.add_steps()->set_normal_force(100);
  twist.add_steps()->set_twist(3e-3);
  twist.add_steps()->set_twist_increment(-1e-3);

  return {Loaded(operations, SteelSphere(), kSessionIds[0], single),
          Loaded(operations, grid, kSessionIds[1], single),
          Loaded(operations, shared, kSessionIds[2], single),
          Loaded(operations, list, kSessionIds[3], each),
          Loaded(operations, twisted, kSessionIds[4], twist)};
}

// Replaces the session `id` by a fresh copy of `snapshot`.
void Reset(ContactOperations& operations, const mdr::v1::SessionSnapshot& snapshot,
           const std::string& id) {
  mdr::v1::DeleteSessionRequest erase;
  erase.set_name(std::string("sessions/") + id);
  (void)operations.DeleteSession(std::nullopt, erase);  // NOT_FOUND the first time
  mdr::v1::ImportSessionRequest import;
  *import.mutable_snapshot() = snapshot;
  import.set_session_id(id);
  mdr::v1::Session session;
  Check(operations.ImportSession(std::nullopt, import, &session).ok(), "baseline imported");
}

mdr::v1::SessionSnapshot Export(ContactOperations& operations, const std::string& name) {
  mdr::v1::ExportSessionRequest request;
  request.set_name(name);
  mdr::v1::SessionSnapshot snapshot;
  Check(operations.ExportSession(std::nullopt, request, &snapshot).ok(), "session exported");
  return snapshot;
}

std::string Exported(ContactOperations& operations, const std::string& name) {
  return Export(operations, name).SerializeAsString();
}

// What must match between a session and its imported copy: the snapshot without its name.
std::string StateBytes(mdr::v1::SessionSnapshot snapshot) {
  snapshot.clear_source_name();
  return snapshot.SerializeAsString();
}

// A batch that the transport's thread may apply (docs/operations.md, "Inline steps") must do
// what the workers' way does, bit for bit. Journaled sessions never run inline, so both ways run
// on two imports of the state into a service without a journal.
void CheckInlineMatchesWorkers(const mdr::v1::SessionSnapshot& state,
                               const mdr::v1::ApplyRequest& request) {
  static ContactOperations plain(mdr::service::ServiceLimits{}, {});
  Reset(plain, state, "inline");
  mdr::v1::ApplyRequest on_inline = request;
  on_inline.set_session("sessions/inline");
  mdr::v1::ApplyResponse inline_response;
  const std::optional<mdr::Status> applied =
      plain.ApplyIfBounded(std::nullopt, on_inline, &inline_response);
  if (!applied) return;
  Check(request.steps_size() == 1, "only one-step batches run inline");
  Reset(plain, state, "worker");
  mdr::v1::ApplyRequest on_worker = request;
  on_worker.set_session("sessions/worker");
  mdr::v1::ApplyResponse worker_response;
  const mdr::Status worker = plain.Apply(std::nullopt, on_worker, nullptr, &worker_response);
  Check(worker.code() == applied->code() && worker.field() == applied->field() &&
            worker.message() == applied->message(),
        "an inline batch fails or succeeds as on a worker");
  Check(worker_response.state().SerializeAsString() == inline_response.state().SerializeAsString(),
        "an inline batch answers the state a worker answers");
  Check(
      StateBytes(Export(plain, "sessions/inline")) == StateBytes(Export(plain, "sessions/worker")),
      "an inline batch leaves the state a worker leaves");
}

// The service with a journal in a temporary directory (removed at exit), as mdrd holds it.
class JournaledService {
 public:
  JournaledService() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "mdr-request-fuzz-XXXXXX").string();
    Check(mkdtemp(pattern.data()) != nullptr, "temporary directory created");
    directory_ = pattern;
    options_.path = (directory_ / "journal.sqlite").string();
    options_.sync = mdr::service::JournalSync::kOff;
    Open();
  }
  ~JournaledService() {
    operations_.reset();
    std::filesystem::remove_all(directory_);
  }
  ContactOperations& operations() { return *operations_; }
  // Ends the process's service without compacting the journal (as a SIGKILL leaves it: every
  // answered change is committed) and restores every session from it.
  void Restart() {
    operations_.reset();
    Open();
  }

 private:
  void Open() {
    operations_ = std::make_unique<ContactOperations>(FuzzLimits(), mdr::service::TestHooks());
    Check(operations_->OpenJournal(options_).ok(), "the journal opens");
  }

  std::filesystem::path directory_;
  mdr::service::JournalOptions options_;
  std::unique_ptr<ContactOperations> operations_;
};

// The round trips of an accepted state of session `name`: imported as a copy it exports the same
// state; restored from the journal it is the same bit for bit; and with `next` (the batch that
// made it, its request id dropped) the restored session and the copy continue alike.
void CheckRoundTrips(JournaledService& service, const std::string& name,
                     const mdr::v1::ApplyRequest* next) {
  const mdr::v1::SessionSnapshot exported = Export(service.operations(), name);
  const std::string copy_id = name == std::string("sessions/") + kCopyId ? "round-trip-2" : kCopyId;
  mdr::v1::ImportSessionRequest import;
  *import.mutable_snapshot() = exported;
  import.set_session_id(copy_id);
  mdr::v1::Session copy;
  const grpc::Status imported =
      ToGrpcStatus(service.operations().ImportSession(std::nullopt, import, &copy));
  Check(imported.ok(), "an exported state imports", imported);
  Check(StateBytes(Export(service.operations(), copy.name())) == StateBytes(exported),
        "the imported copy has the exported state bit for bit");

  service.Restart();
  Check(Exported(service.operations(), name) == exported.SerializeAsString(),
        "the journal restores the state bit for bit");
  Check(StateBytes(Export(service.operations(), copy.name())) == StateBytes(exported),
        "the journal restores the imported copy bit for bit");

  if (next != nullptr) {
    mdr::v1::ApplyRequest again = *next;
    again.clear_request_id();
    mdr::v1::ApplyResponse unused;
    const mdr::Status restored_status =
        service.operations().Apply(std::nullopt, again, nullptr, &unused);
    again.set_session(copy.name());
    const mdr::Status copy_status =
        service.operations().Apply(std::nullopt, again, nullptr, &unused);
    Check(restored_status.code() == copy_status.code(),
          "the restored session and the copy accept the same batch alike");
    Check(StateBytes(Export(service.operations(), name)) ==
              StateBytes(Export(service.operations(), copy.name())),
          "the restored session and the copy continue bit for bit");
  }
  mdr::v1::DeleteSessionRequest erase;
  erase.set_name(copy.name());
  Check(service.operations().DeleteSession(std::nullopt, erase).ok(), "the copy is deleted");
}

// Every error explains itself, as the server sends it (ToGrpcStatus); INVALID_ARGUMENT names the
// field ("field: message" and a google.rpc.BadRequest with that one field).
void CheckError(const grpc::Status& status) {
  Check(!status.error_message().empty(), "an error has a message", status);
  if (status.error_code() != grpc::StatusCode::INVALID_ARGUMENT) return;
  google::rpc::Status rich;
  Check(grpc::ExtractErrorDetails(status, &rich).ok(), "INVALID_ARGUMENT has details", status);
  google::rpc::BadRequest bad_request;
  for (const auto& detail : rich.details()) {
    if (detail.Is<google::rpc::BadRequest>()) detail.UnpackTo(&bad_request);
  }
  Check(bad_request.field_violations_size() == 1, "INVALID_ARGUMENT has one violation", status);
  const std::string& field = bad_request.field_violations(0).field();
  Check(!field.empty(), "INVALID_ARGUMENT names a field", status);
  Check(status.error_message().rfind(field + ": ", 0) == 0, "the message starts with the field",
        status);
}

// The contact of a single-contact session as the core holds it, rebuilt from its export.
std::optional<mdr::Contact> CoreContact(const mdr::v1::SessionSnapshot& snapshot) {
  if (snapshot.scene().has_interface() || snapshot.scene().has_torsion()) return std::nullopt;
  mdr::Result<mdr::ContactConfig> config = mdr::bridge::ToContactConfig(
      snapshot.scene(), snapshot.scene().options().max_memory_vertices(), {});
  Check(config.ok(), "an exported scene converts");
  mdr::Result<mdr::ContactSnapshot> state = mdr::bridge::ToCoreSnapshot(snapshot.contact());
  Check(state.ok(), "an exported state converts");
  mdr::Result<mdr::Contact> contact = mdr::Contact::Restore(std::move(config).value(), *state);
  Check(contact.ok(), "an exported state restores");
  return std::move(contact).value();
}

// One step straight in (delta, ux): no force target, no per-contact values.
bool OneStraightStep(const mdr::v1::ApplyRequest& request) {
  if (request.steps_size() != 1) return false;
  const mdr::v1::Step& step = request.steps(0);
  return step.normal_case() != mdr::v1::Step::kNormalForce &&
         step.tangential_case() != mdr::v1::Step::kTangentialForce;
}

// The slip state, weights and stiffness of a single contact after an accepted Apply agree with
// its memory and with what the batch did (tests/fixtures/slip_state_check.h).
void CheckSlipState(const mdr::v1::SessionSnapshot& before, const mdr::v1::SessionSnapshot& after,
                    const mdr::v1::ApplyRequest& request) {
  const std::optional<mdr::Contact> was = CoreContact(before), is = CoreContact(after);
  if (!was || !is) return;
  const std::string problem = mdr::testing::SlipStateViolation(*was, *is, OneStraightStep(request));
  if (!problem.empty()) std::fprintf(stderr, "%s\n", problem.c_str());
  Check(problem.empty(), "slip state, weights and stiffness agree with the memory");
}

void CheckState(const mdr::v1::ContactState& state) {
  Check(std::isfinite(state.normal_force()) && std::isfinite(state.tangential_force()) &&
            std::isfinite(state.friction_limit()),
        "forces are finite");
  // A torsional state (0 for the others): the moment is finite and within its full-slip moment
  // (to the round-off of the two sums: fully slipping, M is the full-slip moment's integral
  // taken piece by piece).
  Check(std::isfinite(state.twist()) && std::isfinite(state.full_slip_moment()) &&
            std::abs(state.twisting_moment()) <= state.full_slip_moment() * (1 + 1e-12),
        "the twisting moment is finite and at most the full-slip moment");
}

// After an accepted Apply: GetSession shows the state a Query computes from the contact, bit for
// bit (a single contact's session keeps a few values and derives the rest, Session::
// ReadResource), and the answer holds exactly the fields its state_mask selects, with those
// values (all of them for an empty mask).
void CheckAnsweredAndCommittedState(ContactOperations& operations, const std::string& session,
                                    const mdr::v1::ApplyRequest& request,
                                    const mdr::v1::ContactState& answered) {
  mdr::v1::QueryRequest query;
  query.set_session(session);
  mdr::v1::QueryResponse computed;
  Check(operations.Query(std::nullopt, query, &computed).ok(), "the state can be queried");
  mdr::v1::GetSessionRequest get;
  get.set_name(session);
  mdr::v1::Session got;
  Check(operations.GetSession(std::nullopt, get, &got).ok(), "the session can be read");
  CheckState(computed.state());  // the whole state (an answer may hold a few fields)
  Check(got.state().SerializeAsString() == computed.state().SerializeAsString(),
        "GetSession shows the state a Query computes");
  mdr::v1::ContactState expected = computed.state();
  if (request.state_mask().paths_size() > 0) {
    expected.Clear();
    const google::protobuf::Reflection* reflection = expected.GetReflection();
    for (const std::string& path : request.state_mask().paths()) {
      const auto* field = mdr::v1::ContactState::descriptor()->FindFieldByName(path);
      Check(field != nullptr, "an accepted state_mask names ContactState fields");
      if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) {
        reflection->SetDouble(&expected, field, reflection->GetDouble(computed.state(), field));
      } else {
        reflection->SetUInt64(&expected, field, reflection->GetUInt64(computed.state(), field));
      }
    }
  }
  Check(answered.SerializeAsString() == expected.SerializeAsString(),
        "the answer holds the fields its state_mask selects, as the session holds them");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  spdlog::set_level(spdlog::level::off);
  google::protobuf::SetLogHandler(nullptr);  // parse warnings about invalid UTF-8 strings
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static JournaledService service;
  static const std::vector<mdr::v1::SessionSnapshot> baselines =
      MakeBaselines(service.operations());
  // Sessions an accepted Apply changed (a failed request changes none: checked below).
  static std::vector<bool> changed(baselines.size(), true);
  if (size < 2) return 0;
  const int kind = data[0] % 4;
  const std::size_t target = data[1] % kSessionIds.size();
  const std::string session = "sessions/" + kSessionIds[target];
  for (std::size_t i = 0; i < baselines.size(); ++i) {
    if (changed[i]) Reset(service.operations(), baselines[i], kSessionIds[i]);
    changed[i] = false;
  }
  const void* message = data + 2;
  const int message_size = static_cast<int>(size - 2);
  ContactOperations& operations = service.operations();  // until a round trip restarts it

  if (kind == 0 || kind == 3) {  // a new session, created or imported
    mdr::v1::CreateSessionRequest create;
    mdr::v1::ImportSessionRequest import;
    if (!(kind == 0 ? create.ParseFromArray(message, message_size)
                    : import.ParseFromArray(message, message_size))) {
      return 0;
    }
    const std::size_t before = operations.session_count();
    mdr::v1::Session created;
    const grpc::Status status =
        ToGrpcStatus(kind == 0 ? operations.CreateSession(std::nullopt, create, &created)
                               : operations.ImportSession(std::nullopt, import, &created));
    if (!status.ok()) {
      CheckError(status);
      Check(operations.session_count() == before, "a failed create or import adds no session",
            status);
      return 0;
    }
    Check(operations.session_count() == before + 1, "a create or import adds one session");
    CheckRoundTrips(service, created.name(), nullptr);
    mdr::v1::DeleteSessionRequest erase;
    erase.set_name(created.name());
    Check(service.operations().DeleteSession(std::nullopt, erase).ok(),
          "the new session can be deleted");
    return 0;
  }

  const mdr::v1::SessionSnapshot before_state = Export(operations, session);
  const std::string before = before_state.SerializeAsString();
  if (kind == 1) {
    mdr::v1::ApplyRequest request;
    if (!request.ParseFromArray(message, message_size)) return 0;
    request.set_session(session);
    CheckInlineMatchesWorkers(before_state, request);
    mdr::v1::ApplyResponse response;
    const grpc::Status status =
        ToGrpcStatus(operations.Apply(std::nullopt, request, nullptr, &response));
    if (status.ok()) {
      changed[target] = true;
      if (!response.replayed()) {
        CheckAnsweredAndCommittedState(operations, session, request, response.state());
      }
      CheckSlipState(before_state, Export(operations, session), request);
      CheckRoundTrips(service, session, &request);
      return 0;
    }
    CheckError(status);
  } else {
    mdr::v1::QueryRequest request;
    if (!request.ParseFromArray(message, message_size)) return 0;
    request.set_session(session);
    mdr::v1::QueryResponse response;
    const grpc::Status status = ToGrpcStatus(operations.Query(std::nullopt, request, &response));
    if (!status.ok()) CheckError(status);
  }
  Check(Exported(operations, session) == before, "a failed Apply or any Query changes nothing");
  return 0;
}
