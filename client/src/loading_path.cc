#include "mdr/client/loading_path.h"

#include <algorithm>
#include <string>
#include <utility>

#include "mdr/base/validate.h"

namespace mdr::client {
namespace {

using v1::Cycles;
using v1::Step;

std::uint32_t AtLeastOne(std::uint32_t n) { return n == 0 ? 1 : n; }

Status ValidateRamp(const v1::Ramp& ramp) {
  if (ramp.target().normal_case() == Step::NORMAL_NOT_SET &&
      ramp.target().tangential_case() == Step::TANGENTIAL_NOT_SET &&
      ramp.target().torsional_case() == Step::TORSIONAL_NOT_SET) {
    return InvalidArgument("ramp.target", "must set a normal, a tangential or a twist channel");
  }
  return OkStatus();
}

bool IsTwistQuantity(Cycles::Quantity quantity) {
  return quantity == Cycles::TWIST || quantity == Cycles::TWISTING_MOMENT;
}

Status ValidateCycles(const Cycles& cycles, SceneKind kind) {
  if (cycles.quantity() == Cycles::QUANTITY_UNSPECIFIED) {
    return InvalidArgument("cycles.quantity",
                           "must be DEPTH, NORMAL_FORCE, TANGENTIAL_DISPLACEMENT, "
                           "TANGENTIAL_FORCE, TWIST or TWISTING_MOMENT");
  }
  const bool torsion = kind == SceneKind::kTorsion;
  if (IsTwistQuantity(cycles.quantity()) && !torsion) {
    return InvalidArgument("cycles.quantity", Cycles::Quantity_Name(cycles.quantity()) +
                                                  " needs a torsional scene (scene.torsion)");
  }
  if (torsion && (cycles.quantity() == Cycles::TANGENTIAL_DISPLACEMENT ||
                  cycles.quantity() == Cycles::TANGENTIAL_FORCE)) {
    return InvalidArgument("cycles.quantity",
                           Cycles::Quantity_Name(cycles.quantity()) +
                               " is not for a torsional scene (scene.torsion), which is twisted: "
                               "use TWIST or TWISTING_MOMENT");
  }
  if (Status s = RequirePositive("cycles.amplitude", cycles.amplitude()); !s.ok()) return s;
  if (cycles.count() == 0) return InvalidArgument("cycles.count", "must be >= 1");
  return OkStatus();
}

Status ValidateHold(const v1::Hold& hold) {
  if (hold.samples() == 1) return InvalidArgument("hold.samples", "must be >= 2 (0: 101)");
  return OkStatus();
}

// Exactly one of the list (N values) and the generator; field relative to the ContactValues.
Status ValidateContactValues(const v1::ContactValues& values, std::uint64_t contacts) {
  const bool listed = values.values_size() > 0;
  if (listed == values.has_linear()) {
    return InvalidArgument("", "must set either values (one per contact) or linear");
  }
  if (values.has_linear()) {
    if (Status s = RequireFinite("linear.first", values.linear().first()); !s.ok()) return s;
    return RequireFinite("linear.last", values.linear().last());
  }
  // contacts == 0: the population is unset, which the service reports.
  if (contacts > 0 && static_cast<std::uint64_t>(values.values_size()) != contacts) {
    return InvalidArgument("values", "must hold one value per contact (" +
                                         std::to_string(contacts) + "), got " +
                                         std::to_string(values.values_size()));
  }
  for (int i = 0; i < values.values_size(); ++i) {
    const Status s = RequireFinite("values[" + std::to_string(i) + "]", values.values(i));
    if (!s.ok()) return s;
  }
  return OkStatus();
}

Status ValidateContactRamp(const v1::ContactRamp& ramp, std::uint64_t contacts) {
  if (!ramp.has_depth_increments() && !ramp.has_displacement_increments()) {
    return InvalidArgument("contact_ramp", "must set depth_increments or displacement_increments");
  }
  if (ramp.has_depth_increments()) {
    const Status s = ValidateContactValues(ramp.depth_increments(), contacts);
    if (!s.ok()) return s.WithFieldPrefix("contact_ramp.depth_increments");
  }
  if (ramp.has_displacement_increments()) {
    const Status s = ValidateContactValues(ramp.displacement_increments(), contacts);
    if (!s.ok()) return s.WithFieldPrefix("contact_ramp.displacement_increments");
  }
  return OkStatus();
}

Status ValidateContactCycles(const v1::ContactCycles& cycles, std::uint64_t contacts) {
  if (cycles.quantity() != Cycles::DEPTH && cycles.quantity() != Cycles::TANGENTIAL_DISPLACEMENT) {
    return InvalidArgument("contact_cycles.quantity", "must be DEPTH or TANGENTIAL_DISPLACEMENT");
  }
  if (!cycles.has_amplitudes()) {
    return InvalidArgument("contact_cycles.amplitudes", "required: one amplitude per contact");
  }
  const Status s = ValidateContactValues(cycles.amplitudes(), contacts);
  if (!s.ok()) return s.WithFieldPrefix("contact_cycles.amplitudes");
  if (cycles.count() == 0) return InvalidArgument("contact_cycles.count", "must be >= 1");
  return OkStatus();
}

// Which segment kinds a scene takes: a contact list moves each contact by its own values.
Status CheckSegmentFitsScene(const v1::Segment& segment, SceneKind kind) {
  const bool per_contact = segment.has_contact_ramp() || segment.has_contact_cycles();
  const char* name = segment.has_contact_ramp()     ? "contact_ramp"
                     : segment.has_contact_cycles() ? "contact_cycles"
                     : segment.has_ramp()           ? "ramp"
                     : segment.has_cycles()         ? "cycles"
                                                    : "hold";
  if (per_contact && kind != SceneKind::kContactList) {
    return InvalidArgument(name, "needs a contact list (scene.interface.kind KIND_CONTACT_LIST)");
  }
  if (kind == SceneKind::kContactList && !per_contact && !segment.has_step()) {
    return InvalidArgument(name,
                           "not for a contact list, which moves each contact by its own values: "
                           "use contact_ramp, contact_cycles or a step with "
                           "contact_normal_values / contact_tangential_values");
  }
  return OkStatus();
}

// The columns that are counts of InterfaceTotals.
bool IsInterfaceCount(v1::SceneFile::Output output) {
  return output == v1::SceneFile::IN_CONTACT || output == v1::SceneFile::STICKING ||
         output == v1::SceneFile::PARTIAL_SLIP || output == v1::SceneFile::GROSS_SLIP;
}

// The columns that need an interface.
Status ValidateOutputs(const v1::SceneFile& file, SceneKind kind) {
  for (int i = 0; i < file.outputs_size(); ++i) {
    const auto output = v1::SceneFile::Output(file.outputs(i));
    const std::string field = "outputs[" + std::to_string(i) + "]";
    if (output == v1::SceneFile::OUTPUT_UNSPECIFIED) {
      return InvalidArgument(field, "must be a quantity such as NORMAL_FORCE");
    }
    if (IsInterfaceCount(output) && !IsInterface(kind)) {
      return InvalidArgument(
          field, v1::SceneFile::Output_Name(output) + " needs an interface (scene.interface)");
    }
    const bool twist_output = output == v1::SceneFile::TWIST ||
                              output == v1::SceneFile::TWISTING_MOMENT ||
                              output == v1::SceneFile::FULL_SLIP_MOMENT;
    if (twist_output && kind != SceneKind::kTorsion) {
      return InvalidArgument(
          field, v1::SceneFile::Output_Name(output) + " needs a torsional scene (scene.torsion)");
    }
  }
  return OkStatus();
}

// The value of a channel set in `target` at the segment's start: depths and displacements are
// the actuator's (the contact's without scene.rig), as the steps that drive them.
double StartValue(const Step& target, bool normal, const v1::ContactState& start) {
  if (normal) {
    return target.normal_case() == Step::kNormalForce ? start.normal_force()
                                                      : start.actuator_depth();
  }
  return target.tangential_case() == Step::kTangentialForce ? start.tangential_force()
                                                            : start.actuator_displacement();
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
  switch (target.torsional_case()) {
    case Step::kTwist:
      step->set_twist(lerp(start.twist(), target.twist()));
      break;
    case Step::kTwistIncrement:
      step->set_twist_increment(target.twist_increment() / n);
      break;
    case Step::kTwistingMoment:
      step->set_twisting_moment(lerp(start.twisting_moment(), target.twisting_moment()));
      break;
    case Step::TORSIONAL_NOT_SET:
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
    case Cycles::TWIST:
      step->set_twist(value);
      break;
    case Cycles::TWISTING_MOMENT:
      step->set_twisting_moment(value);
      break;
    default:
      step->set_tangential_force(value);
  }
}

double CycledValue(Cycles::Quantity quantity, const v1::ContactState& state) {
  switch (quantity) {
    case Cycles::DEPTH:
      return state.actuator_depth();
    case Cycles::NORMAL_FORCE:
      return state.normal_force();
    case Cycles::TANGENTIAL_DISPLACEMENT:
      return state.actuator_displacement();
    case Cycles::TWIST:
      return state.twist();
    case Cycles::TWISTING_MOMENT:
      return state.twisting_moment();
    default:
      return state.tangential_force();
  }
}

std::vector<Step> ExpandCycles(const Cycles& cycles, const v1::ContactState& start) {
  const std::uint64_t q = AtLeastOne(cycles.steps_per_quarter());
  const std::uint64_t per_cycle = StepsPerCycle(cycles.steps_per_quarter());
  const double center = CycledValue(cycles.quantity(), start);
  std::vector<Step> steps(per_cycle * cycles.count());
  for (std::uint64_t k = 0; k < steps.size(); ++k) {
    const double phase = CyclePhase(k % per_cycle + 1, q);
    SetCycled(cycles.quantity(), phase == 0 ? center : center + phase * cycles.amplitude(),
              &steps[k]);
  }
  return steps;
}

// The value of contact i of N (a valid ContactValues).
double ContactValue(const v1::ContactValues& values, std::uint64_t i, std::uint64_t contacts) {
  if (!values.has_linear()) return values.values(static_cast<int>(i));
  const auto& linear = values.linear();
  if (contacts == 1 || i == 0) return linear.first();
  if (i + 1 == contacts) return linear.last();
  return linear.first() +
         (linear.last() - linear.first()) * (static_cast<double>(i) / (contacts - 1));
}

// Every contact's value times `scale` into `out` (the packed per-contact field of a step).
void SetContactValues(const v1::ContactValues& values, std::uint64_t contacts, double scale,
                      google::protobuf::RepeatedField<double>* out) {
  out->Resize(static_cast<int>(contacts), 0.0);
  for (std::uint64_t i = 0; i < contacts; ++i) {
    out->Set(static_cast<int>(i), scale * ContactValue(values, i, contacts));
  }
}

std::vector<Step> ExpandContactRamp(const v1::ContactRamp& ramp, std::uint64_t contacts) {
  const std::uint32_t n = AtLeastOne(ramp.steps());
  Step step;
  if (ramp.has_depth_increments()) {
    step.set_depth_increment(0);
    SetContactValues(ramp.depth_increments(), contacts, 1.0 / n,
                     step.mutable_contact_normal_values());
  }
  if (ramp.has_displacement_increments()) {
    step.set_displacement_increment(0);
    SetContactValues(ramp.displacement_increments(), contacts, 1.0 / n,
                     step.mutable_contact_tangential_values());
  }
  return std::vector<Step>(n, step);
}

// Increments of 1/q of the amplitude: up in the first and last quarter, down in between.
std::vector<Step> ExpandContactCycles(const v1::ContactCycles& cycles, std::uint64_t contacts) {
  const std::uint64_t q = AtLeastOne(cycles.steps_per_quarter());
  const bool depth = cycles.quantity() == Cycles::DEPTH;
  Step up;
  Step down;
  for (auto [step, sign] : {std::pair{&up, 1.0}, std::pair{&down, -1.0}}) {
    if (depth) {
      step->set_depth_increment(0);
      SetContactValues(cycles.amplitudes(), contacts, sign / q,
                       step->mutable_contact_normal_values());
    } else {
      step->set_displacement_increment(0);
      SetContactValues(cycles.amplitudes(), contacts, sign / q,
                       step->mutable_contact_tangential_values());
    }
  }
  const std::uint64_t per_cycle = StepsPerCycle(cycles.steps_per_quarter());
  std::vector<Step> steps;
  steps.reserve(per_cycle * cycles.count());
  for (std::uint64_t k = 0; k < per_cycle * cycles.count(); ++k) {
    const std::uint64_t j = k % per_cycle;  // 0-based step within the cycle
    steps.push_back(j < q || j >= 3 * q ? up : down);
  }
  return steps;
}

}  // namespace

SceneKind KindOf(const v1::Scene& scene) {
  if (!scene.has_interface()) {
    return scene.has_torsion() ? SceneKind::kTorsion : SceneKind::kSingleContact;
  }
  return scene.interface().kind() == v1::Interface::KIND_CONTACT_LIST ? SceneKind::kContactList
                                                                      : SceneKind::kSharedMotion;
}

std::uint64_t ContactCount(const v1::Scene& scene) {
  if (!scene.has_interface()) return 1;
  const v1::Interface& interface = scene.interface();
  if (interface.has_generated()) return interface.generated().count();
  return static_cast<std::uint64_t>(interface.explicit_list().heights_size());
}

Status ValidateSegment(const v1::Segment& segment, SceneKind kind, std::uint64_t contacts) {
  if (segment.kind_case() != v1::Segment::KIND_NOT_SET) {
    if (Status s = CheckSegmentFitsScene(segment, kind); !s.ok()) return s;
  }
  switch (segment.kind_case()) {
    case v1::Segment::kContactRamp:
      return ValidateContactRamp(segment.contact_ramp(), contacts);
    case v1::Segment::kContactCycles:
      return ValidateContactCycles(segment.contact_cycles(), contacts);
    case v1::Segment::kRamp:
      return ValidateRamp(segment.ramp());
    case v1::Segment::kCycles:
      return ValidateCycles(segment.cycles(), kind);
    case v1::Segment::kHold:
      return ValidateHold(segment.hold());
    case v1::Segment::kStep:
      return OkStatus();
    default:
      return InvalidArgument(
          "", "must set one of step, ramp, cycles, hold, contact_ramp, contact_cycles");
  }
}

Status ValidateSceneFile(const v1::SceneFile& file) {
  if (!file.has_scene()) return InvalidArgument("scene", "is required");
  if (file.steps().empty() && file.path().empty()) {
    return InvalidArgument("path", "must contain at least one segment (or give steps)");
  }
  const SceneKind kind = KindOf(file.scene());
  const std::uint64_t contacts = ContactCount(file.scene());
  for (int i = 0; i < file.path_size(); ++i) {
    const Status status = ValidateSegment(file.path(i), kind, contacts);
    if (!status.ok()) return status.WithFieldPrefix("path[" + std::to_string(i) + "]");
  }
  return ValidateOutputs(file, kind);
}

std::uint64_t StepsPerCycle(std::uint32_t steps_per_quarter) {
  return 4 * static_cast<std::uint64_t>(AtLeastOne(steps_per_quarter));
}

std::vector<v1::SceneFile::Output> TableOutputs(const v1::SceneFile& file) {
  using Output = v1::SceneFile;
  if (!file.outputs().empty()) {
    std::vector<v1::SceneFile::Output> outputs;
    for (int output : file.outputs()) outputs.push_back(v1::SceneFile::Output(output));
    return outputs;
  }
  switch (KindOf(file.scene())) {
    case SceneKind::kSingleContact:
      if (file.scene().has_rig()) {  // the contact's and the actuator's position side by side
        return {Output::DEPTH,
                Output::ACTUATOR_DEPTH,
                Output::TANGENTIAL_DISPLACEMENT,
                Output::ACTUATOR_DISPLACEMENT,
                Output::NORMAL_FORCE,
                Output::TANGENTIAL_FORCE,
                Output::CONTACT_RADIUS};
      }
      return {Output::DEPTH, Output::TANGENTIAL_DISPLACEMENT, Output::NORMAL_FORCE,
              Output::TANGENTIAL_FORCE, Output::CONTACT_RADIUS};
    case SceneKind::kTorsion:
      return {Output::DEPTH, Output::NORMAL_FORCE,    Output::CONTACT_RADIUS,
              Output::TWIST, Output::TWISTING_MOMENT, Output::DISSIPATED_ENERGY};
    case SceneKind::kSharedMotion:
      return {Output::DEPTH,
              Output::TANGENTIAL_DISPLACEMENT,
              Output::NORMAL_FORCE,
              Output::TANGENTIAL_FORCE,
              Output::DISSIPATED_ENERGY,
              Output::IN_CONTACT,
              Output::PARTIAL_SLIP,
              Output::GROSS_SLIP};
    case SceneKind::kContactList:
      return {Output::NORMAL_FORCE, Output::TANGENTIAL_FORCE, Output::DISSIPATED_ENERGY,
              Output::IN_CONTACT,   Output::PARTIAL_SLIP,     Output::GROSS_SLIP};
  }
  return {};
}

bool NeedsInterfaceTotals(const std::vector<v1::SceneFile::Output>& outputs) {
  return std::any_of(outputs.begin(), outputs.end(), IsInterfaceCount);
}

std::uint32_t CycleCount(const v1::Segment& segment) {
  if (segment.has_cycles()) return segment.cycles().count();
  if (segment.has_contact_cycles()) return segment.contact_cycles().count();
  return 0;
}

std::uint64_t StepCount(const v1::Segment& segment) {
  switch (segment.kind_case()) {
    case v1::Segment::kStep:
      return 1;
    case v1::Segment::kRamp:
      return AtLeastOne(segment.ramp().steps());
    case v1::Segment::kCycles:
      return StepsPerCycle(segment.cycles().steps_per_quarter()) * segment.cycles().count();
    case v1::Segment::kContactRamp:
      return AtLeastOne(segment.contact_ramp().steps());
    case v1::Segment::kContactCycles:
      return StepsPerCycle(segment.contact_cycles().steps_per_quarter()) *
             segment.contact_cycles().count();
    default:
      return 0;
  }
}

std::uint64_t StepCount(const v1::SceneFile& file) {
  std::uint64_t count = file.steps_size();
  for (const v1::Segment& segment : file.path()) count += StepCount(segment);
  return count;
}

std::vector<Step> ExpandSegment(const v1::Segment& segment, const v1::ContactState& start,
                                std::uint64_t contacts) {
  switch (segment.kind_case()) {
    case v1::Segment::kStep:
      return {segment.step()};
    case v1::Segment::kRamp:
      return ExpandRamp(segment.ramp(), start);
    case v1::Segment::kCycles:
      return ExpandCycles(segment.cycles(), start);
    case v1::Segment::kContactRamp:
      return ExpandContactRamp(segment.contact_ramp(), contacts);
    case v1::Segment::kContactCycles:
      return ExpandContactCycles(segment.contact_cycles(), contacts);
    default:
      return {};
  }
}

}  // namespace mdr::client
