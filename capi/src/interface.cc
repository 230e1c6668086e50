// The interface handle of the C interface: an interface session's contacts (a shared motion or a
// contact list, docs/interfaces.md) with the service's own construction, steps and snapshots
// (interface_session.cc), so that the library and the service answer the same, bit for bit.
#include "mdr/core/interface.h"

#include <climits>
#include <string>
#include <utility>

#include "boundary.h"
#include "inputs.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/interface_session.h"
#include "mdr/bridge/outputs.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/mdr.h"

// The handle: the scene as given, its contact config (what the scene resolves), the interface and
// the step counter a SessionSnapshot carries.
struct mdr_interface {
  mdr::v1::Scene scene;
  mdr::ContactConfig base;
  mdr::Interface interface;
  std::uint64_t applied_steps = 0;
};

namespace mdr::capi {
namespace {

Status RequireInterface(const v1::Scene& scene, const char* field) {
  if (scene.has_interface()) return OkStatus();
  return InvalidArgument(field,
                         "required: this scene is a single contact; create it with "
                         "mdr_contact_create, mdr_contact_create_from_text or mdr_contact_restore");
}

// The service's size check before anything is built; the library has no state budget, and its
// snapshot's limit is protobuf's.
Status CheckSize(const v1::Scene& scene, const ContactConfig& base) {
  return bridge::CheckInterfaceSize(scene, base, {}, INT_MAX);
}

// A new interface of a scene, as CreateSession builds it.
CallStatus CreateInterface(const v1::Scene& scene, mdr_interface** out) {
  if (Status s = RequireInterface(scene, "scene.interface"); !s.ok()) return s;
  if (Status s = bridge::CheckTorsionScene(scene); !s.ok()) return s;
  Result<ContactConfig> config = bridge::ToContactConfig(scene, MaxMemoryVertices());
  if (!config.ok()) return config.status();
  if (Status s = CheckSize(scene, *config); !s.ok()) return s;
  Result<Interface> interface = bridge::CreateInterface(scene, *config);
  if (!interface.ok()) return interface.status();
  *out = new mdr_interface{scene, std::move(config).value(), std::move(interface).value()};
  return OkStatus();
}

// ImportSession's reading of an interface snapshot (ContactOperations::StateOf).
CallStatus Restore(const void* bytes, std::size_t size, mdr_interface** out) {
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  *out = nullptr;
  Result<v1::SessionSnapshot> snapshot = ParseSnapshot(bytes, size);
  if (!snapshot.ok()) return snapshot.status();
  if (Status s = RequireInterface(snapshot->scene(), "snapshot.scene.interface"); !s.ok()) {
    return s;
  }
  if (Status s = bridge::CheckTorsionScene(snapshot->scene()); !s.ok()) {
    return s.WithFieldPrefix("snapshot");
  }
  Result<Contact> contact = bridge::ToCoreContact(*snapshot, MaxMemoryVertices());
  if (!contact.ok()) return contact.status();
  if (Status s = CheckSize(snapshot->scene(), contact->config()); !s.ok()) {
    return s.WithFieldPrefix("snapshot");
  }
  Result<Interface> interface =
      bridge::RestoreInterface(snapshot->scene(), contact->config(), snapshot->interface());
  if (!interface.ok()) return interface.status().WithFieldPrefix("snapshot");
  *out = new mdr_interface{snapshot->scene(), contact->config(), std::move(interface).value(),
                           snapshot->applied_steps()};
  return OkStatus();
}

// The proto Step of the C arguments: the controls' values, and per-contact values of a contact
// list (the Step's contact_normal_values / contact_tangential_values).
Result<v1::Step> ToProtoStep(int normal_control, double normal_value, int tangential_control,
                             double tangential_value, const double* normal_values,
                             const double* tangential_values, std::size_t n) {
  Result<StepControls> controls =
      ReadStepControls(normal_control, normal_value, tangential_control, tangential_value);
  if (!controls.ok()) return controls.status();
  v1::Step step;  // a held channel stays unset
  SetNormalChannel(controls->normal, normal_value, &step);
  if (controls->tangential) {
    switch (*controls->tangential) {
      case TangentialControl::kDisplacement:
        step.set_displacement(tangential_value);
        break;
      case TangentialControl::kDisplacementIncrement:
        step.set_displacement_increment(tangential_value);
        break;
      case TangentialControl::kForce:
        step.set_tangential_force(tangential_value);
        break;
    }
  }
  if (normal_values != nullptr)
    step.mutable_contact_normal_values()->Add(normal_values, normal_values + n);
  if (tangential_values != nullptr) {
    step.mutable_contact_tangential_values()->Add(tangential_values, tangential_values + n);
  }
  return step;
}

// The service names a Step's fields; the C caller passed them as these arguments.
Status ToArgumentStatus(const Status& status) {
  static const std::pair<const char*, const char*> kArguments[] = {
      {"contact_normal_values", "normal_values"},
      {"contact_tangential_values", "tangential_values"},
      {"depth", "normal_value"},
      {"depth_increment", "normal_value"},
      {"normal_force", "normal_value"},
      {"displacement", "tangential_value"},
      {"displacement_increment", "tangential_value"},
      {"tangential_force", "tangential_value"}};
  const std::string& field = status.field();
  for (const auto& [proto, argument] : kArguments) {
    const std::size_t length = std::char_traits<char>::length(proto);
    if (field.compare(0, length, proto) == 0 &&
        (field.size() == length || field[length] == '[' || field[length] == '.')) {
      return Status(status.code(), argument + field.substr(length), status.ToString());
    }
  }
  return status;
}

CallStatus Step(mdr_interface* handle, int normal_control, double normal_value,
                int tangential_control, double tangential_value, const double* normal_values,
                const double* tangential_values, std::size_t n) {
  if (Status s = RequireNonNull(handle, "interface"); !s.ok()) return s;
  if (Status s = CheckStepCount(handle->applied_steps, "interface"); !s.ok()) return s;
  if (n > 0 && normal_values == nullptr && tangential_values == nullptr) {
    return InvalidArgument("n", "must be 0 when normal_values and tangential_values are NULL");
  }
  Result<v1::Step> step = ToProtoStep(normal_control, normal_value, tangential_control,
                                      tangential_value, normal_values, tangential_values, n);
  if (!step.ok()) return step.status();
  if (Status s = bridge::ApplyInterfaceStep(handle->interface, *step, {}); !s.ok()) {
    return ToArgumentStatus(s);
  }
  ++handle->applied_steps;
  return OkStatus();
}

// The interface's state as the service reports it (WriteInterfaceState), in the C record.
CallStatus State(const mdr_interface* handle, mdr_state* out) {
  if (Status s = RequireNonNull(handle, "interface"); !s.ok()) return s;
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  v1::ContactState state;
  bridge::WriteInterfaceState(handle->interface, handle->applied_steps,
                              bridge::OutputSelection::FullState(), &state);
  *out = mdr_state{.depth = state.depth(),
                   .tangential_displacement = state.tangential_displacement(),
                   .contact_radius = state.contact_radius(),
                   .normal_force = state.normal_force(),
                   .tangential_force = state.tangential_force(),
                   .dissipated_energy = state.dissipated_energy(),
                   .friction_limit = state.friction_limit(),
                   .actuator_displacement = state.actuator_displacement(),
                   .actuator_depth = state.actuator_depth(),
                   .last_step_dissipation = 0,
                   .applied_steps = state.applied_steps(),
                   .memory_vertices = state.memory_vertices()};
  return OkStatus();
}

CallStatus ContactStates(const mdr_interface* handle, mdr_state* out, std::size_t capacity,
                         std::size_t* count) {
  if (Status s = RequireNonNull(handle, "interface"); !s.ok()) return s;
  if (Status s = RequireNonNull(count, "count"); !s.ok()) return s;
  const Interface& interface = handle->interface;
  *count = interface.size();
  if (CallStatus s = RequireCapacity(capacity, interface.size(), "capacity"); !s.ok()) return s;
  if (interface.size() > 0) {
    if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  }
  for (std::size_t i = 0; i < interface.size(); ++i) {
    ReadState(interface.contact(i), handle->applied_steps, &out[i]);
  }
  return OkStatus();
}

// The SessionSnapshot the service's ExportSession writes for an interface session
// (Session::ExportLocked), without the session's name and limits.
CallStatus Snapshot(const mdr_interface* handle, void* buffer, std::size_t capacity,
                    std::size_t* size) {
  if (Status s = RequireNonNull(handle, "interface"); !s.ok()) return s;
  v1::SessionSnapshot snapshot;
  snapshot.set_version(bridge::kSnapshotVersion);
  *snapshot.mutable_scene() = bridge::WithEffectiveOptions(handle->scene, handle->base);
  bridge::ToProtoInterfaceSnapshot(handle->interface, snapshot.mutable_interface());
  snapshot.set_applied_steps(handle->applied_steps);
  return WriteMessage(snapshot, buffer, capacity, size);
}

}  // namespace
}  // namespace mdr::capi

extern "C" {

using mdr::capi::Boundary;
using mdr::capi::CallStatus;

int mdr_interface_create(const void* scene, size_t size, mdr_interface** out) {
  return Boundary("mdr_interface_create", [&] {
    return mdr::capi::CreateFromBytes(scene, size, out, mdr::capi::CreateInterface);
  });
}

int mdr_interface_create_from_text(const char* text, const char* name, mdr_interface** out) {
  return Boundary("mdr_interface_create_from_text", [&] {
    return mdr::capi::CreateFromText(text, name, out, mdr::capi::CreateInterface);
  });
}

int mdr_interface_restore(const void* snapshot, size_t size, mdr_interface** out) {
  return Boundary("mdr_interface_restore", [&] { return mdr::capi::Restore(snapshot, size, out); });
}

void mdr_interface_destroy(mdr_interface* interface) { delete interface; }

int mdr_interface_size(const mdr_interface* interface, size_t* count) {
  return Boundary("mdr_interface_size", [&]() -> CallStatus {
    if (mdr::Status s = mdr::capi::RequireNonNull(interface, "interface"); !s.ok()) return s;
    if (mdr::Status s = mdr::capi::RequireNonNull(count, "count"); !s.ok()) return s;
    *count = interface->interface.size();
    return mdr::OkStatus();
  });
}

int mdr_interface_step(mdr_interface* interface, int normal_control, double normal_value,
                       int tangential_control, double tangential_value, const double* normal_values,
                       const double* tangential_values, size_t n) {
  return Boundary("mdr_interface_step", [&] {
    return mdr::capi::Step(interface, normal_control, normal_value, tangential_control,
                           tangential_value, normal_values, tangential_values, n);
  });
}

int mdr_interface_state(const mdr_interface* interface, mdr_state* out) {
  return Boundary("mdr_interface_state", [&] { return mdr::capi::State(interface, out); });
}

int mdr_interface_contact_states(const mdr_interface* interface, mdr_state* out, size_t capacity,
                                 size_t* count) {
  return Boundary("mdr_interface_contact_states",
                  [&] { return mdr::capi::ContactStates(interface, out, capacity, count); });
}

int mdr_interface_snapshot(const mdr_interface* interface, void* buffer, size_t capacity,
                           size_t* size) {
  return Boundary("mdr_interface_snapshot",
                  [&] { return mdr::capi::Snapshot(interface, buffer, capacity, size); });
}

}  // extern "C"
