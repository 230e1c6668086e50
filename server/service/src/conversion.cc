#include "mdr/service/conversion.h"

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

// Unset options keep the core's defaults.
void ApplyOptions(const v1::ContactOptions& options, ContactConfig* config) {
  if (options.has_track_energy()) config->track_energy = options.track_energy();
  if (options.has_force_path_tolerance()) {
    config->force_path_tolerance = options.force_path_tolerance();
  }
  if (options.has_max_memory_vertices()) {
    config->max_memory_vertices = static_cast<std::size_t>(options.max_memory_vertices());
  }
}

}  // namespace

Result<ContactConfig> ToContactConfig(const v1::Scene& scene) {
  Result<ProfilePtr> profile = ToProfile(scene);
  if (!profile.ok()) return profile.status();
  Result<EffectiveMaterial> material = ToMaterial(scene);
  if (!material.ok()) return material.status();

  ContactConfig config;
  config.profile = std::move(profile).value();
  config.material = *material;
  config.friction = scene.friction();
  ApplyOptions(scene.options(), &config);
  if (Status status = ValidateContactConfig(config); !status.ok()) {
    return Status(status.code(), ScenePath(status.field()), status.message());
  }
  return config;
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

void ToProtoState(const Contact& contact, std::uint64_t applied_steps, v1::ContactState* state) {
  state->set_depth(contact.depth());
  state->set_tangential_displacement(contact.tangential_displacement());
  state->set_contact_radius(contact.contact_radius());
  state->set_normal_force(contact.normal_force());
  state->set_tangential_force(contact.tangential_force());
  state->set_dissipated_energy(contact.dissipated_energy());
  state->set_friction_limit(contact.friction_limit());
  state->set_applied_steps(applied_steps);
  state->set_memory_vertices(contact.memory().vertex_count());
}

void ToProtoStepResult(const Contact& contact, std::uint64_t applied_steps,
                       const StepReport& report, v1::StepResult* result) {
  ToProtoState(contact, applied_steps, result->mutable_state());
  result->set_substeps(report.substeps);
  result->set_path_error(report.path_error);
  result->set_dissipated_energy(report.dissipated);
}

}  // namespace mdr::service
