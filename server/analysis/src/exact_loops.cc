#include "mdr/analysis/exact_loops.h"

#include <cmath>
#include <numbers>
#include <string>

#include "mdr/base/validate.h"

namespace mdr::analysis {
namespace {

Step NormalForceStep(double force) {
  Step s;
  s.normal = NormalControl::kForce;
  s.normal_value = force;
  return s;
}

// A step of the tangential channel to +-amplitude (the normal channel holds).
Step TangentialStep(AmplitudeKind kind, double target) {
  Step s;
  s.tangential =
      kind == AmplitudeKind::kForce ? TangentialControl::kForce : TangentialControl::kDisplacement;
  s.tangential_value = target;
  return s;
}

// The actuator displacement where the branch from this state reaches F_x = 0 (a copy steps
// there: force control, exact at constant normal force).
Result<double> ZeroForceDisplacement(Contact contact) {
  if (Status s = contact.Apply(TangentialStep(AmplitudeKind::kForce, 0)); !s.ok()) return s;
  return contact.actuator_displacement();
}

// The loops of `amplitudes` in order (loop_at(amplitude) -> Result<LoopFigures>); an error of
// the amplitude names its index in "amplitudes".
template <typename LoopAt>
Result<std::vector<LoopFigures>> BackboneOf(const std::vector<double>& amplitudes,
                                            const LoopAt& loop_at) {
  std::vector<LoopFigures> backbone;
  for (std::size_t k = 0; k < amplitudes.size(); ++k) {
    Result<LoopFigures> loop = loop_at(amplitudes[k]);
    if (!loop.ok()) {
      return loop.status().field() == "amplitude"
                 ? Status(loop.status().code(), Indexed("amplitudes", k), loop.status().message())
                 : loop.status();
    }
    backbone.push_back(*loop);
  }
  return backbone;
}

// Ratio that is 0 where its denominator is (a loop without width or amplitude).
double Ratio(double numerator, double denominator) {
  return denominator > 0 ? numerator / denominator : 0;
}

LoopFigures Figures(double normal_force, double force_amplitude, double energy, double half_opening,
                    double contact_amplitude, double actuator_amplitude) {
  LoopFigures f;
  f.normal_force = normal_force;
  f.force_amplitude = force_amplitude;
  f.dissipated_energy = energy;
  f.half_opening = half_opening;
  f.contact_amplitude = contact_amplitude;
  f.actuator_amplitude = actuator_amplitude;
  f.energy_ratio = Ratio(energy, 4 * actuator_amplitude * force_amplitude);
  f.sliding_ratio = Ratio(half_opening, actuator_amplitude);
  f.contact_energy_ratio = Ratio(energy, 4 * contact_amplitude * force_amplitude);
  f.contact_sliding_ratio = Ratio(half_opening, contact_amplitude);
  f.system_free_ratio = Ratio(energy, 4 * half_opening * force_amplitude);
  f.secant_stiffness = Ratio(force_amplitude, actuator_amplitude);
  f.damping_ratio = Ratio(energy, 2 * std::numbers::pi * force_amplitude * actuator_amplitude);
  return f;
}

}  // namespace

Result<LoopFigures> ExactLoop(const ContactConfig& scene, double normal_force, AmplitudeKind kind,
                              double amplitude, const Interrupt& interrupt) {
  if (Status s = RequirePositive("normal_force", normal_force); !s.ok()) return s;
  if (Status s = RequirePositive("amplitude", amplitude); !s.ok()) return s;
  Result<Contact> created = Contact::Create(scene);
  if (!created.ok()) return created.status();
  Contact c = std::move(created).value();
  if (Status s = c.Apply(NormalForceStep(normal_force)); !s.ok()) return s;
  if (kind == AmplitudeKind::kForce && amplitude > c.friction_limit()) {
    return InvalidArgument("amplitude", "a force amplitude must be in (0, mu F_N = " +
                                            FormatNumber(c.friction_limit()) + " N], got " +
                                            FormatNumber(amplitude) + " N");
  }
  // A step the engine refuses (its forces or displacements beyond its ranges) is the amplitude's
  // doing, at this normal force: named so, not by the engine's internal step field.
  auto step = [&](double target) {
    const Status s = c.Apply(TangentialStep(kind, target));
    if (s.ok() || s.code() != StatusCode::kInvalidArgument) return s;
    return InvalidArgument("amplitude", "the loop of amplitude " + FormatNumber(amplitude) +
                                            " at F_N = " + FormatNumber(normal_force) +
                                            " N cannot be followed (" + s.field() + ": " +
                                            s.message() + ")");
  };
  // The virgin loading and one reversal make the loop steady: the cycle -a -> +a -> -a repeats.
  for (double target : {amplitude, -amplitude}) {
    if (Status s = step(target); !s.ok()) return s;
  }
  if (Status s = interrupt.Check(); !s.ok()) return s;
  const double energy_at_start = c.dissipated_energy();
  const Contact lower = c;
  if (Status s = step(amplitude); !s.ok()) return s;
  const Contact upper = c;
  if (Status s = step(-amplitude); !s.ok()) return s;
  const double energy = c.dissipated_energy() - energy_at_start;
  // The branches cross F_x = 0 at the upper reversal's way down and the lower one's way up.
  Result<double> down = ZeroForceDisplacement(upper), up = ZeroForceDisplacement(lower);
  if (!down.ok()) return down.status();
  if (!up.ok()) return up.status();
  const double force_amplitude = 0.5 * (upper.tangential_force() - lower.tangential_force());
  return Figures(normal_force, force_amplitude, energy, 0.5 * (*down - *up),
                 0.5 * (upper.tangential_displacement() - lower.tangential_displacement()),
                 0.5 * (upper.actuator_displacement() - lower.actuator_displacement()));
}

Result<LoopFigures> GrossSlipOnset(const ContactConfig& scene, double normal_force,
                                   const Interrupt& interrupt) {
  if (!(scene.friction > 0)) {
    return FailedPrecondition("friction", "the onset of gross slip needs friction > 0");
  }
  Result<Contact> contact = Contact::Create(scene);
  if (!contact.ok()) return contact.status();
  if (Status s = RequirePositive("normal_force", normal_force); !s.ok()) return s;
  Result<LoopFigures> onset = ExactLoop(
      scene, normal_force, AmplitudeKind::kForce,
      scene.friction * contact->NormalForceAtDepth(contact->DepthAtNormalForce(normal_force)),
      interrupt);
  // Its amplitude is mu F_N: a refused amplitude is the normal force's.
  if (!onset.ok() && onset.status().field() == "amplitude") {
    return Status(onset.status().code(), "normal_force",
                  "the onset of gross slip at it cannot be computed: " + onset.status().message());
  }
  return onset;
}

const char* RegimeName(Regime regime) {
  switch (regime) {
    case Regime::kSticking:
      return "sticking";
    case Regime::kPartialSlip:
      return "partial slip";
    case Regime::kGrossSlip:
      return "gross slip";
  }
  return "unknown";
}

Regime ClassifyCycle(const CycleMetrics& cycle, const LoopFigures& onset) {
  if (!cycle.opening_resolved || !(cycle.dissipated_energy > 0)) return Regime::kSticking;
  if (onset.system_free_ratio > 0) {
    return cycle.system_free_ratio >= onset.system_free_ratio ? Regime::kGrossSlip
                                                              : Regime::kPartialSlip;
  }
  // No partial-slip loop (a flat punch): a loop with width slides.
  return Regime::kGrossSlip;
}

Result<std::vector<FrettingMapLoad>> FrettingMap(const ContactConfig& scene,
                                                 const std::vector<double>& normal_forces,
                                                 const std::vector<double>& relative_amplitudes,
                                                 const Interrupt& interrupt) {
  for (std::size_t k = 0; k < relative_amplitudes.size(); ++k) {
    if (Status s = RequireInRange(Indexed("relative_amplitudes", k), relative_amplitudes[k], 0, 100,
                                  /*lo_open=*/true);
        !s.ok()) {
      return s;
    }
  }
  std::vector<FrettingMapLoad> map;
  for (std::size_t i = 0; i < normal_forces.size(); ++i) {
    Result<LoopFigures> onset = GrossSlipOnset(scene, normal_forces[i], interrupt);
    if (!onset.ok()) {
      const Status& s = onset.status();
      return s.field() == "normal_force"
                 ? Status(s.code(), Indexed("normal_forces", i), s.message())
                 : s;
    }
    FrettingMapLoad load{*onset, {}, {}};
    for (double relative : relative_amplitudes) {
      Result<LoopFigures> loop =
          ExactLoop(scene, normal_forces[i], AmplitudeKind::kActuatorDisplacement,
                    relative * onset->actuator_amplitude, interrupt);
      if (!loop.ok()) {
        const Status& s = loop.status();  // the amplitude follows from the load's onset
        return s.field() == "amplitude" || s.field() == "normal_force"
                   ? Status(s.code(), Indexed("normal_forces", i), s.message())
                   : s;
      }
      load.loops.push_back(*loop);
      load.regimes.push_back(relative < 1 ? Regime::kPartialSlip : Regime::kGrossSlip);
    }
    map.push_back(std::move(load));
  }
  return map;
}

Result<std::vector<LoopFigures>> Backbone(const ContactConfig& scene, double normal_force,
                                          AmplitudeKind kind, const std::vector<double>& amplitudes,
                                          const Interrupt& interrupt) {
  return BackboneOf(amplitudes, [&](double amplitude) {
    return ExactLoop(scene, normal_force, kind, amplitude, interrupt);
  });
}

// ---- Torsional loops ---------------------------------------------------------------------------

Result<TorsionalContact> PressTorsionalContact(const TorsionalScene& scene, double normal_force) {
  if (Status s = RequireNonNegative("rig_compliance", scene.rig_compliance); !s.ok()) return s;
  if (Status s = RequireFinite("rig_compliance", scene.rig_compliance); !s.ok()) return s;
  if (Status s = RequirePositive("normal_force", normal_force); !s.ok()) return s;
  Result<TorsionalContact> created = TorsionalContact::Create(
      scene.profile, scene.friction, scene.effective_modulus, scene.torsional_modulus);
  if (!created.ok()) return created.status();
  TorsionalContact contact = std::move(created).value();
  TorsionStep press;
  press.normal = NormalControl::kForce;
  press.normal_value = normal_force;
  if (Status s = contact.Apply(press); !s.ok()) {
    return Status(s.code(), "normal_force", s.message());
  }
  return contact;
}

Result<double> FullSlipMoment(const TorsionalScene& scene, double normal_force) {
  Result<TorsionalContact> contact = PressTorsionalContact(scene, normal_force);
  if (!contact.ok()) return contact.status();
  return contact->memory().FullSlipMoment();
}

namespace {

// The actuator's twist of a torsional state: the contact's and the rig's.
double ActuatorTwist(const TorsionalContact& c, double compliance) {
  return c.memory().twist() + compliance * c.memory().Moment();
}

// The twist where the branch from this state reaches M = 0 (the rig unloaded there).
Result<double> ZeroMomentTwist(TorsionalContact contact) {
  TorsionStep step;
  step.twist = TwistControl::kMoment;
  step.twist_value = 0;
  if (Status s = contact.Apply(step); !s.ok()) return s;
  return contact.memory().twist();
}

}  // namespace

Result<LoopFigures> ExactTorsionalLoop(const TorsionalScene& scene, double normal_force,
                                       AmplitudeKind kind, double amplitude,
                                       const Interrupt& interrupt) {
  if (Status s = RequirePositive("amplitude", amplitude); !s.ok()) return s;
  Result<TorsionalContact> pressed = PressTorsionalContact(scene, normal_force);
  if (!pressed.ok()) return pressed.status();
  TorsionalContact c = std::move(pressed).value();
  const double limit = c.memory().FullSlipMoment();
  if (kind == AmplitudeKind::kForce && !(amplitude < limit)) {
    return InvalidArgument("amplitude",
                           "a moment amplitude must be in (0, M_slip = " + FormatNumber(limit) +
                               " N m), the full-slip moment that only an infinite twist reaches; "
                               "got " + FormatNumber(amplitude) + " N m");
  }
  auto step = [&](double target) {
    Status s;
    if (kind == AmplitudeKind::kForce) {
      TorsionStep twist;
      twist.twist = TwistControl::kMoment;
      twist.twist_value = target;
      s = c.Apply(twist);
    } else {
      s = c.TwistThroughCompliance(target, scene.rig_compliance);
    }
    if (s.ok() || s.code() != StatusCode::kInvalidArgument) return s;
    return InvalidArgument("amplitude", "the torsional loop of amplitude " +
                                            FormatNumber(amplitude) + " at F_N = " +
                                            FormatNumber(normal_force) +
                                            " N cannot be followed (" + s.field() + ": " +
                                            s.message() + ")");
  };
  // The virgin twist and one reversal make the loop steady (Masing at constant load).
  for (double target : {amplitude, -amplitude}) {
    if (Status s = step(target); !s.ok()) return s;
  }
  if (Status s = interrupt.Check(); !s.ok()) return s;
  const double energy_at_start = c.memory().dissipated_energy();
  const TorsionalContact lower = c;
  if (Status s = step(amplitude); !s.ok()) return s;
  const TorsionalContact upper = c;
  if (Status s = step(-amplitude); !s.ok()) return s;
  const double energy = c.memory().dissipated_energy() - energy_at_start;
  Result<double> down = ZeroMomentTwist(upper), up = ZeroMomentTwist(lower);
  if (!down.ok()) return down.status();
  if (!up.ok()) return up.status();
  const double moment_amplitude = 0.5 * (upper.memory().Moment() - lower.memory().Moment());
  return Figures(normal_force, moment_amplitude, energy, 0.5 * (*down - *up),
                 0.5 * (upper.memory().twist() - lower.memory().twist()),
                 0.5 * (ActuatorTwist(upper, scene.rig_compliance) -
                        ActuatorTwist(lower, scene.rig_compliance)));
}

Regime ClassifyTorsionalCycle(const CycleMetrics& cycle, double full_slip_moment) {
  if (!cycle.opening_resolved || !(cycle.dissipated_energy > 0)) return Regime::kSticking;
  return cycle.force_amplitude >= full_slip_moment ? Regime::kGrossSlip : Regime::kPartialSlip;
}

Result<std::vector<LoopFigures>> TorsionalBackbone(const TorsionalScene& scene,
                                                   double normal_force, AmplitudeKind kind,
                                                   const std::vector<double>& amplitudes,
                                                   const Interrupt& interrupt) {
  return BackboneOf(amplitudes, [&](double amplitude) {
    return ExactTorsionalLoop(scene, normal_force, kind, amplitude, interrupt);
  });
}

}  // namespace mdr::analysis
