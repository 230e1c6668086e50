// Torsional sessions (scene.torsion set; docs/physics.md, "Torsion"): the proto form of the core's
// mdr::TorsionalContact. Built from the scene's contact config (profile, material, friction,
// options, validated by ToContactConfig) and the torsional modulus of the scene's material;
// steps, snapshots and outputs are mapped here so that Session stays one class for every kind.
#pragma once

#include <cstddef>
#include <cstdint>

#include "mdr/analysis/exact_loops.h"
#include "mdr/base/status.h"
#include "mdr/bridge/outputs.h"
#include "mdr/core/contact.h"
#include "mdr/core/torsion.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::bridge {

// What scene.torsion needs besides a valid contact config: a single contact (no interface),
// METHOD_EXACT, no rig. Errors name the Scene field ("scene.interface", "scene.method",
// "scene.rig"); OK for a scene without torsion.
Status CheckTorsionScene(const v1::Scene& scene);

// The torsional scene of the loop analysis (exact torsional loops, backbones, fits) from a scene
// with scene.torsion and its contact config (ToContactConfig passed): the profile, friction, E*,
// G_t of the material and scene.torsion.rig_compliance (finite, >= 0). A flat punch is refused as
// for sessions. Errors name the Scene's fields.
Result<analysis::TorsionalScene> ToTorsionalScene(const v1::Scene& scene,
                                                  const ContactConfig& config);

// The torsional contact of a scene with scene.torsion (CheckTorsionScene passed), unloaded at
// twist 0. Errors name the Scene field (a flat punch: "scene.flat_punch", friction 0:
// "scene.friction").
Result<TorsionalContact> CreateTorsionalContact(const v1::Scene& scene,
                                                const ContactConfig& config);
// The contact of a snapshot's torsion state; errors name "torsion.<field>" (relative to the
// snapshot), e.g. "torsion.pieces[2].radius".
Result<TorsionalContact> RestoreTorsionalContact(const v1::Scene& scene,
                                                 const ContactConfig& config,
                                                 const v1::TorsionSnapshot& snapshot);
void ToProtoTorsionSnapshot(const TorsionalContact& contact, v1::TorsionSnapshot* proto);

// One step of a torsional session: the normal channel or the twist. A tangential channel or
// per-contact values are refused (INVALID_ARGUMENT naming them), a memory beyond
// max_memory_pieces is RESOURCE_EXHAUSTED; errors name fields of the Step. On an error the
// contact may have changed only if the core's step succeeded and the piece limit refused it: the
// caller runs steps on a copy.
Status ApplyTorsionStep(TorsionalContact& contact, const v1::Step& step,
                        std::size_t max_memory_pieces);
// A session that is not torsional refuses a step with a twist (INVALID_ARGUMENT naming it).
Status RefuseTwist(const v1::Step& step);

// The bytes a torsional session holds (its profile and memory) and a bound of its export.
std::size_t StateBytes(const TorsionalContact& contact);
std::size_t ExportBytesBound(const TorsionalContact& contact, std::size_t scene_bytes);

// The selected ContactState fields of a torsional contact: depth, contact radius, normal force,
// dissipated energy, friction limit, counters, the twist, moment and full-slip moment; the
// tangential fields are 0 and the actuator's depth is the contact's (no rig).
void WriteTorsionState(const TorsionalContact& contact, double friction,
                       std::uint64_t applied_steps, const OutputSelection& selection,
                       v1::ContactState* state);
// A StepResult of a torsional step: state as above, substeps 1, path_error 0 (every step is
// exact) and the step's dissipated energy.
void WriteTorsionStepResult(const TorsionalContact& contact, double friction,
                            std::uint64_t applied_steps, const OutputSelection& selection,
                            v1::StepResult* result);
// The selected outputs of a torsional session: state, energy and the torsion.* outputs. The
// tangential outputs (tangential_stiffness, slip_intervals, springs, memory_pieces, jager_*,
// tractions) and the pressure are FAILED_PRECONDITION naming read_mask.
Status WriteTorsionQueryOutputs(const TorsionalContact& contact, const ContactConfig& config,
                                std::uint64_t applied_steps, const OutputSelection& selection,
                                const RadialSampling& sampling, v1::QueryResponse* response,
                                OutputCounters* counters);

}  // namespace mdr::bridge
