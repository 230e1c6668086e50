// Loop analysis of measured fretting samples (issue #24; docs/analysis.md): cycles found by the
// reversals of the displacement, and per cycle the figures rigs report, each labelled by what it
// measures. No gRPC here: a rig's own software links this library.
//
// A test rig measures the actuator's (or a sensor's) tangential displacement u, which is the
// contact's displacement plus the elastic deformation of everything between contact and sensor,
// modelled as a linear spring of compliance C_t in series: u = u_contact + C_t F_x. Over a closed
// cycle the spring gives back its energy, at F_x = 0 it is unloaded, and it carries the same force:
// the dissipated energy Ed, the force amplitude Q*, the half-opening delta_0 and C = Ed / (4
// delta_0 Q*) are the contact's alone; the displacement amplitude, A, B and every slope are biased
// by the rig (Measures::kContactAndRig).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/interrupt.h"

namespace mdr::analysis {

// What a figure measures.
enum class Measures {
  kContact,        // the contact alone: the same whatever the rig in series
  kContactAndRig,  // the contact plus the rig in series (biased by the rig)
};

// The ranges of the samples: beyond them the figures' products overflow or underflow (a
// rig's stroke is millimetres, its forces kilonewtons, its sensors resolve nanometres and
// millinewtons; a torsional rig turns by degrees).
inline constexpr double kMaxSampleDisplacement = 1;  // m, |u|
inline constexpr double kMaxSampleTwist = 100;       // rad, |phi|: sixteen turns
inline constexpr double kMaxSampleForce = 1e9;       // N, |F_x| and F_N; N m, |M|
// m for u, N for F_x (rad and N m for a torsional record): the least span (max - min) of a
// column that is not constant.
inline constexpr double kMinSampleSpan = 1e-15;

// What a record's two loop columns hold. A torsional fretting loop (a ball twisted on a flat) is
// analysed exactly as a tangential one, with the twist for the displacement and the twisting
// moment for the force: every figure keeps its definition, in rad and N m.
enum class LoopChannel {
  kTangential,  // displacement u (m) and tangential force F_x (N)
  kTorsional,   // twist phi (rad) and twisting moment M (N m) about the contact's axis
};

// The names and units of a channel's loop columns, for messages and reports: "displacement",
// "tangential_force", "m", "N"; "twist", "twisting_moment", "rad", "N m".
struct ChannelNames {
  const char* position;
  const char* force;
  const char* position_unit;
  const char* force_unit;
  double max_position;  // kMaxSampleDisplacement or kMaxSampleTwist
};
ChannelNames NamesOf(LoopChannel channel);

// The samples of one run, in SI units, one value per sample in each non-empty column.
struct LoopSamples {
  // u, m: the actuator's (or sensor's) tangential position; |u| <= kMaxSampleDisplacement. A
  // torsional record: the actuator's twist phi in rad, |phi| <= kMaxSampleTwist.
  std::vector<double> displacement;
  // F_x, N; |F_x| <= kMaxSampleForce. A torsional record: the twisting moment M in N m.
  std::vector<double> tangential_force;
  std::vector<double> normal_force;  // F_N, N, in [0, kMaxSampleForce]; empty: not measured
  std::vector<double> time;          // t, s, strictly increasing; empty: not recorded
  LoopChannel channel = LoopChannel::kTangential;
};

struct LoopOptions {
  // Hysteresis of the reversal detection, m: an extreme of u counts as a reversal once u has moved
  // back from it by more than this (noise smaller than it makes no reversal). 0: automatic, 5 % of
  // the median peak-to-peak displacement of the run. Finite, >= 0.
  double reversal_threshold = 0;
  // The rig's tangential compliance C_t in m/N (a torsional record: its torsional compliance in
  // rad/(N m)), if known (measured, or identified by fitting): the contact-level figures
  // (CycleMetrics::contact) are then reported too. Finite, >= 0.
  std::optional<double> rig_compliance;
  // The normal force in N when the samples carry none (for the friction coefficients); finite,
  // > 0. Ignored when normal_force samples are given.
  std::optional<double> normal_force;
  // Flag thresholds (CycleMetrics::flags). Finite, > 0.
  double closure_tolerance = 0.05;   // closure_error above this: the loop does not close
  double asymmetry_tolerance = 0.1;  // asymmetry above this: left/right asymmetric
  double hook_tolerance = 0.1;       // hook_ratio above this (in gross slip): hooked
  double drift_tolerance = 0.1;      // |friction_drift| above this: friction drifts
  // The displacement sensor's resolution, m: a cycle whose half-opening is not above it (nor
  // above its own round-off, CycleMetrics::half_opening_round_off) has no resolved opening.
  // Finite, >= 0.
  double displacement_resolution = 0;
};

// The contact's own figures, from u_contact = u - C_t F_x (with LoopOptions::rig_compliance).
struct ContactFigures {
  double displacement_amplitude;  // delta*_c, m
  double energy_ratio;            // A_c = Ed / (4 delta*_c Q*)
  double sliding_ratio;           // B_c = delta_0 / delta*_c
  double secant_stiffness;        // Q* / delta*_c, N/m
  double stiffness_increasing;    // as CycleMetrics, of the contact alone (N/m)
  double stiffness_decreasing;
};

// Why a loop is not a plain Coulomb / Mindlin loop; each flag with the number behind it.
struct LoopFlags {
  // The cycle does not close: max(|F_end - F_start| / (2 Q*), |u_end - u_start| / (2 delta*)),
  // start and end being the cycle's two upper reversals.
  double closure_error = 0;
  bool not_closed = false;  // closure_error > closure_tolerance
  // Left/right asymmetry: the larger of |F_max + F_min| / (2 Q*) (a force offset) and
  // |k_increasing - k_decreasing| / (k_increasing + k_decreasing) (different reversal slopes).
  double asymmetry = 0;
  bool asymmetric = false;  // asymmetry > asymmetry_tolerance
  // Force rising toward the stroke ends in gross slip: on each branch, (|F| at the stroke's end
  // - |F| where u passes the stroke's middle) / Q*, the larger of the two branches; only for a
  // branch that slides through its middle (its slope there below 10 % of its slope after the
  // reversal), 0 otherwise.
  double hook_ratio = 0;
  bool hooked = false;  // hook_ratio > hook_tolerance
};

// One cycle: from an upper reversal (a maximum of u) through a lower one to the next upper one.
struct CycleMetrics {
  std::size_t first_sample = 0, last_sample = 0;  // the reversals bounding it, inclusive
  std::size_t lower_reversal = 0;                 // the sample of the minimum between them
  double start_time = 0;                          // t at first_sample (NaN without time)

  // Measures::kContact (invariant to the rig):
  double force_amplitude = 0;    // Q* = (F_max - F_min) / 2, N
  double force_offset = 0;       // (F_max + F_min) / 2, N
  double dissipated_energy = 0;  // Ed, J: the loop's area, the integral of F_x du over the cycle
  double half_opening = 0;       // delta_0, m: half the loop's width at F_x = force_offset
  // What an opening of zero can come out as: each crossing is interpolated between samples and
  // carries a round-off of a few ulps of |u| there; 16 eps max |u| over the cycle bounds it.
  double half_opening_round_off = 0;
  // delta_0 > max(LoopOptions::displacement_resolution, half_opening_round_off): the loop can be
  // told from an elastic line. Without it the figures that divide by delta_0 are not identified
  // (NaN) and ClassifyCycle calls the cycle sticking, so that round-off never decides either.
  bool opening_resolved = false;
  double system_free_ratio = 0;  // C = Ed / (4 delta_0 Q*) (NaN without a resolved opening)
  double normal_force = 0;       // P, N: the cycle's mean F_N (or LoopOptions::normal_force; NaN)
  // Q* / P (NaN without P, and for a torsional record: its M* / P is a length, mu times a
  // fraction of the contact radius that the profile sets).
  double friction_coefficient = 0;
  // mu_e = Ed / (4 P delta_0) (NaN without P or without a resolved opening; NaN for a torsional
  // record, as above)
  double energy_friction_coefficient = 0;

  // Measures::kContactAndRig (the measured displacement):
  double displacement_amplitude = 0;  // delta* = (u_max - u_min) / 2, m
  double energy_ratio = 0;            // A = Ed / (4 delta* Q*)
  double sliding_ratio = 0;           // B = delta_0 / delta*
  double secant_stiffness = 0;        // Q* / delta*, N/m
  // Slopes dF_x/du just after the reversals, N/m: the least-squares line through the branch's
  // samples from the reversal until F_x has changed by a fifth of 2 Q* (at least 3 samples):
  // increasing u (after the lower reversal) and decreasing u (after the upper one).
  double stiffness_increasing = 0;
  double stiffness_decreasing = 0;

  std::optional<ContactFigures> contact;  // with LoopOptions::rig_compliance
  LoopFlags flags;
};

// What a figure of CycleMetrics measures, by its member's name (e.g. "dissipated_energy"); the
// contact alone for everything in ContactFigures. For reports and the API's labels.
Measures MeasuresOf(const char* figure);

struct LoopAnalysis {
  double reversal_threshold = 0;       // the hysteresis used (m)
  std::vector<std::size_t> reversals;  // sample indices of the reversals, in order
  std::vector<CycleMetrics> cycles;
  // Friction drift over the run: the least-squares slope of Q* (of the friction coefficient when
  // P is known) against the cycle index, times the number of cycles, over its mean (0 with fewer
  // than 3 cycles). friction_drifts: |friction_drift| > drift_tolerance.
  double friction_drift = 0;
  bool friction_drifts = false;
};

// The options' own ranges (InvalidArgument naming "reversal_threshold", "rig_compliance",
// "normal_force" or a tolerance); AnalyzeLoops checks them first, so a caller that runs this
// before knows any later error is the samples'.
Status ValidateLoopOptions(const LoopOptions& options);

// Analyses the samples. Errors (nothing is returned then): InvalidArgument naming the column and
// sample ("displacement[12]: must be in [-1, 1], got 1e+160", "tangential_force: needs one value
// per displacement sample, got 9 for 10", "time[3]: must increase strictly", "normal_force[5]: must
// be in [0, 1000000000]", "displacement: spans only 1e-160 m (samples 3 and 7) ...") or the option
// ("reversal_threshold", "rig_compliance", "normal_force", the tolerances);
// FailedPrecondition("displacement") when the samples hold no complete cycle (two upper
// reversals with a lower one between them). The interrupt is checked every 65536 samples.
Result<LoopAnalysis> AnalyzeLoops(const LoopSamples& samples, const LoopOptions& options,
                                  const Interrupt& interrupt = {});

}  // namespace mdr::analysis
