#include "fit_model.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "mdr/analysis/signal.h"
#include "mdr/base/validate.h"
#include "mdr/core/torsion.h"

namespace mdr::analysis::internal {
namespace {

constexpr std::uint32_t kInterruptPeriod = 1024;  // samples between interrupt checks
// Forward differences, in solver coordinates. A set whose measured normal force is replayed
// moves both channels together along a curved path, which the engine follows by adaptive
// sub-steps to 1e-8 of mu kappa delta: the replay is a step function at that level (the count of
// sub-steps changes with the parameters), and a step of 1e-7 would read its jumps as slopes.
constexpr double kDifferenceStep = 1e-7;
constexpr double kCurvedPathDifferenceStep = 1e-5;
// The displacement's smoothing: a local quartic over half of its half-cycle at most (and at most
// 2 * 50 + 1 samples): its bias, of the sixth order in the window, stays far below the noise it
// removes, which under a varying normal load would enter the memory of every ring that comes
// into contact (a quarter of the half-cycle halved the bias of mu there against an eighth, half
// of it made E*'s worse: docs/analysis.md, "Coverage measured").
constexpr std::size_t kMaxSmoothingHalfWidth = 50;
constexpr int kSmoothingDegree = 4;
// A channel whose estimated noise is below this fraction of its half-range is noise-free to the
// fit (at most rounding of the recorded digits): it is replayed unsmoothed.
constexpr double kNoiseless = 1e-6;
// A noise estimate never below this fraction of the channel's half-range: weights stay finite
// on noise-free records, whose estimate is the signal's own third differences.
constexpr double kNoiseFloor = 1e-9;

// Runs task(0 .. count - 1) on up to `threads` threads; the first error wins.
template <class Task>
Status ForEach(std::size_t count, int threads, const Task& task) {
  const std::size_t workers = std::min<std::size_t>(count, std::max(threads, 1));
  std::atomic<std::size_t> next{0};
  std::vector<Status> errors(std::max<std::size_t>(workers, 1));
  auto work = [&](std::size_t w) {
    for (std::size_t i = next++; i < count; i = next++) {
      if (Status s = task(i); !s.ok() && errors[w].ok()) errors[w] = s;
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
  if (workers > 0) work(0);
  for (std::thread& t : pool) t.join();
  for (const Status& s : errors) {
    if (!s.ok()) return s;
  }
  return OkStatus();
}

double HalfRange(const std::vector<double>& v) {
  if (v.empty()) return 0;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return 0.5 * (*hi - *lo);
}

// A reversal's sample. Where the extreme stands out of the noise it is the extreme sample; on a
// flat peak (a sine's) many samples lie within two noise deviations of it and the noise decides
// which is largest, so the middle of their span (which the noise moves far less) stands for it.
std::size_t RefineReversal(const std::vector<double>& u, std::size_t raw, std::size_t lo,
                           std::size_t hi, bool upper, double noise) {
  const double sign = upper ? 1 : -1;
  const double level = sign * u[raw] - 2 * noise;
  std::size_t first = raw, last = raw;
  for (std::size_t j = lo; j <= hi; ++j) {
    if (sign * u[j] >= level) {
      first = std::min(first, j);
      last = std::max(last, j);
    }
  }
  return first + (last - first) / 2;
}

// The stretch k of a set with K reversals: [begin, end], ending at reversal k (k < K).
struct Stretch {
  std::size_t begin, end;
};
Stretch StretchOf(const std::vector<std::size_t>& reversals, std::size_t samples, std::size_t k) {
  const std::size_t begin = k == 0 ? 0 : reversals[k - 1] + 1;
  const std::size_t end = k < reversals.size() ? reversals[k] : samples - 1;
  return {begin, end};
}

}  // namespace

double Bounded::Value(double phi) const { return lo + (hi - lo) / (1 + std::exp(-phi)); }
double Bounded::Phi(double value) const { return std::log((value - lo) / (hi - value)); }
double Bounded::Derivative(double phi) const {
  const double s = 1 / (1 + std::exp(-phi));
  return (hi - lo) * s * (1 - s);
}

Result<PreparedSet> PrepareSet(const LoopSet& set, std::size_t index, const FitOptions& options,
                               const Interrupt& interrupt) {
  const std::string field = Indexed("sets", index);
  const LoopSamples& samples = set.samples;
  if (set.normal_force) {
    if (Status s = RequirePositive(field + ".normal_force", *set.normal_force); !s.ok()) return s;
  } else if (samples.normal_force.empty()) {
    return InvalidArgument(field + ".normal_force",
                           "is required for a set without normal_force samples (N, > 0)");
  }
  LoopOptions loop_options;
  loop_options.reversal_threshold = options.reversal_threshold;
  Result<LoopAnalysis> loops = AnalyzeLoops(samples, loop_options, interrupt);
  if (!loops.ok()) return loops.status().WithFieldPrefix(field + ".samples");
  const auto burn_in = static_cast<std::size_t>(std::max(options.burn_in_reversals, 0));
  if (loops->reversals.size() < burn_in) {
    return FailedPrecondition(
        field + ".samples",
        "has " + std::to_string(loops->reversals.size()) +
            " reversals, fewer than burn_in_reversals = " + std::to_string(burn_in));
  }
  if (options.nuisances.moving_mass && samples.time.empty()) {
    return InvalidArgument(field + ".samples.time",
                           "a moving mass needs the time of every sample; this set has none");
  }
  PreparedSet p;
  p.set = &set;
  const std::vector<double>& u = samples.displacement;
  const std::size_t n = p.samples = u.size();
  p.stroke = std::max(HalfRange(u), std::numeric_limits<double>::min());
  p.force_scale = std::max(HalfRange(samples.tangential_force), std::numeric_limits<double>::min());
  p.displacement_noise = options.displacement_noise.value_or(
      std::max(NoiseFromDifferences(u), kNoiseFloor * p.stroke));
  p.force_noise = options.force_noise.value_or(
      std::max(NoiseFromDifferences(samples.tangential_force), kNoiseFloor * p.force_scale));
  p.normal_noise = samples.normal_force.empty() ? 0 : NoiseFromDifferences(samples.normal_force);

  // The reversals, refined between the midpoints to their neighbours.
  const std::vector<std::size_t>& raw = loops->reversals;
  const std::size_t count = raw.size();
  for (std::size_t k = 0; k < count; ++k) {
    const bool upper = k + 1 < count ? u[raw[k]] > u[raw[k + 1]] : u[raw[k]] > u[raw[k - 1]];
    const std::size_t lo = k == 0 ? raw[k] / 2 : (raw[k - 1] + raw[k]) / 2 + 1;
    const std::size_t hi = k + 1 < count ? (raw[k] + raw[k + 1]) / 2 : (raw[k] + n - 1) / 2;
    std::size_t refined = RefineReversal(u, raw[k], lo, hi, upper, p.displacement_noise);
    if (!p.reversals.empty() && refined <= p.reversals.back()) refined = raw[k];
    p.reversals.push_back(refined);
    p.upper.push_back(upper);
  }
  // The displacement smoothed within each stretch between reversals (never across one: a
  // triangle's corner stays sharp), and each turning point's smoothed value from both sides.
  p.smoothed.assign(n, 0);
  std::vector<double> sample_index(n);
  for (std::size_t i = 0; i < n; ++i) sample_index[i] = static_cast<double>(i);
  std::vector<double> from_left(count), from_right(count);
  // A noise-free record is replayed as it is (smoothing would only bend it).
  const bool smooth = p.displacement_noise > kNoiseless * p.stroke;
  for (std::size_t k = 0; k <= count; ++k) {
    const Stretch s = StretchOf(p.reversals, n, k);
    const std::size_t begin = k == 0 ? 0 : p.reversals[k - 1];  // its start reversal included
    const std::size_t half_width =
        smooth ? std::clamp<std::size_t>((s.end - begin) / 4, 2, kMaxSmoothingHalfWidth) : 0;
    const std::vector<double> fit =
        LocalPolynomial(sample_index, u, begin, s.end + 1, half_width, kSmoothingDegree);
    for (std::size_t i = s.begin; i <= s.end; ++i) p.smoothed[i] = fit[i - begin];
    if (k > 0) from_right[k - 1] = fit.front();
    if (k < count) from_left[k] = fit.back();
  }
  for (std::size_t k = 0; k < count; ++k) {
    p.turning.push_back(0.5 * (from_left[k] + from_right[k]));
    p.smoothed[p.reversals[k]] = p.turning.back();
  }
  p.first_residual = burn_in > 0 ? p.reversals[burn_in - 1] : 0;
  p.first_free_turning = burn_in > 0 ? burn_in - 1 : 0;
  p.default_offset = p.smoothed.front();

  const std::vector<double>& t = samples.time;
  p.drift_abscissa.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.drift_abscissa[i] = n < 2       ? 0
                          : t.empty() ? static_cast<double>(i) / static_cast<double>(n - 1)
                                      : (t[i] - t.front()) / (t.back() - t.front());
  }
  // A half-cycle's typical length sets the windows of the normal force and the acceleration.
  std::vector<std::size_t> lengths;
  for (std::size_t k = 1; k < count; ++k) lengths.push_back(p.reversals[k] - p.reversals[k - 1]);
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  const std::size_t half_cycle = lengths.empty() ? n : lengths[lengths.size() / 2];
  if (!samples.normal_force.empty()) {
    // Smooth within a quarter of a half-cycle by a quartic: a load that varies within each cycle
    // is followed, the sensor's noise is not replayed (every dip would erase memory at the edge).
    const bool noisy = p.normal_noise > kNoiseless * HalfRange(samples.normal_force) + 1e-300;
    p.normal = LocalPolynomial(sample_index, samples.normal_force, 0, n,
                               noisy ? std::max<std::size_t>(2, half_cycle / 4) : 0, 4);
    for (double& v : p.normal) v = std::max(v, 0.0);
    // A torsional set is replayed at its column's mean (FitOptions::torsion).
    p.replay_normal = !options.torsion;
    double sum = 0;
    for (double v : p.normal) sum += v;
    p.constant_normal = sum / static_cast<double>(n);
  } else {
    p.constant_normal = *set.normal_force;
  }
  if (options.nuisances.moving_mass) {
    p.acceleration = LocalPolynomial(t, u, 0, n, std::max<std::size_t>(4, half_cycle / 4), 4, 2);
  }
  return p;
}

Layout MakeLayout(const std::vector<PreparedSet>& sets, const FitOptions& options) {
  Layout layout;
  layout.free = options.free.size();
  // One press point for every set when it is a free parameter, else each set's own.
  const bool shared_offset = std::any_of(
      options.free.begin(), options.free.end(),
      [](const FreeParameter& f) { return f.parameter == Parameter::kDisplacementOffset; });
  std::size_t next = layout.free;
  if (options.nuisances.moving_mass) layout.mass = next++;
  for (const PreparedSet& set : sets) {
    Layout::Block block;
    if (options.nuisances.force_offset) block.force_offset = next++;
    if (!shared_offset) block.displacement_offset = next++;
    if (options.nuisances.displacement_drift) block.drift = next++;
    block.turning_begin = next;
    block.turning_count = set.reversals.size() - set.first_free_turning;
    next += block.turning_count;
    layout.blocks.push_back(block);
  }
  layout.size = next;
  return layout;
}

// ---- The model ---------------------------------------------------------------------------------

struct FitModel::Inputs {
  const FitScene* scene = nullptr;
  double offset = 0, drift = 0, force_offset = 0, mass = 0;
  std::vector<double> turning;  // A_k, in actuator coordinates
};

FitModel::FitModel(const ContactConfig& scene, std::vector<PreparedSet> sets,
                   const FitOptions& options, std::vector<Bounded> bounds,
                   const Interrupt& interrupt, int threads)
    : scene_(scene),
      sets_(std::move(sets)),
      options_(options),
      bounds_(std::move(bounds)),
      interrupt_(interrupt),
      threads_(threads),
      layout_(MakeLayout(sets_, options)) {
  for (PreparedSet& s : sets_) {
    s.row_offset = residuals_;
    residuals_ += s.samples - s.first_residual;
  }
  weights_.assign(residuals_, 1);
  slopes_.assign(residuals_, 0);
  normal_slopes_.assign(residuals_, 0);
}

std::vector<double> FitModel::Start(const std::vector<double>& initial) const {
  std::vector<double> x(layout_.size, 0);
  for (std::size_t k = 0; k < bounds_.size(); ++k) x[k] = bounds_[k].Phi(initial[k]);
  return x;
}

std::vector<double> FitModel::Values(const std::vector<double>& x) const {
  std::vector<double> values(bounds_.size());
  for (std::size_t k = 0; k < values.size(); ++k) values[k] = bounds_[k].Value(x[k]);
  return values;
}

double FitModel::Scale(std::size_t coordinate) const {
  if (coordinate < layout_.free) return 1;
  if (layout_.mass && coordinate == *layout_.mass) {
    double force = 0, acceleration = 0;
    for (const PreparedSet& s : sets_) {
      force = std::max(force, s.force_scale);
      for (double a : s.acceleration) acceleration = std::max(acceleration, std::abs(a));
    }
    return acceleration > 0 ? force / acceleration : 1;
  }
  for (std::size_t r = 0; r < sets_.size(); ++r) {
    const Layout::Block& b = layout_.blocks[r];
    if (b.force_offset && coordinate == *b.force_offset) return sets_[r].force_scale;
    if ((b.displacement_offset && coordinate == *b.displacement_offset) ||
        (b.drift && coordinate == *b.drift) ||
        (coordinate >= b.turning_begin && coordinate < b.turning_begin + b.turning_count)) {
      return sets_[r].stroke;
    }
  }
  return 1;
}

Result<FitScene> FitModel::SceneAt(const std::vector<double>& values) const {
  FitScene fit{scene_, options_.torsion};
  ContactConfig& scene = fit.contact;
  scene.track_energy = false;  // the fit compares forces only
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
        (fit.torsion ? fit.torsion->rig_compliance : scene.rig.tangential) = values[k];
        break;
      case Parameter::kTorsionalModulus:
        if (fit.torsion) fit.torsion->torsional_modulus = values[k];
        break;
      case Parameter::kDisplacementOffset:
        break;  // where each set is pressed (InputsFor)
    }
  }
  return fit;
}

FitModel::Inputs FitModel::InputsFor(const std::vector<double>& x, const FitScene& scene,
                                     std::size_t r) const {
  const PreparedSet& set = sets_[r];
  const Layout::Block& block = layout_.blocks[r];
  Inputs in;
  in.scene = &scene;
  in.offset = set.default_offset;
  for (std::size_t k = 0; k < layout_.free; ++k) {
    if (options_.free[k].parameter == Parameter::kDisplacementOffset) {
      in.offset = bounds_[k].Value(x[k]);
    }
  }
  if (block.displacement_offset) in.offset += x[*block.displacement_offset] * set.stroke;
  if (block.drift) in.drift = x[*block.drift] * set.stroke;
  if (block.force_offset) in.force_offset = x[*block.force_offset] * set.force_scale;
  if (layout_.mass) in.mass = x[*layout_.mass] * Scale(*layout_.mass);
  in.turning.resize(set.reversals.size());
  for (std::size_t k = 0; k < set.reversals.size(); ++k) {
    const std::size_t i = set.reversals[k];
    double value = set.turning[k] - in.offset - in.drift * set.drift_abscissa[i];
    if (k >= set.first_free_turning) {
      value += x[block.turning_begin + k - set.first_free_turning] * set.stroke;
    }
    in.turning[k] = value;
  }
  return in;
}

std::vector<double> FitModel::TurningPoints(const std::vector<double>& x, std::size_t r) const {
  const FitScene scene{scene_, options_.torsion};  // the turning points need no parameter
  const Inputs in = InputsFor(x, scene, r);
  const PreparedSet& set = sets_[r];
  std::vector<double> sensor;
  for (std::size_t k = set.first_free_turning; k < set.reversals.size(); ++k) {
    sensor.push_back(in.turning[k] + in.offset + in.drift * set.drift_abscissa[set.reversals[k]]);
  }
  return sensor;
}

// The contact a set is replayed through: the tangential engine (its rig in series inside it), or
// the torsional memory behind the fit's torsional compliance. Copyable: the Jacobian keeps one
// per reversal.
class FitModel::ReplayContact {
 public:
  // The virgin contact pressed to `normal_force` with the actuator at the press point (0).
  static Result<ReplayContact> Press(const FitScene& scene, double normal_force) {
    if (scene.torsion) {
      Result<TorsionalContact> created =
          TorsionalContact::Create(scene.contact.profile, scene.contact.friction,
                                   scene.contact.material.e_star, scene.torsion->torsional_modulus);
      if (!created.ok()) return created.status();
      TorsionalContact c = std::move(created).value();
      TorsionStep press;
      press.normal = NormalControl::kForce;
      press.normal_value = normal_force;
      if (Status s = c.Apply(press); !s.ok()) return s;
      return ReplayContact(std::nullopt, std::move(c), scene.torsion->rig_compliance);
    }
    Result<Contact> created = Contact::Create(scene.contact);
    if (!created.ok()) return created.status();
    Contact c = std::move(created).value();
    Step press;
    press.normal = NormalControl::kForce;
    press.normal_value = normal_force;
    press.tangential = TangentialControl::kDisplacement;
    press.tangential_value = 0;
    if (Status s = c.Apply(press); !s.ok()) return s;
    return ReplayContact(std::move(c), std::nullopt, scene.contact.rig.tangential);
  }

  // The actuator to `actuator` (m or rad) and, where a tangential set replays its column, the
  // normal force to *normal (a curved path of the engine's sub-steps).
  Status Move(double actuator, const double* normal) {
    if (torsional_) return torsional_->TwistThroughCompliance(actuator, compliance_);
    return tangential_->Apply(MoveStep(actuator, normal), nullptr, {},
                              Contact::OnFailure::kDiscarded);
  }
  // F_x (N) or M (N m).
  double Force() const {
    return torsional_ ? torsional_->memory().Moment() : tangential_->tangential_force();
  }
  // The force's slope against the actuator along a branch of that direction, through the rig.
  double Stiffness(bool rising) const {
    double k = 0;
    if (torsional_) {
      k = torsional_->memory().Stiffness(rising ? 1 : -1);
    } else {
      const TangentialStiffness ts = tangential_->tangential_stiffness();
      k = rising ? ts.positive : ts.negative;
    }
    return k / (1 + compliance_ * k);
  }
  // How F_x after a move from this state changes with the move's normal force: a central
  // difference over 1e-4 of it (a sliding contact's F_x follows mu F_N either way; a sticking
  // one's hardly moves). Tangential sets only.
  Result<double> NormalSlope(double actuator, double normal) const {
    const double delta = 1e-4 * std::max(normal, 1e-300);
    double force[2];
    for (int side = 0; side < 2; ++side) {
      Contact trial = *tangential_;
      const double shifted = normal + (side == 0 ? delta : -delta);
      if (Status s = trial.Apply(MoveStep(actuator, &shifted), nullptr, {},
                                 Contact::OnFailure::kDiscarded);
          !s.ok()) {
        return s;
      }
      force[side] = trial.tangential_force();
    }
    return (force[0] - force[1]) / (2 * delta);
  }
  // Nothing after this state can differ from the other's.
  bool SameState(const ReplayContact& other) const {
    if (torsional_) {
      return other.torsional_ && torsional_->memory().Snapshot() == other.torsional_->memory().Snapshot();
    }
    return other.tangential_ && tangential_->config().method == Method::kExact &&
           tangential_->memory() == other.tangential_->memory() &&
           SameBits(tangential_->tangential_displacement(),
                    other.tangential_->tangential_displacement());
  }

 private:
  ReplayContact(std::optional<Contact> tangential, std::optional<TorsionalContact> torsional,
                double compliance)
      : tangential_(std::move(tangential)),
        torsional_(std::move(torsional)),
        compliance_(compliance) {}
  static Step MoveStep(double actuator, const double* normal) {
    Step step;
    step.tangential = TangentialControl::kDisplacement;
    step.tangential_value = actuator;
    if (normal) {
      step.normal = NormalControl::kForce;
      step.normal_value = *normal;
    }
    return step;
  }

  std::optional<Contact> tangential_;
  std::optional<TorsionalContact> torsional_;
  double compliance_ = 0;  // m/N or rad/(N m)
};

// Replays one set: the path stretch by stretch, the engine along it, the model's force and its
// slope along the branch at every sample.
class FitModel::Replayer {
 public:
  Replayer(const FitModel& model, std::size_t r, const Inputs& in)
      : model_(model), set_(model.sets_[r]), in_(in) {
    path.resize(set_.samples);
    force.resize(set_.samples);
    stiffness.resize(set_.samples);
    if (set_.replay_normal) normal_slope.assign(set_.samples, 0);
  }

  // Replays from stretch `from` on: from the pressed virgin contact when from == 0, else from
  // `start`, the state after reversal from - 1. With `checkpoints`, stores the state after each
  // reversal; with `baseline` (another replay's checkpoints), stops after the first reversal at
  // or beyond `merge_after` where the state equals the baseline's (nothing after it can differ).
  // Returns the end of what was replayed (one past its last sample).
  Result<std::size_t> Run(std::size_t from, const ReplayContact* start,
                          std::vector<ReplayContact>* checkpoints,
                          const std::vector<ReplayContact>* baseline, std::size_t merge_after,
                          bool normal_slopes = false) {
    Result<ReplayContact> begun =
        start ? Result<ReplayContact>(*start)
              : ReplayContact::Press(*in_.scene, set_.replay_normal ? set_.normal.front()
                                                                    : set_.constant_normal);
    if (!begun.ok()) return begun.status();
    ReplayContact contact = std::move(begun).value();
    const std::size_t count = set_.reversals.size();
    if (checkpoints) checkpoints->resize(count, contact);
    for (std::size_t k = from; k <= count; ++k) {
      const Stretch s = StretchOf(set_.reversals, set_.samples, k);
      const bool rising = k < count ? set_.upper[k] : !set_.upper[count - 1];
      FillPath(k, s, rising);
      for (std::size_t i = s.begin; i <= s.end; ++i) {
        if (Status st = model_.interrupt_.CheckEvery(kInterruptPeriod, i); !st.ok()) return st;
        const double* normal = set_.replay_normal ? &set_.normal[i] : nullptr;
        if (normal_slopes && normal) {
          Result<double> slope = contact.NormalSlope(path[i], *normal);
          if (!slope.ok()) return slope.status();
          normal_slope[i] = *slope;
        }
        if (Status st = contact.Move(path[i], normal); !st.ok()) return st;
        force[i] = contact.Force();
        stiffness[i] = contact.Stiffness(rising);
      }
      if (k == count) break;
      if (checkpoints) (*checkpoints)[k] = contact;
      if (baseline && k >= merge_after && contact.SameState((*baseline)[k])) return s.end + 1;
    }
    return set_.samples;
  }

  // What the force sensor should read at sample i: the model's force carried to the measured
  // displacement along the branch's slope. Counted samples take the slope of the current
  // reweighting stage (FitModel::Reweigh), so that the residuals are smooth in the parameters:
  // the tangent stiffness jumps where a branch rejoins an outer one (a Masing closure) and
  // where the noise puts a turning point a hair either side of an earlier one.
  double Predicted(std::size_t i) const {
    const double measured_actuator =
        set_.set->samples.displacement[i] - in_.offset - in_.drift * set_.drift_abscissa[i];
    const bool counted = i >= set_.first_residual;
    const std::size_t row = counted ? set_.row_offset + i - set_.first_residual : 0;
    const double slope = counted ? model_.slopes_[row] : stiffness[i];
    double value = force[i] + slope * (measured_actuator - path[i]) + in_.force_offset;
    if (set_.replay_normal) {
      // The same for the normal force: the replayed one is the column smoothed, the sensor's
      // reading differs from it by its noise.
      const double normal_slope_i = counted ? model_.normal_slopes_[row] : 0;
      value += normal_slope_i * (set_.set->samples.normal_force[i] - set_.normal[i]);
    }
    if (!set_.acceleration.empty()) value += in_.mass * set_.acceleration[i];
    return value;
  }

  // The weighted residual rows of samples [begin, end) (those counted) into rows, indexed by
  // residual row.
  void WriteRows(std::size_t begin, std::size_t end, double* rows) const {
    const std::vector<double>& weights = model_.weights_;
    for (std::size_t i = std::max(begin, set_.first_residual); i < end; ++i) {
      const std::size_t row = set_.row_offset + i - set_.first_residual;
      rows[row] = weights[row] * (Predicted(i) - set_.set->samples.tangential_force[i]);
    }
  }

  std::vector<double> path, force, stiffness;
  std::vector<double> normal_slope;  // dF_x/dF_N of each step (with normal_slopes)

 private:
  // Stretch k's path in actuator coordinates: the smoothed displacement less the offset and
  // drift, made monotone in the stretch's direction, held between its turning points, and ending
  // on its own.
  void FillPath(std::size_t k, const Stretch& s, bool rising) {
    for (std::size_t i = s.begin; i <= s.end; ++i) {
      path[i] = set_.smoothed[i] - in_.offset - in_.drift * set_.drift_abscissa[i];
    }
    MakeMonotone(std::span<double>(path.data() + s.begin, s.end - s.begin + 1), rising);
    double lo = -HUGE_VAL, hi = HUGE_VAL;
    const std::size_t count = set_.reversals.size();
    if (k > 0) (rising ? lo : hi) = in_.turning[k - 1];
    if (k < count) (rising ? hi : lo) = in_.turning[k];
    if (lo <= hi) {
      for (std::size_t i = s.begin; i <= s.end; ++i) path[i] = std::clamp(path[i], lo, hi);
    }
    if (k < count) path[s.end] = in_.turning[k];
  }

  const FitModel& model_;
  const PreparedSet& set_;
  const Inputs& in_;
};

Status FitModel::Residuals(const std::vector<double>& x, std::vector<double>* r) const {
  Result<FitScene> scene = SceneAt(Values(x));
  if (!scene.ok()) return scene.status();
  r->assign(residuals_, 0);
  return ForEach(sets_.size(), threads_, [&](std::size_t s) {
    const Inputs in = InputsFor(x, *scene, s);
    Replayer replay(*this, s, in);
    Result<std::size_t> end = replay.Run(0, nullptr, nullptr, nullptr, 0);
    if (!end.ok()) return end.status();
    replay.WriteRows(0, *end, r->data());
    return OkStatus();
  });
}

Status FitModel::Reweigh(const std::vector<double>& x, bool uniform) {
  Result<FitScene> scene = SceneAt(Values(x));
  if (!scene.ok()) return scene.status();
  return ForEach(sets_.size(), threads_, [&](std::size_t s) {
    const PreparedSet& set = sets_[s];
    const Inputs in = InputsFor(x, *scene, s);
    Replayer replay(*this, s, in);
    const bool normal = set.replay_normal;
    Result<std::size_t> end = replay.Run(0, nullptr, nullptr, nullptr, 0, normal);
    if (!end.ok()) return end.status();
    for (std::size_t i = set.first_residual; i < set.samples; ++i) {
      const std::size_t row = set.row_offset + i - set.first_residual;
      slopes_[row] = replay.stiffness[i];
      normal_slopes_[row] = normal ? replay.normal_slope[i] : 0;
      const double spread = replay.stiffness[i] * set.displacement_noise;
      const double normal_spread = normal_slopes_[row] * set.normal_noise;
      weights_[row] = uniform ? 1
                              : 1 / std::sqrt(set.force_noise * set.force_noise + spread * spread +
                                              normal_spread * normal_spread);
    }
    return OkStatus();
  });
}

Result<SetEvaluation> FitModel::Evaluate(const std::vector<double>& x, std::size_t r) const {
  Result<FitScene> scene = SceneAt(Values(x));
  if (!scene.ok()) return scene.status();
  const Inputs in = InputsFor(x, *scene, r);
  Replayer replay(*this, r, in);
  Result<std::size_t> end = replay.Run(0, nullptr, nullptr, nullptr, 0);
  if (!end.ok()) return end.status();
  const PreparedSet& set = sets_[r];
  SetEvaluation e;
  e.path = replay.path;
  e.contact_force = replay.force;
  e.stiffness = replay.stiffness;
  e.normal = set.replay_normal ? set.normal : std::vector<double>(set.samples, set.constant_normal);
  for (std::size_t i = 0; i < set.samples; ++i) e.predicted.push_back(replay.Predicted(i));
  return e;
}

Status FitModel::Jacobian(const std::vector<double>& x, const std::vector<double>& r,
                          std::vector<SparseColumn>* columns) const {
  const std::size_t p = layout_.size;
  Result<FitScene> scene = SceneAt(Values(x));
  if (!scene.ok()) return scene.status();
  // The scenes with each free parameter stepped.
  std::vector<std::vector<double>> stepped_x(layout_.free, x);
  std::vector<FitScene> stepped_scene;
  std::vector<double> steps(p);
  const bool curved = std::any_of(sets_.begin(), sets_.end(),
                                  [](const PreparedSet& s) { return s.replay_normal; });
  const double step = curved ? kCurvedPathDifferenceStep : kDifferenceStep;
  for (std::size_t j = 0; j < p; ++j) steps[j] = step * std::max(1.0, std::abs(x[j]));
  for (std::size_t c = 0; c < layout_.free; ++c) {
    stepped_x[c][c] += steps[c];
    Result<FitScene> s = SceneAt(Values(stepped_x[c]));
    if (!s.ok()) return s.status();
    stepped_scene.push_back(std::move(s).value());
  }
  columns->assign(p, {});
  for (std::size_t c = 0; c < layout_.free; ++c) (*columns)[c].values.assign(residuals_, 0);
  if (layout_.mass) {
    SparseColumn& column = (*columns)[*layout_.mass];
    column.values.assign(residuals_, 0);
    const double scale = Scale(*layout_.mass);
    for (const PreparedSet& set : sets_) {
      for (std::size_t i = set.first_residual; i < set.samples; ++i) {
        const std::size_t row = set.row_offset + i - set.first_residual;
        column.values[row] = weights_[row] * set.acceleration[i] * scale;
      }
    }
  }
  // Each set's replay at x, keeping its state at every reversal.
  std::vector<std::vector<ReplayContact>> checkpoints(sets_.size());
  if (Status s = ForEach(sets_.size(), threads_,
                         [&](std::size_t set) {
                           const Inputs in = InputsFor(x, *scene, set);
                           Replayer replay(*this, set, in);
                           return replay.Run(0, nullptr, &checkpoints[set], nullptr, 0).status();
                         });
      !s.ok()) {
    return s;
  }
  // The tasks: a free parameter's column on one set, a set's offset or drift, one turning point.
  struct Task {
    std::size_t set, coordinate;
  };
  std::vector<Task> tasks;
  for (std::size_t set = 0; set < sets_.size(); ++set) {
    const Layout::Block& b = layout_.blocks[set];
    for (std::size_t c = 0; c < layout_.free; ++c) tasks.push_back({set, c});
    if (b.displacement_offset) tasks.push_back({set, *b.displacement_offset});
    if (b.drift) tasks.push_back({set, *b.drift});
    for (std::size_t t = 0; t < b.turning_count; ++t) tasks.push_back({set, b.turning_begin + t});
    if (b.force_offset) {
      SparseColumn& column = (*columns)[*b.force_offset];
      const PreparedSet& s = sets_[set];
      column.begin = s.row_offset;
      column.values.resize(s.samples - s.first_residual);
      for (std::size_t i = 0; i < column.values.size(); ++i) {
        column.values[i] = weights_[s.row_offset + i] * s.force_scale;
      }
    }
  }
  return ForEach(tasks.size(), threads_, [&](std::size_t t) {
    const Task task = tasks[t];
    const PreparedSet& set = sets_[task.set];
    const Layout::Block& block = layout_.blocks[task.set];
    const bool free = task.coordinate < layout_.free;
    std::vector<double> shifted = free ? stepped_x[task.coordinate] : x;
    if (!free) shifted[task.coordinate] += steps[task.coordinate];
    const Inputs in = InputsFor(shifted, free ? stepped_scene[task.coordinate] : *scene, task.set);
    Replayer replay(*this, task.set, in);
    // A turning point k moves the stretches ending and starting at it: replay from the reversal
    // before it, until the state rejoins the unshifted replay's.
    std::size_t from = 0;
    const ReplayContact* start = nullptr;
    const std::vector<ReplayContact>* baseline = nullptr;
    const bool turning = task.coordinate >= block.turning_begin &&
                         task.coordinate < block.turning_begin + block.turning_count;
    std::size_t k = 0;
    if (turning) {
      k = set.first_free_turning + task.coordinate - block.turning_begin;
      from = k;
      if (k > 0) start = &checkpoints[task.set][k - 1];
      baseline = &checkpoints[task.set];
    }
    Result<std::size_t> end = replay.Run(from, start, nullptr, baseline, k + 1);
    if (!end.ok()) return end.status();
    const std::size_t first_sample =
        std::max(StretchOf(set.reversals, set.samples, from).begin, set.first_residual);
    SparseColumn& column = (*columns)[task.coordinate];
    if (!free) {
      column.begin = set.row_offset + (first_sample - set.first_residual);
      column.values.assign(*end > first_sample ? *end - first_sample : 0, 0);
    }
    for (std::size_t i = first_sample; i < *end; ++i) {
      const std::size_t row = set.row_offset + i - set.first_residual;
      const double shifted_row =
          weights_[row] * (replay.Predicted(i) - set.set->samples.tangential_force[i]);
      const double value = (shifted_row - r[row]) / steps[task.coordinate];
      if (free) {
        column.values[row] = value;
      } else {
        column.values[row - column.begin] = value;
      }
    }
    return OkStatus();
  });
}

}  // namespace mdr::analysis::internal
