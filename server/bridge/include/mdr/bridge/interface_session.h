// Interface sessions (scene.interface set; docs/interfaces.md, "Through the service"): the proto
// form of the core's mdr::Interface. A scene with an interface is built from the scene's contact
// config (material, friction, options, validated by ToContactConfig) and its population; steps,
// snapshots and outputs are mapped here so that Session stays one class for both kinds.
#pragma once

#include <cstdint>
#include <optional>

#include "mdr/base/status.h"
#include "mdr/bridge/outputs.h"
#include "mdr/bridge/state_budget.h"
#include "mdr/core/contact.h"
#include "mdr/core/interface.h"
#include "mdr/core/interrupt.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::bridge {

// The interface a scene with scene.interface describes: Hertz spheres of base's material,
// friction and options. Errors name the field from the Scene down ("scene.interface.kind",
// "scene.interface.generated.count", "scene.interface.explicit_list.radii[3]", "scene.method").
Result<Interface> CreateInterface(const v1::Scene& scene, const ContactConfig& base);
// Checked before anything of an interface is built, so that a client's count cannot make the
// server allocate beyond its limits first: RESOURCE_EXHAUSTED (field ".generated.count" or
// ".explicit_list.heights" under scene.interface) when count fresh contacts would already hold
// more than the room left (room.bytes 0: no limit; the error names room's budget and flag) or could
// not be exported within max_message_bytes (an empty contact snapshot costs 2 bytes). A fresh
// contact's bytes come from probes of one and two contacts (their difference).
Status CheckInterfaceSize(const v1::Scene& scene, const ContactConfig& base, const StateRoom& room,
                          int max_message_bytes);
// An interface restored from a snapshot's state; errors name "interface.contacts[i]..." (relative
// to the snapshot) or the scene's fields as CreateInterface.
Result<Interface> RestoreInterface(const v1::Scene& scene, const ContactConfig& base,
                                   const v1::InterfaceSnapshot& snapshot);
void ToProtoInterfaceSnapshot(const Interface& interface, v1::InterfaceSnapshot* proto);

// One step of an interface session (Interface::Apply for shared motion, ApplyEach with the
// step's per-contact values for a contact list). Errors name fields of the Step; gate: the
// core's commit gate (Interface::CommitGate), whose error is returned as it is.
Status ApplyInterfaceStep(Interface& interface, const v1::Step& step, const Interrupt& interrupt,
                          const Interface::CommitGate& gate = {});
// Whether the step moves every contact exactly once (BoundsAfterOneMove applies): any step of a
// shared motion, a contact list's step without force targets.
bool MovesEveryContactOnce(const Interface& interface, const v1::Step& step);
// A single-contact session's step must not carry per-contact values.
Status CheckSingleContactStep(const v1::Step& step);

// The interface's ContactState (QueryResponse.InterfaceOutputs documents the fields); only the
// selected fields are computed.
void WriteInterfaceState(const Interface& interface, std::uint64_t applied_steps,
                         const OutputSelection& selection, v1::ContactState* state);
// A StepResult of an interface step: state as above, substeps 1, path_error 0, the step's
// dissipated energy.
void WriteInterfaceStepResult(const Interface& interface, std::uint64_t applied_steps,
                              const OutputSelection& selection, v1::StepResult* result);

// What a Query asks of an interface session beyond the read mask.
struct InterfaceQuery {
  std::optional<std::uint64_t> contact_index;
  int slip_histogram_bins = 0;
};
// The selected outputs of an interface session; ordinary paths other than "state" need
// contact_index (whose contact answers them as a single session).
Status WriteInterfaceQueryOutputs(const Interface& interface, std::uint64_t applied_steps,
                                  const OutputSelection& selection, const RadialSampling& sampling,
                                  const InterfaceQuery& query, v1::QueryResponse* response,
                                  OutputCounters* counters);
// A single session refuses interface outputs and contact_index.
Status CheckSingleContactQuery(const OutputSelection& selection, const InterfaceQuery& query);

}  // namespace mdr::bridge
