// Parameter identification from measured loops (issue #24; docs/analysis.md, "Identification"):
// chosen parameters of a scene -- the friction coefficient, the effective modulus, the profile's
// scale, the rig's tangential compliance, a displacement offset -- fitted to one or more loop sets,
// each at its own constant normal force, by replaying the measured actuator path through the exact
// engine with the rig in series and comparing the tangential force sample by sample. Nonlinear
// least squares (GSL's trust-region Levenberg-Marquardt, gsl_multifit_nlinear) on transformed
// parameters, so that bounds hold; standard errors, 95 % intervals and correlations from the
// covariance; and a verdict on what the data can separate, instead of confident numbers where
// they cannot.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "mdr/analysis/loops.h"
#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"

namespace mdr::analysis {

enum class Parameter {
  kFriction,          // mu, dimensionless
  kEffectiveModulus,  // E* in Pa (G* = E* / kappa, kappa of the scene's material kept)
  kProfileScale,      // the profile's parameter, as FitOptions::profile_family takes it
  kRigCompliance,     // C_t in m/N (the scene's rig, tangential)
  // u_0 in m: where, in measured coordinates, the virgin contact was pressed (not free: each
  // set's first replayed sample, ReplayPath)
  kDisplacementOffset,
};
// "friction", "effective_modulus", "profile_scale", "rig_compliance", "displacement_offset".
const char* ParameterName(Parameter parameter);

// The actuator path a fit replays for a set's measured displacement: made monotone between its
// reversals (as AnalyzeLoops finds them at the fit's threshold), each stretch by its least-squares
// monotone fit. Between two reversals the actuator moves one way; a sensor's noise would make the
// replayed contact unload and reload elastically wherever it reverses, which the real contact
// never did. A path that is already monotone there (any noise-free record) is kept exactly. The
// turning points keep their measured values, and their noise (docs/analysis.md, "Limitations").
std::vector<double> ReplayPath(const std::vector<double>& displacement,
                               const std::vector<std::size_t>& reversals);

// One set of loops at one constant normal force: the samples (displacement and tangential force
// are used; time and normal force may be absent) and that force in N.
struct LoopSet {
  LoopSamples samples;
  double normal_force = 0;
};

struct FreeParameter {
  Parameter parameter;
  std::optional<double> initial;  // unset: the scene's value (u_0: the set's first displacement)
  double lower, upper;            // bounds, lower < upper; the initial value inside them
};

struct FitOptions {
  std::vector<FreeParameter> free;  // 1 to 5 distinct parameters
  // The profile at a value of its parameter (e.g. the sphere of radius R: MakeSphere), needed when
  // kProfileScale is free (its initial value must then be given).
  std::function<Result<ProfilePtr>(double)> profile_family;
  // Residuals are counted from this reversal of each set's displacement on (2: after the first
  // full cycle, whose start depends on the history before the recording); 0: from the first
  // sample (then the displacement offset matters). The reversals are found as in AnalyzeLoops.
  int burn_in_reversals = 2;
  double reversal_threshold = 0;  // as LoopOptions::reversal_threshold
  int max_iterations = 200;
  // Convergence: relative step below this in every (transformed) parameter.
  double step_tolerance = 1e-12;
  // Threads for the replays (the Jacobian's columns run concurrently); 0: the hardware's.
  int threads = 0;
};

struct ParameterEstimate {
  Parameter parameter;
  double value = 0;
  double standard_error = 0;
  double lower_95 = 0, upper_95 = 0;  // the 95 % confidence interval (Student t)
  // Whether the data separate this parameter from the others: its interval is narrower than its
  // value (|relative half-width| < 0.5), its correlation with every other free parameter below
  // 0.99 in magnitude, and the fit's condition number below 1e8.
  bool identified = false;
};

struct FitResult {
  std::vector<ParameterEstimate> estimates;      // in the order of FitOptions::free
  std::vector<std::vector<double>> correlation;  // correlation matrix of the estimates
  double residual_rms = 0;                       // N, over the counted samples
  std::size_t residuals = 0;                     // counted samples
  int iterations = 0;
  bool converged = false;
  // What the data can separate. The condition number of the Jacobian with every column scaled
  // by its parameter (relative sensitivities), and the combination of relative parameter changes
  // the data constrain least (its right singular vector, one entry per free parameter).
  double condition_number = 0;
  std::vector<double> weakest_combination;
  bool identified = false;         // every estimate identified
  std::vector<std::string> notes;  // why not, in words ("friction and rig_compliance are
                                   // correlated at -0.998: the loops fix their combination")
  ContactConfig fitted;            // the scene with the estimates
};

// Per iteration: the iteration number, the residual RMS (N) and the current values.
using FitProgress =
    std::function<void(int iteration, double residual_rms, const std::vector<double>& values)>;

// Fits. Errors name the field: "sets" (none), "sets[i].normal_force", the samples as
// AnalyzeLoops names them ("sets[i].samples.displacement[12]"), "free" (none, too many,
// repeated), "free[k].lower" / ".upper" / ".initial" (bounds that exclude the initial value,
// lower >= upper, not finite), "free[k].parameter" (a profile without a scale, a compliance on
// an interface); FailedPrecondition "sets[i].samples" when burn-in leaves no residual. The
// interrupt is checked during every replay; progress is called after every iteration.
Result<FitResult> FitLoops(const ContactConfig& scene, const std::vector<LoopSet>& sets,
                           const FitOptions& options, const Interrupt& interrupt = {},
                           const FitProgress& progress = {});

// The practitioners' starting point for the rig compliance: the apparent stiffness k just after
// the reversals of every set's cycles (AnalyzeLoops), against the normal force; for a power-law
// contact of exponent n at full stick 1 / k = C_t + c P^(-1/(n+1)), so C_t is the intercept of
// 1 / k against P^(-1/(n+1)) (n = 2: a sphere; n = 1: a cone). Needs sets at two or more distinct
// normal forces. The reversal slopes are chords over the first fifth of each branch, a little
// below the full-stick stiffness: a starting point, not an estimate.
struct ComplianceGuess {
  double rig_compliance = 0;  // C_t, m/N (may come out negative with noisy data; not clamped)
  // Of the intercept; NaN with two loads (a line through two points leaves no residual).
  double standard_error = std::numeric_limits<double>::quiet_NaN();
  double slope = 0;                                       // c, in m/N * N^(1/(n+1))
  std::vector<double> normal_forces, apparent_stiffness;  // the points of the line, per set
};
Result<ComplianceGuess> GuessRigCompliance(const std::vector<LoopSet>& sets, double exponent = 2,
                                           double reversal_threshold = 0);

}  // namespace mdr::analysis
