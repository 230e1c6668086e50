// Conversion between the proto messages (mdr.v1) and the physics core. All range checks are the
// core's (MakeSphere, ElasticPair, ValidateContactConfig, Contact::Apply); this layer only maps
// fields and names them by their proto path.
#pragma once

#include <cstdint>

#include "mdr/core/contact.h"
#include "mdr/core/status.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::service {

// Builds and validates the core's configuration. Errors name the field from the Scene message
// down, e.g. "scene.sphere.radius" or "scene.options.force_path_tolerance".
Result<ContactConfig> ToContactConfig(const v1::Scene& scene);

// A proto step; an unset channel holds (increment 0). Values are checked by Contact::Apply.
Step ToCoreStep(const v1::Step& step);

// The observable state of a contact.
void ToProtoState(const Contact& contact, std::uint64_t applied_steps, v1::ContactState* state);

void ToProtoStepResult(const Contact& contact, std::uint64_t applied_steps,
                       const StepReport& report, v1::StepResult* result);

}  // namespace mdr::service
