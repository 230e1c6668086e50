#include "inputs.h"

#include <google/protobuf/stubs/logging.h>

#include <climits>
#include <string>
#include <utility>

#include "mdr/bridge/conversion.h"

namespace mdr::capi {
namespace {

Status CheckBytes(const void* bytes, std::size_t size, const char* argument) {
  if (size > 0 && bytes == nullptr) {
    return InvalidArgument(argument, "must not be NULL when size is " + std::to_string(size));
  }
  if (size > static_cast<std::size_t>(INT_MAX)) {
    return InvalidArgument("size", "must be at most " + std::to_string(INT_MAX) +
                                       " bytes (a protobuf message's limit), got " +
                                       std::to_string(size));
  }
  return OkStatus();
}

// Parses without protobuf's log line on damaged input (invalid UTF-8 in a string): a library
// reports through its status, not on the caller's stderr.
bool QuietParse(const void* bytes, std::size_t size, google::protobuf::Message* message) {
  google::protobuf::LogSilencer silence;
  return message->ParseFromArray(bytes, static_cast<int>(size));
}

}  // namespace

std::size_t MaxMemoryVertices() { return bridge::kDefaultMaxMemoryVertices; }

Result<v1::Scene> ParseScene(const void* bytes, std::size_t size) {
  if (Status s = CheckBytes(bytes, size, "scene"); !s.ok()) return s;
  v1::Scene scene;
  if (!QuietParse(bytes, size, &scene)) {
    return InvalidArgument("scene", "is not a serialized mdr.v1.Scene");
  }
  return scene;
}

CallStatus SceneText::Locate(CallStatus call) const {
  const Status& s = call.status;
  return CallStatus(
      call.code, Status(s.code(), s.field(), s.message() + " (" + document.Where(s.field()) + ")"));
}

Result<SceneText> ParseSceneText(const char* text, const char* name) {
  if (Status s = RequireNonNull(text, "text"); !s.ok()) return s;
  Result<bridge::SceneDocument> document =
      bridge::SceneDocument::Parse(text, name != nullptr ? name : "scene");
  if (!document.ok()) {
    // A syntax error belongs to no field of the scene: it is the text argument's.
    const Status& s = document.status();
    if (s.field().empty()) return Status(s.code(), "text", s.message());
    return s;
  }
  if (!document->file().has_scene()) {
    return document->Error("scene", "required: the scene file has no scene");
  }
  return SceneText{std::move(document).value()};
}

Result<v1::SessionSnapshot> ParseSnapshot(const void* bytes, std::size_t size) {
  if (Status s = CheckBytes(bytes, size, "snapshot"); !s.ok()) return s;
  v1::SessionSnapshot snapshot;
  if (!QuietParse(bytes, size, &snapshot)) {
    return InvalidArgument("snapshot", "is not a serialized mdr.v1.SessionSnapshot");
  }
  if (Status s = bridge::CheckSnapshotHeader(snapshot); !s.ok()) return s;
  return snapshot;
}

CallStatus WriteMessage(const google::protobuf::Message& message, void* buffer,
                        std::size_t capacity, std::size_t* size) {
  if (Status s = RequireNonNull(size, "size"); !s.ok()) return s;
  const std::size_t bytes = message.ByteSizeLong();
  *size = bytes;
  if (CallStatus s = RequireCapacity(capacity, bytes, "capacity"); !s.ok()) return s;
  if (bytes > static_cast<std::size_t>(INT_MAX)) {
    return ResourceExhausted("capacity", "the snapshot of " + std::to_string(bytes) +
                                             " bytes exceeds a protobuf message's 2 GiB");
  }
  if (Status s = RequireNonNull(buffer, "buffer"); !s.ok()) return s;
  if (!message.SerializeToArray(buffer, static_cast<int>(bytes))) {
    return Internal("buffer", "the snapshot could not be serialized");
  }
  return OkStatus();
}

void ReadState(const Contact& c, std::uint64_t applied_steps, mdr_state* out) {
  *out = mdr_state{.depth = c.depth(),
                   .tangential_displacement = c.tangential_displacement(),
                   .contact_radius = c.contact_radius(),
                   .normal_force = c.normal_force(),
                   .tangential_force = c.tangential_force(),
                   .dissipated_energy = c.dissipated_energy(),
                   .friction_limit = c.friction_limit(),
                   .actuator_displacement = c.actuator_displacement(),
                   .actuator_depth = c.actuator_depth(),
                   .last_step_dissipation = c.last_step_dissipation(),
                   .applied_steps = applied_steps,
                   .memory_vertices = c.memory().vertex_count()};
}

Status StepControlsError(int normal_control, double normal_value, int tangential_control,
                         double tangential_value) {
  std::optional<NormalControl> normal;
  std::optional<TangentialControl> tangential;
  if (!DecodeNormalControl(normal_control, &normal)) return NormalControlError(normal_control);
  if (!DecodeTangentialControl(tangential_control, &tangential)) {
    return InvalidArgument("tangential_control",
                           "must be MDR_TANGENTIAL_HOLD (0), _DISPLACEMENT (1), "
                           "_DISPLACEMENT_INCREMENT (2) or _FORCE (3), got " +
                               std::to_string(tangential_control));
  }
  if (!normal && normal_value != 0) return HeldValueError("normal_value", "MDR_NORMAL_HOLD");
  if (!tangential && tangential_value != 0) {
    return HeldValueError("tangential_value", "MDR_TANGENTIAL_HOLD");
  }
  return Internal("", "StepControlsError called for valid controls");
}

Status NormalControlError(int normal_control) {
  return InvalidArgument("normal_control",
                         "must be MDR_NORMAL_HOLD (0), _DEPTH (1), _DEPTH_INCREMENT (2) or "
                         "_FORCE (3), got " +
                             std::to_string(normal_control));
}

// A held channel has no value: a non-zero one is a caller's mistake, not something to ignore.
Status HeldValueError(const char* argument, const char* hold) {
  return InvalidArgument(argument, std::string("must be 0 with ") + hold);
}

void SetNormalChannel(std::optional<NormalControl> control, double value, v1::Step* step) {
  if (!control) return;
  switch (*control) {
    case NormalControl::kDepth:
      step->set_depth(value);
      break;
    case NormalControl::kDepthIncrement:
      step->set_depth_increment(value);
      break;
    case NormalControl::kForce:
      step->set_normal_force(value);
      break;
  }
}

Status CheckStepCount(std::uint64_t applied_steps, const char* argument) {
  if (applied_steps < bridge::kMaxAppliedSteps) return OkStatus();
  return FailedPrecondition(argument, "has applied the most steps a session may apply (" +
                                          std::to_string(bridge::kMaxAppliedSteps) + ")");
}

}  // namespace mdr::capi
