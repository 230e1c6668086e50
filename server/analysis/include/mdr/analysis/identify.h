// Parameter identification from measured loops (issues #24, #47; docs/analysis.md,
// "Identification"): chosen parameters of a scene -- the friction coefficient, the effective
// modulus, the profile's scale, the rig's tangential compliance, a displacement offset -- fitted
// to one or more loop sets by replaying each set through the exact engine with the rig in series
// and comparing the tangential force sample by sample. Both channels are measurements: the
// replayed actuator path is the measured displacement smoothed within each half-cycle, its
// turning points are fitted (one nuisance parameter per reversal: at a given normal load the
// loop depends on the path only through them), and each residual is weighed by its effective
// variance, the force sensor's noise plus the displacement sensor's times the model's local
// slope, squared. A set's normal force is replayed as measured when it has a normal-force column.
// Offsets, a drift and a moving mass can be fitted too. The result gives the noise of each channel
// as estimated from the data, standard errors and 95 % intervals, a verdict on what the data can
// separate, and one on whether the model explains the data to their noise at all: a fit the data
// contradict is never reported as identified.
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
  // u_0 in m: where, in measured coordinates, the virgin contact was pressed, one value for
  // every set. Not free, each set's press point is fitted on its own (a nuisance,
  // Nuisance::kDisplacementOffset).
  kDisplacementOffset,
  // G_t in Pa: the torsional modulus of a torsional fit (FitOptions::torsion), which scales the
  // springs' stiffness and, over mu E*, the twist at which they slide.
  kTorsionalModulus,
};
// "friction", "effective_modulus", "profile_scale", "rig_compliance", "displacement_offset",
// "torsional_modulus".
const char* ParameterName(Parameter parameter);

// A torsional fit's contact besides the scene's profile, E* and friction: the torsional modulus
// G_t (Pa, > 0) and the rig's torsional compliance (rad/(N m), finite, >= 0).
struct TorsionalFitScene {
  double torsional_modulus = 0;
  double rig_compliance = 0;
};

// One set of loops: the samples (displacement and tangential force; normal force and time
// optional) and the normal force it was recorded at.
struct LoopSet {
  LoopSamples samples;
  // N, > 0. Required without a normal-force column; with one, the column is replayed as
  // measured and this, if given, is only checked against it (SetFit::load_mismatch).
  std::optional<double> normal_force;
};

// Nuisance parameters: effects of the sensors and the rig that are not the contact's, each fitted
// when asked (docs/analysis.md, "Nuisance parameters"). Each set's displacement offset -- the
// sensor's reading where the virgin contact was pressed -- is always fitted: it is a point of the
// actuator's path like the turning points, and the loops of partial slip remember it.
struct NuisanceOptions {
  bool force_offset = false;  // b per set, N: the force sensor reads F_x + b
  // d_1 per set, m: the displacement sensor's zero moves by d_1 over the set, linearly in time
  // (in the sample index without time).
  bool displacement_drift = false;
  // m for the campaign, kg: the force sensor reads F_x + m d^2u/dt^2 (the inertia of what moves
  // between the contact and the force sensor); needs time in every set.
  bool moving_mass = false;
};

struct FreeParameter {
  Parameter parameter;
  std::optional<double> initial;  // unset: the scene's value (u_0: the first set's first sample)
  double lower, upper;            // bounds, lower < upper; the initial value inside them
};

struct FitOptions {
  std::vector<FreeParameter> free;  // 1 to 6 distinct parameters
  // A torsional fit (docs/analysis.md, "Torsional records"): every set's samples are torsional
  // (LoopChannel::kTorsional: the twist for the displacement, the twisting moment for the force)
  // and each is replayed through the exact torsional memory of the scene's profile, E* and
  // friction with this G_t, behind this torsional compliance. kRigCompliance is then that
  // compliance (rad/(N m)), kDisplacementOffset the twist's (rad), the force offset the moment's
  // (N m) and the moving mass a moment of inertia (kg m^2). A set is replayed at a constant normal
  // force, the declared one or its column's mean: a load that falls after a twist reversal can
  // leave the memory's exact regime (mdr/core/torsion.h). Unset: a tangential fit.
  std::optional<TorsionalFitScene> torsion;
  // The profile at a value of its parameter (e.g. the sphere of radius R: MakeSphere), needed when
  // kProfileScale is free (its initial value must then be given).
  std::function<Result<ProfilePtr>(double)> profile_family;
  NuisanceOptions nuisances;
  // The sensors' noise (standard deviations, m and N) where known, for every set; unset: each
  // set's own estimate from its samples (NoiseFromDifferences). Finite, > 0.
  std::optional<double> displacement_noise, force_noise;
  // Residuals are counted from this reversal of each set's displacement on (2: after the first
  // full cycle, whose start depends on the history before the recording); 0: from the first
  // sample (then where the contact was pressed matters). The reversals are found as in
  // AnalyzeLoops.
  int burn_in_reversals = 2;
  double reversal_threshold = 0;  // as LoopOptions::reversal_threshold
  int max_iterations = 200;
  // Convergence: no parameter (in the solver's scaled coordinates) moves by more than this
  // relative amount in a step.
  double step_tolerance = 1e-10;
  // Threads for the replays (the Jacobian's columns run concurrently); 0: the hardware's.
  int threads = 0;
  // Also return each set's model sample by sample (FitResult::models).
  bool keep_models = false;
};

// How a reported interval was obtained.
enum class IntervalMethod {
  kWald,  // estimate +- t * standard error from s^2 (J^T W J)^-1, t on n - rank
  // The same from the cluster-robust covariance over the sets' half-cycles, t on (half-cycles -
  // 1): reported where it is the larger (residuals that move together within half-cycles).
  kHalfCycleSandwich,
};
// "wald", "half_cycle_sandwich".
const char* IntervalMethodName(IntervalMethod method);

struct ParameterEstimate {
  Parameter parameter;
  double value = 0;
  double standard_error = 0;
  double lower_95 = 0, upper_95 = 0;  // the 95 % confidence interval
  IntervalMethod interval = IntervalMethod::kWald;
  // Whether the data separate this parameter from the others: its interval is narrower than its
  // value (|relative half-width| < 0.5), its correlation with every other free parameter below
  // 0.99 in magnitude, and the fit's condition number below 1e8.
  bool identified = false;
};

enum class Nuisance {
  kForceOffset,         // N, per set
  kDisplacementOffset,  // m, per set: the sensor's reading at the press point (always fitted)
  kDisplacementDrift,   // m over the set, per set
  kMovingMass,          // kg, the campaign's
};
// "force_offset", "displacement_offset", "displacement_drift", "moving_mass".
const char* NuisanceName(Nuisance nuisance);

struct NuisanceEstimate {
  Nuisance nuisance;
  std::optional<std::size_t> set;  // the set it belongs to; none: the campaign's
  double value = 0;
  double standard_error = 0;
  double lower_95 = 0, upper_95 = 0;  // Wald, 95 %
  // The data determine it: its interval is finite (a gross-slip set, whose memory forgets where
  // it was pressed, leaves its displacement offset undetermined).
  bool identified = false;
  // How much fitting it moved each free parameter (in the order of FitOptions::free): the
  // estimates' change if it were held at zero instead, to first order (from the covariance).
  std::vector<double> effect;
};

// What the fit found in one set, and whether the model explains it.
struct SetFit {
  // The sensors' noise the residuals were weighed with: standard deviations of the displacement
  // (m), the tangential force (N) and the normal force (N, NaN without a column), estimated from
  // the samples (NoiseFromDifferences) unless given in FitOptions.
  double displacement_noise = 0, force_noise = 0;
  double normal_force_noise = std::numeric_limits<double>::quiet_NaN();
  bool noise_estimated = true;
  // The lag-1 correlation of each channel's third differences (signal.h, NoiseCorrelation):
  // about -0.75 for noise independent from sample to sample.
  double displacement_noise_correlation = 0, force_noise_correlation = 0;
  bool normal_force_measured = false;  // replayed from the column (else the declared constant)
  double normal_force = 0;             // N: the replayed normal force's mean
  double normal_force_min = 0, normal_force_max = 0;  // N: its range
  // The declared normal force lies outside the column's range widened by three times its noise
  // (and a millionth of the load): declaration and measurement disagree.
  bool load_mismatch = false;
  std::size_t first_residual = 0;  // the first counted sample
  std::size_t residuals = 0;       // counted samples
  std::size_t turning_points = 0;  // fitted turning points
  // Every counted half-cycle of the fitted model ends in full sliding (no spring sticks at its
  // turning point): the loops forget where the contact was pressed, so the set's displacement
  // offset is undetermined and its force offset is the loops' own. Otherwise the two are fixed
  // only together, unless the virgin loading is counted (burn_in_reversals 0).
  bool gross_slip = false;
  // m: the RMS of how far the fitted turning points lie from the smoothed displacement's extremes.
  double turning_point_shift_rms = 0;
  double residual_rms = 0;  // N: measured minus modelled force, unweighted
  // The adequacy of the model (docs/analysis.md, "Model adequacy"). The sum of squared
  // residuals, each over its noise (effective variance), per degree of freedom: about 1 where
  // the model explains the data to their noise.
  double reduced_chi_square = 0;
  // The lag-1 autocorrelation of the normalised residuals within half-cycles (about 0 for
  // noise; a structure the model misses makes neighbours alike).
  double autocorrelation = 0;
  // The normalised residuals averaged per position along the half-cycles (bins by direction and
  // fraction of the stroke) over all cycles: a structure repeated in every cycle. The statistic
  // is the sum over the bins of count * mean^2 over the larger of 1 and the set's reduced
  // chi-square; without
  // structure it follows chi-square with `structure_bins` degrees of freedom, and
  // structure_p_value is its upper tail.
  double structure_statistic = 0;
  int structure_bins = 0;
  double structure_p_value = 1;
  bool misfit = false;  // the model does not explain this set (why: FitResult::notes)
};

// One set's model at the estimates, sample by sample (with FitOptions::keep_models).
struct SetModel {
  std::vector<double> actuator_path;  // m: the replayed actuator position (press point at 0)
  std::vector<double> normal_force;   // N: the replayed normal force
  std::vector<double> contact_force;  // N: the model contact's F_x on that path
  // N: what the force sensor should read at the measured displacement: the contact's force
  // carried along its branch's slope to the measured position, plus the fitted offset and
  // inertia.
  std::vector<double> predicted_force;
};

struct FitResult {
  std::vector<ParameterEstimate> estimates;      // in the order of FitOptions::free
  std::vector<std::vector<double>> correlation;  // correlation matrix of the estimates
  std::vector<NuisanceEstimate> nuisances;       // per set in set order, then the campaign's
  std::vector<SetFit> sets;                      // in the order of the sets
  double residual_rms = 0;                       // N, over the counted samples
  std::size_t residuals = 0;                     // counted samples
  std::size_t parameters = 0;                    // fitted, nuisances and turning points included
  double reduced_chi_square = 0;                 // over every set
  int iterations = 0;
  bool converged = false;
  // What the data can separate. The condition number of the free parameters' information (the
  // Jacobian with every column scaled by its parameter, the nuisances profiled out), and the
  // combination of relative parameter changes the data constrain least (one entry per free
  // parameter).
  double condition_number = 0;
  std::vector<double> weakest_combination;
  // The model explains every set to its noise and no declared load contradicts its column.
  bool adequate = false;
  bool identified = false;         // adequate and every estimate identified
  std::vector<std::string> notes;  // why not, in words ("friction and rig_compliance are
                                   // correlated at -0.998: the loops fix their combination")
  ContactConfig fitted;            // the scene with the estimates
  // A torsional fit's G_t and compliance at the estimates.
  std::optional<TorsionalFitScene> fitted_torsion;
  std::vector<SetModel> models;    // with FitOptions::keep_models
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
