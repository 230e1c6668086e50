// The loading path of a scene file: its rules (the only place they are checked) and the steps
// each segment expands to from the state where it starts. The values of the steps themselves are
// checked by the service when they are applied.
#pragma once

#include <cstdint>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdr::client {

// What a scene is, as far as the path's rules are concerned.
// kTorsion: a single contact driven about its axis (scene.torsion).
enum class SceneKind { kSingleContact, kSharedMotion, kContactList, kTorsion };
inline bool IsInterface(SceneKind kind) {
  return kind == SceneKind::kSharedMotion || kind == SceneKind::kContactList;
}
SceneKind KindOf(const v1::Scene& scene);
// The number of contacts N: 1 for a single contact, the population's count for an interface
// (0 when the population is unset, which the service refuses).
std::uint64_t ContactCount(const v1::Scene& scene);

// Checks the rules of the path helpers for a scene of `kind` with `contacts` contacts; the field
// is relative to the segment ("ramp.steps").
Status ValidateSegment(const v1::Segment& segment, SceneKind kind, std::uint64_t contacts);
// Checks the file's own rules (a path or steps; every segment; the outputs against the scene's
// kind); fields like "path[2].ramp.steps".
Status ValidateSceneFile(const v1::SceneFile& file);

// The table's columns: SceneFile.outputs, or the defaults for the scene's kind (the proto's doc).
std::vector<v1::SceneFile::Output> TableOutputs(const v1::SceneFile& file);
// True when a column is a count of InterfaceTotals (read by a query after every step).
bool NeedsInterfaceTotals(const std::vector<v1::SceneFile::Output>& outputs);

// Steps the segment applies; known before the run (0 for a hold).
std::uint64_t StepCount(const v1::Segment& segment);
std::uint64_t StepCount(const v1::SceneFile& file);
// Steps of one cycle of a Cycles or ContactCycles segment.
std::uint64_t StepsPerCycle(std::uint32_t steps_per_quarter);
// The cycles of a Cycles or ContactCycles segment (0 for any other kind).
std::uint32_t CycleCount(const v1::Segment& segment);

// The steps of a valid segment that starts at `start`, for a scene of `contacts` contacts (the
// per-contact values of a contact list's segments).
std::vector<v1::Step> ExpandSegment(const v1::Segment& segment, const v1::ContactState& start,
                                    std::uint64_t contacts = 1);

}  // namespace mdr::client
