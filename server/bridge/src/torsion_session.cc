#include "mdr/bridge/torsion_session.h"

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/interface_session.h"
#include "mdr/core/material.h"

namespace mdr::bridge {
namespace {

// The name of the member a oneof case selects (its field number is the case's value).
std::string OneofFieldName(int field_number) {
  const auto* field = v1::Step::descriptor()->FindFieldByNumber(field_number);
  return field != nullptr ? field->name() : "step";
}

std::string ProfilePath(const v1::Scene& scene) {
  const auto* field = v1::Scene::descriptor()->FindFieldByNumber(scene.profile_case());
  return field != nullptr ? "scene." + field->name() : "scene.profile";
}

std::string MaterialPath(const v1::Scene& scene) {
  return scene.material_case() == v1::Scene::kElasticPair ? "scene.elastic_pair"
                                                          : "scene.rigid_on_half_space";
}

// G_t: scene.torsion's, or the scene's material's (validated by ToContactConfig).
Result<double> TorsionalModulus(const v1::Scene& scene) {
  if (scene.torsion().has_torsional_modulus()) {
    const double modulus = scene.torsion().torsional_modulus();
    if (!(modulus >= 1e-100 && modulus <= 1e100)) {
      return InvalidArgument("scene.torsion.torsional_modulus",
                             "must be in [1e-100, 1e100] Pa, got " + FormatNumber(modulus));
    }
    return modulus;
  }
  if (scene.material_case() == v1::Scene::kElasticPair) {
    const v1::ElasticPair& m = scene.elastic_pair();
    Result<double> modulus = TorsionalModulusOfPair(m.youngs_modulus_1(), m.poisson_ratio_1(),
                                                    m.youngs_modulus_2(), m.poisson_ratio_2());
    if (!modulus.ok()) return modulus.status().WithFieldPrefix("scene.elastic_pair");
    return modulus;
  }
  return scene.rigid_on_half_space().shear_modulus();
}

// The core names the contact's inputs bare (profile, friction, the moduli); these are the
// scene's fields.
Status ToSceneField(const Status& status, const v1::Scene& scene) {
  const std::string& field = status.field();
  if (field == "profile") return Status(status.code(), ProfilePath(scene), status.message());
  if (field == "friction") return Status(status.code(), "scene.friction", status.message());
  if (field == "effective_modulus" || field == "torsional_modulus") {
    return Status(status.code(), MaterialPath(scene),
                  "the " + field + " derived from it " + status.message());
  }
  return status;
}

// The snapshot's members as the core names them ("last_step_dissipation") in proto terms.
Status ToSnapshotField(const Status& status) {
  std::string field = status.field();
  if (field == "last_step_dissipation") field = "last_step_dissipated_energy";
  return Status(status.code(), "torsion." + field, status.message());
}

Result<TorsionSnapshot> ToCoreTorsionSnapshot(const v1::TorsionSnapshot& proto) {
  TorsionSnapshot snapshot;
  snapshot.contact_radius = proto.contact_radius();
  snapshot.twist = proto.twist();
  snapshot.dissipated_energy = proto.dissipated_energy();
  snapshot.last_step_dissipation = proto.last_step_dissipated_energy();
  snapshot.pieces.reserve(static_cast<std::size_t>(proto.pieces_size()));
  for (int i = 0; i < proto.pieces_size(); ++i) {
    const v1::TorsionPiece& piece = proto.pieces(i);
    if (piece.sign() < -1 || piece.sign() > 1) {
      return InvalidArgument("torsion.pieces[" + std::to_string(i) + "].sign",
                             "must be -1, 0 or +1, got " + std::to_string(piece.sign()));
    }
    snapshot.pieces.push_back({.end = piece.end(),
                               .sign = static_cast<std::int8_t>(piece.sign()),
                               .radius = piece.radius(),
                               .offset = piece.offset()});
  }
  return snapshot;
}

void ToProtoPieces(const std::vector<TorsionPiece>& pieces,
                   google::protobuf::RepeatedPtrField<v1::TorsionPiece>* proto) {
  proto->Reserve(static_cast<int>(pieces.size()));
  for (const TorsionPiece& piece : pieces) {
    v1::TorsionPiece* out = proto->Add();
    out->set_end(piece.end);
    out->set_sign(piece.sign);
    out->set_radius(piece.radius);
    out->set_offset(piece.offset);
  }
}

TorsionStep ToCoreTorsionStep(const v1::Step& step) {
  TorsionStep core;
  if (step.normal_case() != v1::Step::NORMAL_NOT_SET) {  // the normal channel as ToCoreStep's
    const Step normal = ToCoreStep(step);
    core.normal = normal.normal;
    core.normal_value = normal.normal_value;
  }
  switch (step.torsional_case()) {
    case v1::Step::kTwist:
      core.twist = TwistControl::kAngle;
      core.twist_value = step.twist();
      break;
    case v1::Step::kTwistIncrement:
      core.twist = TwistControl::kAngleIncrement;
      core.twist_value = step.twist_increment();
      break;
    case v1::Step::kTwistingMoment:
      core.twist = TwistControl::kMoment;
      core.twist_value = step.twisting_moment();
      break;
    case v1::Step::TORSIONAL_NOT_SET:
      break;
  }
  return core;
}

constexpr std::size_t kExportAllowanceBytes = 96;  // the snapshot's scalars and tags
constexpr std::size_t kExportBytesPerPiece = 48;   // 3 doubles, a varint sign, tags, length
constexpr std::size_t kBytesPerPiece = sizeof(TorsionPiece) * 2;  // the memory and a step's copy

}  // namespace

Status CheckTorsionScene(const v1::Scene& scene) {
  if (!scene.has_torsion()) return OkStatus();
  if (scene.has_interface()) {
    return InvalidArgument("scene.interface",
                           "must be unset with scene.torsion: a torsional session is a single "
                           "contact");
  }
  if (scene.method() == v1::METHOD_GRID) {
    return InvalidArgument("scene.method",
                           "must be METHOD_EXACT with scene.torsion (the torsional memory is "
                           "exact; there is no grid of it)");
  }
  if (scene.has_rig()) {
    return InvalidArgument("scene.rig",
                           "must be unset with scene.torsion: a torsional rig is "
                           "scene.torsion.rig_compliance");
  }
  if (scene.torsion().rig_compliance() != 0) {
    return InvalidArgument("scene.torsion.rig_compliance",
                           "must be 0 in a session: sessions do not model a torsional rig yet (the "
                           "loop analysis does: Backbone, FitLoops)");
  }
  return OkStatus();
}

Result<analysis::TorsionalScene> ToTorsionalScene(const v1::Scene& scene,
                                                  const ContactConfig& config) {
  const double compliance = scene.torsion().rig_compliance();
  if (!std::isfinite(compliance) || compliance < 0) {
    return InvalidArgument("scene.torsion.rig_compliance",
                           "must be finite and >= 0 (rad/(N m)), got " + FormatNumber(compliance));
  }
  if (scene.has_rig()) {
    return InvalidArgument("scene.rig",
                           "must be unset with scene.torsion: a torsional rig is "
                           "scene.torsion.rig_compliance");
  }
  // The torsional contact's own checks (a flat punch, friction 0), named as for sessions.
  if (Result<TorsionalContact> contact = CreateTorsionalContact(scene, config); !contact.ok()) {
    return contact.status();
  }
  Result<double> modulus = TorsionalModulus(scene);
  if (!modulus.ok()) return modulus.status();
  return analysis::TorsionalScene{.profile = config.profile,
                                  .friction = config.friction,
                                  .effective_modulus = config.material.e_star,
                                  .torsional_modulus = *modulus,
                                  .rig_compliance = compliance};
}

Result<TorsionalContact> CreateTorsionalContact(const v1::Scene& scene,
                                                const ContactConfig& config) {
  Result<double> modulus = TorsionalModulus(scene);
  if (!modulus.ok()) return modulus.status();
  Result<TorsionalContact> contact =
      TorsionalContact::Create(config.profile, config.friction, config.material.e_star, *modulus);
  if (!contact.ok()) return ToSceneField(contact.status(), scene);
  return contact;
}

Result<TorsionalContact> RestoreTorsionalContact(const v1::Scene& scene,
                                                 const ContactConfig& config,
                                                 const v1::TorsionSnapshot& snapshot) {
  // The scene's own errors first (a flat punch, friction 0), named as at creation.
  if (Result<TorsionalContact> fresh = CreateTorsionalContact(scene, config); !fresh.ok()) {
    return fresh.status();
  }
  if (static_cast<std::size_t>(snapshot.pieces_size()) > config.max_memory_vertices) {
    return ResourceExhausted("torsion.pieces", std::to_string(snapshot.pieces_size()) +
                                                   " pieces exceed the session's limit of " +
                                                   std::to_string(config.max_memory_vertices) +
                                                   " (scene.options.max_memory_vertices)");
  }
  Result<TorsionSnapshot> memory = ToCoreTorsionSnapshot(snapshot);
  if (!memory.ok()) return memory.status();
  Result<double> modulus = TorsionalModulus(scene);
  if (!modulus.ok()) return modulus.status();
  Result<TorsionalContact> contact = TorsionalContact::Restore(
      config.profile, config.friction, config.material.e_star, *modulus, snapshot.depth(), *memory);
  if (!contact.ok()) return ToSnapshotField(contact.status());
  return contact;
}

void ToProtoTorsionSnapshot(const TorsionalContact& contact, v1::TorsionSnapshot* proto) {
  const TorsionSnapshot snapshot = contact.memory().Snapshot();
  proto->set_depth(contact.depth());
  proto->set_twist(snapshot.twist);
  proto->set_dissipated_energy(snapshot.dissipated_energy);
  proto->set_last_step_dissipated_energy(snapshot.last_step_dissipation);
  proto->set_contact_radius(snapshot.contact_radius);
  ToProtoPieces(snapshot.pieces, proto->mutable_pieces());
}

Status RefuseTwist(const v1::Step& step) {
  if (step.torsional_case() == v1::Step::TORSIONAL_NOT_SET) return OkStatus();
  return InvalidArgument(OneofFieldName(step.torsional_case()),
                         "must be unset: only a torsional session (scene.torsion) takes a twist");
}

Status ApplyTorsionStep(TorsionalContact& contact, const v1::Step& step,
                        std::size_t max_memory_pieces) {
  if (Status s = CheckSingleContactStep(step); !s.ok()) return s;
  if (step.tangential_case() != v1::Step::TANGENTIAL_NOT_SET) {
    return InvalidArgument(OneofFieldName(step.tangential_case()),
                           "must be unset in a torsional session (scene.torsion): a twist "
                           "combined with a tangential displacement or force has no exact model "
                           "(docs/physics.md, \"Torsion\"); drive such a contact tangentially in a "
                           "session without scene.torsion");
  }
  const TorsionStep core = ToCoreTorsionStep(step);
  const std::string normal_field = OneofFieldName(step.normal_case());
  const std::string twist_field = OneofFieldName(step.torsional_case());
  if (Status s = contact.Apply(core); !s.ok()) {
    if (s.field() == "normal_value") return Status(s.code(), normal_field, s.message());
    if (s.field() == "twist_value" || s.field() == "step") {
      return Status(s.code(), twist_field, s.message());
    }
    return s;
  }
  if (const std::size_t pieces = contact.memory().pieces().size(); pieces > max_memory_pieces) {
    return ResourceExhausted(core.normal ? normal_field : twist_field,
                             "the torsional memory would hold " + std::to_string(pieces) +
                                 " pieces, above scene.options.max_memory_vertices = " +
                                 std::to_string(max_memory_pieces) + " (nothing was applied)");
  }
  return OkStatus();
}

std::size_t StateBytes(const TorsionalContact& contact) {
  return sizeof(TorsionalContact) + contact.memory().pieces().size() * kBytesPerPiece;
}

std::size_t ExportBytesBound(const TorsionalContact& contact, std::size_t scene_bytes) {
  return scene_bytes + kExportAllowanceBytes +
         contact.memory().pieces().size() * kExportBytesPerPiece;
}

void WriteTorsionState(const TorsionalContact& contact, double friction,
                       std::uint64_t applied_steps, const OutputSelection& selection,
                       v1::ContactState* state) {
  const TorsionalMemory& memory = contact.memory();
  if (selection.has(Output::kDepth)) state->set_depth(contact.depth());
  if (selection.has(Output::kActuatorDepth)) state->set_actuator_depth(contact.depth());
  if (selection.has(Output::kContactRadius)) state->set_contact_radius(memory.contact_radius());
  if (selection.has(Output::kNormalForce)) state->set_normal_force(contact.normal_force());
  if (selection.has(Output::kFrictionLimit)) {
    state->set_friction_limit(friction * contact.normal_force());
  }
  if (selection.has(Output::kDissipatedEnergy)) {
    state->set_dissipated_energy(memory.dissipated_energy());
  }
  if (selection.has(Output::kAppliedSteps)) state->set_applied_steps(applied_steps);
  if (selection.has(Output::kMemoryVertices)) state->set_memory_vertices(memory.pieces().size());
  if (selection.has(Output::kTwist)) state->set_twist(memory.twist());
  if (selection.has(Output::kTwistingMoment)) state->set_twisting_moment(memory.Moment());
  if (selection.has(Output::kFullSlipMoment)) {
    state->set_full_slip_moment(memory.FullSlipMoment());
  }
}

void WriteTorsionStepResult(const TorsionalContact& contact, double friction,
                            std::uint64_t applied_steps, const OutputSelection& selection,
                            v1::StepResult* result) {
  if (selection.any_state()) {
    WriteTorsionState(contact, friction, applied_steps, selection, result->mutable_state());
  }
  if (selection.has(Output::kSubsteps)) result->set_substeps(1);
  if (selection.has(Output::kPathError)) result->set_path_error(0);
  if (selection.has(Output::kStepResultDissipatedEnergy)) {
    result->set_dissipated_energy(contact.memory().last_step_dissipation());
  }
}

Status WriteTorsionQueryOutputs(const TorsionalContact& contact, const ContactConfig& config,
                                std::uint64_t applied_steps, const OutputSelection& selection,
                                const RadialSampling& sampling, v1::QueryResponse* response,
                                OutputCounters* counters) {
  if (selection.any_tangential()) {
    return FailedPrecondition(
        "read_mask",
        "a torsional session (scene.torsion) answers state, energy and \"torsion.*\"; the "
        "tangential outputs and the pressure are for sessions without scene.torsion");
  }
  const TorsionalMemory& memory = contact.memory();
  if (selection.any_state()) {
    WriteTorsionState(contact, config.friction, applied_steps, selection,
                      response->mutable_state());
  }
  if (selection.has(Output::kEnergyDissipatedEnergy)) {
    response->mutable_energy()->set_dissipated_energy(memory.dissipated_energy());
    Count(counters, Output::kEnergyDissipatedEnergy);
  }
  if (selection.has(Output::kEnergyLastStepDissipatedEnergy)) {
    response->mutable_energy()->set_last_step_dissipated_energy(memory.last_step_dissipation());
    Count(counters, Output::kEnergyLastStepDissipatedEnergy);
  }
  v1::TorsionOutputs* torsion = response->mutable_torsion();
  if (selection.has(Output::kTorsionStiffness)) {
    torsion->set_stiffness_positive(memory.Stiffness(+1));
    torsion->set_stiffness_negative(memory.Stiffness(-1));
    Count(counters, Output::kTorsionStiffness);
  }
  if (selection.has(Output::kTorsionSlipIntervals)) {
    for (const TorsionSlipInterval& interval : memory.SlipIntervals()) {
      v1::SlipInterval* out = torsion->add_slip_intervals();
      out->set_r_begin(interval.start);
      out->set_r_end(interval.end);
      out->set_direction(interval.sign);
    }
    Count(counters, Output::kTorsionSlipIntervals);
  }
  if (selection.has(Output::kTorsionTractions)) {
    torsion->mutable_tractions()->Reserve(static_cast<int>(sampling.radii.size()));
    for (double radius : sampling.radii) {
      const TorsionTraction traction = memory.Traction(radius);
      v1::TorsionTraction* out = torsion->add_tractions();
      out->set_radius(radius);
      out->set_value(traction.value);
      out->set_route_difference(traction.route_difference);
    }
    Count(counters, Output::kTorsionTractions);
  }
  if (selection.has(Output::kTorsionMemoryPieces)) {
    ToProtoPieces(memory.pieces(), torsion->mutable_memory_pieces());
    Count(counters, Output::kTorsionMemoryPieces);
  }
  if (selection.has(Output::kTorsionStoredEnergy)) {
    torsion->set_stored_energy(memory.StoredEnergy());
    Count(counters, Output::kTorsionStoredEnergy);
  }
  if (!selection.any_torsion()) response->clear_torsion();
  response->mutable_error_estimate()->set_profile_tolerance(config.profile->ToleranceEstimate());
  return OkStatus();
}

}  // namespace mdr::bridge
