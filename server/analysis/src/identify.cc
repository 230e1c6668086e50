#include "mdr/analysis/identify.h"

#include <gsl/gsl_cdf.h>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <set>
#include <thread>

#include "covariance.h"
#include "fit_model.h"
#include "least_squares.h"
#include "mdr/analysis/signal.h"
#include "mdr/base/validate.h"

namespace mdr::analysis {
namespace {

using internal::FitModel;
using internal::Layout;
using internal::PreparedSet;
using internal::SparseColumn;

constexpr double kCorrelationLimit = 0.99;   // beyond: two parameters are not separated
constexpr double kConditionLimit = 1e8;      // beyond: the data constrain a combination poorly
constexpr double kRelativeWidthLimit = 0.5;  // 95 % half-width over |value| beyond: undetermined
constexpr int kMaxReweighings = 5;           // stages: one unweighted, then effective-variance
constexpr double kWeightChange = 1e-3;       // weights settled: a stage moves them less (RMS)
// Model adequacy (docs/analysis.md, "Model adequacy").
constexpr double kMisfitChiSquare = 1.5;  // reduced chi-square beyond: residuals exceed the noise
constexpr double kMisfitPValue = 1e-4;    // a structure repeated over the cycles this unlikely
constexpr int kStructureBinsPerDirection = 8;
constexpr std::size_t kMinBinCount = 5;

Status CheckFreeParameters(const FitOptions& options) {
  if (options.free.empty() || options.free.size() > 6) {
    return InvalidArgument("free",
                           "needs 1 to 6 parameters, got " + std::to_string(options.free.size()));
  }
  std::set<Parameter> seen;
  for (std::size_t k = 0; k < options.free.size(); ++k) {
    const FreeParameter& free = options.free[k];
    const std::string field = Indexed("free", k);
    if (!seen.insert(free.parameter).second) {
      return InvalidArgument(field + ".parameter",
                             std::string(ParameterName(free.parameter)) + " is free twice");
    }
    if (free.parameter == Parameter::kTorsionalModulus && !options.torsion) {
      return InvalidArgument(field + ".parameter",
                             "torsional_modulus is a torsional fit's (torsional records)");
    }
    if (free.parameter == Parameter::kProfileScale && (!options.profile_family || !free.initial)) {
      return InvalidArgument(field + ".parameter",
                             "profile_scale needs the profile family and an initial value");
    }
    if (Status s = RequireFinite(field + ".lower", free.lower); !s.ok()) return s;
    if (Status s = RequireFinite(field + ".upper", free.upper); !s.ok()) return s;
    if (!(free.lower < free.upper)) {
      return InvalidArgument(field + ".upper", "must exceed lower = " + FormatNumber(free.lower) +
                                                   ", got " + FormatNumber(free.upper));
    }
    // The search maps (lower, upper) onto the real line: its width must be a number.
    if (!std::isfinite(free.upper - free.lower)) {
      return InvalidArgument(field + ".upper",
                             "upper - lower must be finite (the bounds' width overflows), got "
                             "lower = " + FormatNumber(free.lower) +
                                 ", upper = " + FormatNumber(free.upper));
    }
    // Every value inside the bounds must make a scene: the physical parameters cannot be
    // negative (the offset can).
    if (free.parameter != Parameter::kDisplacementOffset && free.lower < 0) {
      return InvalidArgument(field + ".lower",
                             std::string(ParameterName(free.parameter)) +
                                 " cannot be negative: must be >= 0, got " +
                                 FormatNumber(free.lower));
    }
  }
  if (options.displacement_noise) {
    if (Status s = RequirePositive("displacement_noise", *options.displacement_noise); !s.ok()) {
      return s;
    }
  }
  if (options.force_noise) {
    if (Status s = RequirePositive("force_noise", *options.force_noise); !s.ok()) return s;
  }
  if (options.torsion) {
    if (Status s = RequirePositive("torsion.torsional_modulus", options.torsion->torsional_modulus);
        !s.ok()) {
      return s;
    }
    if (Status s = RequireNonNegative("torsion.rig_compliance", options.torsion->rig_compliance);
        !s.ok()) {
      return s;
    }
    if (Status s = RequireFinite("torsion.rig_compliance", options.torsion->rig_compliance);
        !s.ok()) {
      return s;
    }
  }
  if (options.burn_in_reversals < 0) {
    return InvalidArgument("burn_in_reversals",
                           "must be >= 0, got " + std::to_string(options.burn_in_reversals));
  }
  return OkStatus();
}

// The initial value of a free parameter: given, or the scene's.
double InitialValue(const FreeParameter& free, const ContactConfig& scene,
                    const FitOptions& options, const std::vector<LoopSet>& sets) {
  if (free.initial) return *free.initial;
  switch (free.parameter) {
    case Parameter::kFriction:
      return scene.friction;
    case Parameter::kEffectiveModulus:
      return scene.material.e_star;
    case Parameter::kRigCompliance:
      return options.torsion ? options.torsion->rig_compliance : scene.rig.tangential;
    case Parameter::kTorsionalModulus:
      return options.torsion ? options.torsion->torsional_modulus : 0;
    case Parameter::kDisplacementOffset:
      return sets.front().samples.displacement.front();
    case Parameter::kProfileScale:
      break;  // always given (checked)
  }
  return 0;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / static_cast<double>(v.size()));
}

// The unweighted residuals (N) from the weighted ones.
std::vector<double> Unweighted(const std::vector<double>& r, const std::vector<double>& weights) {
  std::vector<double> out(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) out[i] = r[i] / weights[i];
  return out;
}

// The adequacy figures of one set from its normalised residuals z (each over its noise) and its
// model path.
void AssessAdequacy(const PreparedSet& set, const std::vector<double>& z,
                    const std::vector<double>& path, double parameters, SetFit* fit) {
  const std::size_t n = z.size();
  double sum = 0;
  for (double v : z) sum += v * v;
  const double dof = std::max(1.0, static_cast<double>(n) - parameters);
  fit->reduced_chi_square = sum / dof;
  // Lag-1 autocorrelation within half-cycles, and the residuals binned by direction and position
  // along each complete half-cycle.
  const std::size_t count = set.reversals.size();
  double lag = 0;
  std::vector<double> bin_sum(2 * kStructureBinsPerDirection, 0);
  std::vector<std::size_t> bin_count(bin_sum.size(), 0);
  for (std::size_t k = 0; k <= count; ++k) {
    const std::size_t begin = k == 0 ? 0 : set.reversals[k - 1] + 1;
    const std::size_t end = k < count ? set.reversals[k] : set.samples - 1;
    const bool rising = k < count ? set.upper[k] : !set.upper[count - 1];
    const bool complete = k > 0 && k < count;
    const double from = complete ? path[set.reversals[k - 1]] : 0;
    const double span = complete ? path[set.reversals[k]] - from : 0;
    for (std::size_t i = std::max(begin, set.first_residual); i <= end; ++i) {
      const std::size_t row = i - set.first_residual;
      if (i + 1 <= end) lag += z[row] * z[row + 1];
      if (!complete || span == 0) continue;
      const double fraction = std::clamp((path[i] - from) / span, 0.0, 1.0);
      const auto bin =
          std::min<std::size_t>(kStructureBinsPerDirection - 1,
                                static_cast<std::size_t>(fraction * kStructureBinsPerDirection));
      const std::size_t b = bin + (rising ? 0 : kStructureBinsPerDirection);
      bin_sum[b] += z[row];
      ++bin_count[b];
    }
  }
  fit->autocorrelation = sum > 0 ? lag / sum : 0;
  double statistic = 0;
  int bins = 0;
  // Against the noise, or the residuals' own scatter where that is larger (a misfit's): a
  // noise-free record's rounding has a structure too, but none that matters.
  const double variance = std::max(fit->reduced_chi_square, 1.0);
  for (std::size_t b = 0; b < bin_sum.size(); ++b) {
    if (bin_count[b] < kMinBinCount) continue;
    const double mean = bin_sum[b] / static_cast<double>(bin_count[b]);
    statistic += static_cast<double>(bin_count[b]) * mean * mean / variance;
    ++bins;
  }
  fit->structure_statistic = statistic;
  fit->structure_bins = bins;
  fit->structure_p_value = bins > 0 ? gsl_cdf_chisq_Q(statistic, bins) : 1;
}

// Everything the result reports, from the solution.
class Assessment {
 public:
  Assessment(const FitModel& model, const std::vector<LoopSet>& sets, const FitOptions& options,
             const std::vector<double>& x, const std::vector<double>& r,
             const std::vector<SparseColumn>& jacobian, FitResult* result)
      : model_(model),
        sets_(sets),
        options_(options),
        x_(x),
        r_(r),
        jacobian_(jacobian),
        result_(result) {}

  Status Run() {
    const Layout& layout = model_.layout();
    const std::size_t n = r_.size(), p = layout.size;
    result_->parameters = p;
    covariance_.emplace(jacobian_, layout);
    const double dof = static_cast<double>(n) - static_cast<double>(covariance_->rank());
    double rss = 0;
    for (double v : r_) rss += v * v;
    s2_ = dof > 0 ? rss / dof : std::numeric_limits<double>::infinity();
    t_ = dof > 0 ? gsl_cdf_tdist_Pinv(0.975, dof) : std::numeric_limits<double>::infinity();
    result_->reduced_chi_square = s2_;
    const std::vector<std::size_t> starts = HalfCycleStarts();
    robust_ = covariance_->ClusterRobust(jacobian_, r_, starts);
    t_robust_ = starts.size() > 1
                    ? gsl_cdf_tdist_Pinv(0.975, static_cast<double>(starts.size() - 1))
                    : std::numeric_limits<double>::infinity();
    Estimates();
    if (Status s = Sets(); !s.ok()) return s;
    Nuisances();
    Verdict();
    return OkStatus();
  }

 private:
  // Where each half-cycle's residual rows start, set by set: the clusters of the sandwich.
  std::vector<std::size_t> HalfCycleStarts() const {
    std::vector<std::size_t> starts;
    for (const PreparedSet& set : model_.sets()) {
      starts.push_back(set.row_offset);
      for (std::size_t r : set.reversals) {
        if (r + 1 > set.first_residual && r + 1 < set.samples) {
          starts.push_back(set.row_offset + r + 1 - set.first_residual);
        }
      }
    }
    return starts;
  }

  struct NuisanceCoordinate {
    Nuisance nuisance;
    std::optional<std::size_t> set;
    std::size_t coordinate;
  };
  std::vector<NuisanceCoordinate> NuisanceCoordinates() const {
    const Layout& layout = model_.layout();
    std::vector<NuisanceCoordinate> out;
    for (std::size_t s = 0; s < layout.blocks.size(); ++s) {
      const Layout::Block& b = layout.blocks[s];
      if (b.force_offset) out.push_back({Nuisance::kForceOffset, s, *b.force_offset});
      if (b.displacement_offset) {
        out.push_back({Nuisance::kDisplacementOffset, s, *b.displacement_offset});
      }
      if (b.drift) out.push_back({Nuisance::kDisplacementDrift, s, *b.drift});
    }
    if (layout.mass) out.push_back({Nuisance::kMovingMass, std::nullopt, *layout.mass});
    return out;
  }

  // The free parameters: values, standard errors and Wald intervals, correlations, the condition
  // of their information with the nuisances profiled out, and what the data separate.
  void Estimates() {
    const std::size_t f = model_.layout().free;
    const std::vector<double> values = model_.Values(x_);
    Eigen::VectorXd derivative(f), scale(f);
    for (std::size_t k = 0; k < f; ++k) {
      derivative[k] = model_.bounds()[k].Derivative(x_[k]);
      scale[k] = options_.free[k].parameter == Parameter::kDisplacementOffset ? DisplacementScale()
                                                                              : std::abs(values[k]);
    }
    // (J^T J)^-1 of the free parameters in theta, relative (over each parameter's scale).
    Eigen::MatrixXd relative(f, f);
    for (std::size_t a = 0; a < f; ++a) {
      for (std::size_t b = 0; b < f; ++b) {
        relative(a, b) =
            covariance_->shared()(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) *
            derivative[a] * derivative[b] / (scale[a] * scale[b]);
      }
    }
    const bool singular = covariance_->singular() || !relative.allFinite();
    result_->condition_number = std::numeric_limits<double>::infinity();
    result_->weakest_combination.assign(f, 0);
    if (!singular) {
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(relative);
      const Eigen::VectorXd lambda = eigen.eigenvalues();  // ascending: of the covariance
      if (lambda[0] > 0) result_->condition_number = std::sqrt(lambda[f - 1] / lambda[0]);
      const Eigen::VectorXd weakest = eigen.eigenvectors().col(static_cast<Eigen::Index>(f) - 1);
      result_->weakest_combination.assign(weakest.data(), weakest.data() + f);
    }
    result_->correlation.assign(f, std::vector<double>(f, 0));
    for (std::size_t a = 0; a < f; ++a) {
      for (std::size_t b = 0; b < f; ++b) {
        const double c = relative(a, b) / std::sqrt(relative(a, a) * relative(b, b));
        result_->correlation[a][b] = a == b ? 1 : (std::isfinite(c) ? c : 1);
      }
    }
    const bool ill_conditioned = !(result_->condition_number < kConditionLimit);
    for (std::size_t k = 0; k < f; ++k) {
      ParameterEstimate e;
      e.parameter = options_.free[k].parameter;
      e.value = values[k];
      e.standard_error = singular ? std::numeric_limits<double>::infinity()
                                  : std::sqrt(s2_ * relative(k, k)) * scale[k];
      double quantile = t_;
      // The half-cycles' sandwich where it is the larger: residuals that move together.
      const auto kk = static_cast<Eigen::Index>(k);
      const double robust = std::sqrt(robust_(kk, kk)) * derivative[kk];
      if (!singular && robust > e.standard_error && std::isfinite(robust)) {
        e.standard_error = robust;
        e.interval = IntervalMethod::kHalfCycleSandwich;
        quantile = t_robust_;
      }
      e.lower_95 = e.value - quantile * e.standard_error;
      e.upper_95 = e.value + quantile * e.standard_error;
      double worst = 0;
      for (std::size_t b = 0; b < f; ++b) {
        if (b != k) worst = std::max(worst, std::abs(result_->correlation[k][b]));
      }
      const double width = quantile * e.standard_error / scale[k];
      e.identified =
          !singular && !ill_conditioned && worst < kCorrelationLimit && width < kRelativeWidthLimit;
      if (!(width < kRelativeWidthLimit)) {
        result_->notes.push_back(std::string(ParameterName(e.parameter)) +
                                 " is not determined by the data: its 95 % interval is +-" +
                                 FormatNumber(quantile * e.standard_error) + " about " +
                                 FormatNumber(e.value));
      }
      for (std::size_t b = k + 1; b < f; ++b) {
        if (std::abs(result_->correlation[k][b]) >= kCorrelationLimit) {
          result_->notes.push_back(std::string(ParameterName(e.parameter)) + " and " +
                                   ParameterName(options_.free[b].parameter) +
                                   " are correlated at " +
                                   FormatNumber(result_->correlation[k][b]) +
                                   ": the loops fix their combination, not each");
        }
      }
      result_->estimates.push_back(e);
    }
    if (ill_conditioned) {
      std::string combination;
      for (std::size_t k = 0; k < f; ++k) {
        combination += (k ? ", " : "") + std::string(ParameterName(options_.free[k].parameter)) +
                       " " + FormatNumber(result_->weakest_combination[k]);
      }
      result_->notes.push_back("the fit is ill-conditioned (condition number " +
                               FormatNumber(result_->condition_number) +
                               "): the data hardly constrain the relative change (" + combination +
                               ")");
    }
    derivative_ = derivative;
  }

  double DisplacementScale() const {
    double scale = 0;
    for (const PreparedSet& s : model_.sets()) scale = std::max(scale, s.stroke);
    return scale;
  }

  void Nuisances() {
    const std::size_t f = model_.layout().free;
    for (const NuisanceCoordinate& c : NuisanceCoordinates()) {
      NuisanceEstimate e;
      e.nuisance = c.nuisance;
      e.set = c.set;
      const double scale = model_.Scale(c.coordinate);
      const double offset =
          c.nuisance == Nuisance::kDisplacementOffset ? model_.sets()[*c.set].default_offset : 0;
      e.value = offset + x_[c.coordinate] * scale;
      // Its variance and covariance with the free parameters (solver coordinates).
      const std::size_t f_mass = model_.layout().free;
      const bool shared = !c.set;
      const double variance = shared ? covariance_->shared()(static_cast<Eigen::Index>(f_mass),
                                                             static_cast<Eigen::Index>(f_mass))
                                     : covariance_->Variance(c.coordinate);
      const Eigen::VectorXd with_free =
          shared ? Eigen::VectorXd(covariance_->shared().col(static_cast<Eigen::Index>(f_mass)))
                 : covariance_->WithShared(c.coordinate);
      const bool determined = (shared || covariance_->determined(c.coordinate)) &&
                              std::isfinite(variance) && variance > 0;
      e.standard_error =
          determined ? std::sqrt(s2_ * variance) * scale : std::numeric_limits<double>::infinity();
      double quantile = t_;
      if (shared && determined) {  // the mass: the half-cycles' sandwich where it is larger
        const auto m = static_cast<Eigen::Index>(f_mass);
        const double robust = std::sqrt(robust_(m, m)) * scale;
        if (robust > e.standard_error && std::isfinite(robust)) {
          e.standard_error = robust;
          quantile = t_robust_;
        }
      }
      e.lower_95 = e.value - quantile * e.standard_error;
      e.upper_95 = e.value + quantile * e.standard_error;
      // Identified: its 95 % interval narrower than half its natural range (the set's force or
      // stroke amplitude; the mass whose inertia would match the force amplitude).
      e.identified = determined && quantile * e.standard_error < kRelativeWidthLimit * scale;
      // Held at zero (its coordinate at 0), the free parameters would move by
      // -cov(free, nuisance) / var(nuisance) times its coordinate, to first order.
      for (std::size_t k = 0; k < f; ++k) {
        e.effect.push_back(determined
                               ? -with_free[static_cast<Eigen::Index>(k)] / variance *
                                     x_[c.coordinate] * derivative_[static_cast<Eigen::Index>(k)]
                               : 0);
      }
      // The press point, fitted always, is undetermined in every set that slides fully: no note.
      if (!e.identified && e.nuisance != Nuisance::kDisplacementOffset) {
        result_->notes.push_back(
            std::string(NuisanceName(e.nuisance)) +
            (c.set ? " of sets[" + std::to_string(*c.set) + "]" : std::string()) +
            " is not determined by the loops (its 95 % interval is +-" +
            FormatNumber(t_ * e.standard_error) + ")");
      }
      result_->nuisances.push_back(std::move(e));
    }
    SeparateOffsets();
  }

  // Loops of partial slip remember where the contact was pressed: their forces carry a constant
  // set by the press point and by the history before the counted samples, which a force offset
  // shifts them by too, so the data fix the two together, not each -- however the covariance
  // at the solution reads (a press point a little further makes the uncounted first loading
  // slide fully, and the memory of it vanishes). Unless the virgin loading is counted
  // (burn_in_reversals 0), a set that is not in gross slip has neither identified; nor does one
  // whose two estimates are correlated beyond the limit.
  void SeparateOffsets() {
    const Layout& layout = model_.layout();
    for (std::size_t s = 0; s < layout.blocks.size(); ++s) {
      const Layout::Block& b = layout.blocks[s];
      if (!b.force_offset || !b.displacement_offset) continue;
      const std::size_t f = *b.force_offset, d = *b.displacement_offset;
      std::string why;
      if (options_.burn_in_reversals > 0 && !result_->sets[s].gross_slip) {
        why =
            ": its loops of partial slip fix their combination, not each (counting the virgin "
            "loading, burn_in_reversals 0, separates them)";
      } else if (covariance_->determined(f) && covariance_->determined(d)) {
        const double c = covariance_->Covariance(f, d) /
                         std::sqrt(covariance_->Variance(f) * covariance_->Variance(d));
        if (std::abs(c) >= kCorrelationLimit) {
          why = " are correlated at " + FormatNumber(c) + ": its loops fix their combination";
        }
      }
      if (why.empty()) continue;
      for (NuisanceEstimate& e : result_->nuisances) {
        if (e.set == s &&
            (e.nuisance == Nuisance::kForceOffset || e.nuisance == Nuisance::kDisplacementOffset)) {
          e.identified = false;
        }
      }
      result_->notes.push_back("force_offset and displacement_offset of sets[" + std::to_string(s) +
                               "] are not identified" + why);
    }
  }

  Status Sets() {
    const Layout& layout = model_.layout();
    const std::vector<double>& weights = model_.weights();
    const std::vector<double> force = Unweighted(r_, weights);
    result_->residual_rms = Rms(force);
    result_->residuals = r_.size();
    const auto n = static_cast<double>(r_.size());
    for (std::size_t s = 0; s < model_.sets().size(); ++s) {
      const PreparedSet& set = model_.sets()[s];
      const LoopSamples& samples = set.set->samples;
      SetFit fit;
      fit.displacement_noise = set.displacement_noise;
      fit.force_noise = set.force_noise;
      fit.noise_estimated = !options_.displacement_noise && !options_.force_noise;
      fit.displacement_noise_correlation = NoiseCorrelation(samples.displacement);
      fit.force_noise_correlation = NoiseCorrelation(samples.tangential_force);
      fit.normal_force_measured = !set.normal.empty();
      if (fit.normal_force_measured) {
        fit.normal_force_noise = NoiseFromDifferences(samples.normal_force);
        const auto [lo, hi] = std::minmax_element(set.normal.begin(), set.normal.end());
        fit.normal_force_min = *lo, fit.normal_force_max = *hi;
        double sum = 0;
        for (double v : set.normal) sum += v;
        fit.normal_force = sum / static_cast<double>(set.normal.size());
        const auto [mlo, mhi] =
            std::minmax_element(samples.normal_force.begin(), samples.normal_force.end());
        // Three noise deviations, and a millionth of the load: a noise-free column's rounding.
        const double margin = 3 * fit.normal_force_noise + 1e-6 * std::abs(*mhi);
        const std::optional<double>& declared = sets_[s].normal_force;
        fit.load_mismatch = declared && (*declared < *mlo - margin || *declared > *mhi + margin);
        if (fit.load_mismatch) {
          result_->notes.push_back("sets[" + std::to_string(s) + "]: the declared normal force " +
                                   FormatNumber(*declared) +
                                   " N lies outside the range its normal_force column measured, [" +
                                   FormatNumber(*mlo) + ", " + FormatNumber(*mhi) +
                                   "] N: declaration and measurement disagree");
        }
      } else {
        fit.normal_force = fit.normal_force_min = fit.normal_force_max = set.constant_normal;
      }
      fit.first_residual = set.first_residual;
      fit.residuals = set.samples - set.first_residual;
      const Layout::Block& block = layout.blocks[s];
      fit.turning_points = block.turning_count;
      const std::vector<double> fitted = model_.TurningPoints(x_, s);
      double shift = 0;
      for (std::size_t k = 0; k < fitted.size(); ++k) {
        const double d = fitted[k] - set.turning[set.first_free_turning + k];
        shift += d * d;
      }
      fit.turning_point_shift_rms =
          fitted.empty() ? 0 : std::sqrt(shift / static_cast<double>(fitted.size()));
      const auto rows_begin = r_.begin() + static_cast<std::ptrdiff_t>(set.row_offset);
      const std::vector<double> z(rows_begin,
                                  rows_begin + static_cast<std::ptrdiff_t>(fit.residuals));
      fit.residual_rms = Rms(std::vector<double>(
          force.begin() + static_cast<std::ptrdiff_t>(set.row_offset),
          force.begin() + static_cast<std::ptrdiff_t>(set.row_offset + fit.residuals)));
      Result<internal::SetEvaluation> evaluation = model_.Evaluate(x_, s);
      if (!evaluation.ok()) return evaluation.status();
      const auto burn_in = static_cast<std::size_t>(options_.burn_in_reversals);
      fit.gross_slip = set.reversals.size() > burn_in;
      for (std::size_t k = burn_in; k < set.reversals.size(); ++k) {
        fit.gross_slip = fit.gross_slip && evaluation->stiffness[set.reversals[k]] == 0;
      }
      // Its share of the parameters: its own, and of the shared ones by its residuals.
      const double own = static_cast<double>(block.turning_count) + (block.force_offset ? 1 : 0) +
                         (block.displacement_offset ? 1 : 0) + (block.drift ? 1 : 0);
      const double shared = static_cast<double>(layout.free + (layout.mass ? 1 : 0)) *
                            static_cast<double>(fit.residuals) / n;
      AssessAdequacy(set, z, evaluation->path, own + shared, &fit);
      fit.misfit =
          fit.reduced_chi_square > kMisfitChiSquare || fit.structure_p_value < kMisfitPValue;
      if (fit.misfit) {
        result_->notes.push_back("sets[" + std::to_string(s) +
                                 "]: the model does not explain the loops to their noise " +
                                 "(reduced chi-square " + FormatNumber(fit.reduced_chi_square) +
                                 ", a structure repeated over the cycles with p = " +
                                 FormatNumber(fit.structure_p_value) + ")");
      }
      if (options_.keep_models) {
        result_->models.push_back({std::move(evaluation->path), std::move(evaluation->normal),
                                   std::move(evaluation->contact_force),
                                   std::move(evaluation->predicted)});
      }
      result_->sets.push_back(fit);
    }
    return OkStatus();
  }

  void Verdict() {
    result_->adequate = std::none_of(result_->sets.begin(), result_->sets.end(),
                                     [](const SetFit& s) { return s.misfit || s.load_mismatch; });
    result_->identified =
        result_->adequate && std::all_of(result_->estimates.begin(), result_->estimates.end(),
                                         [](const ParameterEstimate& e) { return e.identified; });
  }

  const FitModel& model_;
  const std::vector<LoopSet>& sets_;
  const FitOptions& options_;
  const std::vector<double>& x_;
  const std::vector<double>& r_;
  const std::vector<SparseColumn>& jacobian_;
  FitResult* result_;
  std::optional<internal::BlockCovariance> covariance_;
  Eigen::MatrixXd robust_;  // the half-cycles' sandwich of the shared coordinates
  double t_robust_ = 0;
  Eigen::VectorXd derivative_;
  double s2_ = 0, t_ = 0;
};

}  // namespace

const char* ParameterName(Parameter parameter) {
  switch (parameter) {
    case Parameter::kFriction:
      return "friction";
    case Parameter::kEffectiveModulus:
      return "effective_modulus";
    case Parameter::kProfileScale:
      return "profile_scale";
    case Parameter::kRigCompliance:
      return "rig_compliance";
    case Parameter::kDisplacementOffset:
      return "displacement_offset";
    case Parameter::kTorsionalModulus:
      return "torsional_modulus";
  }
  return "unknown";
}

const char* NuisanceName(Nuisance nuisance) {
  switch (nuisance) {
    case Nuisance::kForceOffset:
      return "force_offset";
    case Nuisance::kDisplacementOffset:
      return "displacement_offset";
    case Nuisance::kDisplacementDrift:
      return "displacement_drift";
    case Nuisance::kMovingMass:
      return "moving_mass";
  }
  return "unknown";
}

const char* IntervalMethodName(IntervalMethod method) {
  return method == IntervalMethod::kWald ? "wald" : "half_cycle_sandwich";
}

Result<FitResult> FitLoops(const ContactConfig& scene, const std::vector<LoopSet>& sets,
                           const FitOptions& options, const Interrupt& interrupt,
                           const FitProgress& progress) {
  if (Status s = ValidateContactConfig(scene); !s.ok()) return s.WithFieldPrefix("scene");
  if (Status s = CheckFreeParameters(options); !s.ok()) return s;
  if (sets.empty()) return InvalidArgument("sets", "needs at least one loop set");
  // A torsional fit takes torsional records only, a tangential one tangential records.
  const LoopChannel channel = options.torsion ? LoopChannel::kTorsional : LoopChannel::kTangential;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    if (sets[i].samples.channel != channel) {
      return InvalidArgument(Indexed("sets", i) + ".samples",
                             options.torsion ? "must be a torsional record (twist, twisting moment) "
                                               "for a torsional fit"
                                             : "must be a tangential record (displacement, "
                                               "tangential force) for a tangential fit: a "
                                               "torsional one needs the scene's torsion");
    }
  }
  LoopOptions loop_options;
  loop_options.reversal_threshold = options.reversal_threshold;
  if (Status s = ValidateLoopOptions(loop_options); !s.ok()) return s;  // the fit's own field
  std::vector<PreparedSet> prepared;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    Result<PreparedSet> set = internal::PrepareSet(sets[i], i, options, interrupt);
    if (!set.ok()) return set.status();
    prepared.push_back(std::move(set).value());
  }
  std::vector<internal::Bounded> bounds;
  std::vector<double> initial;
  for (std::size_t k = 0; k < options.free.size(); ++k) {
    const FreeParameter& free = options.free[k];
    const double value = InitialValue(free, scene, options, sets);
    if (!(value > free.lower && value < free.upper)) {
      return InvalidArgument(Indexed("free", k) + ".initial",
                             "the initial value " + FormatNumber(value) + " of " +
                                 ParameterName(free.parameter) + " must lie inside (" +
                                 FormatNumber(free.lower) + ", " + FormatNumber(free.upper) + ")");
    }
    bounds.push_back({free.lower, free.upper});
    initial.push_back(value);
  }
  const int threads = options.threads > 0
                          ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  FitModel model(scene, std::move(prepared), options, bounds, interrupt, threads);
  const std::size_t n = model.residuals(), p = model.parameters();
  if (n <= p) {
    return FailedPrecondition("sets", std::to_string(n) + " counted samples cannot determine " +
                                          std::to_string(p) +
                                          " parameters (turning points and nuisances included)");
  }
  // The first stage unweighted (least squares in N, as robust a start as any), then the
  // effective-variance stages.
  std::vector<double> x = model.Start(initial);
  if (Status s = model.Reweigh(x, /*uniform=*/true); !s.ok()) return s;
  FitResult result;
  internal::SolverOptions solver;
  solver.step_tolerance = options.step_tolerance;
  const auto report = [&](int iteration, const std::vector<double>& r,
                          const std::vector<double>& at) {
    if (progress)
      progress(result.iterations + iteration, Rms(Unweighted(r, model.weights())),
               model.Values(at));
  };
  bool converged = false;
  for (int stage = 0; stage < kMaxReweighings; ++stage) {
    solver.max_iterations = options.max_iterations - result.iterations;
    if (solver.max_iterations <= 0) break;
    Result<internal::SolverOutcome> outcome = internal::SolveLeastSquares(model, x, solver, report);
    if (!outcome.ok()) return outcome.status();
    result.iterations += outcome->iterations;
    converged = outcome->converged;
    x = outcome->x;
    const std::vector<double> before = model.weights();
    if (Status s = model.Reweigh(x); !s.ok()) return s;
    if (stage == 0) continue;  // from uniform weights: always a weighted stage more
    // Settled when the weights move by less than kWeightChange in RMS (an isolated sample where
    // a branch's slope jumps may flip from stage to stage).
    double change = 0;
    for (std::size_t i = 0; i < before.size(); ++i) {
      const double d = model.weights()[i] / before[i] - 1;
      change += d * d;
    }
    if (std::sqrt(change / static_cast<double>(before.size())) < kWeightChange) break;
  }
  result.converged = converged;
  std::vector<double> r;
  std::vector<SparseColumn> jacobian;
  if (Status s = model.Residuals(x, &r); !s.ok()) return s;
  if (Status s = model.Jacobian(x, r, &jacobian); !s.ok()) return s;
  Assessment assessment(model, sets, options, x, r, jacobian, &result);
  if (Status s = assessment.Run(); !s.ok()) return s;
  Result<internal::FitScene> fitted = model.SceneAt(model.Values(x));
  if (!fitted.ok()) return fitted.status();
  result.fitted = std::move(fitted->contact);
  result.fitted.track_energy = scene.track_energy;
  result.fitted_torsion = fitted->torsion;
  return result;
}

Result<ComplianceGuess> GuessRigCompliance(const std::vector<LoopSet>& sets, double exponent,
                                           double reversal_threshold) {
  if (Status s = RequirePositive("exponent", exponent); !s.ok()) return s;
  ComplianceGuess guess;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::string field = Indexed("sets", i);
    const LoopSamples& samples = sets[i].samples;
    double load = 0;
    if (!samples.normal_force.empty()) {
      for (double v : samples.normal_force) load += v;
      load /= static_cast<double>(samples.normal_force.size());
    } else if (sets[i].normal_force) {
      load = *sets[i].normal_force;
    }
    if (Status s = RequirePositive(field + ".normal_force", load); !s.ok()) return s;
    LoopOptions options;
    options.reversal_threshold = reversal_threshold;
    Result<LoopAnalysis> loops = AnalyzeLoops(samples, options);
    if (!loops.ok()) return loops.status().WithFieldPrefix(field + ".samples");
    double stiffness = 0;
    for (const CycleMetrics& cycle : loops->cycles) {
      stiffness += 0.5 * (cycle.stiffness_increasing + cycle.stiffness_decreasing);
    }
    guess.normal_forces.push_back(load);
    guess.apparent_stiffness.push_back(stiffness / static_cast<double>(loops->cycles.size()));
  }
  // 1 / k = C_t + c x with x = P^(-1/(n+1)): least squares.
  const std::size_t m = sets.size();
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  std::vector<double> x(m), y(m);
  for (std::size_t i = 0; i < m; ++i) {
    x[i] = std::pow(guess.normal_forces[i], -1 / (exponent + 1));
    y[i] = 1 / guess.apparent_stiffness[i];
    sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  }
  const double mean_x = m > 0 ? sx / static_cast<double>(m) : 0, spread = sxx - sx * mean_x;
  if (m < 2 || !(spread > 1e-12 * sxx)) {
    return FailedPrecondition("sets", "needs loop sets at two or more distinct normal forces");
  }
  guess.slope = (sxy - sx * sy / static_cast<double>(m)) / spread;
  guess.rig_compliance = sy / static_cast<double>(m) - guess.slope * mean_x;
  if (m > 2) {
    double rss = 0;
    for (std::size_t i = 0; i < m; ++i) {
      const double r = y[i] - guess.rig_compliance - guess.slope * x[i];
      rss += r * r;
    }
    const double s2 = rss / static_cast<double>(m - 2);
    guess.standard_error = std::sqrt(s2 * (1 / static_cast<double>(m) + mean_x * mean_x / spread));
  }
  return guess;
}

}  // namespace mdr::analysis
