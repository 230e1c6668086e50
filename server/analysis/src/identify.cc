#include "mdr/analysis/identify.h"

#include <gsl/gsl_blas.h>
#include <gsl/gsl_cdf.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_multifit_nlinear.h>
#include <gsl/gsl_vector.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <set>
#include <thread>

#include "mdr/base/validate.h"

namespace mdr::analysis {
namespace {

constexpr double kCorrelationLimit = 0.99;   // beyond: two parameters are not separated
constexpr double kConditionLimit = 1e8;      // beyond: the data constrain a combination poorly
constexpr double kRelativeWidthLimit = 0.5;  // 95 % half-width over |value| beyond: undetermined
constexpr std::uint32_t kInterruptPeriod = 1024;  // samples between interrupt checks

// A bounded parameter in the solver's unbounded coordinate phi: theta = lo + (hi - lo) / (1 +
// exp(-phi)), so every trial value lies strictly inside the bounds.
struct Bounded {
  double lo, hi;
  double Value(double phi) const { return lo + (hi - lo) / (1 + std::exp(-phi)); }
  double Phi(double value) const { return std::log((value - lo) / (hi - value)); }
  double Derivative(double phi) const {  // d theta / d phi
    const double s = 1 / (1 + std::exp(-phi));
    return (hi - lo) * s * (1 - s);
  }
};

// One set prepared for replay: its samples and the index from which residuals count.
struct PreparedSet {
  const LoopSet* set;
  std::size_t first_residual;
  // The actuator path the replay follows: the measured displacement made monotone between its
  // reversals (ReplayPath).
  std::vector<double> path;
  std::vector<std::size_t> reversals;
};

// The least-squares non-decreasing fit of v[0, n) in place (pool adjacent violators).
void MakeNonDecreasing(double* v, std::size_t n) {
  std::vector<double> mean;
  std::vector<std::size_t> count;
  for (std::size_t i = 0; i < n; ++i) {
    mean.push_back(v[i]);
    count.push_back(1);
    while (mean.size() > 1 && mean[mean.size() - 2] > mean.back()) {
      const std::size_t c = count.back() + count[count.size() - 2];
      const double m = (mean.back() * static_cast<double>(count.back()) +
                        mean[mean.size() - 2] * static_cast<double>(count[count.size() - 2])) /
                       static_cast<double>(c);
      mean.pop_back(), count.pop_back();
      mean.back() = m, count.back() = c;
    }
  }
  std::size_t i = 0;
  for (std::size_t b = 0; b < mean.size(); ++b) {
    for (std::size_t k = 0; k < count[b]; ++k) v[i++] = mean[b];
  }
}

// Everything the residual function needs.
class Problem {
 public:
  Problem(const ContactConfig& scene, std::vector<PreparedSet> sets, const FitOptions& options,
          std::vector<Bounded> bounds, const Interrupt& interrupt)
      : scene_(scene),
        sets_(std::move(sets)),
        options_(options),
        bounds_(std::move(bounds)),
        interrupt_(interrupt) {
    for (const PreparedSet& s : sets_) {
      offsets_.push_back(residuals_);
      residuals_ += s.set->samples.displacement.size() - s.first_residual;
    }
  }

  std::size_t residuals() const { return residuals_; }

  // Where each half-cycle's residuals start (indices into the residual vector, ascending): the
  // clusters of the robust covariance. A turning point's displacement, as measured, shapes the
  // model's whole next half-cycle, so its noise makes their residuals move together.
  std::vector<std::size_t> HalfCycleStarts() const {
    std::vector<std::size_t> starts;
    for (std::size_t i = 0; i < sets_.size(); ++i) {
      const PreparedSet& s = sets_[i];
      starts.push_back(offsets_[i]);
      for (std::size_t r : s.reversals) {
        const std::size_t next = r + 1;  // the reversal's sample closes its stretch
        if (next > s.first_residual && next < s.set->samples.displacement.size()) {
          starts.push_back(offsets_[i] + (next - s.first_residual));
        }
      }
    }
    return starts;
  }
  std::size_t parameters() const { return bounds_.size(); }
  const std::vector<Bounded>& bounds() const { return bounds_; }

  std::vector<double> Values(const double* phi) const {
    std::vector<double> values(bounds_.size());
    for (std::size_t k = 0; k < values.size(); ++k) values[k] = bounds_[k].Value(phi[k]);
    return values;
  }

  // The scene at these parameter values.
  Result<ContactConfig> SceneAt(const std::vector<double>& values) const {
    ContactConfig scene = scene_;
    const double kappa = scene.material.kappa();
    for (std::size_t k = 0; k < values.size(); ++k) {
      switch (options_.free[k].parameter) {
        case Parameter::kFriction:
          scene.friction = values[k];
          break;
        case Parameter::kEffectiveModulus:
          scene.material.e_star = values[k];
          scene.material.g_star = values[k] / kappa;
          break;
        case Parameter::kProfileScale: {
          Result<ProfilePtr> profile = options_.profile_family(values[k]);
          if (!profile.ok()) return profile.status();
          scene.profile = std::move(profile).value();
          break;
        }
        case Parameter::kRigCompliance:
          scene.rig.tangential = values[k];
          break;
        case Parameter::kDisplacementOffset:
          break;  // used by the replay
      }
    }
    return scene;
  }

  // Where the virgin contact is pressed in set i's coordinates.
  double Offset(const std::vector<double>& values, std::size_t i) const {
    for (std::size_t k = 0; k < values.size(); ++k) {
      if (options_.free[k].parameter == Parameter::kDisplacementOffset) return values[k];
    }
    return sets_[i].path.front();
  }

  // Residuals (model - measured force) of every set at phi, written to r; the sets run on up to
  // `threads` threads. Fails if a replay fails or the interrupt fires.
  Status Residuals(const double* phi, double* r, int threads) const {
    const std::vector<double> values = Values(phi);
    Result<ContactConfig> scene = SceneAt(values);
    if (!scene.ok()) return scene.status();
    return ForEach(sets_.size(), threads, [&](std::size_t i) {
      return Replay(*scene, Offset(values, i), i, r + offsets_[i]);
    });
  }

  // Runs task(0 .. count - 1) on up to `threads` threads; the first error wins.
  template <class Task>
  static Status ForEach(std::size_t count, int threads, const Task& task) {
    const std::size_t workers = std::min<std::size_t>(count, std::max(threads, 1));
    std::atomic<std::size_t> next{0};
    std::vector<Status> errors(workers);
    auto work = [&](std::size_t w) {
      for (std::size_t i = next++; i < count; i = next++) {
        if (Status s = task(i); !s.ok() && errors[w].ok()) errors[w] = s;
      }
    };
    std::vector<std::thread> pool;
    for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
    work(0);
    for (std::thread& t : pool) t.join();
    for (const Status& s : errors) {
      if (!s.ok()) return s;
    }
    return OkStatus();
  }

 private:
  // The measured actuator path of set i through the exact engine.
  Status Replay(const ContactConfig& scene, double offset, std::size_t i, double* r) const {
    const PreparedSet& prepared = sets_[i];
    const LoopSamples& samples = prepared.set->samples;
    Result<Contact> created = Contact::Create(scene);
    if (!created.ok()) return created.status();
    Contact c = std::move(created).value();
    Step to_offset, press, move;
    to_offset.tangential = move.tangential = TangentialControl::kDisplacement;
    to_offset.tangential_value = offset;
    press.normal = NormalControl::kForce;
    press.normal_value = prepared.set->normal_force;
    if (Status s = c.Apply(to_offset); !s.ok()) return s;
    if (Status s = c.Apply(press); !s.ok()) return s;
    for (std::size_t k = 0; k < prepared.path.size(); ++k) {
      if (Status s = interrupt_.CheckEvery(kInterruptPeriod, k); !s.ok()) return s;
      move.tangential_value = prepared.path[k];
      // A failure ends the replay (c is dropped): no undo copy per sample.
      if (Status s = c.Apply(move, nullptr, {}, Contact::OnFailure::kDiscarded); !s.ok()) {
        return s;
      }
      if (k >= prepared.first_residual) {
        *r++ = c.tangential_force() - samples.tangential_force[k];
      }
    }
    return OkStatus();
  }

  const ContactConfig& scene_;
  std::vector<PreparedSet> sets_;
  const FitOptions& options_;
  std::vector<Bounded> bounds_;
  const Interrupt& interrupt_;
  std::vector<std::size_t> offsets_;
  std::size_t residuals_ = 0;
};

// What the GSL callbacks see.
struct Callbacks {
  const Problem* problem;
  int threads;
  Status error;  // the first failure of a residual evaluation
};

int ResidualFunction(const gsl_vector* x, void* params, gsl_vector* f) {
  auto* c = static_cast<Callbacks*>(params);
  Status s = c->problem->Residuals(x->data, f->data, c->threads);
  if (s.ok()) return GSL_SUCCESS;
  if (c->error.ok()) c->error = s;
  return GSL_EFAILED;
}

// Forward differences in phi, the columns computed concurrently.
int JacobianFunction(const gsl_vector* x, void* params, gsl_matrix* jacobian) {
  auto* c = static_cast<Callbacks*>(params);
  const Problem& problem = *c->problem;
  const std::size_t n = problem.residuals(), p = problem.parameters();
  std::vector<double> base(n);
  std::vector<std::vector<double>> columns(p, std::vector<double>(n));
  std::vector<double> phi(x->data, x->data + p);
  Status s = problem.Residuals(phi.data(), base.data(), c->threads);
  if (s.ok()) {
    s = Problem::ForEach(p, c->threads, [&](std::size_t k) {
      std::vector<double> shifted = phi;
      const double h = 1e-7 * std::max(1.0, std::abs(phi[k]));
      shifted[k] += h;
      if (Status e = problem.Residuals(shifted.data(), columns[k].data(), 1); !e.ok()) return e;
      for (std::size_t i = 0; i < n; ++i) columns[k][i] = (columns[k][i] - base[i]) / h;
      return OkStatus();
    });
  }
  if (!s.ok()) {
    if (c->error.ok()) c->error = s;
    return GSL_EFAILED;
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < p; ++k) gsl_matrix_set(jacobian, i, k, columns[k][i]);
  }
  return GSL_SUCCESS;
}

double Rms(const gsl_vector* f) {
  return f->size > 0 ? gsl_blas_dnrm2(f) / std::sqrt(static_cast<double>(f->size)) : 0;
}

Status CheckFreeParameters(const ContactConfig& scene, const FitOptions& options) {
  if (options.free.empty() || options.free.size() > 5) {
    return InvalidArgument("free",
                           "needs 1 to 5 parameters, got " + std::to_string(options.free.size()));
  }
  std::set<Parameter> seen;
  for (std::size_t k = 0; k < options.free.size(); ++k) {
    const FreeParameter& free = options.free[k];
    const std::string field = Indexed("free", k);
    if (!seen.insert(free.parameter).second) {
      return InvalidArgument(field + ".parameter",
                             std::string(ParameterName(free.parameter)) + " is free twice");
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
  }
  (void)scene;
  return OkStatus();
}

// The initial value of a free parameter: given, or the scene's.
double InitialValue(const FreeParameter& free, const ContactConfig& scene,
                    const std::vector<LoopSet>& sets) {
  if (free.initial) return *free.initial;
  switch (free.parameter) {
    case Parameter::kFriction:
      return scene.friction;
    case Parameter::kEffectiveModulus:
      return scene.material.e_star;
    case Parameter::kRigCompliance:
      return scene.rig.tangential;
    case Parameter::kDisplacementOffset:
      return sets.front().samples.displacement.front();
    case Parameter::kProfileScale:
      break;  // always given (checked)
  }
  return 0;
}

// The sets, checked and with their burn-in: residuals from the burn_in-th reversal on.
Result<std::vector<PreparedSet>> PrepareSets(const std::vector<LoopSet>& sets,
                                             const FitOptions& options,
                                             const Interrupt& interrupt) {
  if (sets.empty()) return InvalidArgument("sets", "needs at least one loop set");
  LoopOptions loop_options;
  loop_options.reversal_threshold = options.reversal_threshold;
  if (Status s = ValidateLoopOptions(loop_options); !s.ok()) return s;  // the fit's own field
  std::vector<PreparedSet> prepared;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::string field = Indexed("sets", i);
    if (Status s = RequirePositive(field + ".normal_force", sets[i].normal_force); !s.ok()) {
      return s;
    }
    Result<LoopAnalysis> loops = AnalyzeLoops(sets[i].samples, loop_options, interrupt);
    if (!loops.ok()) return loops.status().WithFieldPrefix(field + ".samples");
    const auto burn_in = static_cast<std::size_t>(std::max(options.burn_in_reversals, 0));
    std::size_t first = 0;
    if (burn_in > 0) {
      if (loops->reversals.size() < burn_in) {
        return FailedPrecondition(
            field + ".samples",
            "has " + std::to_string(loops->reversals.size()) +
                " reversals, fewer than burn_in_reversals = " + std::to_string(burn_in));
      }
      first = loops->reversals[burn_in - 1];
    }
    prepared.push_back({&sets[i], first, ReplayPath(sets[i].samples.displacement, loops->reversals),
                        loops->reversals});
  }
  return prepared;
}

// Estimates, correlations and the verdict from the Jacobian at the solution.
// The cluster-robust (sandwich) covariance of theta, clusters the half-cycles: bread (J^T J)^-1,
// meat the sum over clusters of (J_g^T r_g)(J_g^T r_g)^T, with the small-sample factor
// G/(G-1) (n-1)/(n-p). It is what the residuals' own correlation says, where s^2 (J^T J)^-1
// assumes independent ones.
Eigen::MatrixXd ClusterCovariance(const Eigen::MatrixXd& j_theta, const Eigen::VectorXd& residual,
                                  const Eigen::MatrixXd& bread,
                                  const std::vector<std::size_t>& starts) {
  const Eigen::Index n = j_theta.rows(), p = j_theta.cols();
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(p, p);
  for (std::size_t g = 0; g < starts.size(); ++g) {
    const auto begin = static_cast<Eigen::Index>(starts[g]);
    const Eigen::Index end = g + 1 < starts.size() ? static_cast<Eigen::Index>(starts[g + 1]) : n;
    const Eigen::VectorXd score =
        j_theta.middleRows(begin, end - begin).transpose() * residual.segment(begin, end - begin);
    meat += score * score.transpose();
  }
  const auto clusters = static_cast<double>(starts.size());
  const double factor =
      clusters / (clusters - 1) * static_cast<double>(n - 1) / static_cast<double>(n - p);
  return factor * bread * meat * bread;
}

void Assess(const Problem& problem, const std::vector<double>& phi, const Eigen::MatrixXd& jacobian,
            const Eigen::VectorXd& residual, const FitOptions& options,
            const std::vector<LoopSet>& sets, FitResult* result) {
  const double rss = residual.squaredNorm();
  const std::size_t n = problem.residuals(), p = problem.parameters();
  const std::vector<double> values = problem.Values(phi.data());
  Eigen::VectorXd derivative(p), scale(p);
  double displacement_scale = 0;  // for a relative offset: the data's amplitude
  for (const LoopSet& set : sets) {
    const auto [lo, hi] =
        std::minmax_element(set.samples.displacement.begin(), set.samples.displacement.end());
    displacement_scale = std::max(displacement_scale, 0.5 * (*hi - *lo));
  }
  for (std::size_t k = 0; k < p; ++k) {
    derivative[k] = problem.bounds()[k].Derivative(phi[k]);
    scale[k] = options.free[k].parameter == Parameter::kDisplacementOffset ? displacement_scale
                                                                           : std::abs(values[k]);
  }
  // J in theta, and with relative columns (dr / (d theta / theta)).
  const Eigen::MatrixXd j_theta = jacobian * derivative.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd j_relative = j_theta * scale.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(j_relative, Eigen::ComputeThinV);
  const Eigen::VectorXd sigma = svd.singularValues();
  result->condition_number = sigma[static_cast<Eigen::Index>(p) - 1] > 0
                                 ? sigma[0] / sigma[static_cast<Eigen::Index>(p) - 1]
                                 : std::numeric_limits<double>::infinity();
  const Eigen::VectorXd weakest = svd.matrixV().col(static_cast<Eigen::Index>(p) - 1);
  result->weakest_combination.assign(weakest.data(), weakest.data() + p);
  // Covariance of theta: s^2 (J^T J)^-1, through the SVD (infinite along a null direction).
  const double dof = static_cast<double>(n) - static_cast<double>(p);
  const double s2 = dof > 0 ? rss / dof : std::numeric_limits<double>::infinity();
  // The correlations come from (J^T J)^-1 alone, so that they stay defined when the data are
  // matched exactly (s^2 = 0, noise-free loops).
  Eigen::MatrixXd covariance(p, p), relative(p, p);
  const bool singular = !(result->condition_number < 1e15);
  if (singular) {
    covariance.setConstant(std::numeric_limits<double>::infinity());
    relative.setConstant(std::numeric_limits<double>::infinity());
  } else {
    const Eigen::MatrixXd v = svd.matrixV();
    const Eigen::VectorXd inverse_square = sigma.array().square().inverse();
    relative = v * inverse_square.asDiagonal() * v.transpose();
    covariance = s2 * (scale.asDiagonal() * relative * scale.asDiagonal());
  }
  const double t =
      dof > 0 ? gsl_cdf_tdist_Pinv(0.975, dof) : std::numeric_limits<double>::infinity();
  // Where the half-cycles' residuals move together (a turning point's displacement noise), the
  // sandwich is the larger and its interval, on G - 1 degrees of freedom, is the one reported.
  const std::vector<std::size_t> starts = problem.HalfCycleStarts();
  Eigen::MatrixXd robust =
      Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(p), 0);
  double t_robust = std::numeric_limits<double>::infinity();
  if (!singular && starts.size() > 1) {
    robust = ClusterCovariance(j_theta, residual,
                               scale.asDiagonal() * relative * scale.asDiagonal(), starts);
    t_robust = gsl_cdf_tdist_Pinv(0.975, static_cast<double>(starts.size() - 1));
  }
  result->correlation.assign(p, std::vector<double>(p, 0));
  for (std::size_t a = 0; a < p; ++a) {
    for (std::size_t b = 0; b < p; ++b) {
      const double c = relative(a, b) / std::sqrt(relative(a, a) * relative(b, b));
      result->correlation[a][b] = a == b ? 1 : (std::isfinite(c) ? c : 1);
    }
  }
  result->identified = true;
  const bool ill_conditioned = !(result->condition_number < kConditionLimit);
  for (std::size_t k = 0; k < p; ++k) {
    ParameterEstimate e;
    e.parameter = options.free[k].parameter;
    e.value = values[k];
    const auto kk = static_cast<Eigen::Index>(k);
    const bool clustered = robust(kk, kk) > covariance(kk, kk);
    e.standard_error = std::sqrt(clustered ? robust(kk, kk) : covariance(kk, kk));
    const double quantile = clustered ? t_robust : t;
    e.lower_95 = e.value - quantile * e.standard_error;
    e.upper_95 = e.value + quantile * e.standard_error;
    double worst = 0;
    for (std::size_t b = 0; b < p; ++b) {
      if (b != k) worst = std::max(worst, std::abs(result->correlation[k][b]));
    }
    const double width = quantile * e.standard_error / scale[k];
    e.identified =
        !singular && !ill_conditioned && worst < kCorrelationLimit && width < kRelativeWidthLimit;
    result->identified = result->identified && e.identified;
    if (!(width < kRelativeWidthLimit)) {
      result->notes.push_back(std::string(ParameterName(e.parameter)) +
                              " is not determined by the data: its 95 % interval is +-" +
                              FormatNumber(t * e.standard_error) + " about " +
                              FormatNumber(e.value));
    }
    for (std::size_t b = k + 1; b < p; ++b) {
      if (std::abs(result->correlation[k][b]) >= kCorrelationLimit) {
        result->notes.push_back(std::string(ParameterName(e.parameter)) + " and " +
                                ParameterName(options.free[b].parameter) + " are correlated at " +
                                FormatNumber(result->correlation[k][b]) +
                                ": the loops fix their combination, not each");
      }
    }
    result->estimates.push_back(e);
  }
  if (ill_conditioned) {
    std::string combination;
    for (std::size_t k = 0; k < p; ++k) {
      combination += (k ? ", " : "") + std::string(ParameterName(options.free[k].parameter)) + " " +
                     FormatNumber(result->weakest_combination[k]);
    }
    result->notes.push_back(
        "the fit is ill-conditioned (condition number " + FormatNumber(result->condition_number) +
        "): the data hardly constrain the relative change (" + combination + ")");
  }
}

}  // namespace

// Each stretch (after one reversal, up to and including the next) replaced by its least-squares
// monotone fit in its direction (identify.h).
std::vector<double> ReplayPath(const std::vector<double>& u,
                               const std::vector<std::size_t>& reversals) {
  std::vector<double> path = u;
  std::size_t begin = 0;
  auto fit = [&](std::size_t end) {  // the stretch [begin, end]
    if (end <= begin) return;
    const bool rising = u[end] >= u[begin];
    double* v = path.data() + begin;
    const std::size_t n = end - begin + 1;
    if (!rising) std::for_each(v, v + n, [](double& x) { x = -x; });
    MakeNonDecreasing(v, n);
    if (!rising) std::for_each(v, v + n, [](double& x) { x = -x; });
    begin = end + 1;
  };
  for (std::size_t r : reversals) fit(r);
  if (!u.empty()) fit(u.size() - 1);
  return path;
}

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
  }
  return "unknown";
}

Result<FitResult> FitLoops(const ContactConfig& scene, const std::vector<LoopSet>& sets,
                           const FitOptions& options, const Interrupt& interrupt,
                           const FitProgress& progress) {
  if (Status s = ValidateContactConfig(scene); !s.ok()) return s.WithFieldPrefix("scene");
  if (Status s = CheckFreeParameters(scene, options); !s.ok()) return s;
  Result<std::vector<PreparedSet>> prepared = PrepareSets(sets, options, interrupt);
  if (!prepared.ok()) return prepared.status();
  std::vector<Bounded> bounds;
  std::vector<double> phi;
  for (std::size_t k = 0; k < options.free.size(); ++k) {
    const FreeParameter& free = options.free[k];
    const double initial = InitialValue(free, scene, sets);
    if (!(initial > free.lower && initial < free.upper)) {
      return InvalidArgument(Indexed("free", k) + ".initial",
                             "the initial value " + FormatNumber(initial) + " of " +
                                 ParameterName(free.parameter) + " must lie inside (" +
                                 FormatNumber(free.lower) + ", " + FormatNumber(free.upper) + ")");
    }
    bounds.push_back({free.lower, free.upper});
    phi.push_back(bounds.back().Phi(initial));
  }
  const Problem problem(scene, std::move(prepared).value(), options, bounds, interrupt);
  const std::size_t n = problem.residuals(), p = problem.parameters();
  if (n < p) {
    return FailedPrecondition("sets", std::to_string(n) + " counted samples cannot determine " +
                                          std::to_string(p) + " parameters");
  }
  const int threads = options.threads > 0
                          ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  Callbacks callbacks{&problem, threads, OkStatus()};
  gsl_set_error_handler_off();
  gsl_multifit_nlinear_fdf fdf;
  fdf.f = ResidualFunction;
  fdf.df = JacobianFunction;
  fdf.fvv = nullptr;
  fdf.n = n;
  fdf.p = p;
  fdf.params = &callbacks;
  gsl_multifit_nlinear_parameters parameters = gsl_multifit_nlinear_default_parameters();
  parameters.scale = gsl_multifit_nlinear_scale_more;
  std::unique_ptr<gsl_multifit_nlinear_workspace, void (*)(gsl_multifit_nlinear_workspace*)>
      workspace(gsl_multifit_nlinear_alloc(gsl_multifit_nlinear_trust, &parameters, n, p),
                gsl_multifit_nlinear_free);
  gsl_vector_view x = gsl_vector_view_array(phi.data(), p);
  int status = gsl_multifit_nlinear_init(&x.vector, &fdf, workspace.get());
  FitResult result;
  while (status == GSL_SUCCESS && result.iterations < options.max_iterations) {
    status = gsl_multifit_nlinear_iterate(workspace.get());
    ++result.iterations;
    const gsl_vector* at = gsl_multifit_nlinear_position(workspace.get());
    if (progress) {
      progress(result.iterations, Rms(gsl_multifit_nlinear_residual(workspace.get())),
               problem.Values(at->data));
    }
    if (status == GSL_ENOPROG) {  // no step lowers the cost: a minimum to the residuals' noise
      result.converged = true;
      status = GSL_SUCCESS;
      break;
    }
    if (status != GSL_SUCCESS) break;
    int info = 0;
    if (gsl_multifit_nlinear_test(options.step_tolerance, 0, 0, &info, workspace.get()) ==
            GSL_SUCCESS &&
        info > 0) {
      result.converged = true;
      break;
    }
  }
  if (!callbacks.error.ok()) return callbacks.error;
  if (status != GSL_SUCCESS) {
    return FailedPrecondition("free", std::string("the fit failed: ") + gsl_strerror(status));
  }
  const gsl_vector* solution = gsl_multifit_nlinear_position(workspace.get());
  std::vector<double> best(solution->data, solution->data + p);
  gsl_matrix* j = gsl_matrix_alloc(n, p);
  const int jacobian_status = JacobianFunction(solution, &callbacks, j);
  Eigen::MatrixXd jacobian(n, p);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < p; ++k)
      jacobian(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) =
          gsl_matrix_get(j, i, k);
  }
  gsl_matrix_free(j);
  if (jacobian_status != GSL_SUCCESS) return callbacks.error;
  const gsl_vector* f = gsl_multifit_nlinear_residual(workspace.get());
  result.residuals = n;
  result.residual_rms = Rms(f);
  Assess(problem, best, jacobian,
         Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<>>(
             f->data, static_cast<Eigen::Index>(n), Eigen::InnerStride<>(f->stride)),
         options, sets, &result);
  Result<ContactConfig> fitted = problem.SceneAt(problem.Values(best.data()));
  if (!fitted.ok()) return fitted.status();
  result.fitted = std::move(fitted).value();
  return result;
}

Result<ComplianceGuess> GuessRigCompliance(const std::vector<LoopSet>& sets, double exponent,
                                           double reversal_threshold) {
  if (Status s = RequirePositive("exponent", exponent); !s.ok()) return s;
  ComplianceGuess guess;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::string field = Indexed("sets", i);
    if (Status s = RequirePositive(field + ".normal_force", sets[i].normal_force); !s.ok()) {
      return s;
    }
    LoopOptions options;
    options.reversal_threshold = reversal_threshold;
    Result<LoopAnalysis> loops = AnalyzeLoops(sets[i].samples, options);
    if (!loops.ok()) return loops.status().WithFieldPrefix(field + ".samples");
    double stiffness = 0;
    for (const CycleMetrics& cycle : loops->cycles) {
      stiffness += 0.5 * (cycle.stiffness_increasing + cycle.stiffness_decreasing);
    }
    guess.normal_forces.push_back(sets[i].normal_force);
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
  const double mean_x = sx / static_cast<double>(m), spread = sxx - sx * mean_x;
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
