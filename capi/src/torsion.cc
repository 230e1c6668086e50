// The torsional handle of the C interface: a torsional session's contact (scene.torsion) with the
// service's own construction, steps, outputs and snapshots (torsion_session.cc), so that the
// library and the service answer the same, bit for bit.
#include "mdr/core/torsion.h"

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "boundary.h"
#include "inputs.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/outputs.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/mdr.h"

// The handle: the scene as given, its contact config (friction, the piece limit, the options a
// snapshot spells out), the contact, the copy a step runs on (kept, so that a step reuses its
// memory's capacity), and the step counter a SessionSnapshot carries.
struct mdr_torsion {
  mdr::v1::Scene scene;
  mdr::ContactConfig config;
  mdr::TorsionalContact contact;
  mdr::TorsionalContact trial;
  std::uint64_t applied_steps = 0;
};

namespace mdr::capi {
namespace {

Status RequireTorsion(const v1::Scene& scene, const char* field) {
  if (scene.has_torsion()) return OkStatus();
  return InvalidArgument(field,
                         "required for an mdr_torsion: this scene is not torsional; create a "
                         "tangential contact with mdr_contact_create, mdr_contact_create_from_text "
                         "or mdr_contact_restore (an interface with the mdr_interface functions)");
}

// A new torsional contact of a scene, with CreateSession's checks in its order: the scene's
// contact config, then what torsion needs.
CallStatus CreateTorsion(const v1::Scene& scene, mdr_torsion** out) {
  if (Status s = RequireTorsion(scene, "scene.torsion"); !s.ok()) return s;
  Result<ContactConfig> config = bridge::ToContactConfig(scene, MaxMemoryVertices());
  if (!config.ok()) return config.status();
  // What Contact::Create checks of the session's contact.
  if (Status s = ValidateContactConfig(*config); !s.ok()) return s.WithFieldPrefix("scene");
  if (Status s = bridge::CheckTorsionScene(scene); !s.ok()) return s;
  Result<TorsionalContact> contact = bridge::CreateTorsionalContact(scene, *config);
  if (!contact.ok()) return contact.status();
  *out = new mdr_torsion{scene, std::move(config).value(), *contact, *contact};
  return OkStatus();
}

// ImportSession's reading of a torsional snapshot (ContactOperations::StateOf).
CallStatus Restore(const void* bytes, std::size_t size, mdr_torsion** out) {
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  *out = nullptr;
  Result<v1::SessionSnapshot> snapshot = ParseSnapshot(bytes, size);
  if (!snapshot.ok()) return snapshot.status();
  const v1::Scene& scene = snapshot->scene();
  if (Status s = RequireTorsion(scene, "snapshot.scene.torsion"); !s.ok()) return s;
  Result<Contact> contact = bridge::ToCoreContact(*snapshot, MaxMemoryVertices());
  if (!contact.ok()) return contact.status();
  if (Status s = bridge::CheckTorsionScene(scene); !s.ok()) return s.WithFieldPrefix("snapshot");
  Result<TorsionalContact> torsion =
      bridge::RestoreTorsionalContact(scene, contact->config(), snapshot->torsion());
  if (!torsion.ok()) return torsion.status().WithFieldPrefix("snapshot");
  *out = new mdr_torsion{scene, contact->config(), *torsion, *torsion, snapshot->applied_steps()};
  return OkStatus();
}

// The proto Step of the C arguments (a held channel stays unset), or false when a control is not
// one or a held channel has a value other than 0 (TorsionStepError then names the argument).
bool ToProtoTorsionStep(int normal_control, double normal_value, int twist_control,
                        double twist_value, v1::Step* step) {
  std::optional<NormalControl> normal;
  if (!DecodeNormalControl(normal_control, &normal) || (!normal && normal_value != 0)) {
    return false;
  }
  SetNormalChannel(normal, normal_value, step);
  switch (twist_control) {
    case MDR_TWIST_HOLD:
      return twist_value == 0;
    case MDR_TWIST_ANGLE:
      step->set_twist(twist_value);
      return true;
    case MDR_TWIST_ANGLE_INCREMENT:
      step->set_twist_increment(twist_value);
      return true;
    case MDR_TWIST_MOMENT:
      step->set_twisting_moment(twist_value);
      return true;
    default:
      return false;
  }
}

Status TorsionStepError(int normal_control, double normal_value, int twist_control,
                        double twist_value) {
  std::optional<NormalControl> normal;
  if (!DecodeNormalControl(normal_control, &normal)) return NormalControlError(normal_control);
  if (twist_control < MDR_TWIST_HOLD || twist_control > MDR_TWIST_MOMENT) {
    return InvalidArgument("twist_control",
                           "must be MDR_TWIST_HOLD (0), _ANGLE (1), _ANGLE_INCREMENT (2) or "
                           "_MOMENT (3), got " +
                               std::to_string(twist_control));
  }
  if (!normal && normal_value != 0) return HeldValueError("normal_value", "MDR_NORMAL_HOLD");
  if (twist_control == MDR_TWIST_HOLD && twist_value != 0) {
    return HeldValueError("twist_value", "MDR_TWIST_HOLD");
  }
  return Internal("", "TorsionStepError called for valid controls");
}

// The name of the Step field a oneof case selects (its field number is the case's value).
const std::string& StepFieldName(int field_number) {
  return v1::Step::descriptor()->FindFieldByNumber(field_number)->name();
}

// ApplyTorsionStep names the Step's fields; the C caller passed their values as normal_value and
// twist_value. A step moving both channels is refused for its choice of controls (the core checks
// that before anything else, under the twist's field).
Status ToArgumentStatus(const Status& status, const v1::Step& step) {
  const bool normal = step.normal_case() != v1::Step::NORMAL_NOT_SET;
  const bool twist = step.torsional_case() != v1::Step::TORSIONAL_NOT_SET;
  const char* argument = nullptr;
  if (normal && twist) {
    argument = "twist_control";
  } else if (normal && status.field() == StepFieldName(step.normal_case())) {
    argument = "normal_value";
  } else if (twist && status.field() == StepFieldName(step.torsional_case())) {
    argument = "twist_value";
  }
  if (argument == nullptr) return status;
  return Status(status.code(), argument, status.ToString());
}

// What the service's StepResult of a torsional step reports besides the state.
void WriteReport(const mdr_torsion& handle, mdr_step_report* out) {
  static const bridge::OutputSelection kReport = [] {
    bridge::OutputSelection selection;
    selection.add(bridge::Output::kSubsteps);
    selection.add(bridge::Output::kPathError);
    selection.add(bridge::Output::kStepResultDissipatedEnergy);
    return selection;
  }();
  v1::StepResult result;
  bridge::WriteTorsionStepResult(handle.contact, handle.config.friction, handle.applied_steps,
                                 kReport, &result);
  *out = mdr_step_report{.substeps = result.substeps(),
                         .reserved = 0,
                         .path_error = result.path_error(),
                         .dissipated = result.dissipated_energy()};
}

CallStatus Step(mdr_torsion* handle, int normal_control, double normal_value, int twist_control,
                double twist_value, mdr_step_report* report) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  if (Status s = CheckStepCount(handle->applied_steps, "torsion"); !s.ok()) return s;
  v1::Step step;
  if (!ToProtoTorsionStep(normal_control, normal_value, twist_control, twist_value, &step)) {
    return TorsionStepError(normal_control, normal_value, twist_control, twist_value);
  }
  // ApplyTorsionStep may refuse after the core's step changed its contact (the piece limit): it
  // runs on the copy, which replaces the contact only once accepted.
  handle->trial = handle->contact;
  if (Status s = bridge::ApplyTorsionStep(handle->trial, step, handle->config.max_memory_vertices);
      !s.ok()) {
    return ToArgumentStatus(s, step);
  }
  std::swap(handle->contact, handle->trial);
  ++handle->applied_steps;
  if (report != nullptr) WriteReport(*handle, report);
  return OkStatus();
}

// The state as the service's WriteTorsionState reports it, in the C record.
CallStatus State(const mdr_torsion* handle, mdr_torsional_state* out) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  static const bridge::OutputSelection kFullState = bridge::OutputSelection::FullState();
  v1::ContactState state;
  bridge::WriteTorsionState(handle->contact, handle->config.friction, handle->applied_steps,
                            kFullState, &state);
  *out =
      mdr_torsional_state{.depth = state.depth(),
                          .contact_radius = state.contact_radius(),
                          .normal_force = state.normal_force(),
                          .twist = state.twist(),
                          .twisting_moment = state.twisting_moment(),
                          .full_slip_moment = state.full_slip_moment(),
                          .dissipated_energy = state.dissipated_energy(),
                          .last_step_dissipation = handle->contact.memory().last_step_dissipation(),
                          .friction_limit = state.friction_limit(),
                          .applied_steps = state.applied_steps(),
                          .memory_pieces = state.memory_vertices()};
  return OkStatus();
}

// The service's torsion.stiffness.
CallStatus Stiffness(const mdr_torsion* handle, double* positive, double* negative) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  if (Status s = RequireNonNull(positive, "positive"); !s.ok()) return s;
  if (Status s = RequireNonNull(negative, "negative"); !s.ok()) return s;
  *positive = handle->contact.memory().Stiffness(+1);
  *negative = handle->contact.memory().Stiffness(-1);
  return OkStatus();
}

// The service's torsion.slip_intervals.
CallStatus SlipIntervals(const mdr_torsion* handle, double* r_begin, double* r_end,
                         std::int32_t* direction, std::size_t capacity, std::size_t* count) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  if (Status s = RequireNonNull(count, "count"); !s.ok()) return s;
  const std::vector<TorsionSlipInterval> intervals = handle->contact.memory().SlipIntervals();
  *count = intervals.size();
  if (CallStatus s = RequireCapacity(capacity, intervals.size(), "capacity"); !s.ok()) return s;
  if (!intervals.empty()) {
    if (Status s = RequireNonNull(r_begin, "r_begin"); !s.ok()) return s;
    if (Status s = RequireNonNull(r_end, "r_end"); !s.ok()) return s;
    if (Status s = RequireNonNull(direction, "direction"); !s.ok()) return s;
  }
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    r_begin[i] = intervals[i].start;
    r_end[i] = intervals[i].end;
    direction[i] = intervals[i].sign;
  }
  return OkStatus();
}

// The service's torsion.tractions, its radii checked as the service checks QueryRequest.radii.
CallStatus Tractions(const mdr_torsion* handle, const double* radii, std::size_t n,
                     double* traction, double* route_difference, std::size_t capacity) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  if (n > 0) {
    if (Status s = RequireNonNull(radii, "radii"); !s.ok()) return s;
  }
  if (CallStatus s = RequireCapacity(capacity, n, "capacity"); !s.ok()) return s;
  google::protobuf::RepeatedField<double> proto_radii(radii, radii + n);
  Result<bridge::RadialSampling> sampling =
      bridge::ToRadialSampling(proto_radii, v1::TRACTION_ROUTE_BOTH);
  if (!sampling.ok()) return sampling.status();
  const TorsionalMemory& memory = handle->contact.memory();
  for (std::size_t i = 0; i < n; ++i) {
    const TorsionTraction value = memory.Traction(sampling->radii[i]);
    if (traction != nullptr) traction[i] = value.value;
    if (route_difference != nullptr) route_difference[i] = value.route_difference;
  }
  return OkStatus();
}

// The SessionSnapshot the service's ExportSession writes for a torsional session
// (Session::ExportLocked), without the session's name and limits.
CallStatus Snapshot(const mdr_torsion* handle, void* buffer, std::size_t capacity,
                    std::size_t* size) {
  if (Status s = RequireNonNull(handle, "torsion"); !s.ok()) return s;
  v1::SessionSnapshot snapshot;
  snapshot.set_version(bridge::kSnapshotVersion);
  *snapshot.mutable_scene() = bridge::WithEffectiveOptions(handle->scene, handle->config);
  bridge::ToProtoTorsionSnapshot(handle->contact, snapshot.mutable_torsion());
  snapshot.set_applied_steps(handle->applied_steps);
  return WriteMessage(snapshot, buffer, capacity, size);
}

}  // namespace
}  // namespace mdr::capi

extern "C" {

using mdr::capi::Boundary;
using mdr::capi::CallStatus;

int mdr_torsion_create(const void* scene, size_t size, mdr_torsion** out) {
  return Boundary("mdr_torsion_create", [&] {
    return mdr::capi::CreateFromBytes(scene, size, out, mdr::capi::CreateTorsion);
  });
}

int mdr_torsion_create_from_text(const char* text, const char* name, mdr_torsion** out) {
  return Boundary("mdr_torsion_create_from_text", [&] {
    return mdr::capi::CreateFromText(text, name, out, mdr::capi::CreateTorsion);
  });
}

int mdr_torsion_restore(const void* snapshot, size_t size, mdr_torsion** out) {
  return Boundary("mdr_torsion_restore", [&] { return mdr::capi::Restore(snapshot, size, out); });
}

void mdr_torsion_destroy(mdr_torsion* torsion) { delete torsion; }

int mdr_torsion_step(mdr_torsion* torsion, int normal_control, double normal_value,
                     int twist_control, double twist_value, mdr_step_report* report) {
  return Boundary("mdr_torsion_step", [&] {
    return mdr::capi::Step(torsion, normal_control, normal_value, twist_control, twist_value,
                           report);
  });
}

int mdr_torsion_state(const mdr_torsion* torsion, mdr_torsional_state* out) {
  return Boundary("mdr_torsion_state", [&] { return mdr::capi::State(torsion, out); });
}

int mdr_torsion_stiffness(const mdr_torsion* torsion, double* positive, double* negative) {
  return Boundary("mdr_torsion_stiffness",
                  [&] { return mdr::capi::Stiffness(torsion, positive, negative); });
}

int mdr_torsion_slip_intervals(const mdr_torsion* torsion, double* r_begin, double* r_end,
                               int32_t* direction, size_t capacity, size_t* count) {
  return Boundary("mdr_torsion_slip_intervals", [&] {
    return mdr::capi::SlipIntervals(torsion, r_begin, r_end, direction, capacity, count);
  });
}

int mdr_torsion_tractions(const mdr_torsion* torsion, const double* radii, size_t n,
                          double* traction, double* route_difference, size_t capacity) {
  return Boundary("mdr_torsion_tractions", [&] {
    return mdr::capi::Tractions(torsion, radii, n, traction, route_difference, capacity);
  });
}

int mdr_torsion_stored_energy(const mdr_torsion* torsion, double* energy) {
  return Boundary("mdr_torsion_stored_energy", [&]() -> CallStatus {
    if (mdr::Status s = mdr::capi::RequireNonNull(torsion, "torsion"); !s.ok()) return s;
    if (mdr::Status s = mdr::capi::RequireNonNull(energy, "energy"); !s.ok()) return s;
    *energy = torsion->contact.memory().StoredEnergy();
    return mdr::OkStatus();
  });
}

int mdr_torsion_snapshot(const mdr_torsion* torsion, void* buffer, size_t capacity, size_t* size) {
  return Boundary("mdr_torsion_snapshot",
                  [&] { return mdr::capi::Snapshot(torsion, buffer, capacity, size); });
}

}  // extern "C"
