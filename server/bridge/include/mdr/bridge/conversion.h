// Conversion between the proto messages (mdr.v1) and the physics core. All physical range checks
// are the core's (MakeSphere, ElasticPair, ValidateContactConfig, Contact::Apply,
// Contact::Restore); this layer maps fields and names them by their proto path.
#pragma once

#include <google/protobuf/repeated_field.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/jager.h"
#include "mdr/core/memory.h"
#include "mdr/core/sampled_weight.h"
#include "mdr/core/traction.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::bridge {

// Where the radial outputs (springs, tractions, pressure) are evaluated, validated.
struct RadialSampling {
  std::vector<double> radii;  // m, finite, >= 0
  TractionOptions traction_options;
};

// The largest scene.options.max_memory_vertices a scene may ask for unless a server sets a lower
// limit (mdrd --max-memory-vertices); the C library's limit.
inline constexpr std::size_t kDefaultMaxMemoryVertices = std::size_t{1} << 20;

// Builds and validates the core's configuration. max_memory_vertices is the server's limit: the
// default when scene.options leaves it unset (if below the core's default) and the largest value
// a scene may ask for. Errors name the field from the Scene message down, e.g.
// "scene.sphere.radius" or "scene.options.force_path_tolerance". interrupt stops a long profile
// construction (a tabulated profile).
Result<ContactConfig> ToContactConfig(const v1::Scene& scene, std::size_t max_memory_vertices,
                                      const Interrupt& interrupt = {});

// A core error whose field names a ContactConfig member ("friction", "grid_size") renamed to its
// Scene path ("scene.friction", "scene.grid.size"); other statuses unchanged.
Status ToSceneStatus(const Status& status);

// The scene with every option spelled out as the config resolved it, so that a snapshot behaves
// the same on a server with other defaults.
v1::Scene WithEffectiveOptions(const v1::Scene& scene, const ContactConfig& config);

// A proto step; an unset channel holds (increment 0). Values are checked by Contact::Apply.
Step ToCoreStep(const v1::Step& step);

// The exact contact state, both ways. Out-of-range bounds map to a tag the core rejects; packed
// grid anchors whose values do not line up with their bytes are refused (InvalidArgument naming
// grid_anchor_displacements or grid_anchor_depths, relative to the ContactSnapshot).
Result<ContactSnapshot> ToCoreSnapshot(const v1::ContactSnapshot& snapshot);
// The SessionSnapshot format that every export writes (the service's and the C library's) and
// every import reads.
inline constexpr std::uint32_t kSnapshotVersion = 1;
// Most steps a session applies in its life (applied_steps stays exact in a double and far from
// wrapping); a step beyond fails with FAILED_PRECONDITION.
inline constexpr std::uint64_t kMaxAppliedSteps = std::uint64_t{1} << 53;
// What a SessionSnapshot carries beyond the contact, which Contact::Restore checks (its
// dissipated_energy included): snapshot.version == kSnapshotVersion,
// snapshot.contact.last_step_dissipated_energy finite and >= 0, and snapshot.applied_steps <=
// kMaxAppliedSteps so that the step counter cannot wrap later.
Status CheckSnapshotHeader(const v1::SessionSnapshot& snapshot);
// The contact of a SessionSnapshot (ImportSession, the journal and the C library restore with it):
// the scene's config (max_memory_vertices as for ToContactConfig), the state in the member of the
// scene's kind and method, at most the config's vertices, then Contact::Restore. The counters and
// the version are the caller's to check (CheckSnapshotHeader). For an interface or torsional scene
// the contact is the unloaded one of its scene. Errors name "snapshot.<field>".
Result<Contact> ToCoreContact(const v1::SessionSnapshot& snapshot, std::size_t max_memory_vertices,
                              const Interrupt& interrupt = {});
void ToProtoSnapshot(const ContactSnapshot& snapshot, v1::ContactSnapshot* proto);

v1::MemoryBound ToProtoBound(std::uint8_t tag);
void ToProtoMemory(const PiecewiseLinearMemory& memory,
                   google::protobuf::RepeatedPtrField<v1::MemoryVertex>* vertices);

// The core's traction options for a route; an unknown enum value is INVALID_ARGUMENT (field).
Result<TractionOptions> ToTractionOptions(v1::TractionRoute route, const std::string& field);
// Radii (each finite and >= 0, field "radii[i]") and route (field "traction_route") of a
// request's radial outputs.
Result<RadialSampling> ToRadialSampling(const google::protobuf::RepeatedField<double>& radii,
                                        v1::TractionRoute route);
// Appends the values and returns the largest error estimate among them (0 for none).
double ToProtoRadialValues(const std::vector<RadialValue>& values,
                           google::protobuf::RepeatedPtrField<v1::RadialValue>* proto);

void ToProtoJagerWeights(const JagerWeights& weights, v1::JagerWeights* proto);
void ToProtoTerms(const std::vector<CattaneoMindlinTerm>& terms,
                  google::protobuf::RepeatedPtrField<v1::CattaneoMindlinTerm>* proto);
// The terms of a superposition by the coordinates it names (depths: a and c from g^-1; radii:
// depths from g). Errors name "terms[i].a" etc. (relative to the superposition) or "coordinates";
// depth ranges are MemoryFromTerms' to check.
Result<std::vector<CattaneoMindlinTerm>> ToCoreTerms(
    const v1::CattaneoMindlinSuperposition& superposition, const Profile& profile);
void ToProtoSampledWeight(const SampledWeight& weight, v1::SampledWeight* proto);

}  // namespace mdr::bridge
