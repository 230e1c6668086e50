#include "mdr/analysis/loops.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include "mdr/base/validate.h"

namespace mdr::analysis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint32_t kInterruptPeriod = 65536;  // samples between interrupt checks

// Fractions the header defines.
constexpr double kStiffnessWindow = 0.2;      // of 2 Q*: the fit after a reversal
constexpr double kSlidingSlope = 0.1;         // of the slope after the reversal
constexpr double kMiddleWindow = 0.05;        // of the stroke, either side of its middle
constexpr double kAutomaticThreshold = 0.05;  // of the median peak-to-peak displacement
constexpr int kCoarsePasses = 5;              // of the automatic threshold: range/4 ... range/1024

// The columns one cycle is measured from.
struct Columns {
  const double* u;
  const double* f;
};

// ---- Validation -------------------------------------------------------------------------------

}  // namespace

Status ValidateLoopOptions(const LoopOptions& o) {
  if (Status s = RequireNonNegative("reversal_threshold", o.reversal_threshold); !s.ok()) return s;
  if (Status s = RequireNonNegative("displacement_resolution", o.displacement_resolution);
      !s.ok()) {
    return s;
  }
  if (o.rig_compliance) {
    if (Status s = RequireNonNegative("rig_compliance", *o.rig_compliance); !s.ok()) return s;
  }
  // Checked even when normal_force samples make it unused: a wrong value is a caller's mistake.
  if (o.normal_force) {
    if (Status s = RequirePositive("normal_force", *o.normal_force); !s.ok()) return s;
  }
  const std::array<std::pair<const char*, double>, 4> tolerances = {{
      {"closure_tolerance", o.closure_tolerance},
      {"asymmetry_tolerance", o.asymmetry_tolerance},
      {"hook_tolerance", o.hook_tolerance},
      {"drift_tolerance", o.drift_tolerance},
  }};
  for (const auto& [name, value] : tolerances) {
    if (Status s = RequirePositive(name, value); !s.ok()) return s;
  }
  return OkStatus();
}

namespace {

Status RequireLength(const char* name, std::size_t size, std::size_t n, bool optional,
                     const char* position) {
  if (size == n || (optional && size == 0)) return OkStatus();
  return InvalidArgument(name, std::string("needs one value per ") + position + " sample" +
                                   (optional ? " (or none)" : "") + ", got " +
                                   std::to_string(size) + " for " + std::to_string(n));
}

// Each value passes `ok`; the first that does not is reported by `report` (which builds the
// message, so the field's string is made only on failure).
template <typename Ok, typename Report>
Status CheckColumn(const std::vector<double>& values, const Interrupt& interrupt, Ok ok,
                   Report report) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (Status s = interrupt.CheckEvery(kInterruptPeriod, i); !s.ok()) return s;
    if (!ok(i)) return report(i);
  }
  return OkStatus();
}

// A column that varies must vary by kMinSampleSpan at least: below it the products of the
// figures (squares of displacements, force times displacement) underflow to zero or lose every
// digit, and the figures would come out NaN or infinite. A constant column is no error (no
// reversal, or a zero force: the figures say so).
Status SpanAtLeast(const char* name, const std::vector<double>& v, const char* unit) {
  if (v.empty()) return OkStatus();
  const auto [lowest, highest] = std::minmax_element(v.begin(), v.end());
  const double span = *highest - *lowest;
  if (span == 0 || span >= kMinSampleSpan) return OkStatus();
  return InvalidArgument(
      name, "spans only " + FormatNumber(span) + " " + unit + " (samples " +
                std::to_string(lowest - v.begin()) + " and " + std::to_string(highest - v.begin()) +
                "); a column that varies must span at least " + FormatNumber(kMinSampleSpan) + " " +
                unit + ", below any sensor's resolution");
}

Status ValidateSamples(const LoopSamples& s, const Interrupt& interrupt) {
  const ChannelNames names = NamesOf(s.channel);
  const std::size_t n = s.displacement.size();
  if (Status st = RequireLength(names.force, s.tangential_force.size(), n, false, names.position);
      !st.ok())
    return st;
  if (Status st = RequireLength("normal_force", s.normal_force.size(), n, true, names.position);
      !st.ok())
    return st;
  if (Status st = RequireLength("time", s.time.size(), n, true, names.position); !st.ok())
    return st;

  auto within = [&](const char* name, const std::vector<double>& v, double lo, double hi) {
    return CheckColumn(
        v, interrupt, [&](std::size_t i) { return v[i] >= lo && v[i] <= hi; },
        [&](std::size_t i) { return RequireInRange(Indexed(name, i), v[i], lo, hi); });
  };
  if (Status st = within(names.position, s.displacement, -names.max_position, names.max_position);
      !st.ok()) {
    return st;
  }
  if (Status st = within(names.force, s.tangential_force, -kMaxSampleForce, kMaxSampleForce);
      !st.ok()) {
    return st;
  }
  if (Status st = within("normal_force", s.normal_force, 0, kMaxSampleForce); !st.ok()) return st;
  if (Status st = SpanAtLeast(names.position, s.displacement, names.position_unit); !st.ok()) {
    return st;
  }
  if (Status st = SpanAtLeast(names.force, s.tangential_force, names.force_unit); !st.ok()) {
    return st;
  }
  auto finite = [&](const char* name, const std::vector<double>& v) {
    return CheckColumn(
        v, interrupt, [&](std::size_t i) { return std::isfinite(v[i]); },
        [&](std::size_t i) { return RequireFinite(Indexed(name, i), v[i]); });
  };
  if (Status st = finite("time", s.time); !st.ok()) return st;
  const std::vector<double>& t = s.time;
  return CheckColumn(
      t, interrupt, [&](std::size_t i) { return i == 0 || t[i] > t[i - 1]; },
      [&](std::size_t i) {
        return InvalidArgument(Indexed("time", i), "must increase strictly, got " +
                                                       FormatNumber(t[i]) + " after " +
                                                       FormatNumber(t[i - 1]));
      });
}

// ---- Reversals ---------------------------------------------------------------------------------

struct Reversals {
  std::vector<std::size_t> at;
  bool first_is_upper = true;
};

// The Schmitt trigger: an extreme becomes a reversal once u has moved back from it by more than
// `threshold`. The first sample is no reversal (nothing is known of u before it): u must first
// leave it by more than the threshold, which sets the direction.
Result<Reversals> FindReversals(const std::vector<double>& u, double threshold,
                                const Interrupt& interrupt) {
  enum class Trend { kUnknown, kRising, kFalling };
  Reversals out;
  Trend trend = Trend::kUnknown;
  std::size_t extreme = 0;
  for (std::size_t i = 1; i < u.size(); ++i) {
    if (Status s = interrupt.CheckEvery(kInterruptPeriod, i); !s.ok()) return s;
    switch (trend) {
      case Trend::kUnknown:
        if (std::abs(u[i] - u[0]) > threshold) {
          trend = u[i] > u[0] ? Trend::kRising : Trend::kFalling;
          extreme = i;
        }
        break;
      case Trend::kRising:
        if (u[i] > u[extreme]) {
          extreme = i;
        } else if (u[extreme] - u[i] > threshold) {
          if (out.at.empty()) out.first_is_upper = true;
          out.at.push_back(extreme);
          trend = Trend::kFalling;
          extreme = i;
        }
        break;
      case Trend::kFalling:
        if (u[i] < u[extreme]) {
          extreme = i;
        } else if (u[i] - u[extreme] > threshold) {
          if (out.at.empty()) out.first_is_upper = false;
          out.at.push_back(extreme);
          trend = Trend::kRising;
          extreme = i;
        }
        break;
    }
  }
  return out;
}

// 5 % of the median swing between consecutive reversals. The swings come from a coarse pass whose
// threshold is a fraction of the whole range (a quarter, then a sixteenth ... for a run whose mean
// drifts), the first that finds three reversals; 0 if none does (then no cycle is found).
Result<double> AutomaticThreshold(const std::vector<double>& u, const Interrupt& interrupt) {
  if (u.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(u.begin(), u.end());
  const double range = *hi - *lo;
  double coarse = range;
  for (int pass = 0; pass < kCoarsePasses; ++pass) {
    coarse /= 4;
    Result<Reversals> found = FindReversals(u, coarse, interrupt);
    if (!found.ok()) return found.status();
    const std::vector<std::size_t>& at = found->at;
    if (at.size() < 3) continue;
    std::vector<double> swings(at.size() - 1);
    for (std::size_t k = 0; k + 1 < at.size(); ++k) swings[k] = std::abs(u[at[k + 1]] - u[at[k]]);
    const auto middle = swings.begin() + static_cast<std::ptrdiff_t>(swings.size() / 2);
    std::nth_element(swings.begin(), middle, swings.end());
    return kAutomaticThreshold * *middle;
  }
  return 0.0;
}

// ---- One cycle ---------------------------------------------------------------------------------

// Least-squares line of y against x, its sums taken relative to the first point so that a small
// window far from the origin keeps its precision.
class LineFit {
 public:
  void Add(double x, double y) {
    if (n_ == 0) x0_ = x, y0_ = y;
    x -= x0_, y -= y0_;
    ++n_, sx_ += x, sy_ += y, sxx_ += x * x, sxy_ += x * y;
  }
  std::size_t count() const { return static_cast<std::size_t>(n_); }
  double Slope() const {
    const double d = n_ * sxx_ - sx_ * sx_;
    return d > 0 ? (n_ * sxy_ - sx_ * sy_) / d : kNaN;
  }
  // The line's value at x.
  double At(double x) const { return y0_ + (sy_ + Slope() * (n_ * (x - x0_) - sx_)) / n_; }

 private:
  double n_ = 0;
  double x0_ = 0, y0_ = 0, sx_ = 0, sy_ = 0, sxx_ = 0, sxy_ = 0;
};

// dF/du just after the reversal `begin` of the branch [begin, end], against u - c F: the fit
// through the samples until F has changed by a fifth of 2 Q* (at least 3, at most the branch).
double ReversalStiffness(Columns s, std::size_t begin, std::size_t end, double q, double c) {
  const double change = kStiffnessWindow * 2 * q;
  LineFit fit;
  for (std::size_t i = begin; i <= end; ++i) {
    fit.Add(s.u[i] - c * s.f[i], s.f[i]);
    if (i >= begin + 2 && std::abs(s.f[i] - s.f[begin]) >= change) break;
  }
  return fit.Slope();
}

// u where F crosses `level` on the branch [begin, end] (linear between samples), the crossing
// nearest to the middle of the branch's stroke when noise makes several; NaN if F never crosses.
double Crossing(Columns s, std::size_t begin, std::size_t end, double level) {
  const double middle = 0.5 * (s.u[begin] + s.u[end]);
  double best = kNaN, distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = begin; i < end; ++i) {
    const double g0 = s.f[i] - level, g1 = s.f[i + 1] - level;
    if (!((g0 <= 0 && g1 > 0) || (g0 >= 0 && g1 < 0))) continue;
    const double at = g0 == 0 ? s.u[i] : s.u[i] + (s.u[i + 1] - s.u[i]) * (g0 / (g0 - g1));
    if (std::abs(at - middle) < distance) best = at, distance = std::abs(at - middle);
  }
  return best;
}

// The hook of the branch [begin, end] (the reversal it ends at is `end`): F at the stroke's end
// less F where u passes the stroke's middle (the fitted line there, robust to noise), along the
// branch's direction, over Q*. 0 unless the branch slides through its middle (a fit over +-5 % of
// the stroke, at least 3 samples, with |slope| < 10 % of `slope_after`).
double HookOf(Columns s, std::size_t begin, std::size_t end, double q, double slope_after) {
  const double middle = 0.5 * (s.u[begin] + s.u[end]);
  const double half_width = kMiddleWindow * std::abs(s.u[end] - s.u[begin]);
  LineFit fit;
  for (std::size_t i = begin; i <= end; ++i) {
    if (std::abs(s.u[i] - middle) <= half_width) fit.Add(s.u[i], s.f[i]);
  }
  if (fit.count() < 3 || !(std::abs(fit.Slope()) < kSlidingSlope * slope_after)) return 0;
  const double direction = s.u[end] > s.u[begin] ? 1 : -1;
  return direction * (s.f[end] - fit.At(middle)) / q;
}

struct Extremes {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
};

// Extremes of u - c F over [a, b].
Extremes DisplacementExtremes(Columns s, std::size_t a, std::size_t b, double c) {
  Extremes e;
  for (std::size_t i = a; i <= b; ++i) {
    const double x = s.u[i] - c * s.f[i];
    e.min = std::min(e.min, x), e.max = std::max(e.max, x);
  }
  return e;
}

// The closed integral of F du: trapezoids over [a, b], closed by the segment from b back to a.
double LoopArea(Columns s, std::size_t a, std::size_t b) {
  double area = 0;
  for (std::size_t i = a; i < b; ++i) area += 0.5 * (s.f[i] + s.f[i + 1]) * (s.u[i + 1] - s.u[i]);
  return area + 0.5 * (s.f[b] + s.f[a]) * (s.u[a] - s.u[b]);
}

ContactFigures ContactFiguresOf(Columns s, const CycleMetrics& m, double c) {
  const Extremes x = DisplacementExtremes(s, m.first_sample, m.last_sample, c);
  ContactFigures out;
  out.displacement_amplitude = 0.5 * (x.max - x.min);
  out.energy_ratio = m.dissipated_energy / (4 * out.displacement_amplitude * m.force_amplitude);
  out.sliding_ratio = m.half_opening / out.displacement_amplitude;
  out.secant_stiffness = m.force_amplitude / out.displacement_amplitude;
  out.stiffness_increasing =
      ReversalStiffness(s, m.lower_reversal, m.last_sample, m.force_amplitude, c);
  out.stiffness_decreasing =
      ReversalStiffness(s, m.first_sample, m.lower_reversal, m.force_amplitude, c);
  return out;
}

LoopFlags FlagsOf(Columns s, const CycleMetrics& m, const LoopOptions& o) {
  const std::size_t a = m.first_sample, low = m.lower_reversal, b = m.last_sample;
  const double q = m.force_amplitude;
  LoopFlags flags;
  flags.closure_error = std::max(std::abs(s.f[b] - s.f[a]) / (2 * q),
                                 std::abs(s.u[b] - s.u[a]) / (2 * m.displacement_amplitude));
  flags.not_closed = flags.closure_error > o.closure_tolerance;
  const double k_inc = m.stiffness_increasing, k_dec = m.stiffness_decreasing;
  flags.asymmetry =
      std::max(std::abs(m.force_offset) / q, std::abs(k_inc - k_dec) / (k_inc + k_dec));
  flags.asymmetric = flags.asymmetry > o.asymmetry_tolerance;
  flags.hook_ratio = std::max(HookOf(s, low, b, q, k_inc), HookOf(s, a, low, q, k_dec));
  flags.hooked = flags.hook_ratio > o.hook_tolerance;
  return flags;
}

CycleMetrics MeasureCycle(const LoopSamples& samples, std::size_t a, std::size_t low, std::size_t b,
                          const LoopOptions& o) {
  const Columns s{samples.displacement.data(), samples.tangential_force.data()};
  CycleMetrics m;
  m.first_sample = a, m.lower_reversal = low, m.last_sample = b;
  m.start_time = samples.time.empty() ? kNaN : samples.time[a];

  const auto [f_min, f_max] = std::minmax_element(s.f + a, s.f + b + 1);
  m.force_amplitude = 0.5 * (*f_max - *f_min);
  m.force_offset = 0.5 * (*f_max + *f_min);
  m.dissipated_energy = LoopArea(s, a, b);
  // The rig's spring is unloaded at F_x = 0, not at the offset; but the two crossings are at the
  // same force, so the spring shifts both alike and the opening is the contact's.
  m.half_opening =
      0.5 * std::abs(Crossing(s, a, low, m.force_offset) - Crossing(s, low, b, m.force_offset));
  const Extremes u = DisplacementExtremes(s, a, b, 0);
  m.half_opening_round_off =
      16 * std::numeric_limits<double>::epsilon() * std::max(std::abs(u.min), std::abs(u.max));
  m.opening_resolved =
      m.half_opening > std::max(o.displacement_resolution, m.half_opening_round_off);
  // Below the resolution delta_0 is noise or round-off, and a ratio over it any number.
  const double resolved_opening = m.opening_resolved ? m.half_opening : kNaN;
  m.system_free_ratio = m.dissipated_energy / (4 * resolved_opening * m.force_amplitude);

  if (!samples.normal_force.empty()) {
    double sum = 0;  // over [a, b): the closing sample is the next cycle's first
    for (std::size_t i = a; i < b; ++i) sum += samples.normal_force[i];
    m.normal_force = sum / static_cast<double>(b - a);
  } else {
    m.normal_force = o.normal_force.value_or(kNaN);
  }
  // A torsional M* / P is a length (mu times a fraction of the contact radius): no coefficient.
  const bool torsional = samples.channel == LoopChannel::kTorsional;
  m.friction_coefficient = torsional ? kNaN : m.force_amplitude / m.normal_force;
  m.energy_friction_coefficient =
      torsional ? kNaN : m.dissipated_energy / (4 * m.normal_force * resolved_opening);

  m.displacement_amplitude = 0.5 * (u.max - u.min);
  m.energy_ratio = m.dissipated_energy / (4 * m.displacement_amplitude * m.force_amplitude);
  m.sliding_ratio = m.half_opening / m.displacement_amplitude;
  m.secant_stiffness = m.force_amplitude / m.displacement_amplitude;
  m.stiffness_increasing = ReversalStiffness(s, low, b, m.force_amplitude, 0);
  m.stiffness_decreasing = ReversalStiffness(s, a, low, m.force_amplitude, 0);

  if (o.rig_compliance) m.contact = ContactFiguresOf(s, m, *o.rig_compliance);
  m.flags = FlagsOf(s, m, o);
  return m;
}

// Least-squares slope of Q* (of Q*/P when P is known) against the cycle index, times the number
// of cycles, over the mean; 0 with fewer than 3 cycles.
double FrictionDrift(const std::vector<CycleMetrics>& cycles, bool normal_force_known) {
  if (cycles.size() < 3) return 0;
  LineFit fit;
  double sum = 0;
  for (std::size_t k = 0; k < cycles.size(); ++k) {
    const CycleMetrics& c = cycles[k];
    const double y = normal_force_known ? c.friction_coefficient : c.force_amplitude;
    fit.Add(static_cast<double>(k), y);
    sum += y;
  }
  const double n = static_cast<double>(cycles.size());
  return fit.Slope() * n / (sum / n);
}

}  // namespace

ChannelNames NamesOf(LoopChannel channel) {
  if (channel == LoopChannel::kTorsional) {
    return {"twist", "twisting_moment", "rad", "N m", kMaxSampleTwist};
  }
  return {"displacement", "tangential_force", "m", "N", kMaxSampleDisplacement};
}

Measures MeasuresOf(const char* figure) {
  if (figure == nullptr) return Measures::kContactAndRig;
  const std::string_view name(figure);
  // Everything in ContactFigures ("contact.energy_ratio") is the contact's by construction.
  if (name.starts_with("contact.")) return Measures::kContact;
  static constexpr std::array<std::string_view, 10> kContactOnly = {
      "force_amplitude",      "force_offset",
      "dissipated_energy",    "half_opening",
      "system_free_ratio",    "normal_force",
      "friction_coefficient", "energy_friction_coefficient",
      "friction_drift",       "onset_system_free_ratio"};
  // The rest (displacements, slopes, the flags, which use them) carry the rig.
  return std::find(kContactOnly.begin(), kContactOnly.end(), name) != kContactOnly.end()
             ? Measures::kContact
             : Measures::kContactAndRig;
}

Result<LoopAnalysis> AnalyzeLoops(const LoopSamples& samples, const LoopOptions& options,
                                  const Interrupt& interrupt) {
  if (Status s = ValidateLoopOptions(options); !s.ok()) return s;
  if (Status s = ValidateSamples(samples, interrupt); !s.ok()) return s;

  LoopAnalysis out;
  out.reversal_threshold = options.reversal_threshold;
  if (out.reversal_threshold == 0) {
    Result<double> automatic = AutomaticThreshold(samples.displacement, interrupt);
    if (!automatic.ok()) return automatic.status();
    out.reversal_threshold = *automatic;
  }
  Result<Reversals> reversals =
      FindReversals(samples.displacement, out.reversal_threshold, interrupt);
  if (!reversals.ok()) return reversals.status();
  out.reversals = std::move(reversals->at);

  const std::vector<std::size_t>& at = out.reversals;
  std::size_t measured = 0;  // samples so far, for the interrupt
  for (std::size_t k = reversals->first_is_upper ? 0 : 1; k + 2 < at.size(); k += 2) {
    const std::size_t before = measured;
    measured += at[k + 2] - at[k];
    if (measured / kInterruptPeriod != before / kInterruptPeriod) {
      if (Status s = interrupt.Check(); !s.ok()) return s;
    }
    out.cycles.push_back(MeasureCycle(samples, at[k], at[k + 1], at[k + 2], options));
  }
  if (out.cycles.empty()) {
    const ChannelNames names = NamesOf(samples.channel);
    return FailedPrecondition(
        names.position,
        std::string("holds no complete cycle (two upper reversals with a lower one between them, "
                    "the ") +
            names.position + " moving back from each by more than the reversal threshold " +
            FormatNumber(out.reversal_threshold) + " " + names.position_unit + "); found " +
            std::to_string(at.size()) + " reversals in " +
            std::to_string(samples.displacement.size()) + " samples");
  }
  // A torsional record drifts in M* (it has no friction coefficient).
  const bool normal_force_known = samples.channel == LoopChannel::kTangential &&
                                  (!samples.normal_force.empty() || options.normal_force);
  out.friction_drift = FrictionDrift(out.cycles, normal_force_known);
  out.friction_drifts = std::abs(out.friction_drift) > options.drift_tolerance;
  return out;
}

}  // namespace mdr::analysis
