// Output selection: which fields of a StepResult or QueryResponse a request asked for (its field
// mask), and one function per output that computes it. Only selected outputs are computed: a
// query for state.normal_force never evaluates the memory pieces, slip zones or spring samples.
#pragma once

#include <google/protobuf/field_mask.pb.h>
#include <google/protobuf/repeated_field.h>

#include <array>
#include <atomic>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/bridge/conversion.h"
#include "mdr/core/contact.h"
#include "mdr/core/traction.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::bridge {

// The leaves a field mask can select.
enum class Output : std::uint8_t {
  // ContactState (StepResult.state and QueryResponse.state).
  kDepth,
  kTangentialDisplacement,
  kContactRadius,
  kNormalForce,
  kTangentialForce,
  kDissipatedEnergy,
  kFrictionLimit,
  kAppliedSteps,
  kMemoryVertices,
  kActuatorDisplacement,
  kActuatorDepth,
  kTwist,
  kTwistingMoment,
  kFullSlipMoment,
  // StepResult.
  kSubsteps,
  kPathError,
  kStepResultDissipatedEnergy,
  // QueryResponse.
  kStiffnessPositive,
  kStiffnessNegative,
  kSlipIntervals,
  kSpringTangentialDisplacement,
  kSpringNormalDisplacement,
  kMemoryPieces,
  kEnergyDissipatedEnergy,
  kEnergyLastStepDissipatedEnergy,
  kJagerWeights,
  kJagerDecomposition,
  kTractions,
  kPressure,
  kComputeSeconds,
  // QueryResponse.interface (interface sessions).
  kInterfaceTotals,
  kInterfaceSlipHistogram,
  kInterfaceMemoryBytes,
  // QueryResponse.torsion (torsional sessions).
  kTorsionStiffness,
  kTorsionSlipIntervals,
  kTorsionTractions,
  kTorsionMemoryPieces,
  kTorsionStoredEnergy,
  kCount,
};
constexpr std::size_t kOutputCount = static_cast<std::size_t>(Output::kCount);

class OutputSelection {
 public:
  // Every ContactState field.
  static OutputSelection FullState();
  // The ContactState fields a single contact's session keeps for GetSession after every batch:
  // those that need the contact's memory or counters. The others follow from them and the
  // session's config (WriteCompleteState), computed only when they are read.
  static OutputSelection KeptState();

  bool has(Output output) const { return bits_.test(static_cast<std::size_t>(output)); }
  void add(Output output) { bits_.set(static_cast<std::size_t>(output)); }
  bool empty() const { return bits_.none(); }
  // The outputs selected here and not in other.
  OutputSelection Without(const OutputSelection& other) const {
    OutputSelection rest;
    rest.bits_ = bits_ & ~other.bits_;
    return rest;
  }
  bool any_state() const;
  bool any_springs() const {
    return has(Output::kSpringTangentialDisplacement) || has(Output::kSpringNormalDisplacement);
  }
  // Springs, tractions or pressure: outputs sampled at QueryRequest.radii.
  bool any_radial() const {
    return any_springs() || has(Output::kTractions) || has(Output::kPressure) ||
           has(Output::kTorsionTractions);
  }
  // The QueryResponse.torsion outputs.
  bool any_torsion() const {
    return has(Output::kTorsionStiffness) || has(Output::kTorsionSlipIntervals) ||
           has(Output::kTorsionTractions) || has(Output::kTorsionMemoryPieces) ||
           has(Output::kTorsionStoredEnergy);
  }
  // The outputs of a tangential contact beyond its state and energy (what a torsional session
  // does not have).
  bool any_tangential() const {
    return has(Output::kStiffnessPositive) || has(Output::kStiffnessNegative) ||
           has(Output::kSlipIntervals) || any_springs() || has(Output::kMemoryPieces) ||
           has(Output::kJagerWeights) || has(Output::kJagerDecomposition) ||
           has(Output::kTractions) || has(Output::kPressure);
  }
  bool any_interface() const {
    return has(Output::kInterfaceTotals) || has(Output::kInterfaceSlipHistogram) ||
           has(Output::kInterfaceMemoryBytes);
  }

 private:
  std::bitset<kOutputCount> bits_;
};

// The outputs named by ApplyRequest.step_mask (paths of StepResult); empty mask: none. Errors
// name "step_mask.paths[i]" and list the valid paths.
Result<OutputSelection> SelectStepOutputs(const google::protobuf::FieldMask& mask);
// The outputs named by ApplyRequest.state_mask (paths of ContactState); empty mask: every field.
// Errors name "state_mask.paths[i]".
Result<OutputSelection> SelectStateOutputs(const google::protobuf::FieldMask& mask);

// What an Apply batch answers: the per-step results (step_mask) and the final state's fields
// (state_mask).
struct BatchOutputs {
  OutputSelection steps;
  OutputSelection state = OutputSelection::FullState();
};
Result<BatchOutputs> SelectBatchOutputs(const v1::ApplyRequest& request);

// The outputs named by QueryRequest.read_mask (paths of QueryResponse); empty mask: "state".
// Errors name "read_mask.paths[i]".
Result<OutputSelection> SelectQueryOutputs(const google::protobuf::FieldMask& mask);

// Test hook: how often each output was computed (Query outputs; per-step outputs are not counted).
struct OutputCounters {
  std::array<std::atomic<std::uint64_t>, kOutputCount> computed{};
  std::uint64_t operator[](Output output) const {
    return computed[static_cast<std::size_t>(output)].load();
  }
};

// Counts one computation of output (no-op without counters).
void Count(OutputCounters* counters, Output output);

// The most radii whose selected radial outputs (springs, tractions, pressure) fit in a response
// of max_message_bytes; no limit (SIZE_MAX) when none is selected. Derived from the encoded size
// of the outputs, so a request within it never fails for the size of its response.
std::size_t MaxRadii(const OutputSelection& selection, int max_message_bytes);
// INVALID_ARGUMENT naming "radii" and MaxRadii when count exceeds it; checked before any work.
Status CheckRadiiCount(int count, const OutputSelection& selection, int max_message_bytes);

// The error estimates of the scene's approximations: ErrorEstimate.grid_spacing of the grid
// method and profile_tolerance of a tabulated profile.
void WriteApproximationErrors(const Contact& contact, v1::ErrorEstimate* estimate);

// The selected ContactState fields (nothing else is evaluated).
void WriteState(const Contact& contact, std::uint64_t applied_steps,
                const OutputSelection& selection, v1::ContactState* state,
                OutputCounters* counters = nullptr);

// Copies the selected ContactState fields of from into *to (of a state computed once).
void CopyStateFields(const v1::ContactState& from, const OutputSelection& selection,
                     v1::ContactState* to);

// The values of OutputSelection::KeptState, as a single contact's session keeps them after every
// batch for GetSession (a plain struct: copied under a lock with every message).
struct KeptState {
  double depth = 0, tangential_displacement = 0, tangential_force = 0, dissipated_energy = 0;
  std::uint64_t applied_steps = 0, memory_vertices = 0;
};
KeptState KeepState(const Contact& contact, std::uint64_t applied_steps);
// The selected fields of OutputSelection::KeptState, from kept.
void WriteKeptState(const KeptState& kept, const OutputSelection& selection,
                    v1::ContactState* state);
// Every ContactState field: the kept ones, and those that follow from them and the contact's
// config (contact radius, normal force, friction limit, actuator position), bit for bit as
// WriteState writes them from the contact.
void WriteCompleteState(const ContactConfig& config, const KeptState& kept,
                        v1::ContactState* state);

void WriteStepResult(const Contact& contact, std::uint64_t applied_steps, const StepReport& report,
                     const OutputSelection& selection, v1::StepResult* result);

// The selected QueryResponse outputs and error_estimate, except compute_seconds. Fails
// (FAILED_PRECONDITION) when a selected output does not exist for this contact: Jäger weights,
// decomposition and tractions for the grid method, weights and decomposition for friction 0.
Status WriteQueryOutputs(const Contact& contact, std::uint64_t applied_steps,
                         const OutputSelection& selection, const RadialSampling& sampling,
                         v1::QueryResponse* response, OutputCounters* counters);

}  // namespace mdr::bridge
