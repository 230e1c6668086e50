#include "mdr/service/conversion.h"

#include <algorithm>
#include <string>

#include "mdr/core/material.h"
#include "mdr/core/profile.h"

namespace mdr::service {
namespace {

// The core names parameters bare ("radius"); prefix them with their proto path.
template <typename T>
Result<T> Prefixed(Result<T> result, const std::string& path) {
  if (result.ok()) return result;
  return result.status().WithFieldPrefix(path);
}

Result<ProfilePtr> ToProfile(const v1::Scene& scene) {
  switch (scene.profile_case()) {
    case v1::Scene::kSphere:
      return Prefixed(MakeSphere(scene.sphere().radius()), "scene.sphere");
    case v1::Scene::kCone:
      return Prefixed(MakeCone(scene.cone().slope_angle()), "scene.cone");
    case v1::Scene::kPowerLaw:
      return Prefixed(MakePowerLaw(scene.power_law().coefficient(), scene.power_law().exponent()),
                      "scene.power_law");
    case v1::Scene::kFlatPunch:
      return Prefixed(MakeFlatPunch(scene.flat_punch().radius()), "scene.flat_punch");
    case v1::Scene::PROFILE_NOT_SET:
      break;
  }
  return InvalidArgument("scene.profile",
                         "required: set one of sphere, cone, power_law, flat_punch");
}

Result<EffectiveMaterial> ToMaterial(const v1::Scene& scene) {
  switch (scene.material_case()) {
    case v1::Scene::kRigidOnHalfSpace: {
      const v1::RigidOnHalfSpace& m = scene.rigid_on_half_space();
      return Prefixed(RigidOnHalfSpace(m.shear_modulus(), m.poisson_ratio()),
                      "scene.rigid_on_half_space");
    }
    case v1::Scene::kElasticPair: {
      const v1::ElasticPair& m = scene.elastic_pair();
      return Prefixed(ElasticPair(m.youngs_modulus_1(), m.poisson_ratio_1(), m.youngs_modulus_2(),
                                  m.poisson_ratio_2()),
                      "scene.elastic_pair");
    }
    case v1::Scene::MATERIAL_NOT_SET:
      break;
  }
  return InvalidArgument("scene.material",
                         "required: set one of rigid_on_half_space, elastic_pair");
}

// The proto path of a ContactConfig field named by ValidateContactConfig ("friction",
// "force_path_tolerance", ...): numerical options live in scene.options.
std::string ScenePath(const std::string& config_field) {
  if (config_field.starts_with("scene")) return config_field;
  const auto* options = v1::ContactOptions::descriptor();
  const std::string top_level = config_field.substr(0, config_field.find('.'));
  if (options->FindFieldByName(top_level) != nullptr) return "scene.options." + config_field;
  return "scene." + config_field;
}

// Unset options keep the core's defaults; the vertex limit defaults to at most the server's.
Status ApplyOptions(const v1::ContactOptions& options, std::size_t max_memory_vertices,
                    ContactConfig* config) {
  if (options.has_track_energy()) config->track_energy = options.track_energy();
  if (options.has_force_path_tolerance()) {
    config->force_path_tolerance = options.force_path_tolerance();
  }
  config->max_memory_vertices = std::min(config->max_memory_vertices, max_memory_vertices);
  if (options.has_max_memory_vertices()) {
    if (options.max_memory_vertices() > max_memory_vertices) {
      return InvalidArgument("scene.options.max_memory_vertices",
                             "must be <= " + std::to_string(max_memory_vertices) +
                                 " (the server's --max-memory-vertices), got " +
                                 std::to_string(options.max_memory_vertices()));
    }
    config->max_memory_vertices = static_cast<std::size_t>(options.max_memory_vertices());
  }
  return OkStatus();
}

}  // namespace

Result<ContactConfig> ToContactConfig(const v1::Scene& scene, std::size_t max_memory_vertices) {
  Result<ProfilePtr> profile = ToProfile(scene);
  if (!profile.ok()) return profile.status();
  Result<EffectiveMaterial> material = ToMaterial(scene);
  if (!material.ok()) return material.status();

  ContactConfig config;
  config.profile = std::move(profile).value();
  config.material = *material;
  config.friction = scene.friction();
  if (Status status = ApplyOptions(scene.options(), max_memory_vertices, &config); !status.ok()) {
    return status;
  }
  if (Status status = ValidateContactConfig(config); !status.ok()) {
    return Status(status.code(), ScenePath(status.field()), status.message());
  }
  return config;
}

v1::Scene WithEffectiveOptions(const v1::Scene& scene, const ContactConfig& config) {
  v1::Scene effective = scene;
  v1::ContactOptions* options = effective.mutable_options();
  options->set_track_energy(config.track_energy);
  options->set_force_path_tolerance(config.force_path_tolerance);
  options->set_max_memory_vertices(config.max_memory_vertices);
  return effective;
}

Step ToCoreStep(const v1::Step& step) {
  Step core;  // defaults: both channels hold (increment 0)
  switch (step.normal_case()) {
    case v1::Step::kDepth:
      core.normal = NormalControl::kDepth;
      core.normal_value = step.depth();
      break;
    case v1::Step::kDepthIncrement:
      core.normal = NormalControl::kDepthIncrement;
      core.normal_value = step.depth_increment();
      break;
    case v1::Step::kNormalForce:
      core.normal = NormalControl::kForce;
      core.normal_value = step.normal_force();
      break;
    case v1::Step::NORMAL_NOT_SET:
      break;
  }
  switch (step.tangential_case()) {
    case v1::Step::kDisplacement:
      core.tangential = TangentialControl::kDisplacement;
      core.tangential_value = step.displacement();
      break;
    case v1::Step::kDisplacementIncrement:
      core.tangential = TangentialControl::kDisplacementIncrement;
      core.tangential_value = step.displacement_increment();
      break;
    case v1::Step::kTangentialForce:
      core.tangential = TangentialControl::kForce;
      core.tangential_value = step.tangential_force();
      break;
    case v1::Step::TANGENTIAL_NOT_SET:
      break;
  }
  return core;
}

ContactSnapshot ToCoreSnapshot(const v1::ContactSnapshot& snapshot) {
  constexpr std::uint8_t kRejectedTag = 0xFF;  // the core accepts tags 0..3 only
  ContactSnapshot core;
  core.depth = snapshot.depth();
  core.tangential_displacement = snapshot.tangential_displacement();
  core.dissipated_energy = snapshot.dissipated_energy();
  core.last_step_dissipation = snapshot.last_step_dissipated_energy();
  const int n = snapshot.memory_size();
  core.z.reserve(n);
  core.u.reserve(n);
  core.tags.reserve(n);
  for (const v1::MemoryVertex& vertex : snapshot.memory()) {
    core.z.push_back(vertex.z());
    core.u.push_back(vertex.u());
    const int bound = vertex.bound();
    core.tags.push_back(bound >= 0 && bound <= kOnBoth ? static_cast<std::uint8_t>(bound)
                                                       : kRejectedTag);
  }
  return core;
}

void ToProtoSnapshot(const ContactSnapshot& snapshot, v1::ContactSnapshot* proto) {
  proto->set_depth(snapshot.depth);
  proto->set_tangential_displacement(snapshot.tangential_displacement);
  proto->set_dissipated_energy(snapshot.dissipated_energy);
  proto->set_last_step_dissipated_energy(snapshot.last_step_dissipation);
  proto->mutable_memory()->Reserve(static_cast<int>(snapshot.z.size()));
  for (std::size_t i = 0; i < snapshot.z.size(); ++i) {
    v1::MemoryVertex* vertex = proto->add_memory();
    vertex->set_z(snapshot.z[i]);
    vertex->set_u(snapshot.u[i]);
    vertex->set_bound(ToProtoBound(snapshot.tags[i]));
  }
}

v1::MemoryBound ToProtoBound(std::uint8_t tag) {
  switch (tag) {
    case kOnUpper:
      return v1::MEMORY_BOUND_UPPER;
    case kOnLower:
      return v1::MEMORY_BOUND_LOWER;
    case kOnBoth:
      return v1::MEMORY_BOUND_BOTH;
    default:
      return v1::MEMORY_BOUND_INSIDE;
  }
}

}  // namespace mdr::service
