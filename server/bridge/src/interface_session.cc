#include "mdr/bridge/interface_session.h"

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/state_budget.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/core/population.h"

namespace mdr::bridge {
namespace {

// A core status whose field starts with `from` renamed to start with `to`; others unchanged.
Status RenameField(const Status& status, const std::string& from, const std::string& to) {
  if (!status.field().starts_with(from)) return status;
  return Status(status.code(), to + status.field().substr(from.size()), status.message());
}

// A contact's own refusal of its step value ("contacts[i].normal_force: must be >= 0") named as
// the request's field that carried it ("contact_normal_values[i]"); other fields unchanged.
Status NameContactValue(const Status& status, const Step& step) {
  const std::string& field = status.field();
  const std::size_t close = field.find("].");
  if (!field.starts_with("contacts[") || close == std::string::npos) return status;
  const std::string index = field.substr(9, close - 9);
  const std::string value = field.substr(close + 2);
  if (value == FieldName(step.normal)) {
    return Status(status.code(), "contact_normal_values[" + index + "]", status.message());
  }
  if (value == FieldName(step.tangential)) {
    return Status(status.code(), "contact_tangential_values[" + index + "]", status.message());
  }
  return status;
}

Result<PopulationSpec> ToPopulationSpec(const v1::GeneratedPopulation& generated,
                                        const v1::Scene& scene) {
  PopulationSpec spec;
  spec.count = generated.count();
  switch (generated.height_distribution()) {
    case v1::GeneratedPopulation::HEIGHT_DISTRIBUTION_UNSPECIFIED:
    case v1::GeneratedPopulation::HEIGHT_DISTRIBUTION_GAUSSIAN:
      spec.heights = HeightDistribution::kGaussian;
      break;
    case v1::GeneratedPopulation::HEIGHT_DISTRIBUTION_EXPONENTIAL:
      spec.heights = HeightDistribution::kExponential;
      break;
    default:
      return InvalidArgument("height_distribution",
                             "must be HEIGHT_DISTRIBUTION_GAUSSIAN or _EXPONENTIAL, got " +
                                 std::to_string(generated.height_distribution()));
  }
  const bool spheres = scene.profile_case() == v1::Scene::kSphere;
  switch (generated.radius_distribution()) {
    case v1::GeneratedPopulation::RADIUS_DISTRIBUTION_UNSPECIFIED:
    case v1::GeneratedPopulation::RADIUS_DISTRIBUTION_FIXED:
      // Every contact has the scene's profile: a sphere of the scene's radius, or any other.
      spec.radii = spheres ? RadiusDistribution::kFixed : RadiusDistribution::kNone;
      break;
    case v1::GeneratedPopulation::RADIUS_DISTRIBUTION_LOGNORMAL:
      if (!spheres) {
        return InvalidArgument("radius_distribution",
                               "must be RADIUS_DISTRIBUTION_FIXED (or unset) when the scene's "
                               "profile is not a sphere: every contact has that profile");
      }
      spec.radii = RadiusDistribution::kLognormal;
      break;
    default:
      return InvalidArgument("radius_distribution",
                             "must be RADIUS_DISTRIBUTION_FIXED or _LOGNORMAL, got " +
                                 std::to_string(generated.radius_distribution()));
  }
  spec.height_scale = generated.height_scale();
  spec.radius = scene.sphere().radius();
  spec.log_sigma = generated.log_sigma();
  spec.seed = generated.seed();
  return spec;
}

// The summits of scene.interface; errors name fields from the Scene down.
Result<Population> ToPopulation(const v1::Scene& scene) {
  const v1::Interface& interface = scene.interface();
  switch (interface.population_case()) {
    case v1::Interface::kGenerated: {
      const std::string prefix = "scene.interface.generated";
      Result<PopulationSpec> spec = ToPopulationSpec(interface.generated(), scene);
      if (!spec.ok()) return spec.status().WithFieldPrefix(prefix);
      Result<Population> population = GeneratePopulation(*spec);
      if (!population.ok()) {
        const Status& s = population.status();
        // The radius (median) is the scene's sphere radius.
        if (s.field() == "radius") return RenameField(s, "radius", "scene.sphere.radius");
        return s.WithFieldPrefix(prefix);
      }
      return population;
    }
    case v1::Interface::kExplicitList: {
      const v1::ExplicitPopulation& list = interface.explicit_list();
      if (scene.profile_case() != v1::Scene::kSphere && list.radii_size() > 0) {
        return InvalidArgument("scene.interface.explicit_list.radii",
                               "must be empty when the scene's profile is not a sphere (every "
                               "contact has that profile), got " +
                                   std::to_string(list.radii_size()) + " radii");
      }
      Result<Population> population =
          ExplicitPopulation(std::vector<double>(list.heights().begin(), list.heights().end()),
                             std::vector<double>(list.radii().begin(), list.radii().end()));
      if (!population.ok()) {
        return population.status().WithFieldPrefix("scene.interface.explicit_list");
      }
      return population;
    }
    case v1::Interface::POPULATION_NOT_SET:
      break;
  }
  return InvalidArgument("scene.interface.population",
                         "required: set scene.interface.generated or explicit_list");
}

Result<InterfaceKind> ToInterfaceKind(v1::Interface::Kind kind) {
  switch (kind) {
    case v1::Interface::KIND_SHARED_MOTION:
      return InterfaceKind::kSharedMotion;
    case v1::Interface::KIND_CONTACT_LIST:
      return InterfaceKind::kContactList;
    default:
      return InvalidArgument(
          "scene.interface.kind",
          "must be KIND_SHARED_MOTION or KIND_CONTACT_LIST, got " + std::to_string(kind));
  }
}

// The population's contacts with every option of base (validated by ToContactConfig): Hertz
// spheres of the population's radii, or, without radii, all with the scene's profile.
Result<InterfaceConfig> ToInterfaceConfig(const v1::Scene& scene, const ContactConfig& base) {
  Result<InterfaceKind> kind = ToInterfaceKind(scene.interface().kind());
  if (!kind.ok()) return kind.status();
  if (base.method != Method::kExact) {
    return InvalidArgument("scene.method", "must be METHOD_EXACT for an interface");
  }
  if (base.rig.tangential > 0 || base.rig.normal > 0) {
    return InvalidArgument("scene.rig",
                           "must be unset for an interface (a rig is in series with one contact)");
  }
  Result<Population> population = ToPopulation(scene);
  if (!population.ok()) return population.status();
  Result<InterfaceConfig> config =
      population->radii.empty()
          ? SharedProfileInterfaceConfig(*population, base)
          : HertzInterfaceConfig(*population, base.material, base.friction, base.track_energy);
  if (!config.ok()) return config.status().WithFieldPrefix("scene.interface");
  config->kind = *kind;
  if (*kind == InterfaceKind::kContactList) config->heights.clear();
  for (ContactConfig& contact : config->contacts) {
    contact.force_path_tolerance = base.force_path_tolerance;
    contact.max_memory_vertices = base.max_memory_vertices;
  }
  return config;
}

Result<InterfaceSnapshot> ToCoreInterfaceSnapshot(const v1::InterfaceSnapshot& proto) {
  InterfaceSnapshot snapshot;
  snapshot.approach = proto.approach();
  snapshot.tangential_displacement = proto.tangential_displacement();
  snapshot.contacts.reserve(static_cast<std::size_t>(proto.contacts_size()));
  for (int i = 0; i < proto.contacts_size(); ++i) {
    Result<ContactSnapshot> contact = ToCoreSnapshot(proto.contacts(i));
    if (!contact.ok()) {
      return contact.status().WithFieldPrefix(Indexed("contacts", static_cast<std::size_t>(i)));
    }
    snapshot.contacts.push_back(std::move(contact).value());
  }
  return snapshot;
}

// The per-contact values of one channel of a contact-list step: `values` when the channel is set
// (its own value must be 0, exactly n values), else n zeros (the contacts hold).
Result<std::span<const double>> ListChannel(bool channel_set, double own_value,
                                            const std::string& own_field,
                                            const google::protobuf::RepeatedField<double>& values,
                                            const std::string& values_field, std::size_t n,
                                            std::vector<double>* zeros) {
  if (!channel_set) {
    if (!values.empty()) {
      return InvalidArgument(values_field,
                             "must be empty when the step sets no channel for it "
                             "(the contacts hold), got " +
                                 std::to_string(values.size()) + " values");
    }
    zeros->assign(n, 0.0);
    return std::span<const double>(*zeros);
  }
  if (own_value != 0) {
    return InvalidArgument(own_field,
                           "must be 0 in a contact-list step: it only chooses the "
                           "meaning of " +
                               values_field + ", which carries the values");
  }
  if (static_cast<std::size_t>(values.size()) != n) {
    return InvalidArgument(values_field, "must hold one value per contact (" + std::to_string(n) +
                                             "), got " + std::to_string(values.size()));
  }
  return std::span<const double>(values.data(), n);
}

Status ApplyListStep(Interface& interface, const v1::Step& step, const Interrupt& interrupt,
                     const Interface::CommitGate& gate) {
  const Step core = ToCoreStep(step);
  const std::size_t n = interface.size();
  std::vector<double> normal_zeros, tangential_zeros;
  Result<std::span<const double>> normal = ListChannel(
      step.normal_case() != v1::Step::NORMAL_NOT_SET, core.normal_value, FieldName(core.normal),
      step.contact_normal_values(), "contact_normal_values", n, &normal_zeros);
  if (!normal.ok()) return normal.status();
  Result<std::span<const double>> tangential =
      ListChannel(step.tangential_case() != v1::Step::TANGENTIAL_NOT_SET, core.tangential_value,
                  FieldName(core.tangential), step.contact_tangential_values(),
                  "contact_tangential_values", n, &tangential_zeros);
  if (!tangential.ok()) return tangential.status();
  const ContactListStep list{.normal = core.normal,
                             .normal_values = *normal,
                             .tangential = core.tangential,
                             .tangential_values = *tangential};
  Status status = NameContactValue(interface.ApplyEach(list, interrupt, gate), core);
  status = RenameField(status, "normal_values", "contact_normal_values");
  return RenameField(status, "tangential_values", "contact_tangential_values");
}

// Ordinary QueryResponse outputs that only a single contact has (besides "state").
bool AnyContactOutput(const OutputSelection& selection) {
  for (auto i = static_cast<std::size_t>(Output::kStiffnessPositive);
       i <= static_cast<std::size_t>(Output::kPressure); ++i) {
    if (selection.has(static_cast<Output>(i))) return true;
  }
  return false;
}

// The totals a ContactState shows, each summed in index order like Interface::Totals (so the
// values are the same bits), without the stiffnesses and slip states that Totals also computes
// (several times the cost: this runs after every batch). Only the selected sums are taken.
Interface::ForceSums SumStateFields(const Interface& interface, const OutputSelection& selection) {
  return interface.SumForces(
      selection.has(Output::kNormalForce) || selection.has(Output::kFrictionLimit),
      selection.has(Output::kTangentialForce), selection.has(Output::kDissipatedEnergy));
}

void WriteTotals(const InterfaceTotals& totals, v1::InterfaceTotals* proto) {
  proto->set_normal_force(totals.normal_force);
  proto->set_tangential_force(totals.tangential_force);
  proto->set_dissipated_energy(totals.dissipated_energy);
  proto->set_last_step_dissipated_energy(totals.last_step_dissipation);
  proto->set_friction_limit(totals.friction_limit);
  proto->set_normal_stiffness(totals.normal_stiffness);
  proto->mutable_tangential_stiffness()->set_positive(totals.tangential_stiffness.positive);
  proto->mutable_tangential_stiffness()->set_negative(totals.tangential_stiffness.negative);
  proto->set_in_contact(totals.in_contact);
  proto->set_sticking(totals.sticking);
  proto->set_partial_slip(totals.partial_slip);
  proto->set_gross_slip(totals.gross_slip);
}

Status WriteInterfaceOutputs(const Interface& interface, const OutputSelection& selection,
                             const InterfaceQuery& query, v1::InterfaceOutputs* outputs,
                             OutputCounters* counters) {
  const auto count = [counters](Output output) {
    if (counters != nullptr) ++counters->computed[static_cast<std::size_t>(output)];
  };
  outputs->set_contact_count(interface.size());
  if (selection.has(Output::kInterfaceTotals)) {
    Result<InterfaceTotals> totals = interface.Totals();
    if (!totals.ok()) return totals.status();
    WriteTotals(*totals, outputs->mutable_totals());
    count(Output::kInterfaceTotals);
  }
  if (selection.has(Output::kInterfaceSlipHistogram)) {
    Result<std::vector<std::size_t>> histogram = interface.SlipHistogram(query.slip_histogram_bins);
    if (!histogram.ok()) return RenameField(histogram.status(), "bins", "slip_histogram_bins");
    outputs->mutable_slip_histogram()->Add(histogram->begin(), histogram->end());
    count(Output::kInterfaceSlipHistogram);
  }
  if (selection.has(Output::kInterfaceMemoryBytes)) {
    outputs->set_memory_bytes(interface.MemoryBytes());
    count(Output::kInterfaceMemoryBytes);
  }
  return OkStatus();
}

// How a session holds its interface (also the one the size check measures): every response
// states the force sums, so each in-place step keeps its contacts' forces for them.
void UseAsSession(Interface& interface) { interface.set_keep_step_forces(true); }

}  // namespace

Status CheckInterfaceSize(const v1::Scene& scene, const ContactConfig& base, const StateRoom& room,
                          int max_message_bytes) {
  const v1::Interface& interface = scene.interface();
  const bool generated = interface.population_case() == v1::Interface::kGenerated;
  const std::size_t count =
      generated ? interface.generated().count()
                : static_cast<std::size_t>(interface.explicit_list().heights_size());
  const std::string field =
      generated ? "scene.interface.generated.count" : "scene.interface.explicit_list.heights";
  constexpr std::size_t kEmptySnapshotBytes = 2;  // tag and length of an empty ContactSnapshot
  if (count > static_cast<std::size_t>(max_message_bytes) / kEmptySnapshotBytes) {
    return ResourceExhausted(field, std::to_string(count) +
                                        " contacts could not be exported within the message "
                                        "limit of " +
                                        std::to_string(max_message_bytes) +
                                        " bytes (mdrd --max-message-bytes)");
  }
  if (room.bytes == 0) return OkStatus();
  // What one more contact adds (the interface's own fixed bytes are not per contact).
  Result<Interface> one =
      Interface::Create({.kind = InterfaceKind::kContactList, .contacts = {base}, .heights = {}});
  Result<Interface> two = Interface::Create(
      {.kind = InterfaceKind::kContactList, .contacts = {base, base}, .heights = {}});
  if (!one.ok() || !two.ok()) return OkStatus();  // the real construction reports the error
  UseAsSession(*one);
  UseAsSession(*two);
  const std::size_t per_contact = StateBytes(*two) - StateBytes(*one);
  if (count > room.bytes / per_contact) {
    return ResourceExhausted(field, std::to_string(count) + " contacts need at least " +
                                        std::to_string(per_contact) + " bytes each; " + room.whose +
                                        " has " + std::to_string(room.bytes) +
                                        " bytes left (mdrd " + room.flag + ")");
  }
  return OkStatus();
}

Result<Interface> CreateInterface(const v1::Scene& scene, const ContactConfig& base) {
  Result<InterfaceConfig> config = ToInterfaceConfig(scene, base);
  if (!config.ok()) return config.status();
  Result<Interface> interface = Interface::Create(std::move(config).value());
  if (!interface.ok()) return interface.status().WithFieldPrefix("scene.interface");
  UseAsSession(*interface);
  return interface;
}

Result<Interface> RestoreInterface(const v1::Scene& scene, const ContactConfig& base,
                                   const v1::InterfaceSnapshot& snapshot) {
  Result<InterfaceConfig> config = ToInterfaceConfig(scene, base);
  if (!config.ok()) return config.status();
  Result<InterfaceSnapshot> state = ToCoreInterfaceSnapshot(snapshot);
  if (!state.ok()) return state.status().WithFieldPrefix("interface");
  Result<Interface> interface = Interface::Restore(std::move(config).value(), *state);
  if (!interface.ok()) return interface.status().WithFieldPrefix("interface");
  UseAsSession(*interface);
  return interface;
}

void ToProtoInterfaceSnapshot(const Interface& interface, v1::InterfaceSnapshot* proto) {
  proto->set_approach(interface.approach());
  proto->set_tangential_displacement(interface.tangential_displacement());
  proto->mutable_contacts()->Reserve(static_cast<int>(interface.size()));
  interface.SnapshotEach([&](std::size_t, const ContactSnapshot& contact) {
    ToProtoSnapshot(contact, proto->add_contacts());
  });
}

Status ApplyInterfaceStep(Interface& interface, const v1::Step& step, const Interrupt& interrupt,
                          const Interface::CommitGate& gate) {
  if (Status s = RefuseTwist(step); !s.ok()) return s;
  if (interface.kind() == InterfaceKind::kContactList) {
    return ApplyListStep(interface, step, interrupt, gate);
  }
  if (!step.contact_normal_values().empty() || !step.contact_tangential_values().empty()) {
    return InvalidArgument(
        step.contact_normal_values().empty() ? "contact_tangential_values"
                                             : "contact_normal_values",
        "must be empty for a KIND_SHARED_MOTION interface (the step's own values drive it)");
  }
  return interface.Apply(ToCoreStep(step), nullptr, interrupt, gate);
}

bool MovesEveryContactOnce(const Interface& interface, const v1::Step& step) {
  return interface.kind() == InterfaceKind::kSharedMotion ||
         (step.normal_case() != v1::Step::kNormalForce &&
          step.tangential_case() != v1::Step::kTangentialForce);
}

Status CheckSingleContactStep(const v1::Step& step) {
  if (step.contact_normal_values().empty() && step.contact_tangential_values().empty()) {
    return OkStatus();
  }
  return InvalidArgument(
      step.contact_normal_values().empty() ? "contact_tangential_values" : "contact_normal_values",
      "must be empty: per-contact values are for KIND_CONTACT_LIST interface sessions");
}

void WriteInterfaceState(const Interface& interface, std::uint64_t applied_steps,
                         const OutputSelection& selection, v1::ContactState* state) {
  const bool shared = interface.kind() == InterfaceKind::kSharedMotion;
  if (selection.has(Output::kDepth)) state->set_depth(shared ? interface.approach() : 0.0);
  if (selection.has(Output::kTangentialDisplacement)) {
    state->set_tangential_displacement(shared ? interface.tangential_displacement() : 0.0);
  }
  // No rig in series with an interface: the actuator is where the shared motion is.
  if (selection.has(Output::kActuatorDepth)) {
    state->set_actuator_depth(shared ? interface.approach() : 0.0);
  }
  if (selection.has(Output::kActuatorDisplacement)) {
    state->set_actuator_displacement(shared ? interface.tangential_displacement() : 0.0);
  }
  if (selection.has(Output::kContactRadius)) state->set_contact_radius(0);
  if (selection.has(Output::kNormalForce) || selection.has(Output::kTangentialForce) ||
      selection.has(Output::kDissipatedEnergy) || selection.has(Output::kFrictionLimit)) {
    const Interface::ForceSums sums = SumStateFields(interface, selection);
    if (selection.has(Output::kNormalForce)) state->set_normal_force(sums.normal_force);
    if (selection.has(Output::kTangentialForce)) state->set_tangential_force(sums.tangential_force);
    if (selection.has(Output::kDissipatedEnergy)) {
      state->set_dissipated_energy(sums.dissipated_energy);
    }
    if (selection.has(Output::kFrictionLimit)) state->set_friction_limit(sums.friction_limit);
  }
  if (selection.has(Output::kAppliedSteps)) state->set_applied_steps(applied_steps);
  if (selection.has(Output::kMemoryVertices)) {
    state->set_memory_vertices(interface.vertex_count());
  }
}

void WriteInterfaceStepResult(const Interface& interface, std::uint64_t applied_steps,
                              const OutputSelection& selection, v1::StepResult* result) {
  if (selection.any_state()) {
    WriteInterfaceState(interface, applied_steps, selection, result->mutable_state());
  }
  if (selection.has(Output::kSubsteps)) result->set_substeps(1);
  if (selection.has(Output::kPathError)) result->set_path_error(0);
  if (selection.has(Output::kStepResultDissipatedEnergy)) {
    double energy = 0;  // summed in index order, as Interface::Totals
    for (std::size_t i = 0; i < interface.size(); ++i) {
      energy += interface.contact_last_step_dissipation(i);
    }
    result->set_dissipated_energy(energy);
  }
}

Status WriteInterfaceQueryOutputs(const Interface& interface, std::uint64_t applied_steps,
                                  const OutputSelection& selection, const RadialSampling& sampling,
                                  const InterfaceQuery& query, v1::QueryResponse* response,
                                  OutputCounters* counters) {
  if (query.contact_index) {
    if (*query.contact_index >= interface.size()) {
      return InvalidArgument("contact_index", "must be in [0, " +
                                                  std::to_string(interface.size() - 1) +
                                                  "] (the interface's contacts), got " +
                                                  std::to_string(*query.contact_index));
    }
    if (Status status = WriteQueryOutputs(interface.contact(*query.contact_index), applied_steps,
                                          selection, sampling, response, counters);
        !status.ok()) {
      return status;
    }
  } else if (AnyContactOutput(selection)) {
    return InvalidArgument("contact_index",
                           "required: read_mask selects outputs of one contact (only \"state\" "
                           "and \"interface.*\" describe the whole interface)");
  } else {
    if (selection.any_state()) {
      WriteInterfaceState(interface, applied_steps, selection, response->mutable_state());
    }
    response->mutable_error_estimate();
  }
  if (!selection.any_interface()) return OkStatus();
  return WriteInterfaceOutputs(interface, selection, query, response->mutable_interface(),
                               counters);
}

Status CheckSingleContactQuery(const OutputSelection& selection, const InterfaceQuery& query) {
  if (query.contact_index) {
    return InvalidArgument("contact_index", "must be unset: the session is a single contact");
  }
  if (selection.any_interface()) {
    return FailedPrecondition(
        "read_mask", "\"interface.*\" outputs need an interface session (scene.interface)");
  }
  return OkStatus();
}

}  // namespace mdr::bridge
