#include "mdr/bridge/conversion.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mdr/base/validate.h"
#include "mdr/core/material.h"
#include "mdr/core/profile.h"
#include "mdr/core/tabulated_profile.h"

namespace mdr::bridge {
namespace {

// The core names parameters bare ("radius"); prefix them with their proto path.
template <typename T>
Result<T> Prefixed(Result<T> result, const std::string& path) {
  if (result.ok()) return result;
  return result.status().WithFieldPrefix(path);
}

Result<TabulatedOptions::Interpolation> ToInterpolation(
    v1::TabulatedProfile::Interpolation interpolation) {
  switch (interpolation) {
    case v1::TabulatedProfile::INTERPOLATION_UNSPECIFIED:
    case v1::TabulatedProfile::INTERPOLATION_STEFFEN:
      return TabulatedOptions::Interpolation::kSteffen;
    case v1::TabulatedProfile::INTERPOLATION_CUBIC_SPLINE:
      return TabulatedOptions::Interpolation::kCubicSpline;
    default:
      break;
  }
  return InvalidArgument("interpolation",
                         "must be INTERPOLATION_STEFFEN or "
                         "INTERPOLATION_CUBIC_SPLINE, got " +
                             std::to_string(interpolation));
}

Result<ProfilePtr> ToTabulatedProfile(const v1::TabulatedProfile& tabulated,
                                      const Interrupt& interrupt) {
  Result<TabulatedOptions::Interpolation> interpolation =
      ToInterpolation(tabulated.interpolation());
  if (!interpolation.ok()) return interpolation.status();
  TabulatedOptions options;
  options.interpolation = *interpolation;
  if (tabulated.has_tolerance()) options.tolerance = tabulated.tolerance();
  options.interrupt = interrupt;
  Result<ProfilePtr> profile =
      MakeTabulatedProfile({tabulated.radii().begin(), tabulated.radii().end()},
                           {tabulated.heights().begin(), tabulated.heights().end()}, options);
  // The internal grid's node limit is reached by asking for too small a tolerance.
  if (!profile.ok() && profile.status().field() == "max_grid_nodes") {
    return Status(profile.status().code(), "tolerance", profile.status().message());
  }
  return profile;
}

Result<ProfilePtr> ToProfile(const v1::Scene& scene, const Interrupt& interrupt) {
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
    case v1::Scene::kTabulated:
      return Prefixed(ToTabulatedProfile(scene.tabulated(), interrupt), "scene.tabulated");
    case v1::Scene::PROFILE_NOT_SET:
      break;
  }
  return InvalidArgument("scene.profile",
                         "required: set one of sphere, cone, power_law, flat_punch, tabulated");
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

// The proto path of a ContactConfig field named by the core ("friction",
// "force_path_tolerance", "grid_size", ...): numerical options live in scene.options, the grid
// settings in scene.grid.
std::string ScenePath(const std::string& config_field) {
  if (config_field.starts_with("scene")) return config_field;
  if (config_field == "grid_size") return "scene.grid.size";
  if (config_field == "grid_max_radius") return "scene.grid.max_radius";
  const auto* options = v1::ContactOptions::descriptor();
  const std::string top_level = config_field.substr(0, config_field.find('.'));
  if (options->FindFieldByName(top_level) != nullptr) return "scene.options." + config_field;
  return "scene." + config_field;
}

// The core checks the effective moduli ("material.e_star", "material.g_star") it was given; they
// are derived, not request fields, so such an error names the material the request set. (The
// moduli's own range keeps them finite and positive, so this is a safety net.)
Status NamedAsInRequest(const Status& status, const v1::Scene& scene) {
  if (!status.field().starts_with("material.")) return status;
  const std::string material = scene.material_case() == v1::Scene::kElasticPair
                                   ? "scene.elastic_pair"
                                   : "scene.rigid_on_half_space";
  return Status(status.code(), material,
                "the effective " + status.field().substr(std::string("material.").size()) +
                    " derived from these moduli " + status.message());
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

Status ApplyMethod(const v1::Scene& scene, ContactConfig* config) {
  switch (scene.method()) {
    case v1::METHOD_UNSPECIFIED:
    case v1::METHOD_EXACT:
      config->method = Method::kExact;
      break;
    case v1::METHOD_GRID:
      config->method = Method::kGrid;
      break;
    default:
      return InvalidArgument("scene.method", "must be METHOD_EXACT or METHOD_GRID, got " +
                                                 std::to_string(scene.method()));
  }
  const v1::GridSettings& grid = scene.grid();
  if (grid.size() != 0) config->grid_size = grid.size();
  config->grid_max_radius = grid.max_radius();
  switch (grid.step_rule()) {
    case v1::GRID_STEP_RULE_UNSPECIFIED:
    case v1::GRID_STEP_RULE_EXACT:
      config->grid_step_rule = GridStepRule::kExact;
      break;
    case v1::GRID_STEP_RULE_NAIVE:
      config->grid_step_rule = GridStepRule::kNaive;
      break;
    default:
      return InvalidArgument("scene.grid.step_rule",
                             "must be GRID_STEP_RULE_EXACT or GRID_STEP_RULE_NAIVE, got " +
                                 std::to_string(grid.step_rule()));
  }
  return OkStatus();
}

// A MemoryBound as the core's tag; values beyond BOTH become one the core refuses.
std::uint8_t ToCoreTag(int bound) {
  constexpr std::uint8_t kRejectedTag = 0xFF;  // the core accepts tags 0..3 only
  return bound >= 0 && bound <= kOnBoth ? static_cast<std::uint8_t>(bound) : kRejectedTag;
}

SegmentAnchor ToCoreAnchor(const v1::MemoryAnchor& anchor) {
  return {static_cast<BoundTag>(ToCoreTag(anchor.bound())), anchor.tangential_displacement(),
          anchor.depth()};
}

void ToProtoAnchor(const SegmentAnchor& anchor, v1::MemoryAnchor* proto) {
  proto->set_bound(ToProtoBound(anchor.bound));
  proto->set_tangential_displacement(anchor.tangential_displacement);
  proto->set_depth(anchor.depth);
}

// The grid's anchors, packed (ContactSnapshot.grid_anchor_*): a byte per spring, and the values
// of the anchored ones in order.
void ToProtoGridAnchors(const std::vector<SegmentAnchor>& anchors, v1::ContactSnapshot* proto) {
  if (anchors.empty()) return;
  std::string* bounds = proto->mutable_grid_anchor_bounds();
  bounds->reserve(anchors.size());
  for (const SegmentAnchor& anchor : anchors) {
    bounds->push_back(static_cast<char>(anchor.bound));
    if (anchor.bound == kInside) continue;
    proto->add_grid_anchor_displacements(anchor.tangential_displacement);
    proto->add_grid_anchor_depths(anchor.depth);
  }
}

// The inverse: values for exactly the anchored springs.
Result<std::vector<SegmentAnchor>> ToCoreGridAnchors(const v1::ContactSnapshot& snapshot) {
  const std::string& bounds = snapshot.grid_anchor_bounds();
  const auto anchored = static_cast<int>(
      std::count_if(bounds.begin(), bounds.end(), [](char byte) { return byte != kInside; }));
  for (const auto& [name, count] :
       {std::pair{"grid_anchor_displacements", snapshot.grid_anchor_displacements_size()},
        std::pair{"grid_anchor_depths", snapshot.grid_anchor_depths_size()}}) {
    if (count != anchored) {
      return InvalidArgument(
          name, "needs one value per anchored spring (" + std::to_string(anchored) +
                    " nonzero bytes in grid_anchor_bounds), got " + std::to_string(count));
    }
  }
  std::vector<SegmentAnchor> anchors;
  anchors.reserve(bounds.size());
  int next = 0;
  for (char byte : bounds) {
    if (byte == kInside) {
      anchors.push_back({});
      continue;
    }
    anchors.push_back({static_cast<BoundTag>(ToCoreTag(static_cast<std::uint8_t>(byte))),
                       snapshot.grid_anchor_displacements(next),
                       snapshot.grid_anchor_depths(next)});
    ++next;
  }
  return anchors;
}

// The vertices, with the anchors of their segments when given (snapshots).
void ToProtoVertices(const std::vector<double>& z, const std::vector<double>& u,
                     const std::vector<std::uint8_t>& tags,
                     const std::vector<SegmentAnchor>& anchors,
                     google::protobuf::RepeatedPtrField<v1::MemoryVertex>* vertices) {
  vertices->Reserve(static_cast<int>(z.size()));
  for (std::size_t i = 0; i < z.size(); ++i) {
    v1::MemoryVertex* vertex = vertices->Add();
    vertex->set_z(z[i]);
    vertex->set_u(u[i]);
    vertex->set_bound(ToProtoBound(tags[i]));
    if (i < anchors.size() && anchors[i].bound != kInside) {
      ToProtoAnchor(anchors[i], vertex->mutable_anchor());
    }
  }
}

// g^-1(depth) for display; 0 for a depth the core will reject (negative or not finite).
double RadiusForReading(const Profile& profile, double depth) {
  return std::isfinite(depth) && depth >= 0 ? profile.RadiusAtDepth(depth) : 0;
}

// The snapshot carries the state of its scene's method: a polyline or grid springs, not both.
Status CheckSnapshotMethod(const v1::ContactSnapshot& contact, Method method) {
  if (method == Method::kGrid && contact.memory_size() > 0) {
    return InvalidArgument("snapshot.contact.memory",
                           "must be empty for METHOD_GRID (the state is in grid_u)");
  }
  if (method == Method::kExact && contact.grid_u_size() > 0) {
    return InvalidArgument("snapshot.contact.grid_u",
                           "must be empty for METHOD_EXACT (the state is in memory)");
  }
  return OkStatus();
}

// An interface session's state is in snapshot.interface, a single contact's in snapshot.contact.
Status CheckSnapshotKind(const v1::SessionSnapshot& snapshot) {
  if (snapshot.scene().has_interface() && snapshot.has_contact()) {
    return InvalidArgument("snapshot.contact",
                           "must be unset for an interface session (its state is in "
                           "snapshot.interface)");
  }
  if (!snapshot.scene().has_interface() && snapshot.has_interface()) {
    return InvalidArgument("snapshot.interface",
                           "must be unset: the scene has no interface (the state is in "
                           "snapshot.contact)");
  }
  if (snapshot.scene().has_torsion() && snapshot.has_contact()) {
    return InvalidArgument("snapshot.contact",
                           "must be unset for a torsional session (its state is in "
                           "snapshot.torsion)");
  }
  if (!snapshot.scene().has_torsion() && snapshot.has_torsion()) {
    return InvalidArgument("snapshot.torsion",
                           "must be unset: the scene has no torsion (scene.torsion)");
  }
  return OkStatus();
}

}  // namespace

Result<ContactConfig> ToContactConfig(const v1::Scene& scene, std::size_t max_memory_vertices,
                                      const Interrupt& interrupt) {
  Result<ProfilePtr> profile = ToProfile(scene, interrupt);
  if (!profile.ok()) return profile.status();
  Result<EffectiveMaterial> material = ToMaterial(scene);
  if (!material.ok()) return material.status();

  ContactConfig config;
  config.profile = std::move(profile).value();
  config.material = *material;
  config.friction = scene.friction();
  config.rig = {scene.rig().tangential_compliance(), scene.rig().normal_compliance()};
  if (Status status = ApplyOptions(scene.options(), max_memory_vertices, &config); !status.ok()) {
    return status;
  }
  if (Status status = ApplyMethod(scene, &config); !status.ok()) return status;
  if (Status status = ValidateContactConfig(config); !status.ok()) {
    return ToSceneStatus(NamedAsInRequest(status, scene));
  }
  return config;
}

Status ToSceneStatus(const Status& status) {
  if (status.ok()) return status;
  return Status(status.code(), ScenePath(status.field()), status.message());
}

v1::Scene WithEffectiveOptions(const v1::Scene& scene, const ContactConfig& config) {
  v1::Scene effective = scene;
  v1::ContactOptions* options = effective.mutable_options();
  options->set_track_energy(config.track_energy);
  options->set_force_path_tolerance(config.force_path_tolerance);
  options->set_max_memory_vertices(config.max_memory_vertices);
  if (effective.has_tabulated()) {
    v1::TabulatedProfile* tabulated = effective.mutable_tabulated();
    if (tabulated->interpolation() == v1::TabulatedProfile::INTERPOLATION_UNSPECIFIED) {
      tabulated->set_interpolation(v1::TabulatedProfile::INTERPOLATION_STEFFEN);
    }
    if (!tabulated->has_tolerance()) tabulated->set_tolerance(TabulatedOptions{}.tolerance);
  }
  effective.set_method(config.method == Method::kGrid ? v1::METHOD_GRID : v1::METHOD_EXACT);
  if (config.method != Method::kGrid) return effective;
  v1::GridSettings* grid = effective.mutable_grid();
  grid->set_size(static_cast<std::uint32_t>(config.grid_size));
  grid->set_max_radius(config.grid_max_radius);
  grid->set_step_rule(config.grid_step_rule == GridStepRule::kNaive ? v1::GRID_STEP_RULE_NAIVE
                                                                    : v1::GRID_STEP_RULE_EXACT);
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

Result<ContactSnapshot> ToCoreSnapshot(const v1::ContactSnapshot& snapshot) {
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
    core.tags.push_back(ToCoreTag(vertex.bound()));
  }
  // Anchors only when some vertex has one: a snapshot without any is completed by the core.
  const bool anchored = std::any_of(snapshot.memory().begin(), snapshot.memory().end(),
                                    [](const v1::MemoryVertex& v) { return v.has_anchor(); });
  if (anchored) {
    core.anchors.reserve(n);
    for (const v1::MemoryVertex& vertex : snapshot.memory()) {
      core.anchors.push_back(ToCoreAnchor(vertex.anchor()));
    }
  }
  core.grid_u.assign(snapshot.grid_u().begin(), snapshot.grid_u().end());
  Result<std::vector<SegmentAnchor>> grid_anchors = ToCoreGridAnchors(snapshot);
  if (!grid_anchors.ok()) return grid_anchors.status();
  core.grid_anchors = std::move(grid_anchors).value();
  return core;
}

Status CheckSnapshotHeader(const v1::SessionSnapshot& snapshot) {
  if (snapshot.version() != kSnapshotVersion) {
    return InvalidArgument("snapshot.version", "must be " + std::to_string(kSnapshotVersion) +
                                                   " (the snapshot format of this build), got " +
                                                   std::to_string(snapshot.version()));
  }
  if (Status s = RequireNonNegative("snapshot.contact.last_step_dissipated_energy",
                                    snapshot.contact().last_step_dissipated_energy());
      !s.ok()) {
    return s;
  }
  if (snapshot.applied_steps() > kMaxAppliedSteps) {
    return InvalidArgument("snapshot.applied_steps",
                           "must be in [0, " + std::to_string(kMaxAppliedSteps) + "], got " +
                               std::to_string(snapshot.applied_steps()));
  }
  return OkStatus();
}

Result<Contact> ToCoreContact(const v1::SessionSnapshot& snapshot, std::size_t max_memory_vertices,
                              const Interrupt& interrupt) {
  Result<ContactConfig> config = ToContactConfig(snapshot.scene(), max_memory_vertices, interrupt);
  if (!config.ok()) return config.status().WithFieldPrefix("snapshot");
  if (Status s = CheckSnapshotKind(snapshot); !s.ok()) return s;
  if (Status s = CheckSnapshotMethod(snapshot.contact(), config->method); !s.ok()) {
    return s;
  }
  const auto vertices = static_cast<std::size_t>(snapshot.contact().memory_size());
  if (vertices > config->max_memory_vertices) {
    return ResourceExhausted("snapshot.contact.memory",
                             std::to_string(vertices) + " vertices exceed the session's limit of " +
                                 std::to_string(config->max_memory_vertices) +
                                 " (scene.options.max_memory_vertices)");
  }
  Result<ContactSnapshot> contact_state = ToCoreSnapshot(snapshot.contact());
  if (!contact_state.ok()) return contact_state.status().WithFieldPrefix("snapshot.contact");
  Result<Contact> contact = Contact::Restore(std::move(config).value(), *contact_state);
  if (!contact.ok()) return contact.status().WithFieldPrefix("snapshot.contact");
  return contact;
}

void ToProtoSnapshot(const ContactSnapshot& snapshot, v1::ContactSnapshot* proto) {
  proto->set_depth(snapshot.depth);
  proto->set_tangential_displacement(snapshot.tangential_displacement);
  proto->set_dissipated_energy(snapshot.dissipated_energy);
  proto->set_last_step_dissipated_energy(snapshot.last_step_dissipation);
  ToProtoVertices(snapshot.z, snapshot.u, snapshot.tags, snapshot.anchors, proto->mutable_memory());
  proto->mutable_grid_u()->Add(snapshot.grid_u.begin(), snapshot.grid_u.end());
  ToProtoGridAnchors(snapshot.grid_anchors, proto);
}

void ToProtoMemory(const PiecewiseLinearMemory& memory,
                   google::protobuf::RepeatedPtrField<v1::MemoryVertex>* vertices) {
  ToProtoVertices(memory.z(), memory.u(), memory.tags(), {}, vertices);
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

Result<TractionOptions> ToTractionOptions(v1::TractionRoute route, const std::string& field) {
  TractionOptions options;
  switch (route) {
    case v1::TRACTION_ROUTE_UNSPECIFIED:
    case v1::TRACTION_ROUTE_BOTH:
      options.routes = TractionRoute::kBoth;
      return options;
    case v1::TRACTION_ROUTE_ABEL:
      options.routes = TractionRoute::kAbel;
      return options;
    case v1::TRACTION_ROUTE_JAGER:
      options.routes = TractionRoute::kJager;
      return options;
    default:
      break;
  }
  return InvalidArgument(
      field,
      "must be TRACTION_ROUTE_BOTH, TRACTION_ROUTE_ABEL or TRACTION_ROUTE_JAGER, "
      "got " +
          std::to_string(route));
}

Result<RadialSampling> ToRadialSampling(const google::protobuf::RepeatedField<double>& radii,
                                        v1::TractionRoute route) {
  RadialSampling sampling;
  for (int i = 0; i < radii.size(); ++i) {
    if (Status s = RequireNonNegative("radii[" + std::to_string(i) + "]", radii[i]); !s.ok()) {
      return s;
    }
  }
  sampling.radii.assign(radii.begin(), radii.end());
  Result<TractionOptions> options = ToTractionOptions(route, "traction_route");
  if (!options.ok()) return options.status();
  sampling.traction_options = *options;
  return sampling;
}

double ToProtoRadialValues(const std::vector<RadialValue>& values,
                           google::protobuf::RepeatedPtrField<v1::RadialValue>* proto) {
  double max_error = 0;
  proto->Reserve(static_cast<int>(values.size()));
  for (const RadialValue& value : values) {
    v1::RadialValue* out = proto->Add();
    out->set_radius(value.radius);
    if (value.abel) out->set_abel(*value.abel);
    if (value.jager) out->set_jager(*value.jager);
    out->set_value(value.value);
    switch (value.chosen) {
      case TractionRoute::kBoth:
        out->set_route(v1::TRACTION_ROUTE_BOTH);
        break;
      case TractionRoute::kAbel:
        out->set_route(v1::TRACTION_ROUTE_ABEL);
        break;
      case TractionRoute::kJager:
        out->set_route(v1::TRACTION_ROUTE_JAGER);
        break;
    }
    out->set_error_estimate(value.error_estimate);
    max_error = std::max(max_error, value.error_estimate);
  }
  return max_error;
}

void ToProtoJagerWeights(const JagerWeights& weights, v1::JagerWeights* proto) {
  proto->set_contact_radius(weights.contact_radius);
  proto->mutable_intervals()->Reserve(static_cast<int>(weights.intervals.size()));
  for (const WeightInterval& interval : weights.intervals) {
    v1::WeightInterval* out = proto->add_intervals();
    out->set_r_begin(interval.r_begin);
    out->set_r_end(interval.r_end);
    out->set_depth_begin(interval.depth_begin);
    out->set_depth_end(interval.depth_end);
    out->set_weight(interval.weight);
  }
  proto->set_edge_weight(weights.edge_weight);
}

void ToProtoTerms(const std::vector<CattaneoMindlinTerm>& terms,
                  google::protobuf::RepeatedPtrField<v1::CattaneoMindlinTerm>* proto) {
  proto->Reserve(static_cast<int>(terms.size()));
  for (const CattaneoMindlinTerm& term : terms) {
    v1::CattaneoMindlinTerm* out = proto->Add();
    out->set_weight(term.weight);
    out->set_a(term.a);
    out->set_c(term.c);
    out->set_depth_a(term.depth_a);
    out->set_depth_c(term.depth_c);
  }
}

Result<std::vector<CattaneoMindlinTerm>> ToCoreTerms(
    const v1::CattaneoMindlinSuperposition& superposition, const Profile& profile) {
  std::vector<CattaneoMindlinTerm> terms;
  terms.reserve(static_cast<std::size_t>(superposition.terms_size()));
  switch (superposition.coordinates()) {
    case v1::CattaneoMindlinSuperposition::COORDINATES_UNSPECIFIED:
    case v1::CattaneoMindlinSuperposition::COORDINATES_DEPTHS:
      // Checked against each other and the depth by MemoryFromTerms; a and c for reading.
      for (const v1::CattaneoMindlinTerm& term : superposition.terms()) {
        terms.push_back({term.weight(), RadiusForReading(profile, term.depth_a()),
                         RadiusForReading(profile, term.depth_c()), term.depth_a(),
                         term.depth_c()});
      }
      return terms;
    case v1::CattaneoMindlinSuperposition::COORDINATES_RADII:
      for (int i = 0; i < superposition.terms_size(); ++i) {
        const v1::CattaneoMindlinTerm& term = superposition.terms(i);
        Result<CattaneoMindlinTerm> core =
            CattaneoMindlinTermFromRadii(term.weight(), term.a(), term.c(), profile);
        if (!core.ok()) return core.status().WithFieldPrefix("terms[" + std::to_string(i) + "]");
        terms.push_back(*core);
      }
      return terms;
    default:
      break;
  }
  return InvalidArgument("coordinates", "must be COORDINATES_DEPTHS or COORDINATES_RADII, got " +
                                            std::to_string(superposition.coordinates()));
}

void ToProtoSampledWeight(const SampledWeight& weight, v1::SampledWeight* proto) {
  proto->set_kind(weight.kind == WeightKind::kStepFunction ? v1::SampledWeight::KIND_STEP_FUNCTION
                                                           : v1::SampledWeight::KIND_CONTINUOUS);
  proto->set_tolerance(weight.tolerance);
  proto->mutable_midpoints()->Add(weight.midpoints.begin(), weight.midpoints.end());
  proto->mutable_weights()->Add(weight.weights.begin(), weight.weights.end());
  ToProtoTerms(weight.terms, proto->mutable_terms());
  proto->set_max_residual(weight.max_residual);
}

}  // namespace mdr::bridge
