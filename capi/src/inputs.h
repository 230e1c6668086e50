// What the contact and the interface handles share: the service's reading of a scene (bytes, or
// a scene file's text with the line of every field) and of a SessionSnapshot, and the state
// record of one contact.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "boundary.h"
#include "mdr/base/status.h"
#include "mdr/bridge/scene_file.h"
#include "mdr/core/contact.h"
#include "mdr/mdr.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::capi {

// The service's default limit of memory vertices, so a scene behaves here as on a default mdrd.
std::size_t MaxMemoryVertices();

// A scene from a serialized mdr.v1.Scene; errors name "scene" or "size".
Result<v1::Scene> ParseScene(const void* bytes, std::size_t size);

// A scene from a scene file's YAML or JSON text, as mdrctl reads it; its document places the
// errors of later checks (Locate).
struct SceneText {
  bridge::SceneDocument document;
  const v1::Scene& scene() const { return document.file().scene(); }
  // `call` with the scene file's line of its field in the message.
  CallStatus Locate(CallStatus call) const;
};
Result<SceneText> ParseSceneText(const char* text, const char* name);

// A handle (mdr_contact, mdr_interface) made by create(scene, out) from a serialized Scene, or
// from a scene file's text with the line of a failing field in the error. *out is null on error.
template <typename Handle, typename Create>
CallStatus CreateFromBytes(const void* bytes, std::size_t size, Handle** out, Create create) {
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  *out = nullptr;
  Result<v1::Scene> scene = ParseScene(bytes, size);
  if (!scene.ok()) return scene.status();
  return create(*scene, out);
}
template <typename Handle, typename Create>
CallStatus CreateFromText(const char* text, const char* name, Handle** out, Create create) {
  if (Status s = RequireNonNull(out, "out"); !s.ok()) return s;
  *out = nullptr;
  Result<SceneText> scene = ParseSceneText(text, name);
  if (!scene.ok()) return scene.status();
  CallStatus status = create(scene->scene(), out);
  return status.ok() ? status : scene->Locate(status);
}

// A snapshot from serialized bytes with ImportSession's checks of its version and counters;
// errors name "snapshot.<field>".
Result<v1::SessionSnapshot> ParseSnapshot(const void* bytes, std::size_t size);

// Writes a serialized message into the caller's buffer (*size: its length; MDR_OUT_OF_RANGE
// naming capacity when it does not fit).
CallStatus WriteMessage(const google::protobuf::Message& message, void* buffer,
                        std::size_t capacity, std::size_t* size);

// The state record of a contact after applied_steps steps.
void ReadState(const Contact& contact, std::uint64_t applied_steps, mdr_state* out);

// The channels of a step as the caller chose them: a control per channel, or none (HOLD: the
// channel stays, its value must be 0). The controls' values are checked here, the values by the
// core (or the service's interface step).
struct StepControls {
  std::optional<NormalControl> normal;
  double normal_value = 0;
  std::optional<TangentialControl> tangential;
  double tangential_value = 0;

  // The core step: a held channel is an increment of 0 (the proto Step's unset channel).
  Step ToCoreStep() const {
    return Step{.normal = normal.value_or(NormalControl::kDepthIncrement),
                .normal_value = normal_value,
                .tangential = tangential.value_or(TangentialControl::kDisplacementIncrement),
                .tangential_value = tangential_value};
  }
};
// The controls' values: the tangential ones are 0..3; 4..6 (the proto Step's field numbers, the
// values of the header's revision 1) are read as 1..3. Inline and without strings: a step's hot
// path (docs/capi.md, "Timing").
inline bool DecodeNormalControl(int control, std::optional<NormalControl>* out) {
  switch (control) {
    case MDR_NORMAL_HOLD:
      *out = std::nullopt;
      return true;
    case MDR_NORMAL_DEPTH:
      *out = NormalControl::kDepth;
      return true;
    case MDR_NORMAL_DEPTH_INCREMENT:
      *out = NormalControl::kDepthIncrement;
      return true;
    case MDR_NORMAL_FORCE:
      *out = NormalControl::kForce;
      return true;
    default:
      return false;
  }
}
inline bool DecodeTangentialControl(int control, std::optional<TangentialControl>* out) {
  switch (control) {
    case MDR_TANGENTIAL_HOLD:
      *out = std::nullopt;
      return true;
    case MDR_TANGENTIAL_DISPLACEMENT:
    case v1::Step::kDisplacementFieldNumber:
      *out = TangentialControl::kDisplacement;
      return true;
    case MDR_TANGENTIAL_DISPLACEMENT_INCREMENT:
    case v1::Step::kDisplacementIncrementFieldNumber:
      *out = TangentialControl::kDisplacementIncrement;
      return true;
    case MDR_TANGENTIAL_FORCE:
    case v1::Step::kTangentialForceFieldNumber:
      *out = TangentialControl::kForce;
      return true;
    default:
      return false;
  }
}
static_assert(v1::Step::kDisplacementFieldNumber == 4 &&
              v1::Step::kDisplacementIncrementFieldNumber == 5 &&
              v1::Step::kTangentialForceFieldNumber == 6);

// A step's controls and values, or false when a control is not one or a held channel has a
// value other than 0 (StepControlsError then names the argument).
inline bool DecodeStepControls(int normal_control, double normal_value, int tangential_control,
                               double tangential_value, StepControls* out) {
  out->normal_value = normal_value;
  out->tangential_value = tangential_value;
  return DecodeNormalControl(normal_control, &out->normal) &&
         DecodeTangentialControl(tangential_control, &out->tangential) &&
         (out->normal || normal_value == 0) && (out->tangential || tangential_value == 0);
}
// The error of arguments DecodeStepControls refused, naming normal_control, tangential_control,
// normal_value or tangential_value.
Status StepControlsError(int normal_control, double normal_value, int tangential_control,
                         double tangential_value);
// INVALID_ARGUMENT naming normal_control: not an mdr_normal_control (DecodeNormalControl refused).
Status NormalControlError(int normal_control);
// INVALID_ARGUMENT naming `argument` (normal_value, ...): a held channel's value is not 0.
Status HeldValueError(const char* argument, const char* hold);

// The proto Step's normal channel for the control (unset for a held channel).
void SetNormalChannel(std::optional<NormalControl> control, double value, v1::Step* step);

inline Result<StepControls> ReadStepControls(int normal_control, double normal_value,
                                             int tangential_control, double tangential_value) {
  StepControls controls;
  if (DecodeStepControls(normal_control, normal_value, tangential_control, tangential_value,
                         &controls)) {
    return controls;
  }
  return StepControlsError(normal_control, normal_value, tangential_control, tangential_value);
}

// FAILED_PRECONDITION naming `argument` once applied_steps reached the session's limit.
Status CheckStepCount(std::uint64_t applied_steps, const char* argument);

}  // namespace mdr::capi
