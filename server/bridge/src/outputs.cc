#include "mdr/bridge/outputs.h"

#include <algorithm>
#include <iterator>
#include <limits>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mdr/base/log_value.h"
#include "mdr/bridge/conversion.h"
#include "mdr/core/jager.h"
#include "mdr/core/tabulated_profile.h"

namespace mdr::bridge {
namespace {

struct Leaf {
  std::string path;
  Output output;
};

using StateWriter = void (*)(const Contact&, std::uint64_t, v1::ContactState*);

struct StateField {
  const char* name;
  Output output;
  StateWriter write;
};

// One writer per ContactState field, each calling only what its field needs.
const StateField kStateFields[] = {
    {"depth", Output::kDepth,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) { s->set_depth(c.depth()); }},
    {"tangential_displacement", Output::kTangentialDisplacement,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_tangential_displacement(c.tangential_displacement());
     }},
    {"contact_radius", Output::kContactRadius,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_contact_radius(c.contact_radius());
     }},
    {"normal_force", Output::kNormalForce,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_normal_force(c.normal_force());
     }},
    {"tangential_force", Output::kTangentialForce,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_tangential_force(c.tangential_force());
     }},
    {"dissipated_energy", Output::kDissipatedEnergy,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_dissipated_energy(c.dissipated_energy());
     }},
    {"friction_limit", Output::kFrictionLimit,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_friction_limit(c.friction_limit());
     }},
    {"applied_steps", Output::kAppliedSteps,
     [](const Contact&, std::uint64_t applied, v1::ContactState* s) {
       s->set_applied_steps(applied);
     }},
    {"memory_vertices", Output::kMemoryVertices,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_memory_vertices(c.memory().vertex_count());
     }},
    {"actuator_displacement", Output::kActuatorDisplacement,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_actuator_displacement(c.actuator_displacement());
     }},
    {"actuator_depth", Output::kActuatorDepth,
     [](const Contact& c, std::uint64_t, v1::ContactState* s) {
       s->set_actuator_depth(c.actuator_depth());
     }},
    // A tangential contact has no twist (WriteTorsionState writes these).
    {"twist", Output::kTwist, [](const Contact&, std::uint64_t, v1::ContactState*) {}},
    {"twisting_moment", Output::kTwistingMoment,
     [](const Contact&, std::uint64_t, v1::ContactState*) {}},
    {"full_slip_moment", Output::kFullSlipMoment,
     [](const Contact&, std::uint64_t, v1::ContactState*) {}},
};

std::vector<Leaf> StateLeaves() {
  std::vector<Leaf> leaves;
  for (const StateField& field : kStateFields) {
    leaves.push_back({std::string("state.") + field.name, field.output});
  }
  return leaves;
}

const std::vector<Leaf>& StepResultLeaves() {
  static const std::vector<Leaf> leaves = [] {
    std::vector<Leaf> all = StateLeaves();
    all.push_back({"substeps", Output::kSubsteps});
    all.push_back({"path_error", Output::kPathError});
    all.push_back({"dissipated_energy", Output::kStepResultDissipatedEnergy});
    return all;
  }();
  return leaves;
}

const std::vector<Leaf>& QueryResponseLeaves() {
  static const std::vector<Leaf> leaves = [] {
    std::vector<Leaf> all = StateLeaves();
    all.push_back({"tangential_stiffness.positive", Output::kStiffnessPositive});
    all.push_back({"tangential_stiffness.negative", Output::kStiffnessNegative});
    all.push_back({"slip_intervals", Output::kSlipIntervals});
    all.push_back({"springs.tangential_displacement", Output::kSpringTangentialDisplacement});
    all.push_back({"springs.normal_displacement", Output::kSpringNormalDisplacement});
    all.push_back({"memory_pieces", Output::kMemoryPieces});
    all.push_back({"energy.dissipated_energy", Output::kEnergyDissipatedEnergy});
    all.push_back({"energy.last_step_dissipated_energy", Output::kEnergyLastStepDissipatedEnergy});
    all.push_back({"jager_weights", Output::kJagerWeights});
    all.push_back({"jager_decomposition", Output::kJagerDecomposition});
    all.push_back({"tractions", Output::kTractions});
    all.push_back({"pressure", Output::kPressure});
    all.push_back({"compute_seconds", Output::kComputeSeconds});
    all.push_back({"interface.totals", Output::kInterfaceTotals});
    all.push_back({"interface.slip_histogram", Output::kInterfaceSlipHistogram});
    all.push_back({"interface.memory_bytes", Output::kInterfaceMemoryBytes});
    all.push_back({"torsion.stiffness", Output::kTorsionStiffness});
    all.push_back({"torsion.slip_intervals", Output::kTorsionSlipIntervals});
    all.push_back({"torsion.tractions", Output::kTorsionTractions});
    all.push_back({"torsion.memory_pieces", Output::kTorsionMemoryPieces});
    all.push_back({"torsion.stored_energy", Output::kTorsionStoredEnergy});
    return all;
  }();
  return leaves;
}

// "state, substeps, ..." : the top-level paths, for error messages.
std::string TopLevelPaths(const std::vector<Leaf>& leaves) {
  std::vector<std::string> names;
  std::set<std::string> seen;
  for (const Leaf& leaf : leaves) {
    const std::string top = leaf.path.substr(0, leaf.path.find('.'));
    if (seen.insert(top).second) names.push_back(top);
  }
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

// A path selects the leaf it names and every leaf below it.
Result<OutputSelection> Select(const google::protobuf::FieldMask& mask,
                               const std::vector<Leaf>& leaves, const char* mask_field,
                               const char* message_name) {
  OutputSelection selection;
  for (int i = 0; i < mask.paths_size(); ++i) {
    const std::string& path = mask.paths(i);
    bool matched = false;
    for (const Leaf& leaf : leaves) {
      // No string built: a mask is parsed once per message of a stream.
      const bool below = leaf.path.size() > path.size() && leaf.path[path.size()] == '.' &&
                         leaf.path.starts_with(path);
      if (below || leaf.path == path) {
        selection.add(leaf.output);
        matched = true;
      }
    }
    if (!matched) {
      return InvalidArgument(std::string(mask_field) + ".paths[" + std::to_string(i) + "]",
                             Quoted(path) + " is not a field of " + message_name +
                                 "; valid: " + TopLevelPaths(leaves) +
                                 " or one of their fields (e.g. \"state.normal_force\")");
    }
  }
  return selection;
}

void WriteTangentialStiffness(const Contact& contact, const OutputSelection& selection,
                              v1::TangentialStiffness* stiffness) {
  const TangentialStiffness computed = contact.tangential_stiffness();
  if (selection.has(Output::kStiffnessPositive)) stiffness->set_positive(computed.positive);
  if (selection.has(Output::kStiffnessNegative)) stiffness->set_negative(computed.negative);
}

void WriteSlipIntervals(const Contact& contact,
                        google::protobuf::RepeatedPtrField<v1::SlipInterval>* intervals) {
  for (const SlipInterval& interval : contact.slip_intervals()) {
    v1::SlipInterval* out = intervals->Add();
    out->set_r_begin(interval.r_begin);
    out->set_r_end(interval.r_end);
    out->set_direction(interval.direction);
  }
}

void WriteSpringTangentialDisplacements(const Contact& contact, const std::vector<double>& radii,
                                        v1::SpringDisplacements* springs) {
  springs->mutable_tangential_displacement()->Reserve(static_cast<int>(radii.size()));
  for (double radius : radii) {
    springs->add_tangential_displacement(contact.tangential_displacement_at(radius));
  }
}

void WriteSpringNormalDisplacements(const Contact& contact, const std::vector<double>& radii,
                                    v1::SpringDisplacements* springs) {
  springs->mutable_normal_displacement()->Reserve(static_cast<int>(radii.size()));
  for (double radius : radii) {
    springs->add_normal_displacement(contact.normal_displacement_at(radius));
  }
}

void WriteMemoryPieces(const Contact& contact,
                       google::protobuf::RepeatedPtrField<v1::MemoryPiece>* pieces) {
  for (const MemoryPiece& piece : contact.memory_pieces()) {
    v1::MemoryPiece* out = pieces->Add();
    out->set_x_begin(piece.x_begin);
    out->set_x_end(piece.x_end);
    out->set_z_begin(piece.z_begin);
    out->set_z_end(piece.z_end);
    out->set_intercept(piece.intercept);
    out->set_slope(piece.slope);
    out->set_bound(ToProtoBound(piece.bound));
  }
}

Status WriteJagerWeights(const Contact& contact, v1::JagerWeights* weights) {
  if (Status s = RequireExactMethod(contact, "jager_weights"); !s.ok()) return s;
  Result<JagerWeights> computed = ComputeJagerWeights(contact);
  if (!computed.ok()) return ToSceneStatus(computed.status());
  ToProtoJagerWeights(*computed, weights);
  return OkStatus();
}

Status WriteJagerDecomposition(const Contact& contact,
                               google::protobuf::RepeatedPtrField<v1::CattaneoMindlinTerm>* terms) {
  if (Status s = RequireExactMethod(contact, "jager_decomposition"); !s.ok()) return s;
  Result<std::vector<CattaneoMindlinTerm>> computed = DecomposeMemory(contact);
  if (!computed.ok()) return ToSceneStatus(computed.status());
  ToProtoTerms(*computed, terms);
  return OkStatus();
}

Status WriteTractions(const Contact& contact, const RadialSampling& sampling,
                      google::protobuf::RepeatedPtrField<v1::RadialValue>* tractions,
                      v1::ErrorEstimate* estimate) {
  if (Status s = RequireExactMethod(contact, "tractions"); !s.ok()) return s;
  Result<std::vector<RadialValue>> computed =
      ComputeTangentialTraction(contact, sampling.radii, sampling.traction_options);
  if (!computed.ok()) return computed.status();
  estimate->set_traction_error(ToProtoRadialValues(*computed, tractions));
  return OkStatus();
}

Status WritePressure(const Contact& contact, const RadialSampling& sampling,
                     google::protobuf::RepeatedPtrField<v1::RadialValue>* pressure,
                     v1::ErrorEstimate* estimate) {
  Result<std::vector<RadialValue>> computed =
      ComputeNormalPressure(contact, sampling.radii, sampling.traction_options);
  if (!computed.ok()) return computed.status();
  estimate->set_pressure_error(ToProtoRadialValues(*computed, pressure));
  return OkStatus();
}

// The most bytes one RadialValue adds to a response: every field set, plus the repeated field's
// tag and length prefix.
std::size_t MaxRadialValueBytes() {
  constexpr std::size_t kTagAndLengthBytes = 3;
  v1::RadialValue widest;
  widest.set_radius(1);
  widest.set_abel(1);
  widest.set_jager(1);
  widest.set_value(1);
  widest.set_route(v1::TRACTION_ROUTE_JAGER);
  widest.set_error_estimate(1);
  return widest.ByteSizeLong() + kTagAndLengthBytes;
}

std::size_t MaxTorsionTractionBytes() {
  constexpr std::size_t kTagAndLengthBytes = 3;
  v1::TorsionTraction widest;
  widest.set_radius(1);
  widest.set_value(1);
  widest.set_route_difference(1);
  return widest.ByteSizeLong() + kTagAndLengthBytes;
}

// The bytes one radius adds to a response with these radial outputs (packed doubles for the
// springs, a RadialValue for tractions and pressure).
std::size_t BytesPerRadius(const OutputSelection& selection) {
  static const std::size_t radial_value_bytes = MaxRadialValueBytes();
  std::size_t bytes = 0;
  if (selection.has(Output::kSpringTangentialDisplacement)) bytes += sizeof(double);
  if (selection.has(Output::kSpringNormalDisplacement)) bytes += sizeof(double);
  if (selection.has(Output::kTractions)) bytes += radial_value_bytes;
  if (selection.has(Output::kPressure)) bytes += radial_value_bytes;
  if (selection.has(Output::kTorsionTractions)) bytes += MaxTorsionTractionBytes();
  return bytes;
}

}  // namespace

void Count(OutputCounters* counters, Output output) {
  if (counters != nullptr) {
    counters->computed[static_cast<std::size_t>(output)].fetch_add(1, std::memory_order_relaxed);
  }
}

std::size_t MaxRadii(const OutputSelection& selection, int max_message_bytes) {
  // Room for the state, the error estimate and the other small fields of the response.
  constexpr std::size_t kOtherFieldsBytes = 1024;
  const std::size_t per_radius = BytesPerRadius(selection);
  const auto message_bytes = static_cast<std::size_t>(std::max(max_message_bytes, 0));
  if (per_radius == 0) return std::numeric_limits<std::size_t>::max();
  if (message_bytes <= kOtherFieldsBytes) return 0;
  return (message_bytes - kOtherFieldsBytes) / per_radius;
}

Status CheckRadiiCount(int count, const OutputSelection& selection, int max_message_bytes) {
  const std::size_t max_radii = MaxRadii(selection, max_message_bytes);
  if (static_cast<std::size_t>(count) <= max_radii) return OkStatus();
  return InvalidArgument("radii", "at most " + std::to_string(max_radii) +
                                      " radii fit in one response of the selected outputs "
                                      "(--max-message-bytes " +
                                      std::to_string(max_message_bytes) + "), got " +
                                      std::to_string(count) + "; split the request");
}

void WriteApproximationErrors(const Contact& contact, v1::ErrorEstimate* estimate) {
  estimate->set_grid_spacing(contact.grid_spacing());
  estimate->set_profile_tolerance(contact.config().profile->ToleranceEstimate());
}

OutputSelection OutputSelection::FullState() {
  static const OutputSelection full = [] {
    OutputSelection selection;
    for (const StateField& field : kStateFields) selection.add(field.output);
    return selection;
  }();
  return full;
}

bool OutputSelection::any_state() const {
  for (const StateField& field : kStateFields) {
    if (has(field.output)) return true;
  }
  return false;
}

Result<OutputSelection> SelectStepOutputs(const google::protobuf::FieldMask& mask) {
  if (mask.paths_size() == 0) return OutputSelection();
  return Select(mask, StepResultLeaves(), "step_mask", "StepResult");
}

Result<OutputSelection> SelectStateOutputs(const google::protobuf::FieldMask& mask) {
  if (mask.paths_size() == 0) return OutputSelection::FullState();
  // ContactState has no nested fields: a path is a field's name (compared as views, whose
  // lengths are known: a stream parses its mask with every message).
  static const std::vector<std::string_view> kNames = [] {
    std::vector<std::string_view> names;
    for (const StateField& field : kStateFields) names.emplace_back(field.name);
    return names;
  }();
  OutputSelection selection;
  for (int i = 0; i < mask.paths_size(); ++i) {
    const std::string_view path = mask.paths(i);
    const auto named = std::find(kNames.begin(), kNames.end(), path);
    if (named == kNames.end()) {
      std::string valid;
      for (const std::string_view name : kNames) {
        valid += (valid.empty() ? "" : ", ") + std::string(name);
      }
      return InvalidArgument(
          "state_mask.paths[" + std::to_string(i) + "]",
          Quoted(mask.paths(i)) + " is not a field of ContactState; valid: " + valid);
    }
    selection.add(kStateFields[named - kNames.begin()].output);
  }
  return selection;
}

Result<BatchOutputs> SelectBatchOutputs(const v1::ApplyRequest& request) {
  Result<OutputSelection> steps = SelectStepOutputs(request.step_mask());
  if (!steps.ok()) return steps.status();
  Result<OutputSelection> state = SelectStateOutputs(request.state_mask());
  if (!state.ok()) return state.status();
  return BatchOutputs{*steps, *state};
}

Result<OutputSelection> SelectQueryOutputs(const google::protobuf::FieldMask& mask) {
  if (mask.paths_size() == 0) return OutputSelection::FullState();
  return Select(mask, QueryResponseLeaves(), "read_mask", "QueryResponse");
}

void WriteState(const Contact& contact, std::uint64_t applied_steps,
                const OutputSelection& selection, v1::ContactState* state,
                OutputCounters* counters) {
  for (const StateField& field : kStateFields) {
    if (!selection.has(field.output)) continue;
    field.write(contact, applied_steps, state);
    Count(counters, field.output);
  }
}

OutputSelection OutputSelection::KeptState() {
  static const OutputSelection kept = [] {
    OutputSelection selection;
    for (Output output :
         {Output::kDepth, Output::kTangentialDisplacement, Output::kTangentialForce,
          Output::kDissipatedEnergy, Output::kAppliedSteps, Output::kMemoryVertices}) {
      selection.add(output);
    }
    return selection;
  }();
  return kept;
}

KeptState KeepState(const Contact& contact, std::uint64_t applied_steps) {
  return {contact.depth(),
          contact.tangential_displacement(),
          contact.tangential_force(),
          contact.dissipated_energy(),
          applied_steps,
          contact.memory().vertex_count()};
}

void WriteKeptState(const KeptState& kept, const OutputSelection& selection,
                    v1::ContactState* state) {
  if (selection.has(Output::kDepth)) state->set_depth(kept.depth);
  if (selection.has(Output::kTangentialDisplacement)) {
    state->set_tangential_displacement(kept.tangential_displacement);
  }
  if (selection.has(Output::kTangentialForce)) state->set_tangential_force(kept.tangential_force);
  if (selection.has(Output::kDissipatedEnergy)) {
    state->set_dissipated_energy(kept.dissipated_energy);
  }
  if (selection.has(Output::kAppliedSteps)) state->set_applied_steps(kept.applied_steps);
  if (selection.has(Output::kMemoryVertices)) state->set_memory_vertices(kept.memory_vertices);
}

void CopyStateFields(const v1::ContactState& from, const OutputSelection& selection,
                     v1::ContactState* to) {
  using google::protobuf::FieldDescriptor;
  static const std::vector<std::pair<Output, const FieldDescriptor*>> kFields = [] {
    std::vector<std::pair<Output, const FieldDescriptor*>> fields;
    for (const StateField& field : kStateFields) {
      fields.emplace_back(field.output,
                          v1::ContactState::descriptor()->FindFieldByName(field.name));
    }
    return fields;
  }();
  const google::protobuf::Reflection* reflection = from.GetReflection();
  for (const auto& [output, field] : kFields) {
    if (!selection.has(output)) continue;
    if (field->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE) {
      reflection->SetDouble(to, field, reflection->GetDouble(from, field));
    } else {
      reflection->SetUInt64(to, field, reflection->GetUInt64(from, field));
    }
  }
}

// The same expressions as Contact's accessors (contact.cc) on the kept values: bit for bit.
void WriteCompleteState(const ContactConfig& config, const KeptState& kept,
                        v1::ContactState* state) {
  WriteKeptState(kept, OutputSelection::FullState(), state);
  const double normal_force = NormalForceAtDepth(config, kept.depth);
  state->set_contact_radius(ContactRadiusAtDepth(config, kept.depth));
  state->set_normal_force(normal_force);
  state->set_friction_limit(config.friction * normal_force);
  state->set_actuator_displacement(ActuatorPosition(
      config.rig.tangential, kept.tangential_displacement, [&] { return kept.tangential_force; }));
  state->set_actuator_depth(
      ActuatorPosition(config.rig.normal, kept.depth, [&] { return normal_force; }));
}

void WriteStepResult(const Contact& contact, std::uint64_t applied_steps, const StepReport& report,
                     const OutputSelection& selection, v1::StepResult* result) {
  if (selection.any_state()) {
    WriteState(contact, applied_steps, selection, result->mutable_state());
  }
  if (selection.has(Output::kSubsteps)) result->set_substeps(report.substeps);
  if (selection.has(Output::kPathError)) result->set_path_error(report.path_error);
  if (selection.has(Output::kStepResultDissipatedEnergy)) {
    result->set_dissipated_energy(report.dissipated);
  }
}

Status WriteQueryOutputs(const Contact& contact, std::uint64_t applied_steps,
                         const OutputSelection& selection, const RadialSampling& sampling,
                         v1::QueryResponse* response, OutputCounters* counters) {
  const std::vector<double>& radii = sampling.radii;
  if (selection.any_torsion()) {
    return FailedPrecondition("read_mask",
                              "\"torsion.*\" outputs need a torsional session (scene.torsion)");
  }
  if (selection.any_state()) {
    WriteState(contact, applied_steps, selection, response->mutable_state(), counters);
  }
  if (selection.has(Output::kStiffnessPositive) || selection.has(Output::kStiffnessNegative)) {
    WriteTangentialStiffness(contact, selection, response->mutable_tangential_stiffness());
    if (selection.has(Output::kStiffnessPositive)) Count(counters, Output::kStiffnessPositive);
    if (selection.has(Output::kStiffnessNegative)) Count(counters, Output::kStiffnessNegative);
  }
  if (selection.has(Output::kSlipIntervals)) {
    WriteSlipIntervals(contact, response->mutable_slip_intervals());
    Count(counters, Output::kSlipIntervals);
  }
  if (selection.has(Output::kSpringTangentialDisplacement)) {
    WriteSpringTangentialDisplacements(contact, radii, response->mutable_springs());
    Count(counters, Output::kSpringTangentialDisplacement);
  }
  if (selection.has(Output::kSpringNormalDisplacement)) {
    WriteSpringNormalDisplacements(contact, radii, response->mutable_springs());
    Count(counters, Output::kSpringNormalDisplacement);
  }
  if (selection.has(Output::kMemoryPieces)) {
    WriteMemoryPieces(contact, response->mutable_memory_pieces());
    Count(counters, Output::kMemoryPieces);
  }
  if (selection.has(Output::kEnergyDissipatedEnergy)) {
    response->mutable_energy()->set_dissipated_energy(contact.dissipated_energy());
    Count(counters, Output::kEnergyDissipatedEnergy);
  }
  if (selection.has(Output::kEnergyLastStepDissipatedEnergy)) {
    response->mutable_energy()->set_last_step_dissipated_energy(contact.last_step_dissipation());
    Count(counters, Output::kEnergyLastStepDissipatedEnergy);
  }
  if (selection.has(Output::kJagerWeights)) {
    if (Status s = WriteJagerWeights(contact, response->mutable_jager_weights()); !s.ok()) return s;
    Count(counters, Output::kJagerWeights);
  }
  if (selection.has(Output::kJagerDecomposition)) {
    if (Status s = WriteJagerDecomposition(contact, response->mutable_jager_decomposition());
        !s.ok()) {
      return s;
    }
    Count(counters, Output::kJagerDecomposition);
  }
  v1::ErrorEstimate* estimate = response->mutable_error_estimate();
  if (selection.has(Output::kTractions)) {
    if (Status s = WriteTractions(contact, sampling, response->mutable_tractions(), estimate);
        !s.ok()) {
      return s;
    }
    Count(counters, Output::kTractions);
  }
  if (selection.has(Output::kPressure)) {
    if (Status s = WritePressure(contact, sampling, response->mutable_pressure(), estimate);
        !s.ok()) {
      return s;
    }
    Count(counters, Output::kPressure);
  }
  WriteApproximationErrors(contact, estimate);
  return OkStatus();
}

}  // namespace mdr::bridge
