// The contact handle of the C interface: the service's scene conversion, validation and snapshot
// code around one mdr::Contact, so that the library and the service answer the same, bit for bit.
#include "mdr/core/contact.h"

#include <string>
#include <utility>
#include <vector>

#include "boundary.h"
#include "inputs.h"
#include "mdr/bridge/conversion.h"
#include "mdr/core/jager.h"
#include "mdr/core/traction.h"
#include "mdr/mdr.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

// The handle: the scene as given (exported with its effective options), the contact, and the
// counters a SessionSnapshot carries.
struct mdr_contact {
  mdr::v1::Scene scene;
  mdr::Contact contact;
  std::uint64_t applied_steps = 0;
};

namespace mdr::capi {
namespace {

// An interface scene has its own handle (mdr_interface).
Status RefuseInterface(const v1::Scene& scene, const char* field) {
  if (!scene.has_interface()) return OkStatus();
  return InvalidArgument(field,
                         "this scene is an interface (many contacts): create it with "
                         "mdr_interface_create, mdr_interface_create_from_text or "
                         "mdr_interface_restore");
}

// A torsional scene has its own handle (mdr_torsion): an mdr_contact steps the tangential
// channel, and must not take a torsional scene for a tangential one.
Status RefuseTorsion(const v1::Scene& scene, const char* field) {
  if (!scene.has_torsion()) return OkStatus();
  return InvalidArgument(field,
                         "must be unset for an mdr_contact, which is driven tangentially: this "
                         "scene is torsional; create it with mdr_torsion_create, "
                         "mdr_torsion_create_from_text or mdr_torsion_restore");
}

// A new contact of a validated scene, as CreateSession builds it.
CallStatus CreateContact(const v1::Scene& scene, mdr_contact** out) {
  if (Status s = RefuseInterface(scene, "scene.interface"); !s.ok()) return s;
  if (Status s = RefuseTorsion(scene, "scene.torsion"); !s.ok()) return s;
  Result<ContactConfig> config = bridge::ToContactConfig(scene, MaxMemoryVertices());
  if (!config.ok()) return config.status();
  Result<Contact> contact = Contact::Create(std::move(config).value());
  if (!contact.ok()) return contact.status().WithFieldPrefix("scene");
  *out = new mdr_contact{scene, std::move(contact).value()};
  return OkStatus();
}

// The core names a step's value by its proto field ("depth", "tangential_force"); the C caller
// passed it as normal_value or tangential_value, which the error names instead.
Status ToArgumentStatus(const Status& status, const Step& step) {
  std::string argument;
  if (status.field() == FieldName(step.normal)) argument = "normal_value";
  if (status.field() == FieldName(step.tangential)) argument = "tangential_value";
  if (argument.empty()) return status;
  return Status(status.code(), argument, status.ToString());
}

CallStatus Step(mdr_contact* handle, int normal_control, double normal_value,
                int tangential_control, double tangential_value, mdr_step_report* report) {
  // The checks build no Status unless they fail: this is a rig loop's hot path.
  if (handle == nullptr) return RequireNonNull(handle, "contact");
  if (handle->applied_steps >= bridge::kMaxAppliedSteps) {
    return CheckStepCount(handle->applied_steps, "contact");
  }
  StepControls controls;
  if (!DecodeStepControls(normal_control, normal_value, tangential_control, tangential_value,
                          &controls)) {
    return StepControlsError(normal_control, normal_value, tangential_control, tangential_value);
  }
  const mdr::Step step = controls.ToCoreStep();
  StepReport core_report;
  if (Status s = handle->contact.Apply(step, &core_report); !s.ok()) {
    return ToArgumentStatus(s, step);
  }
  ++handle->applied_steps;
  if (report != nullptr) {
    *report = mdr_step_report{.substeps = core_report.substeps,
                              .reserved = 0,
                              .path_error = core_report.path_error,
                              .dissipated = core_report.dissipated};
  }
  return OkStatus();
}

CallStatus SlipIntervals(const mdr_contact* handle, double* r_begin, double* r_end,
                         std::int32_t* direction, std::size_t capacity, std::size_t* count) {
  if (Status s = RequireNonNull(handle, "contact"); !s.ok()) return s;
  if (Status s = RequireNonNull(count, "count"); !s.ok()) return s;
  const std::vector<SlipInterval> intervals = handle->contact.slip_intervals();
  *count = intervals.size();
  if (CallStatus s = RequireCapacity(capacity, intervals.size(), "capacity"); !s.ok()) return s;
  if (!intervals.empty()) {
    if (Status s = RequireNonNull(r_begin, "r_begin"); !s.ok()) return s;
    if (Status s = RequireNonNull(r_end, "r_end"); !s.ok()) return s;
    if (Status s = RequireNonNull(direction, "direction"); !s.ok()) return s;
  }
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    r_begin[i] = intervals[i].r_begin;
    r_end[i] = intervals[i].r_end;
    direction[i] = intervals[i].direction;
  }
  return OkStatus();
}

CallStatus Weights(const mdr_contact* handle, double* r_begin, double* r_end, double* weight,
                   std::size_t capacity, std::size_t* count, double* edge_weight) {
  if (Status s = RequireNonNull(handle, "contact"); !s.ok()) return s;
  if (Status s = RequireNonNull(count, "count"); !s.ok()) return s;
  // The service's jager_weights output: the same checks and the same core call.
  if (Status s = RequireExactMethod(handle->contact, "jager_weights"); !s.ok()) return s;
  Result<JagerWeights> computed = ComputeJagerWeights(handle->contact);
  if (!computed.ok()) return bridge::ToSceneStatus(computed.status());
  const std::vector<WeightInterval>& intervals = computed->intervals;
  *count = intervals.size();
  if (CallStatus s = RequireCapacity(capacity, intervals.size(), "capacity"); !s.ok()) return s;
  if (!intervals.empty()) {
    if (Status s = RequireNonNull(r_begin, "r_begin"); !s.ok()) return s;
    if (Status s = RequireNonNull(r_end, "r_end"); !s.ok()) return s;
    if (Status s = RequireNonNull(weight, "weight"); !s.ok()) return s;
  }
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    r_begin[i] = intervals[i].r_begin;
    r_end[i] = intervals[i].r_end;
    weight[i] = intervals[i].weight;
  }
  if (edge_weight != nullptr) *edge_weight = computed->edge_weight;
  return OkStatus();
}

void CopyRadial(const std::vector<RadialValue>& values, double* value, double* error) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (value != nullptr) value[i] = values[i].value;
    if (error != nullptr) error[i] = values[i].error_estimate;
  }
}

CallStatus Tractions(const mdr_contact* handle, const double* radii, std::size_t n, int route,
                     double* tangential, double* tangential_error, double* normal,
                     double* normal_error, std::size_t capacity) {
  if (Status s = RequireNonNull(handle, "contact"); !s.ok()) return s;
  if (n > 0) {
    if (Status s = RequireNonNull(radii, "radii"); !s.ok()) return s;
  }
  if (CallStatus s = RequireCapacity(capacity, n, "capacity"); !s.ok()) return s;
  // The service's validation of radii and route (ToRadialSampling), then its two outputs.
  google::protobuf::RepeatedField<double> proto_radii(radii, radii + n);
  Result<bridge::RadialSampling> sampling =
      bridge::ToRadialSampling(proto_radii, static_cast<v1::TractionRoute>(route));
  if (!sampling.ok()) {
    const Status& s = sampling.status();
    if (s.field() != "traction_route") return s;
    return InvalidArgument("route",
                           "must be MDR_ROUTE_BOTH (1), MDR_ROUTE_ABEL (2) or "
                           "MDR_ROUTE_JAGER (3), got " +
                               std::to_string(route));
  }
  const Contact& contact = handle->contact;
  if (tangential != nullptr || tangential_error != nullptr) {
    if (Status s = RequireExactMethod(contact, "tangential"); !s.ok()) return s;
  }
  Result<std::vector<RadialValue>> tau{std::vector<RadialValue>{}};
  if (tangential != nullptr || tangential_error != nullptr) {
    tau = ComputeTangentialTraction(contact, sampling->radii, sampling->traction_options);
    if (!tau.ok()) return tau.status();
  }
  Result<std::vector<RadialValue>> p{std::vector<RadialValue>{}};
  if (normal != nullptr || normal_error != nullptr) {
    p = ComputeNormalPressure(contact, sampling->radii, sampling->traction_options);
    if (!p.ok()) return p.status();
  }
  CopyRadial(*tau, tangential, tangential_error);
  CopyRadial(*p, normal, normal_error);
  return OkStatus();
}

// The SessionSnapshot the service's ExportSession writes for a session of this scene and state
// (Session::ExportLocked), without the session's name and limits, which a library has not.
v1::SessionSnapshot ToSessionSnapshot(const mdr_contact& handle) {
  v1::SessionSnapshot snapshot;
  snapshot.set_version(bridge::kSnapshotVersion);
  *snapshot.mutable_scene() = bridge::WithEffectiveOptions(handle.scene, handle.contact.config());
  bridge::ToProtoSnapshot(handle.contact.Snapshot(), snapshot.mutable_contact());
  snapshot.set_applied_steps(handle.applied_steps);
  return snapshot;
}

CallStatus Snapshot(const mdr_contact* handle, void* buffer, std::size_t capacity,
                    std::size_t* size) {
  if (Status s = RequireNonNull(handle, "contact"); !s.ok()) return s;
  return WriteMessage(ToSessionSnapshot(*handle), buffer, capacity, size);
}

// ImportSession's checks of a snapshot of one contact (ContactOperations::StateOf), without the
// session's own fields (limits, source name).
CallStatus Restore(const void* bytes, std::size_t size, mdr_contact** out) {
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  *out = nullptr;
  Result<v1::SessionSnapshot> snapshot = ParseSnapshot(bytes, size);
  if (!snapshot.ok()) return snapshot.status();
  if (Status s = RefuseInterface(snapshot->scene(), "snapshot.scene.interface"); !s.ok()) {
    return s;
  }
  if (Status s = RefuseTorsion(snapshot->scene(), "snapshot.scene.torsion"); !s.ok()) return s;
  Result<Contact> contact = bridge::ToCoreContact(*snapshot, MaxMemoryVertices());
  if (!contact.ok()) return contact.status();
  *out = new mdr_contact{snapshot->scene(), std::move(contact).value(), snapshot->applied_steps()};
  return OkStatus();
}

}  // namespace
}  // namespace mdr::capi

extern "C" {

using mdr::capi::Boundary;
using mdr::capi::CallStatus;

int mdr_version(void) { return MDR_C_API_VERSION; }

int mdr_api_revision(void) { return MDR_C_API_REVISION; }

size_t mdr_struct_size(int id) {
  switch (id) {
    case MDR_STRUCT_STATE:
      return sizeof(mdr_state);
    case MDR_STRUCT_STEP_REPORT:
      return sizeof(mdr_step_report);
    case MDR_STRUCT_TORSIONAL_STATE:
      return sizeof(mdr_torsional_state);
    default:
      return 0;
  }
}

const char* mdr_version_string(void) { return MDR_C_VERSION_STRING; }

int mdr_contact_create(const void* scene, size_t size, mdr_contact** out) {
  return Boundary("mdr_contact_create", [&] {
    return mdr::capi::CreateFromBytes(scene, size, out, mdr::capi::CreateContact);
  });
}

int mdr_contact_create_from_text(const char* text, const char* name, mdr_contact** out) {
  return Boundary("mdr_contact_create_from_text", [&] {
    return mdr::capi::CreateFromText(text, name, out, mdr::capi::CreateContact);
  });
}

int mdr_contact_restore(const void* snapshot, size_t size, mdr_contact** out) {
  return Boundary("mdr_contact_restore", [&] { return mdr::capi::Restore(snapshot, size, out); });
}

void mdr_contact_destroy(mdr_contact* contact) { delete contact; }

int mdr_contact_step(mdr_contact* contact, int normal_control, double normal_value,
                     int tangential_control, double tangential_value, mdr_step_report* report) {
  return Boundary("mdr_contact_step", [&] {
    return mdr::capi::Step(contact, normal_control, normal_value, tangential_control,
                           tangential_value, report);
  });
}

int mdr_contact_state(const mdr_contact* contact, mdr_state* out) {
  return Boundary("mdr_contact_state", [&]() -> CallStatus {
    if (contact == nullptr) return mdr::capi::RequireNonNull(contact, "contact");
    if (out == nullptr) return mdr::capi::RequireNonNull(out, "out");
    mdr::capi::ReadState(contact->contact, contact->applied_steps, out);
    return mdr::OkStatus();
  });
}

int mdr_contact_stiffness(const mdr_contact* contact, double* positive, double* negative) {
  return Boundary("mdr_contact_stiffness", [&]() -> CallStatus {
    if (mdr::Status s = mdr::capi::RequireNonNull(contact, "contact"); !s.ok()) return s;
    if (mdr::Status s = mdr::capi::RequireNonNull(positive, "positive"); !s.ok()) return s;
    if (mdr::Status s = mdr::capi::RequireNonNull(negative, "negative"); !s.ok()) return s;
    const mdr::TangentialStiffness stiffness = contact->contact.tangential_stiffness();
    *positive = stiffness.positive;
    *negative = stiffness.negative;
    return mdr::OkStatus();
  });
}

int mdr_contact_slip_intervals(const mdr_contact* contact, double* r_begin, double* r_end,
                               int32_t* direction, size_t capacity, size_t* count) {
  return Boundary("mdr_contact_slip_intervals", [&] {
    return mdr::capi::SlipIntervals(contact, r_begin, r_end, direction, capacity, count);
  });
}

int mdr_contact_jager_weights(const mdr_contact* contact, double* r_begin, double* r_end,
                              double* weight, size_t capacity, size_t* count, double* edge_weight) {
  return Boundary("mdr_contact_jager_weights", [&] {
    return mdr::capi::Weights(contact, r_begin, r_end, weight, capacity, count, edge_weight);
  });
}

int mdr_contact_tractions(const mdr_contact* contact, const double* radii, size_t n, int route,
                          double* tangential, double* tangential_error, double* normal,
                          double* normal_error, size_t capacity) {
  return Boundary("mdr_contact_tractions", [&] {
    return mdr::capi::Tractions(contact, radii, n, route, tangential, tangential_error, normal,
                                normal_error, capacity);
  });
}

int mdr_contact_snapshot(const mdr_contact* contact, void* buffer, size_t capacity, size_t* size) {
  return Boundary("mdr_contact_snapshot",
                  [&] { return mdr::capi::Snapshot(contact, buffer, capacity, size); });
}

}  // extern "C"
