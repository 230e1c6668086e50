#include "mdr/bridge/analysis_ops.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "mdr/analysis/exact_loops.h"
#include "mdr/analysis/identify.h"
#include "mdr/analysis/loops.h"
#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/torsion_session.h"

namespace mdr::bridge {
namespace {

using analysis::CycleMetrics;
using analysis::LoopFigures;

// The scene of a single contact, converted as a session's (errors name "scene...").
Result<ContactConfig> AnalysisScene(const v1::Scene& scene, std::size_t max_memory_vertices,
                                    const Interrupt& interrupt) {
  if (scene.has_interface()) {
    return InvalidArgument("scene.interface", "must be unset: the loop analysis is of one contact");
  }
  return ToContactConfig(scene, max_memory_vertices, interrupt);
}

bool IsTorsional(const v1::LoopSamples& s) {
  return s.twist_size() > 0 || s.twisting_moment_size() > 0;
}

// A record is tangential or torsional, not both (errors name the first column of the other pair).
Status CheckChannel(const v1::LoopSamples& s) {
  if (IsTorsional(s) && (s.displacement_size() > 0 || s.tangential_force_size() > 0)) {
    return InvalidArgument("twist",
                           "a record is tangential (displacement, tangential_force) or torsional "
                           "(twist, twisting_moment), not both");
  }
  return OkStatus();
}

std::size_t SampleCount(const v1::LoopSamples& s) {
  return static_cast<std::size_t>(IsTorsional(s) ? s.twist_size() : s.displacement_size());
}

analysis::LoopSamples ToCore(const v1::LoopSamples& s) {
  analysis::LoopSamples core;
  if (IsTorsional(s)) {
    core.channel = analysis::LoopChannel::kTorsional;
    core.displacement.assign(s.twist().begin(), s.twist().end());
    core.tangential_force.assign(s.twisting_moment().begin(), s.twisting_moment().end());
  } else {
    core.displacement.assign(s.displacement().begin(), s.displacement().end());
    core.tangential_force.assign(s.tangential_force().begin(), s.tangential_force().end());
  }
  core.normal_force.assign(s.normal_force().begin(), s.normal_force().end());
  core.time.assign(s.time().begin(), s.time().end());
  return core;
}

// The torsional scene of a request (errors name "scene...").
Result<analysis::TorsionalScene> AnalysisTorsionalScene(const v1::Scene& scene,
                                                        std::size_t max_memory_vertices,
                                                        const Interrupt& interrupt) {
  Result<ContactConfig> config = AnalysisScene(scene, max_memory_vertices, interrupt);
  if (!config.ok()) return config.status();
  return ToTorsionalScene(scene, *config);
}

analysis::LoopOptions ToCore(const v1::LoopAnalysisOptions& o) {
  analysis::LoopOptions core;
  core.reversal_threshold = o.reversal_threshold();
  core.displacement_resolution = o.displacement_resolution();
  if (o.has_rig_compliance()) core.rig_compliance = o.rig_compliance();
  if (o.has_normal_force()) core.normal_force = o.normal_force();
  if (o.has_closure_tolerance()) core.closure_tolerance = o.closure_tolerance();
  if (o.has_asymmetry_tolerance()) core.asymmetry_tolerance = o.asymmetry_tolerance();
  if (o.has_hook_tolerance()) core.hook_tolerance = o.hook_tolerance();
  if (o.has_drift_tolerance()) core.drift_tolerance = o.drift_tolerance();
  return core;
}

v1::Regime ToProto(analysis::Regime regime) {
  switch (regime) {
    case analysis::Regime::kSticking:
      return v1::REGIME_STICKING;
    case analysis::Regime::kPartialSlip:
      return v1::REGIME_PARTIAL_SLIP;
    case analysis::Regime::kGrossSlip:
      return v1::REGIME_GROSS_SLIP;
  }
  return v1::REGIME_UNSPECIFIED;
}

// A sample index or count as the proto's uint32: every request is checked against
// kMaxAnalyzedSamples first, which the static_assert keeps below 2^32.
static_assert(kMaxAnalyzedSamples <= std::numeric_limits<std::uint32_t>::max());
static_assert(kMaxFittedSamples <= kMaxAnalyzedSamples);
std::uint32_t SampleIndex(std::size_t index) { return static_cast<std::uint32_t>(index); }

void ToProto(const CycleMetrics& c, v1::CycleFigures* p) {
  p->set_first_sample(SampleIndex(c.first_sample));
  p->set_last_sample(SampleIndex(c.last_sample));
  p->set_lower_reversal(SampleIndex(c.lower_reversal));
  p->set_start_time(c.start_time);
  p->set_force_amplitude(c.force_amplitude);
  p->set_force_offset(c.force_offset);
  p->set_dissipated_energy(c.dissipated_energy);
  p->set_half_opening(c.half_opening);
  p->set_system_free_ratio(c.system_free_ratio);
  p->set_normal_force(c.normal_force);
  p->set_friction_coefficient(c.friction_coefficient);
  p->set_energy_friction_coefficient(c.energy_friction_coefficient);
  p->set_displacement_amplitude(c.displacement_amplitude);
  p->set_energy_ratio(c.energy_ratio);
  p->set_sliding_ratio(c.sliding_ratio);
  p->set_secant_stiffness(c.secant_stiffness);
  p->set_stiffness_increasing(c.stiffness_increasing);
  p->set_stiffness_decreasing(c.stiffness_decreasing);
  if (c.contact) {
    v1::ContactFigures* contact = p->mutable_contact();
    contact->set_displacement_amplitude(c.contact->displacement_amplitude);
    contact->set_energy_ratio(c.contact->energy_ratio);
    contact->set_sliding_ratio(c.contact->sliding_ratio);
    contact->set_secant_stiffness(c.contact->secant_stiffness);
    contact->set_stiffness_increasing(c.contact->stiffness_increasing);
    contact->set_stiffness_decreasing(c.contact->stiffness_decreasing);
  }
  v1::LoopFlags* flags = p->mutable_flags();
  flags->set_closure_error(c.flags.closure_error);
  flags->set_not_closed(c.flags.not_closed);
  flags->set_asymmetry(c.flags.asymmetry);
  flags->set_asymmetric(c.flags.asymmetric);
  flags->set_hook_ratio(c.flags.hook_ratio);
  flags->set_hooked(c.flags.hooked);
}

void ToProto(const LoopFigures& f, v1::LoopFigures* p) {
  p->set_normal_force(f.normal_force);
  p->set_force_amplitude(f.force_amplitude);
  p->set_dissipated_energy(f.dissipated_energy);
  p->set_half_opening(f.half_opening);
  p->set_contact_amplitude(f.contact_amplitude);
  p->set_actuator_amplitude(f.actuator_amplitude);
  p->set_energy_ratio(f.energy_ratio);
  p->set_sliding_ratio(f.sliding_ratio);
  p->set_contact_energy_ratio(f.contact_energy_ratio);
  p->set_contact_sliding_ratio(f.contact_sliding_ratio);
  p->set_system_free_ratio(f.system_free_ratio);
  p->set_secant_stiffness(f.secant_stiffness);
  p->set_damping_ratio(f.damping_ratio);
}

v1::Measures ToProto(analysis::Measures measures) {
  return measures == analysis::Measures::kContact ? v1::MEASURES_CONTACT
                                                  : v1::MEASURES_CONTACT_AND_RIG;
}

// What each figure of CycleFigures (its doubles but the time stamp, and its contact figures)
// and the response's friction_drift measure.
void FillMeasures(v1::AnalyzeLoopsResponse* response) {
  auto* measures = response->mutable_measures();
  const google::protobuf::Descriptor* cycle = v1::CycleFigures::descriptor();
  for (int i = 0; i < cycle->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* field = cycle->field(i);
    if (field->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) continue;
    if (field->name() == "start_time") continue;  // when, not what
    (*measures)[field->name()] = ToProto(analysis::MeasuresOf(field->name().c_str()));
  }
  (*measures)["friction_drift"] = ToProto(analysis::MeasuresOf("friction_drift"));
  const google::protobuf::Descriptor* contact = v1::ContactFigures::descriptor();
  for (int i = 0; i < contact->field_count(); ++i) {
    (*measures)["contact." + contact->field(i)->name()] = v1::MEASURES_CONTACT;
  }
}

Status CheckCount(const std::string& field, int count, int max) {
  if (count >= 1 && count <= max) return OkStatus();
  return count < 1
             ? InvalidArgument(field, "needs at least one value")
             : ResourceExhausted(field, "holds " + std::to_string(count) +
                                            " values, above the limit of " + std::to_string(max));
}

// The profile at a value of its scale, for PROFILE_SCALE: a sphere's radius or a power law's
// coefficient; its current value. Other profiles have no scale parameter here.
struct ProfileFamily {
  std::function<Result<ProfilePtr>(double)> make;
  double current;
};
std::optional<ProfileFamily> FamilyOf(const v1::Scene& scene) {
  if (scene.has_sphere())
    return ProfileFamily{[](double r) { return MakeSphere(r); }, scene.sphere().radius()};
  if (scene.has_power_law()) {
    const double n = scene.power_law().exponent();
    return ProfileFamily{[n](double c) { return MakePowerLaw(c, n); },
                         scene.power_law().coefficient()};
  }
  return std::nullopt;
}

// The exponent n of F_N ~ a^(n+1) for the compliance guess (power laws), or nothing.
std::optional<double> ExponentOf(const v1::Scene& scene) {
  if (scene.has_sphere()) return 2.0;
  if (scene.has_cone()) return 1.0;
  if (scene.has_power_law()) return scene.power_law().exponent();
  return std::nullopt;
}

analysis::Parameter ToCore(v1::FitParameter parameter) {
  switch (parameter) {
    case v1::FIT_PARAMETER_EFFECTIVE_MODULUS:
      return analysis::Parameter::kEffectiveModulus;
    case v1::FIT_PARAMETER_PROFILE_SCALE:
      return analysis::Parameter::kProfileScale;
    case v1::FIT_PARAMETER_RIG_COMPLIANCE:
      return analysis::Parameter::kRigCompliance;
    case v1::FIT_PARAMETER_DISPLACEMENT_OFFSET:
      return analysis::Parameter::kDisplacementOffset;
    case v1::FIT_PARAMETER_TORSIONAL_MODULUS:
      return analysis::Parameter::kTorsionalModulus;
    default:
      return analysis::Parameter::kFriction;
  }
}

// The request's scene with the fitted values written into it: moduli scaled together (kappa
// kept), the profile's scale, friction and the rig.
v1::Scene FittedScene(const v1::Scene& scene, const ContactConfig& start,
                      const analysis::FitResult& fit) {
  v1::Scene fitted = scene;
  for (const analysis::ParameterEstimate& e : fit.estimates) {
    switch (e.parameter) {
      case analysis::Parameter::kFriction:
        fitted.set_friction(e.value);
        break;
      case analysis::Parameter::kEffectiveModulus: {
        const double factor = e.value / start.material.e_star;
        if (fitted.has_rigid_on_half_space()) {
          auto* m = fitted.mutable_rigid_on_half_space();
          m->set_shear_modulus(m->shear_modulus() * factor);
        } else {
          auto* m = fitted.mutable_elastic_pair();
          m->set_youngs_modulus_1(m->youngs_modulus_1() * factor);
          m->set_youngs_modulus_2(m->youngs_modulus_2() * factor);
        }
        break;
      }
      case analysis::Parameter::kProfileScale:
        if (fitted.has_sphere()) {
          fitted.mutable_sphere()->set_radius(e.value);
        } else {
          fitted.mutable_power_law()->set_coefficient(e.value);
        }
        break;
      case analysis::Parameter::kRigCompliance:
        if (fitted.has_torsion()) {
          fitted.mutable_torsion()->set_rig_compliance(e.value);
        } else {
          fitted.mutable_rig()->set_tangential_compliance(e.value);
        }
        break;
      case analysis::Parameter::kTorsionalModulus:
        fitted.mutable_torsion()->set_torsional_modulus(e.value);
        break;
      case analysis::Parameter::kDisplacementOffset:
        break;  // not part of a scene
    }
  }
  return fitted;
}

v1::Nuisance ToProto(analysis::Nuisance nuisance) {
  switch (nuisance) {
    case analysis::Nuisance::kForceOffset:
      return v1::NUISANCE_FORCE_OFFSET;
    case analysis::Nuisance::kDisplacementOffset:
      return v1::NUISANCE_DISPLACEMENT_OFFSET;
    case analysis::Nuisance::kDisplacementDrift:
      return v1::NUISANCE_DISPLACEMENT_DRIFT;
    case analysis::Nuisance::kMovingMass:
      return v1::NUISANCE_MOVING_MASS;
  }
  return v1::NUISANCE_UNSPECIFIED;
}

void ToProto(const analysis::NuisanceEstimate& e, v1::NuisanceEstimate* out) {
  out->set_nuisance(ToProto(e.nuisance));
  if (e.set) out->set_set(SampleIndex(*e.set));
  out->set_value(e.value);
  out->set_standard_error(e.standard_error);
  out->set_lower_95(e.lower_95);
  out->set_upper_95(e.upper_95);
  out->set_identified(e.identified);
  out->mutable_effect()->Add(e.effect.begin(), e.effect.end());
}

void ToProto(const analysis::SetFit& s, v1::SetFit* out) {
  out->set_displacement_noise(s.displacement_noise);
  out->set_force_noise(s.force_noise);
  out->set_normal_force_noise(s.normal_force_noise);
  out->set_noise_estimated(s.noise_estimated);
  out->set_displacement_noise_correlation(s.displacement_noise_correlation);
  out->set_force_noise_correlation(s.force_noise_correlation);
  out->set_normal_force_measured(s.normal_force_measured);
  out->set_normal_force(s.normal_force);
  out->set_normal_force_min(s.normal_force_min);
  out->set_normal_force_max(s.normal_force_max);
  out->set_load_mismatch(s.load_mismatch);
  out->set_first_residual(SampleIndex(s.first_residual));
  out->set_residuals(SampleIndex(s.residuals));
  out->set_turning_points(SampleIndex(s.turning_points));
  out->set_turning_point_shift_rms(s.turning_point_shift_rms);
  out->set_gross_slip(s.gross_slip);
  out->set_residual_rms(s.residual_rms);
  out->set_reduced_chi_square(s.reduced_chi_square);
  out->set_autocorrelation(s.autocorrelation);
  out->set_structure_statistic(s.structure_statistic);
  out->set_structure_bins(s.structure_bins);
  out->set_structure_p_value(s.structure_p_value);
  out->set_misfit(s.misfit);
}

}  // namespace

Status RunAnalyzeLoops(const v1::AnalyzeLoopsRequest& request, std::size_t max_memory_vertices,
                       const Interrupt& interrupt, v1::AnalyzeLoopsResponse* response) {
  if (Status s = CheckChannel(request.samples()); !s.ok()) return s.WithFieldPrefix("samples");
  const bool torsional = IsTorsional(request.samples());
  const std::size_t samples = SampleCount(request.samples());
  if (samples > kMaxAnalyzedSamples) {
    return ResourceExhausted(torsional ? "samples.twist" : "samples.displacement",
                             std::to_string(samples) + " samples exceed the limit of " +
                                 std::to_string(kMaxAnalyzedSamples));
  }
  // A torsional record is classified against a torsional scene, a tangential one against the
  // tangential contact.
  std::optional<ContactConfig> scene;
  std::optional<analysis::TorsionalScene> torsion;
  if (request.has_scene()) {
    if (request.scene().has_torsion() != torsional) {
      return InvalidArgument("scene.torsion",
                             torsional ? "is required to classify a torsional record (twist, "
                                         "twisting_moment): the scene's torsional contact"
                                       : "must be unset to classify a tangential record "
                                         "(displacement, tangential_force)");
    }
    if (torsional) {
      Result<analysis::TorsionalScene> config =
          AnalysisTorsionalScene(request.scene(), max_memory_vertices, interrupt);
      if (!config.ok()) return config.status();
      torsion = std::move(config).value();
    } else {
      Result<ContactConfig> config =
          AnalysisScene(request.scene(), max_memory_vertices, interrupt);
      if (!config.ok()) return config.status();
      scene = std::move(config).value();
    }
  }
  const analysis::LoopOptions options = ToCore(request.options());
  if (Status s = analysis::ValidateLoopOptions(options); !s.ok()) {
    return s.WithFieldPrefix("options");
  }
  Result<analysis::LoopAnalysis> loops =
      analysis::AnalyzeLoops(ToCore(request.samples()), options, interrupt);
  if (!loops.ok()) {
    const Status& s = loops.status();  // the options passed: a field here is the samples'
    return s.field().empty() ? s : s.WithFieldPrefix("samples");
  }
  response->set_reversal_threshold(loops->reversal_threshold);
  for (const std::size_t reversal : loops->reversals)
    response->add_reversals(SampleIndex(reversal));
  response->set_friction_drift(loops->friction_drift);
  response->set_friction_drifts(loops->friction_drifts);
  for (const CycleMetrics& cycle : loops->cycles) {
    v1::CycleFigures* figures = response->add_cycles();
    ToProto(cycle, figures);
    if (!scene && !torsion) continue;
    if (!(cycle.normal_force > 0)) {
      return FailedPrecondition("options.normal_force",
                                "the scene classifies each cycle at its normal force: give "
                                "normal_force samples or options.normal_force");
    }
    if (torsion) {
      Result<double> slip = analysis::FullSlipMoment(*torsion, cycle.normal_force);
      if (!slip.ok()) return ToSceneStatus(slip.status());
      figures->set_regime(ToProto(analysis::ClassifyTorsionalCycle(cycle, *slip)));
      figures->set_full_slip_moment(*slip);
      continue;
    }
    Result<LoopFigures> onset = analysis::GrossSlipOnset(*scene, cycle.normal_force, interrupt);
    if (!onset.ok()) return ToSceneStatus(onset.status());
    figures->set_regime(ToProto(analysis::ClassifyCycle(cycle, *onset)));
    figures->set_onset_system_free_ratio(onset->system_free_ratio);
  }
  FillMeasures(response);
  return OkStatus();
}

Status RunFitLoops(const v1::FitLoopsRequest& request, std::size_t max_memory_vertices,
                   const Interrupt& interrupt,
                   const std::function<void(const v1::FitProgress&)>& progress,
                   v1::FitResult* result) {
  if (Status s = CheckCount("sets", request.sets_size(), kMaxLoopSets); !s.ok()) return s;
  std::size_t samples = 0;
  for (int k = 0; k < request.sets_size(); ++k) {
    const v1::LoopSamples& set = request.sets(k).samples();
    if (Status s = CheckChannel(set); !s.ok()) {
      return s.WithFieldPrefix(Indexed("sets", static_cast<std::size_t>(k)) + ".samples");
    }
    samples += SampleCount(set);
  }
  if (samples > kMaxFittedSamples) {
    return ResourceExhausted("sets", std::to_string(samples) + " samples exceed the limit of " +
                                         std::to_string(kMaxFittedSamples) + " for a fit");
  }
  if (request.max_iterations() < 0 || request.max_iterations() > kMaxFitIterations) {
    return InvalidArgument("max_iterations", "must be in [0, " + std::to_string(kMaxFitIterations) +
                                                 "], got " +
                                                 std::to_string(request.max_iterations()));
  }
  Result<ContactConfig> scene = AnalysisScene(request.scene(), max_memory_vertices, interrupt);
  if (!scene.ok()) return scene.status();
  const std::optional<ProfileFamily> family = FamilyOf(request.scene());
  analysis::FitOptions options;
  if (request.scene().has_torsion()) {
    Result<analysis::TorsionalScene> torsion = ToTorsionalScene(request.scene(), *scene);
    if (!torsion.ok()) return torsion.status();
    options.torsion = analysis::TorsionalFitScene{.torsional_modulus = torsion->torsional_modulus,
                                                  .rig_compliance = torsion->rig_compliance};
  }
  for (int k = 0; k < request.free_size(); ++k) {
    const auto& free = request.free(k);
    const std::string field = Indexed("free", static_cast<std::size_t>(k));
    if (free.parameter() == v1::FIT_PARAMETER_UNSPECIFIED ||
        !v1::FitParameter_IsValid(free.parameter())) {
      return InvalidArgument(field + ".parameter", "must be one of the FitParameter values");
    }
    analysis::FreeParameter core{ToCore(free.parameter()), std::nullopt, free.lower(),
                                 free.upper()};
    if (free.has_initial()) core.initial = free.initial();
    if (core.parameter == analysis::Parameter::kProfileScale) {
      if (!family) {
        return InvalidArgument(field + ".parameter",
                               "PROFILE_SCALE needs a sphere (its radius) or a power law (its "
                               "coefficient) in the scene");
      }
      options.profile_family = family->make;
      if (!core.initial) core.initial = family->current;
    }
    options.free.push_back(core);
  }
  if (request.has_burn_in_reversals()) options.burn_in_reversals = request.burn_in_reversals();
  if (options.burn_in_reversals < 0) {
    return InvalidArgument("burn_in_reversals",
                           "must be >= 0, got " + std::to_string(options.burn_in_reversals));
  }
  options.reversal_threshold = request.reversal_threshold();
  options.nuisances.force_offset = request.nuisances().force_offset();
  options.nuisances.displacement_drift = request.nuisances().displacement_drift();
  options.nuisances.moving_mass = request.nuisances().moving_mass();
  if (request.has_displacement_noise()) options.displacement_noise = request.displacement_noise();
  if (request.has_force_noise()) options.force_noise = request.force_noise();
  options.keep_models = request.include_models();
  options.threads = 1;  // the call's own worker: concurrency comes from the pool, not from a call
  if (request.max_iterations() > 0) options.max_iterations = request.max_iterations();
  std::vector<analysis::LoopSet> sets;
  for (const auto& set : request.sets()) {
    analysis::LoopSet core{ToCore(set.samples()), std::nullopt};
    if (set.has_normal_force()) core.normal_force = set.normal_force();
    sets.push_back(std::move(core));
  }
  Result<analysis::FitResult> fit =
      analysis::FitLoops(*scene, sets, options, interrupt,
                         [&](int iteration, double rms, const std::vector<double>& v) {
                           v1::FitProgress message;
                           message.set_iteration(iteration);
                           message.set_residual_rms(rms);
                           message.mutable_values()->Add(v.begin(), v.end());
                           progress(message);
                         });
  if (!fit.ok()) {
    const Status& s = fit.status();
    return s.field().rfind("scene", 0) == 0 ? ToSceneStatus(s) : s;
  }
  for (const analysis::ParameterEstimate& e : fit->estimates) {
    v1::ParameterEstimate* out = result->add_estimates();
    out->set_parameter(request.free(static_cast<int>(result->estimates_size() - 1)).parameter());
    out->set_value(e.value);
    out->set_standard_error(e.standard_error);
    out->set_lower_95(e.lower_95);
    out->set_upper_95(e.upper_95);
    out->set_identified(e.identified);
    out->set_interval(e.interval == analysis::IntervalMethod::kWald
                          ? v1::INTERVAL_METHOD_WALD
                          : v1::INTERVAL_METHOD_HALF_CYCLE_SANDWICH);
  }
  for (const analysis::NuisanceEstimate& e : fit->nuisances) ToProto(e, result->add_nuisances());
  for (const analysis::SetFit& s : fit->sets) ToProto(s, result->add_sets());
  for (analysis::SetModel& m : fit->models) {
    v1::SetModel* out = result->add_models();
    out->mutable_actuator_path()->Add(m.actuator_path.begin(), m.actuator_path.end());
    out->mutable_normal_force()->Add(m.normal_force.begin(), m.normal_force.end());
    out->mutable_contact_force()->Add(m.contact_force.begin(), m.contact_force.end());
    out->mutable_predicted_force()->Add(m.predicted_force.begin(), m.predicted_force.end());
  }
  result->set_parameters(SampleIndex(fit->parameters));
  result->set_reduced_chi_square(fit->reduced_chi_square);
  result->set_adequate(fit->adequate);
  for (const std::vector<double>& row : fit->correlation) {
    result->mutable_correlation()->Add(row.begin(), row.end());
  }
  result->set_residual_rms(fit->residual_rms);
  result->set_residuals(SampleIndex(fit->residuals));
  result->set_iterations(fit->iterations);
  result->set_converged(fit->converged);
  result->set_condition_number(fit->condition_number);
  result->mutable_weakest_combination()->Add(fit->weakest_combination.begin(),
                                             fit->weakest_combination.end());
  result->set_identified(fit->identified);
  for (const std::string& note : fit->notes) result->add_notes(note);
  *result->mutable_fitted_scene() = FittedScene(request.scene(), *scene, *fit);
  std::set<double> loads;
  for (const analysis::SetFit& set : fit->sets) loads.insert(set.normal_force);
  if (const std::optional<double> n = ExponentOf(request.scene());
      n && loads.size() >= 2 && !options.torsion) {
    Result<analysis::ComplianceGuess> guess =
        analysis::GuessRigCompliance(sets, *n, options.reversal_threshold);
    if (guess.ok()) {
      result->set_guessed_rig_compliance(guess->rig_compliance);
      if (std::isfinite(guess->standard_error)) {
        result->set_guessed_rig_compliance_error(guess->standard_error);
      }
    }
  }
  return OkStatus();
}

Status RunFrettingMap(const v1::FrettingMapRequest& request, std::size_t max_memory_vertices,
                      const Interrupt& interrupt, v1::FrettingMapResponse* response) {
  if (Status s = CheckCount("normal_forces", request.normal_forces_size(), kMaxMapForces);
      !s.ok()) {
    return s;
  }
  if (Status s =
          CheckCount("relative_amplitudes", request.relative_amplitudes_size(), kMaxMapAmplitudes);
      !s.ok()) {
    return s;
  }
  if (request.scene().has_torsion()) {
    return InvalidArgument("scene.torsion",
                           "must be unset: a twisted contact of a smooth profile never slides as a "
                           "whole at a finite twist, so it has no onset of gross slip to map (its "
                           "loops: Backbone with scene.torsion)");
  }
  Result<ContactConfig> scene = AnalysisScene(request.scene(), max_memory_vertices, interrupt);
  if (!scene.ok()) return scene.status();
  Result<std::vector<analysis::FrettingMapLoad>> map = analysis::FrettingMap(
      *scene, {request.normal_forces().begin(), request.normal_forces().end()},
      {request.relative_amplitudes().begin(), request.relative_amplitudes().end()}, interrupt);
  if (!map.ok()) {
    return map.status().field() == "friction" ? ToSceneStatus(map.status()) : map.status();
  }
  for (const analysis::FrettingMapLoad& load : *map) {
    v1::FrettingMapResponse::Load* out = response->add_loads();
    ToProto(load.onset, out->mutable_onset());
    for (const LoopFigures& loop : load.loops) ToProto(loop, out->add_loops());
    for (analysis::Regime regime : load.regimes) out->add_regimes(ToProto(regime));
  }
  return OkStatus();
}

Status RunBackbone(const v1::BackboneRequest& request, std::size_t max_memory_vertices,
                   const Interrupt& interrupt, v1::BackboneResponse* response) {
  if (Status s = CheckCount("amplitudes", request.amplitudes_size(), kMaxBackboneAmplitudes);
      !s.ok()) {
    return s;
  }
  if (request.kind() != v1::BackboneRequest::AMPLITUDE_KIND_FORCE &&
      request.kind() != v1::BackboneRequest::AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT) {
    return InvalidArgument("kind",
                           "must be AMPLITUDE_KIND_FORCE or "
                           "AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT");
  }
  const analysis::AmplitudeKind kind = request.kind() == v1::BackboneRequest::AMPLITUDE_KIND_FORCE
                                           ? analysis::AmplitudeKind::kForce
                                           : analysis::AmplitudeKind::kActuatorDisplacement;
  const std::vector<double> amplitudes(request.amplitudes().begin(), request.amplitudes().end());
  Result<std::vector<LoopFigures>> backbone = std::vector<LoopFigures>{};
  if (request.scene().has_torsion()) {
    Result<analysis::TorsionalScene> scene =
        AnalysisTorsionalScene(request.scene(), max_memory_vertices, interrupt);
    if (!scene.ok()) return scene.status();
    backbone = analysis::TorsionalBackbone(*scene, request.normal_force(), kind, amplitudes,
                                           interrupt);
  } else {
    Result<ContactConfig> scene = AnalysisScene(request.scene(), max_memory_vertices, interrupt);
    if (!scene.ok()) return scene.status();
    backbone = analysis::Backbone(*scene, request.normal_force(), kind, amplitudes, interrupt);
  }
  if (!backbone.ok()) return backbone.status();
  for (const LoopFigures& loop : *backbone) ToProto(loop, response->add_loops());
  return OkStatus();
}

}  // namespace mdr::bridge
