// The loading path of a scene file: its rules (the only place they are checked) and the steps
// each segment expands to from the state where it starts. The values of the steps themselves are
// checked by the service when they are applied.
#pragma once

#include <cstdint>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdr::client {

// Checks the rules of the path helpers; the field is relative to the segment ("ramp.steps").
Status ValidateSegment(const v1::Segment& segment);
// Checks the file's own rules (a path or steps; every segment); fields like "path[2].ramp.steps".
Status ValidateSceneFile(const v1::SceneFile& file);

// Steps the segment applies; known before the run (0 for a hold).
std::uint64_t StepCount(const v1::Segment& segment);
std::uint64_t StepCount(const v1::SceneFile& file);
// Steps of one cycle of a Cycles segment.
std::uint64_t StepsPerCycle(const v1::Cycles& cycles);

// The steps of a valid segment that starts at `start`.
std::vector<v1::Step> ExpandSegment(const v1::Segment& segment, const v1::ContactState& start);

}  // namespace mdr::client
