// What the contact and the interface handles share: the service's reading of a scene (bytes, or
// a scene file's text with the line of every field) and of a SessionSnapshot, and the state
// record of one contact.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "boundary.h"
#include "mdr/base/status.h"
#include "mdr/client/scene_file.h"
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
  client::SceneDocument document;
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

// FAILED_PRECONDITION naming `argument` once applied_steps reached the session's limit.
Status CheckStepCount(std::uint64_t applied_steps, const char* argument);

}  // namespace mdr::capi
