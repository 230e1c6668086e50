// Conversion between the proto messages (mdr.v1) and the physics core. All physical range checks
// are the core's (MakeSphere, ElasticPair, ValidateContactConfig, Contact::Apply,
// Contact::Restore); this layer maps fields and names them by their proto path.
#pragma once

#include <cstddef>

#include "mdr/core/contact.h"
#include "mdr/core/status.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::service {

// Builds and validates the core's configuration. max_memory_vertices is the server's limit: the
// default when scene.options leaves it unset (if below the core's default) and the largest value
// a scene may ask for. Errors name the field from the Scene message down, e.g.
// "scene.sphere.radius" or "scene.options.force_path_tolerance".
Result<ContactConfig> ToContactConfig(const v1::Scene& scene, std::size_t max_memory_vertices);

// The scene with every option spelled out as the config resolved it, so that a snapshot behaves
// the same on a server with other defaults.
v1::Scene WithEffectiveOptions(const v1::Scene& scene, const ContactConfig& config);

// A proto step; an unset channel holds (increment 0). Values are checked by Contact::Apply.
Step ToCoreStep(const v1::Step& step);

// The exact contact state, both ways. Out-of-range bounds map to a tag the core rejects.
ContactSnapshot ToCoreSnapshot(const v1::ContactSnapshot& snapshot);
void ToProtoSnapshot(const ContactSnapshot& snapshot, v1::ContactSnapshot* proto);

v1::MemoryBound ToProtoBound(std::uint8_t tag);

}  // namespace mdr::service
