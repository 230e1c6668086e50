// libFuzzer target for the service's request validation: bytes -> a CreateSessionRequest,
// ApplyRequest or QueryRequest (ParseFromArray), run by ContactOperations (no network) on fresh
// copies of an exact and a grid session. Checks: nothing crashes (ASan + UBSan); every error has
// a message, and INVALID_ARGUMENT names its field in the message and in a BadRequest detail; a
// failed request changes no session and creates none; a successful Apply leaves finite forces.
// (The physical invariants over realistic scales are engine_fuzz's: here values up to 1e308 m
// reach the core, where force control loses its precision.) Build and run: tests/fuzz/run.sh.
//
// Input: byte 0 chooses the request (mod 3), byte 1 the session an Apply or Query goes to (even:
// exact, odd: grid; its `session` field is replaced), the rest is the serialized message.
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/support/error_details.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "mdr/service/operations.h"
#include "mdr/service/grpc_status.h"

namespace {

using mdr::service::ContactOperations;
using mdr::service::ToGrpcStatus;

constexpr char kExact[] = "exact";
constexpr char kGrid[] = "grid";

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
  return scene;
}

// The two sessions every input starts from: loaded to F_N = 100 N and partly slipping.
struct Baseline {
  mdr::v1::SessionSnapshot exact;
  mdr::v1::SessionSnapshot grid;
};

mdr::v1::SessionSnapshot Loaded(ContactOperations& operations, const mdr::v1::Scene& scene,
                                const std::string& id) {
  mdr::v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = scene;
  create.set_session_id(id);
  mdr::v1::Session session;
  Check(operations.CreateSession(std::nullopt, create, &session).ok(), "baseline created");
  mdr::v1::ApplyRequest apply;
  apply.set_session(session.name());
  apply.add_steps()->set_normal_force(100);
  apply.add_steps()->set_tangential_force(15);
  apply.add_steps()->set_tangential_force(-5);
  mdr::v1::ApplyResponse response;
  Check(operations.Apply(std::nullopt, apply, nullptr, &response).ok(), "baseline loaded");
  mdr::v1::ExportSessionRequest request;
  request.set_name(session.name());
  mdr::v1::SessionSnapshot snapshot;
  Check(operations.ExportSession(std::nullopt, request, &snapshot).ok(), "baseline exported");
  mdr::v1::DeleteSessionRequest erase;
  erase.set_name(session.name());
  Check(operations.DeleteSession(std::nullopt, erase).ok(), "baseline deleted");
  return snapshot;
}

Baseline MakeBaseline(ContactOperations& operations) {
  mdr::v1::Scene grid = SteelSphere();
  grid.set_method(mdr::v1::METHOD_GRID);
  grid.mutable_grid()->set_size(64);
  grid.mutable_grid()->set_max_radius(1e-3);
  return {Loaded(operations, SteelSphere(), kExact), Loaded(operations, grid, kGrid)};
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

std::string Exported(ContactOperations& operations, const std::string& name) {
  mdr::v1::ExportSessionRequest request;
  request.set_name(name);
  mdr::v1::SessionSnapshot snapshot;
  Check(operations.ExportSession(std::nullopt, request, &snapshot).ok(), "session exported");
  return snapshot.SerializeAsString();
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

void CheckState(const mdr::v1::ContactState& state) {
  Check(std::isfinite(state.normal_force()) && std::isfinite(state.tangential_force()) &&
            std::isfinite(state.friction_limit()),
        "forces are finite");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  spdlog::set_level(spdlog::level::off);
  google::protobuf::SetLogHandler(nullptr);  // parse warnings about invalid UTF-8 strings
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ContactOperations operations(FuzzLimits(), mdr::service::TestHooks());
  static const Baseline baseline = MakeBaseline(operations);
  if (size < 2) return 0;
  const int kind = data[0] % 3;
  const bool grid = data[1] % 2 == 1;
  const std::string session = std::string("sessions/") + (grid ? kGrid : kExact);
  Reset(operations, baseline.exact, kExact);
  Reset(operations, baseline.grid, kGrid);
  const void* message = data + 2;
  const int message_size = static_cast<int>(size - 2);

  if (kind == 0) {
    mdr::v1::CreateSessionRequest request;
    if (!request.ParseFromArray(message, message_size)) return 0;
    const std::size_t before = operations.session_count();
    mdr::v1::Session created;
    const grpc::Status status =
        ToGrpcStatus(operations.CreateSession(std::nullopt, request, &created));
    if (!status.ok()) {
      CheckError(status);
      Check(operations.session_count() == before, "a failed create adds no session", status);
      return 0;
    }
    Check(operations.session_count() == before + 1, "a create adds one session");
    mdr::v1::DeleteSessionRequest erase;
    erase.set_name(created.name());
    Check(operations.DeleteSession(std::nullopt, erase).ok(), "the new session can be deleted");
    return 0;
  }

  const std::string before = Exported(operations, session);
  if (kind == 1) {
    mdr::v1::ApplyRequest request;
    if (!request.ParseFromArray(message, message_size)) return 0;
    request.set_session(session);
    mdr::v1::ApplyResponse response;
    const grpc::Status status =
        ToGrpcStatus(operations.Apply(std::nullopt, request, nullptr, &response));
    if (status.ok()) {
      CheckState(response.state());
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
