// Exact fretting loops of a scene, computed by the engine (issue #24; docs/analysis.md, "Regimes,
// thresholds and maps"): the loop figures of a steady Mindlin-Deresiewicz cycle at constant
// normal force, through the scene's rig; the thresholds at the onset of gross slip that measured
// cycles are classified against; the fretting map; and the backbone (secant stiffness and
// equivalent damping against amplitude) that bolted-joint rigs compare with modal tests.
//
// Every figure comes from exact engine steps (constant normal force: straight steps, exact also
// through a rig), not from sampled loops: Ed is the engine's dissipated energy over one steady
// cycle, delta_0 the displacement a force-controlled return to F_x = 0 reaches.
#pragma once

#include <vector>

#include "mdr/analysis/loops.h"
#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/torsion.h"

namespace mdr::analysis {

// How a loop's amplitude is given: the tangential force amplitude Q* (N), or the actuator's
// displacement amplitude (m; the contact's own without a rig).
enum class AmplitudeKind { kForce, kActuatorDisplacement };

// The figures of one exact steady cycle, as LoopAnalysis defines them (loops.h).
struct LoopFigures {
  double normal_force = 0;       // P, N
  double force_amplitude = 0;    // Q*, N
  double dissipated_energy = 0;  // Ed, J (per steady cycle)
  double half_opening = 0;       // delta_0, m
  double contact_amplitude = 0;  // delta*_c, m: the contact's displacement amplitude
  // delta* = delta*_c + C_t Q*, m: the amplitude the actuator moves (what the rig measures).
  double actuator_amplitude = 0;
  double energy_ratio = 0;          // A = Ed / (4 delta* Q*), as measured through the rig
  double sliding_ratio = 0;         // B = delta_0 / delta*, as measured
  double contact_energy_ratio = 0;  // A and B of the contact alone (delta*_c)
  double contact_sliding_ratio = 0;
  double system_free_ratio = 0;  // C = Ed / (4 delta_0 Q*), rig-free (0 where delta_0 = 0)
  double secant_stiffness = 0;   // Q* / delta*, N/m, as measured
  // Equivalent viscous damping ratio Ed / (4 pi U), U = Q* delta* / 2 the peak strain energy.
  double damping_ratio = 0;
};

// The steady loop of amplitude `amplitude` (AmplitudeKind) at normal force P > 0 for the scene:
// press to P, cycle +a, -a, +a, -a; Ed is the dissipation of the last full cycle. A force
// amplitude must be in (0, mu P]; mu P is the onset of gross slip. Errors name "normal_force",
// "amplitude" or the scene's field.
Result<LoopFigures> ExactLoop(const ContactConfig& scene, double normal_force, AmplitudeKind kind,
                              double amplitude, const Interrupt& interrupt = {});

// The loop at the onset of gross slip, Q* = mu P: the thresholds of the regimes for this scene
// (profile, material, rig) at this normal force. For a power-law profile at constant P, A = 1 /
// (2n + 1), B = 2^(1/(n+1)) - 1 of the contact (docs/analysis.md derives them); a flat punch has no
// partial-slip loop (A = B = C = 0 at the onset). Needs friction > 0.
Result<LoopFigures> GrossSlipOnset(const ContactConfig& scene, double normal_force,
                                   const Interrupt& interrupt = {});

enum class Regime { kSticking, kPartialSlip, kGrossSlip };
const char* RegimeName(Regime regime);  // "sticking", "partial slip", "gross slip"

// A measured cycle's regime against the scene's onset: sticking if its opening is not resolved
// (CycleMetrics::opening_resolved: not above the sensor's resolution nor the cycle's round-off, so
// the loop cannot be told from an elastic line) or it dissipates nothing (Ed <= 0: slip always
// dissipates, and a loop running the wrong way round is noise); else gross slip if its rig-free
// ratio C reaches the onset's C (for a profile without a partial-slip loop, if it has width at
// all), partial slip otherwise.
Regime ClassifyCycle(const CycleMetrics& cycle, const LoopFigures& onset);

// The fretting map of a scene: at each normal force, the exact loops along actuator amplitudes
// `relative_amplitudes` times the onset's actuator amplitude (each in (0, 100]), with the onset
// itself. Through a soft rig the partial-slip loops narrow to the rig's elastic line and the
// contact switches sharply from near-sticking to gross slip (docs/analysis.md).
struct FrettingMapLoad {
  LoopFigures onset;
  std::vector<LoopFigures> loops;  // one per relative amplitude, in order
  std::vector<Regime> regimes;     // each loop's regime (from its amplitude against the onset)
};
Result<std::vector<FrettingMapLoad>> FrettingMap(const ContactConfig& scene,
                                                 const std::vector<double>& normal_forces,
                                                 const std::vector<double>& relative_amplitudes,
                                                 const Interrupt& interrupt = {});

// The backbone at normal force P: the exact loops at the given amplitudes (AmplitudeKind), each
// with its secant stiffness and damping ratio (LoopFigures). Force amplitudes beyond mu P are
// refused (gross slip has no steady force loop); displacement amplitudes may reach into gross
// slip.
Result<std::vector<LoopFigures>> Backbone(const ContactConfig& scene, double normal_force,
                                          AmplitudeKind kind, const std::vector<double>& amplitudes,
                                          const Interrupt& interrupt = {});

// ---- Torsional loops (docs/analysis.md, "Torsional records") ----------------------------------
//
// The same figures for a contact twisted about its axis (LoopChannel::kTorsional: the twist for
// the displacement, the twisting moment for the force), from exact steps of the torsional memory
// (mdr/core/torsion.h) at constant normal force, through a rig's torsional compliance.

// A torsional scene: the profile with its normal problem (E*), friction, the torsional modulus
// G_t (1/G_t = 1/G_1 + 1/G_2) and the rig's torsional compliance C in rad/(N m) (0: none).
struct TorsionalScene {
  ProfilePtr profile;
  double friction = 0;
  double effective_modulus = 0;  // E*, Pa
  double torsional_modulus = 0;  // G_t, Pa
  double rig_compliance = 0;     // rad / (N m), finite, >= 0
};

// The contact of the scene pressed to P > 0 at twist 0. Errors name "profile", "friction",
// "effective_modulus", "torsional_modulus", "rig_compliance" or "normal_force".
Result<TorsionalContact> PressTorsionalContact(const TorsionalScene& scene, double normal_force);

// The steady torsional loop of amplitude `amplitude` at normal force P > 0: AmplitudeKind::kForce
// is the moment amplitude M* (N m, in (0, M_slip): the full-slip moment is reached only by an
// infinite twist), kActuatorDisplacement the actuator's twist amplitude (rad). The figures of
// LoopFigures in rad and N m (force_amplitude is M*, half_opening the twist's at M = 0, ...).
Result<LoopFigures> ExactTorsionalLoop(const TorsionalScene& scene, double normal_force,
                                       AmplitudeKind kind, double amplitude,
                                       const Interrupt& interrupt = {});

// The full-slip moment of the scene at P (N m): the supremum of every torsional loop's M*
// (Hertz: 3 pi mu P a / 16).
Result<double> FullSlipMoment(const TorsionalScene& scene, double normal_force);

// A measured torsional cycle's regime: sticking as ClassifyCycle (no resolved opening, or no
// loss); gross slip if its moment amplitude reaches the full-slip moment, which no partial-slip
// state of the model carries (a smooth profile's centre never slips at a finite twist, so there
// is no onset at a finite amplitude as in the tangential case); partial slip otherwise.
Regime ClassifyTorsionalCycle(const CycleMetrics& cycle, double full_slip_moment);

// The torsional backbone at P: the exact loops at the given amplitudes (AmplitudeKind), each with
// its secant torsional stiffness (N m/rad) and damping ratio.
Result<std::vector<LoopFigures>> TorsionalBackbone(const TorsionalScene& scene,
                                                   double normal_force, AmplitudeKind kind,
                                                   const std::vector<double>& amplitudes,
                                                   const Interrupt& interrupt = {});

}  // namespace mdr::analysis
