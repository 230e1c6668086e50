#include "mdr/client/loading_path.h"

#include <string>

#include "mdr/base/validate.h"

namespace mdr::client {
namespace {

using v1::Cycles;
using v1::Step;

std::uint32_t AtLeastOne(std::uint32_t n) { return n == 0 ? 1 : n; }

Status ValidateRamp(const v1::Ramp& ramp) {
  if (ramp.target().normal_case() == Step::NORMAL_NOT_SET &&
      ramp.target().tangential_case() == Step::TANGENTIAL_NOT_SET) {
    return InvalidArgument("ramp.target", "must set a normal or a tangential channel");
  }
  return OkStatus();
}

Status ValidateCycles(const Cycles& cycles) {
  if (cycles.quantity() == Cycles::QUANTITY_UNSPECIFIED) {
    return InvalidArgument("cycles.quantity",
                           "must be DEPTH, NORMAL_FORCE, TANGENTIAL_DISPLACEMENT or "
                           "TANGENTIAL_FORCE");
  }
  if (Status s = RequirePositive("cycles.amplitude", cycles.amplitude()); !s.ok()) return s;
  if (cycles.count() == 0) return InvalidArgument("cycles.count", "must be >= 1");
  return OkStatus();
}

Status ValidateHold(const v1::Hold& hold) {
  if (hold.samples() == 1) return InvalidArgument("hold.samples", "must be >= 2 (0: 101)");
  return OkStatus();
}

// The value of a channel set in `target` at the segment's start.
double StartValue(const Step& target, bool normal, const v1::ContactState& start) {
  if (normal) {
    return target.normal_case() == Step::kNormalForce ? start.normal_force() : start.depth();
  }
  return target.tangential_case() == Step::kTangentialForce ? start.tangential_force()
                                                            : start.tangential_displacement();
}

// Step i (1-based) of n of a ramp of one channel; increments are split, targets interpolated
// (the last step hits the target exactly).
void SetRampChannel(const Step& target, const v1::ContactState& start, std::uint32_t i,
                    std::uint32_t n, Step* step) {
  const double f = static_cast<double>(i) / n;
  const auto lerp = [&](double from, double to) { return i == n ? to : from + (to - from) * f; };
  switch (target.normal_case()) {
    case Step::kDepth:
      step->set_depth(lerp(StartValue(target, true, start), target.depth()));
      break;
    case Step::kDepthIncrement:
      step->set_depth_increment(target.depth_increment() / n);
      break;
    case Step::kNormalForce:
      step->set_normal_force(lerp(StartValue(target, true, start), target.normal_force()));
      break;
    case Step::NORMAL_NOT_SET:
      break;
  }
  switch (target.tangential_case()) {
    case Step::kDisplacement:
      step->set_displacement(lerp(StartValue(target, false, start), target.displacement()));
      break;
    case Step::kDisplacementIncrement:
      step->set_displacement_increment(target.displacement_increment() / n);
      break;
    case Step::kTangentialForce:
      step->set_tangential_force(lerp(StartValue(target, false, start), target.tangential_force()));
      break;
    case Step::TANGENTIAL_NOT_SET:
      break;
  }
}

std::vector<Step> ExpandRamp(const v1::Ramp& ramp, const v1::ContactState& start) {
  const std::uint32_t n = AtLeastOne(ramp.steps());
  std::vector<Step> steps(n);
  for (std::uint32_t i = 1; i <= n; ++i) SetRampChannel(ramp.target(), start, i, n, &steps[i - 1]);
  return steps;
}

// The cycle's shape at step j of 4q: 0 -> 1 -> -1 -> 0, exact at the turning points.
double CyclePhase(std::uint64_t j, std::uint64_t q) {
  if (j <= q) return static_cast<double>(j) / q;
  if (j <= 3 * q) return 1.0 - static_cast<double>(j - q) / q;
  return -1.0 + static_cast<double>(j - 3 * q) / q;
}

void SetCycled(Cycles::Quantity quantity, double value, Step* step) {
  switch (quantity) {
    case Cycles::DEPTH:
      step->set_depth(value);
      break;
    case Cycles::NORMAL_FORCE:
      step->set_normal_force(value);
      break;
    case Cycles::TANGENTIAL_DISPLACEMENT:
      step->set_displacement(value);
      break;
    default:
      step->set_tangential_force(value);
  }
}

double CycledValue(Cycles::Quantity quantity, const v1::ContactState& state) {
  switch (quantity) {
    case Cycles::DEPTH:
      return state.depth();
    case Cycles::NORMAL_FORCE:
      return state.normal_force();
    case Cycles::TANGENTIAL_DISPLACEMENT:
      return state.tangential_displacement();
    default:
      return state.tangential_force();
  }
}

std::vector<Step> ExpandCycles(const Cycles& cycles, const v1::ContactState& start) {
  const std::uint64_t q = AtLeastOne(cycles.steps_per_quarter());
  const std::uint64_t per_cycle = StepsPerCycle(cycles);
  const double center = CycledValue(cycles.quantity(), start);
  std::vector<Step> steps(per_cycle * cycles.count());
  for (std::uint64_t k = 0; k < steps.size(); ++k) {
    const double phase = CyclePhase(k % per_cycle + 1, q);
    SetCycled(cycles.quantity(), phase == 0 ? center : center + phase * cycles.amplitude(),
              &steps[k]);
  }
  return steps;
}

}  // namespace

Status ValidateSegment(const v1::Segment& segment) {
  switch (segment.kind_case()) {
    case v1::Segment::kRamp:
      return ValidateRamp(segment.ramp());
    case v1::Segment::kCycles:
      return ValidateCycles(segment.cycles());
    case v1::Segment::kHold:
      return ValidateHold(segment.hold());
    case v1::Segment::kStep:
      return OkStatus();
    default:
      return InvalidArgument("", "must set one of step, ramp, cycles, hold");
  }
}

Status ValidateSceneFile(const v1::SceneFile& file) {
  if (!file.has_scene()) return InvalidArgument("scene", "is required");
  if (file.steps().empty() && file.path().empty()) {
    return InvalidArgument("path", "must contain at least one segment (or give steps)");
  }
  for (int i = 0; i < file.path_size(); ++i) {
    const Status status = ValidateSegment(file.path(i));
    if (!status.ok()) return status.WithFieldPrefix("path[" + std::to_string(i) + "]");
  }
  for (int i = 0; i < file.outputs_size(); ++i) {
    if (file.outputs(i) == v1::SceneFile::OUTPUT_UNSPECIFIED) {
      return InvalidArgument("outputs[" + std::to_string(i) + "]",
                             "must be a quantity such as NORMAL_FORCE");
    }
  }
  return OkStatus();
}

std::uint64_t StepsPerCycle(const Cycles& cycles) {
  return 4 * static_cast<std::uint64_t>(AtLeastOne(cycles.steps_per_quarter()));
}

std::uint64_t StepCount(const v1::Segment& segment) {
  switch (segment.kind_case()) {
    case v1::Segment::kStep:
      return 1;
    case v1::Segment::kRamp:
      return AtLeastOne(segment.ramp().steps());
    case v1::Segment::kCycles:
      return StepsPerCycle(segment.cycles()) * segment.cycles().count();
    default:
      return 0;
  }
}

std::uint64_t StepCount(const v1::SceneFile& file) {
  std::uint64_t count = file.steps_size();
  for (const v1::Segment& segment : file.path()) count += StepCount(segment);
  return count;
}

std::vector<Step> ExpandSegment(const v1::Segment& segment, const v1::ContactState& start) {
  switch (segment.kind_case()) {
    case v1::Segment::kStep:
      return {segment.step()};
    case v1::Segment::kRamp:
      return ExpandRamp(segment.ramp(), start);
    case v1::Segment::kCycles:
      return ExpandCycles(segment.cycles(), start);
    default:
      return {};
  }
}

}  // namespace mdr::client
