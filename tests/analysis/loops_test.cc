// Loop analysis of measured fretting samples (issue #24; docs/analysis.md): cycles by the
// reversals of u, the figures against the Mindlin-Deresiewicz closed forms and the engine, the rig
// in series, the flags and every refused input.
#include "mdr/analysis/loops.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/core/contact.h"

namespace mdr::analysis {
namespace {

constexpr double kMu = 0.3, kNormalForce = 100;  // N
constexpr double kSlip = 1e-6;                   // mu kappa d, m: the gross-slip displacement

// Energy per Mindlin-Deresiewicz cycle of a sphere (n = 2) over mu^2 P kappa d. The two terms
// cancel to O(s^3), so long double with expm1/log1p (good to ~1e-19/s^2 relative).
double EnergyRatio(double s) {
  const long double n = 2, log_rest = std::log1pl(-static_cast<long double>(s));
  const long double a = -8 * (n + 1) / (2 * n + 1) * std::expm1l((2 * n + 1) / (n + 1) * log_rest);
  const long double b = 4 * s * (2 + std::expm1l(n / (n + 1) * log_rest));
  return static_cast<double>(a - b);
}

// A Hertz sphere cycled between +-amplitude at constant P (Mindlin-Deresiewicz): virgin curve
// Phi(v) = mu P [1 - (1 - v/g)^{3/2}], g = mu kappa d, flat at mu P beyond g (gross slip).
struct Hertz {
  double g = kSlip, mu_p = kMu * kNormalForce, amplitude;

  static Hertz AtRatio(double s) { return {.amplitude = kSlip * (1 - std::cbrt(Sq(1 - s)))}; }
  static double Sq(double x) { return x * x; }

  double Phi(double v) const { return v >= g ? mu_p : mu_p * (1 - std::pow(1 - v / g, 1.5)); }
  double PhiSlope(double v) const { return v >= g ? 0 : 1.5 * mu_p / g * std::sqrt(1 - v / g); }
  double Q() const { return Phi(amplitude); }
  double Force(double u, bool increasing) const {
    return increasing ? -Q() + 2 * Phi((u + amplitude) / 2) : Q() - 2 * Phi((amplitude - u) / 2);
  }
  double Ratio() const { return Q() / mu_p; }
  double Energy() const { return mu_p * g * EnergyRatio(Ratio()); }  // W, J
  // Where the branches cross F = 0: u = -+delta_0 with Phi((amplitude -+ u)/2) = Q/2.
  double HalfOpening() const {
    const double s = Ratio();
    return g * (2 * std::cbrt(Sq(1 - s / 2)) - std::cbrt(Sq(1 - s)) - 1);
  }
  double InitialStiffness() const { return PhiSlope(0); }  // N/m
};

// A loop to sample: F on the branch of increasing (true) or decreasing u, between +-amplitude.
struct Loop {
  std::function<double(double, bool)> force;
  double amplitude;
  std::vector<double> extra;  // further u sampled on both branches (the crossings, for exactness)
};

Loop HertzLoop(const Hertz& h, bool with_crossings = false) {
  Loop loop{[h](double u, bool inc) { return h.Force(u, inc); }, h.amplitude, {}};
  if (with_crossings) loop.extra = {-h.HalfOpening(), h.HalfOpening()};
  return loop;
}

// u on the increasing branch: per_cycle/2 equal steps from -amplitude to +amplitude, plus extra.
std::vector<double> BranchPoints(const Loop& loop, int per_cycle) {
  const int half = per_cycle / 2;
  std::vector<double> u;
  for (int i = 0; i <= half; ++i) u.push_back(loop.amplitude * (2.0 * i / half - 1));
  for (double x : loop.extra) u.push_back(x);
  std::sort(u.begin(), u.end());
  u.erase(std::unique(u.begin(), u.end()), u.end());
  return u;
}

// `cycles` whole cycles (upper reversal, lower, upper) with a lead-in from u = 0 up and a tail
// down to u = 0, so the first and last upper reversals are found. Time 1 ms per sample.
LoopSamples Sample(const Loop& loop, int cycles, int per_cycle = 500) {
  const std::vector<double> up = BranchPoints(loop, per_cycle);
  LoopSamples s;
  auto add = [&](double u, bool increasing) {
    s.displacement.push_back(u);
    s.tangential_force.push_back(loop.force(u, increasing));
    s.time.push_back(1e-3 * static_cast<double>(s.time.size()));
  };
  for (std::size_t i = 0; i + 1 < up.size(); ++i) {
    if (up[i] >= 0) add(up[i], true);
  }
  for (int c = 0; c < cycles; ++c) {
    for (std::size_t i = up.size() - 1; i > 0; --i) add(up[i], false);
    for (std::size_t i = 0; i + 1 < up.size(); ++i) add(up[i], true);
  }
  add(up.back(), false);
  for (std::size_t i = up.size() - 1; i-- > 0 && up[i] >= 0;) add(up[i], false);
  return s;
}

// The same samples measured through a rig of compliance c in series: u + c F.
LoopSamples ThroughRig(LoopSamples s, double c) {
  for (std::size_t i = 0; i < s.displacement.size(); ++i) {
    s.displacement[i] += c * s.tangential_force[i];
  }
  return s;
}

LoopAnalysis Analyze(const LoopSamples& s, const LoopOptions& o = {}) {
  Result<LoopAnalysis> r = AnalyzeLoops(s, o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(r).value() : LoopAnalysis{};
}

void ExpectRelative(double actual, double expected, double tolerance, const char* what) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected)) << what;
}

// H1 driven by a triangle wave of the given amplitude at constant depth (F_N = 100 N) from u = 0,
// `cycles` cycles and a tail; also records the engine's dissipated energy per sample.
struct EngineRun {
  LoopSamples samples;
  std::vector<double> energy;
  double slip, limit;  // mu kappa d (m), mu F_N (N)
};

EngineRun RunEngine(double amplitude_ratio, int cycles, int per_cycle) {
  Contact contact = reference::LoadedH1Contact();
  EngineRun run;
  run.slip = contact.mu_kappa() * contact.depth();
  run.limit = contact.friction_limit();
  const int half = per_cycle / 2;
  for (int k = half / 2; k <= half / 2 + cycles * per_cycle + half; ++k) {
    const double u = reference::TriangleWave(amplitude_ratio * run.slip, k, half);
    EXPECT_TRUE(contact.MoveTo(contact.depth(), u).ok());
    run.samples.displacement.push_back(u);
    run.samples.tangential_force.push_back(contact.tangential_force());
    run.samples.normal_force.push_back(contact.normal_force());
    run.energy.push_back(contact.dissipated_energy());
  }
  return run;
}

// ---- (1) The rig in series --------------------------------------------------------------------

// u + C_t F_x: the contact's figures do not move, the displacement's follow the series model,
// and with rig_compliance = C_t the contact figures are the rig-free run's.
void ExpectSeriesInvariance(const LoopSamples& free_samples, double c_t, const LoopOptions& o) {
  SCOPED_TRACE("C_t = " + std::to_string(c_t));
  const LoopAnalysis free = Analyze(free_samples, o);
  const LoopAnalysis rig = Analyze(ThroughRig(free_samples, c_t), o);
  LoopOptions with_c = o;
  with_c.rig_compliance = c_t;
  const LoopAnalysis known = Analyze(ThroughRig(free_samples, c_t), with_c);
  ASSERT_FALSE(free.cycles.empty());
  ASSERT_EQ(rig.reversals, free.reversals);
  ASSERT_EQ(known.cycles.size(), free.cycles.size());
  constexpr double kTol = 1e-9;
  for (std::size_t k = 0; k < free.cycles.size(); ++k) {
    const CycleMetrics &f = free.cycles[k], &r = rig.cycles[k];
    ExpectRelative(r.dissipated_energy, f.dissipated_energy, kTol, "Ed");
    ExpectRelative(r.force_amplitude, f.force_amplitude, kTol, "Q*");
    ExpectRelative(r.half_opening, f.half_opening, kTol, "delta_0");
    ExpectRelative(r.system_free_ratio, f.system_free_ratio, kTol, "C");
    ExpectRelative(r.friction_coefficient, f.friction_coefficient, kTol, "mu");
    ExpectRelative(r.energy_friction_coefficient, f.energy_friction_coefficient, kTol, "mu_e");
    // Series model: delta* grows by C_t Q* (max u and max F at the same reversal).
    const double amplitude = f.displacement_amplitude + c_t * f.force_amplitude;
    ExpectRelative(r.displacement_amplitude, amplitude, kTol, "delta*");
    const double shrink = f.displacement_amplitude / amplitude;
    ExpectRelative(r.energy_ratio, f.energy_ratio * shrink, kTol, "A");
    ExpectRelative(r.sliding_ratio, f.sliding_ratio * shrink, kTol, "B");
    ExpectRelative(r.secant_stiffness, 1 / (1 / f.secant_stiffness + c_t), kTol, "Q*/delta*");
    EXPECT_LT(r.stiffness_increasing, f.stiffness_increasing);  // the rig softens every slope

    ASSERT_TRUE(known.cycles[k].contact.has_value());
    EXPECT_FALSE(f.contact.has_value());
    const ContactFigures& c = *known.cycles[k].contact;
    ExpectRelative(c.displacement_amplitude, f.displacement_amplitude, kTol, "delta*_c");
    ExpectRelative(c.energy_ratio, f.energy_ratio, kTol, "A_c");
    ExpectRelative(c.sliding_ratio, f.sliding_ratio, kTol, "B_c");
    ExpectRelative(c.secant_stiffness, f.secant_stiffness, kTol, "secant_c");
    ExpectRelative(c.stiffness_increasing, f.stiffness_increasing, kTol, "k_inc_c");
    ExpectRelative(c.stiffness_decreasing, f.stiffness_decreasing, kTol, "k_dec_c");
  }
}

TEST(LoopsTest, RigInSeriesBiasesOnlyTheDisplacementFigures) {
  LoopOptions o;
  o.normal_force = kNormalForce;
  for (double s : {0.3, 0.9}) {
    const Hertz h = Hertz::AtRatio(s);
    const LoopSamples samples = Sample(HertzLoop(h), 3);
    // The last one makes the rig 3x softer than the contact at the reversal.
    for (double c_t : {0.01, 0.5, 3.0}) {
      ExpectSeriesInvariance(samples, c_t / h.InitialStiffness(), o);
    }
  }
  // Gross slip: the loop slides at mu P beyond the stick part.
  Hertz gross{.amplitude = 3 * kSlip};
  ExpectSeriesInvariance(Sample(HertzLoop(gross), 3), 3 / gross.InitialStiffness(), o);
}

TEST(LoopsTest, RigInSeriesOnEngineLoops) {
  EngineRun run = RunEngine(0.6, 3, 400);
  const double k0 = 1.5 * run.limit / run.slip;  // Hertz: the contact's stiffness at a reversal
  for (double c_t : {0.2 / k0, 3 / k0}) ExpectSeriesInvariance(run.samples, c_t, {});
}

// The engine with its own rig (ContactConfig::rig): the actuator's samples, analysed with the
// rig's compliance, give the contact's loop of the rig-free engine.
TEST(LoopsTest, EngineRigRecoversTheContactLoop) {
  const double c_t = 5e-8;  // m/N, several times softer than H1 at 100 N
  ContactConfig config = reference::H1Config();
  config.rig = {c_t, 0};
  Contact contact = std::move(Contact::Create(config)).value();
  Step load;
  load.normal = NormalControl::kForce;
  load.normal_value = reference::H1::kNormalForce;
  ASSERT_TRUE(contact.Apply(load).ok());
  const double amplitude = 0.5 * contact.mu_kappa() * contact.depth() + c_t * 15;
  LoopSamples samples;
  std::vector<double> contact_u;
  for (int k = 100; k <= 100 + 3 * 400 + 200; ++k) {
    Step step;
    step.tangential = TangentialControl::kDisplacement;
    step.tangential_value = reference::TriangleWave(amplitude, k, 200);
    ASSERT_TRUE(contact.Apply(step).ok());
    samples.displacement.push_back(contact.actuator_displacement());
    samples.tangential_force.push_back(contact.tangential_force());
    contact_u.push_back(contact.tangential_displacement());
  }
  LoopOptions o;
  o.rig_compliance = c_t;
  const LoopAnalysis rig = Analyze(samples, o);
  samples.displacement = contact_u;
  const LoopAnalysis free = Analyze(samples);
  ASSERT_EQ(rig.cycles.size(), 3u);
  ASSERT_EQ(free.cycles.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const CycleMetrics &r = rig.cycles[k], &f = free.cycles[k];
    ExpectRelative(r.dissipated_energy, f.dissipated_energy, 1e-9, "Ed");
    ExpectRelative(r.half_opening, f.half_opening, 1e-9, "delta_0");
    ExpectRelative(r.contact->displacement_amplitude, f.displacement_amplitude, 1e-9, "delta*");
    ExpectRelative(r.contact->energy_ratio, f.energy_ratio, 1e-9, "A");
    ExpectRelative(r.contact->stiffness_increasing, f.stiffness_increasing, 1e-9, "k");
    EXPECT_GT(r.displacement_amplitude, 1.5 * f.displacement_amplitude);
  }
}

// ---- (2) Closed forms ---------------------------------------------------------------------------

// The header's slope after a reversal, done plainly: the least-squares line of F against u
// through the samples from `reversal` to the first where F has moved by 2 q / 5 (at least 3).
double ReferenceStiffness(const LoopSamples& s, std::size_t reversal, double q) {
  const std::vector<double>&u = s.displacement, &f = s.tangential_force;
  std::size_t end = reversal + 2;
  while (std::abs(f[end] - f[reversal]) < 0.4 * q) ++end;
  const double n = static_cast<double>(end - reversal + 1);
  double mu = 0, mf = 0;
  for (std::size_t i = reversal; i <= end; ++i) mu += u[i] / n, mf += f[i] / n;
  double suf = 0, suu = 0;
  for (std::size_t i = reversal; i <= end; ++i) {
    suf += (u[i] - mu) * (f[i] - mf), suu += (u[i] - mu) * (u[i] - mu);
  }
  return suf / suu;
}

// Trapezoids with step h over a branch err by (h^2/12) [F'(end) - F'(start)] (Euler-Maclaurin);
// over the loop: Ed - W = (h^2/6) (Phi'(u*) - Phi'(0)) + O(h^4), the samples at the crossings
// changing it by O(h^3).
TEST(LoopsTest, HertzLoopsMatchTheClosedForms) {
  const int per_cycle = 1000;
  LoopOptions o;
  o.normal_force = kNormalForce;
  for (double s : {1e-2, 0.1, 0.3, 0.6, 0.9, 0.99, 1.0}) {
    SCOPED_TRACE("s = " + std::to_string(s));
    const Hertz hz = Hertz::AtRatio(s);
    const LoopSamples samples = Sample(HertzLoop(hz, true), 2, per_cycle);
    const LoopAnalysis a = Analyze(samples, o);
    ASSERT_EQ(a.cycles.size(), 2u);
    const double q = s * kMu * kNormalForce, u_star = hz.amplitude;
    const double step = 4 * u_star / per_cycle;
    const double lead = step * step / 6 * (hz.PhiSlope(u_star) - hz.PhiSlope(0));
    for (const CycleMetrics& c : a.cycles) {
      ExpectRelative(c.force_amplitude, q, 1e-12, "Q*");
      EXPECT_NEAR(c.force_offset, 0, 1e-12 * q);
      ExpectRelative(c.displacement_amplitude, u_star, 1e-12, "delta*");
      ExpectRelative(c.half_opening, hz.HalfOpening(), 1e-9, "delta_0");
      // The rest is the crossings' O(h^3) (about 0.3 % of the leading error here; 3e-7 without
      // them, see the engine's test), and at s = 1 the O(h^{5/2}) of F'' ~ (1 - v/g)^{-1/2}.
      EXPECT_NEAR(c.dissipated_energy, hz.Energy() + lead, (s < 1 ? 0.005 : 0.02) * std::abs(lead));
      ExpectRelative(c.dissipated_energy, hz.Energy(), 6.0 / (per_cycle * per_cycle), "Ed");
      ExpectRelative(c.friction_coefficient, s * kMu, 1e-12, "mu");
      ExpectRelative(c.sliding_ratio, hz.HalfOpening() / u_star, 1e-9, "B");
      ExpectRelative(c.energy_ratio, hz.Energy() / (4 * u_star * q), 1e-5, "A");
      ExpectRelative(c.system_free_ratio, hz.Energy() / (4 * hz.HalfOpening() * q), 1e-5, "C");
      ExpectRelative(c.energy_friction_coefficient,
                     hz.Energy() / (4 * kNormalForce * hz.HalfOpening()), 1e-5, "mu_e");
      ExpectRelative(c.stiffness_increasing, ReferenceStiffness(samples, c.lower_reversal, q), 1e-9,
                     "k_inc");
      ExpectRelative(c.stiffness_decreasing, ReferenceStiffness(samples, c.first_sample, q), 1e-9,
                     "k_dec");
      // The fit after a reversal lies between the slopes at the ends of its window.
      const double window_end = std::pow(1 - 0.2 * s, 2.0 / 3);  // 1 - v/g where F moved 0.4 Q*
      for (double k : {c.stiffness_increasing, c.stiffness_decreasing}) {
        EXPECT_LT(k, hz.InitialStiffness());
        EXPECT_GT(k, hz.InitialStiffness() * std::sqrt(window_end) * 0.99);
      }
      EXPECT_FALSE(c.flags.not_closed || c.flags.asymmetric || c.flags.hooked);
    }
    if (s == 1.0) {  // the onset of gross slip
      EXPECT_NEAR(a.cycles[0].energy_ratio, 0.2, 1e-5);
      EXPECT_NEAR(a.cycles[0].sliding_ratio, std::cbrt(2.0) - 1, 1e-12);
      EXPECT_NEAR(a.cycles[0].system_free_ratio, 0.2 / (std::cbrt(2.0) - 1), 1e-4);
    }
  }
}

// An opening not above the sensor's resolution identifies no C and no mu_e (NaN, never a ratio over
// noise); everything that does not divide by delta_0 is the same, and the opening itself is still
// reported. Just above the resolution the figures are the plain ones, bit for bit.
TEST(LoopsTest, OpeningBelowTheResolutionIdentifiesNoRatioOverIt) {
  LoopOptions o;
  o.normal_force = kNormalForce;
  const Hertz hz = Hertz::AtRatio(0.3);
  const LoopSamples samples = Sample(HertzLoop(hz, true), 2);
  const LoopAnalysis plain = Analyze(samples, o);
  ASSERT_EQ(plain.cycles.size(), 2u);
  const double delta_0 = plain.cycles[0].half_opening;
  for (const CycleMetrics& c : plain.cycles) {
    EXPECT_TRUE(c.opening_resolved);
    EXPECT_GT(c.half_opening, 1e6 * c.half_opening_round_off);
  }
  for (double resolution : {delta_0, 2 * delta_0, std::nextafter(delta_0, 0.0)}) {
    SCOPED_TRACE("resolution " + std::to_string(resolution / delta_0) + " delta_0");
    o.displacement_resolution = resolution;
    const LoopAnalysis a = Analyze(samples, o);
    ASSERT_EQ(a.cycles.size(), 2u);
    for (std::size_t k = 0; k < a.cycles.size(); ++k) {
      const CycleMetrics &c = a.cycles[k], &p = plain.cycles[k];
      const bool resolved = p.half_opening > resolution;
      EXPECT_EQ(c.opening_resolved, resolved);
      EXPECT_EQ(c.half_opening, p.half_opening);
      EXPECT_EQ(c.dissipated_energy, p.dissipated_energy);
      EXPECT_EQ(c.sliding_ratio, p.sliding_ratio);
      EXPECT_EQ(c.friction_coefficient, p.friction_coefficient);
      if (resolved) {
        EXPECT_EQ(c.system_free_ratio, p.system_free_ratio);
        EXPECT_EQ(c.energy_friction_coefficient, p.energy_friction_coefficient);
      } else {
        EXPECT_TRUE(std::isnan(c.system_free_ratio)) << c.system_free_ratio;
        EXPECT_TRUE(std::isnan(c.energy_friction_coefficient)) << c.energy_friction_coefficient;
      }
    }
  }
}

// The engine's exact energy per cycle, and its loops against the closed forms.
TEST(LoopsTest, EngineLoopsMatchItsEnergyAndTheClosedForms) {
  const int per_cycle = 400;
  const double ratio = 0.6;  // u*/(mu kappa d)
  const EngineRun run = RunEngine(ratio, 3, per_cycle);
  const LoopAnalysis a = Analyze(run.samples);
  ASSERT_EQ(a.cycles.size(), 3u);
  const Hertz hz{.g = run.slip, .mu_p = run.limit, .amplitude = ratio * run.slip};
  const double step = 4 * hz.amplitude / per_cycle;
  const double lead = step * step / 6 * (hz.PhiSlope(hz.amplitude) - hz.PhiSlope(0));
  for (const CycleMetrics& c : a.cycles) {
    const double exact = run.energy[c.last_sample] - run.energy[c.first_sample];
    ExpectRelative(exact, hz.Energy(), 1e-9, "engine vs W");
    // Uniform steps: the rest is O(h^4), 1e-3 of the leading O(h^2) error is ample.
    EXPECT_NEAR(c.dissipated_energy, exact + lead, 1e-3 * std::abs(lead));
    ExpectRelative(c.force_amplitude, hz.Q(), 1e-9, "Q*");
    ExpectRelative(c.normal_force, reference::H1::kNormalForce, 1e-9, "P");
    ExpectRelative(c.friction_coefficient, hz.Q() / reference::H1::kNormalForce, 1e-9, "mu");
    // delta_0 by linear interpolation: the chord's error, (du^2/8) F''/F' at the crossing.
    ExpectRelative(c.half_opening, hz.HalfOpening(), 1e-4, "delta_0");
    EXPECT_EQ(c.last_sample - c.first_sample, static_cast<std::size_t>(per_cycle));
  }
}

// ---- (3) Reversals ----------------------------------------------------------------------------

TEST(LoopsTest, NoiseBelowTheThresholdMakesNoReversal) {
  const Hertz hz = Hertz::AtRatio(0.5);
  const int cycles = 20, per_cycle = 500;
  const LoopSamples clean = Sample(HertzLoop(hz), cycles, per_cycle);
  const LoopAnalysis reference = Analyze(clean);
  ASSERT_EQ(reference.cycles.size(), static_cast<std::size_t>(cycles));

  std::mt19937_64 rng(2024);
  std::normal_distribution<double> noise(0, 1);
  LoopSamples noisy = clean;
  const double sigma_u = 0.005 * hz.amplitude;
  for (std::size_t i = 0; i < noisy.displacement.size(); ++i) {
    noisy.displacement[i] += sigma_u * noise(rng);
    noisy.tangential_force[i] += 0.005 * hz.Q() * noise(rng);
  }
  LoopOptions explicit_threshold;
  explicit_threshold.reversal_threshold = 20 * sigma_u;
  for (const LoopOptions& o : {explicit_threshold, LoopOptions{}}) {
    const LoopAnalysis a = Analyze(noisy, o);
    ASSERT_EQ(a.cycles.size(), static_cast<std::size_t>(cycles));
    ASSERT_EQ(a.reversals.size(), reference.reversals.size());
    for (std::size_t k = 0; k < a.reversals.size(); ++k) {
      EXPECT_NEAR(static_cast<double>(a.reversals[k]), static_cast<double>(reference.reversals[k]),
                  8);
    }
    for (const CycleMetrics& c : a.cycles) {
      ExpectRelative(c.force_amplitude, hz.Q(), 0.03, "Q*");
      ExpectRelative(c.dissipated_energy, hz.Energy(), 0.05, "Ed");
    }
  }
  // Automatic: 5 % of the median peak-to-peak, 2 u*.
  EXPECT_NEAR(Analyze(noisy).reversal_threshold, 0.1 * hz.amplitude, 0.01 * hz.amplitude);
  EXPECT_DOUBLE_EQ(reference.reversal_threshold, 0.1 * hz.amplitude);
  // Noise larger than the threshold does make reversals.
  LoopOptions too_small;
  too_small.reversal_threshold = 0.5 * sigma_u;
  EXPECT_GT(Analyze(noisy, too_small).cycles.size(), static_cast<std::size_t>(2 * cycles));
}

// A mean that drifts by 20 u* over the run: the coarse pass at a quarter of the range finds
// nothing, a finer one the cycles.
TEST(LoopsTest, AutomaticThresholdFollowsADriftingMean) {
  const Hertz hz = Hertz::AtRatio(0.5);
  LoopSamples s = Sample(HertzLoop(hz), 10, 500);
  const double n = static_cast<double>(s.displacement.size());
  for (std::size_t i = 0; i < s.displacement.size(); ++i) {
    s.displacement[i] += 20 * hz.amplitude * static_cast<double>(i) / n;
  }
  const LoopAnalysis a = Analyze(s);
  EXPECT_EQ(a.cycles.size(), 10u);
  EXPECT_GT(a.reversal_threshold, 0.04 * hz.amplitude);
  EXPECT_LT(a.reversal_threshold, 0.2 * hz.amplitude);
}

// Spikes that cross F = 0 far from the middle of a branch do not move delta_0.
TEST(LoopsTest, ExtraCrossingsTakeTheOneNearestTheMiddle) {
  const Hertz hz = Hertz::AtRatio(0.5);
  const LoopSamples clean = Sample(HertzLoop(hz), 2, 200);
  LoopSamples spiky = clean;
  int spikes = 0;
  for (std::size_t i = 0; i < clean.displacement.size(); ++i) {
    // Near both ends of both branches, the force jumps across 0 for one sample.
    if (std::abs(std::abs(clean.displacement[i] / hz.amplitude) - 0.9) < 0.005) {
      spiky.tangential_force[i] = -std::copysign(0.5 * hz.Q(), clean.tangential_force[i]);
      ++spikes;
    }
  }
  ASSERT_GE(spikes, 8);  // two per branch
  const LoopAnalysis a = Analyze(clean), b = Analyze(spiky);
  ASSERT_EQ(b.cycles.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    ExpectRelative(b.cycles[k].half_opening, a.cycles[k].half_opening, 1e-12, "delta_0");
  }
}

// The trigger's rule: a move back by more than the threshold makes a reversal, one by less does
// not; the first sample is none.
TEST(LoopsTest, ReversalsNeedAMoveBackBeyondTheThreshold) {
  // Piecewise linear through the corners, 10 samples per leg, F = 1000 u.
  auto path = [](std::vector<double> corners) {
    LoopSamples s;
    for (std::size_t k = 0; k + 1 < corners.size(); ++k) {
      for (int i = 0; i < 10; ++i) {
        s.displacement.push_back(corners[k] + (corners[k + 1] - corners[k]) * i / 10);
      }
    }
    s.displacement.push_back(corners.back());
    for (double u : s.displacement) s.tangential_force.push_back(1000 * u);
    return s;
  };
  LoopOptions o;
  o.reversal_threshold = 0.1;
  // A dip of 0.09 at 0.5 is no reversal; one of 0.11 makes two.
  const LoopAnalysis small = Analyze(path({0, 1, -1, 0.5, 0.41, 1, -1, 1, 0}), o);
  EXPECT_EQ(small.reversals, (std::vector<std::size_t>{10, 20, 50, 60, 70}));
  EXPECT_EQ(small.cycles.size(), 2u);
  // A move back of exactly the threshold is none either (0.125 and 0.375 are exact in binary).
  LoopOptions exact;
  exact.reversal_threshold = 0.125;
  EXPECT_EQ(Analyze(path({0, 1, -1, 0.5, 0.375, 1, -1, 1, 0}), exact).reversals, small.reversals);
  const LoopAnalysis large = Analyze(path({0, 1, -1, 0.5, 0.39, 1, -1, 1, 0}), o);
  EXPECT_EQ(large.reversals, (std::vector<std::size_t>{10, 20, 30, 40, 50, 60, 70}));
  // Upper reversals at 10, 30 (the dip's top), 50 and 70: three cycles, the middle one the dip.
  ASSERT_EQ(large.cycles.size(), 3u);
  EXPECT_EQ(large.cycles[1].first_sample, 30u);
  EXPECT_EQ(large.cycles[1].lower_reversal, 40u);
  EXPECT_EQ(large.cycles[1].last_sample, 50u);
  // Starting at the top: the first sample is no reversal, so the first cycle begins at 20.
  const LoopAnalysis top = Analyze(path({1, -1, 1, -1, 1, 0}), o);
  EXPECT_EQ(top.reversals, (std::vector<std::size_t>{10, 20, 30, 40}));
  ASSERT_EQ(top.cycles.size(), 1u);
  EXPECT_EQ(top.cycles[0].first_sample, 20u);
  EXPECT_EQ(top.cycles[0].lower_reversal, 30u);
  EXPECT_EQ(top.cycles[0].last_sample, 40u);
  EXPECT_TRUE(std::isnan(top.cycles[0].start_time));
}

TEST(LoopsTest, CycleBookkeeping) {
  const Hertz hz = Hertz::AtRatio(0.4);
  LoopSamples s = Sample(HertzLoop(hz), 4, 100);
  for (std::size_t i = 0; i < s.displacement.size(); ++i) {
    s.normal_force.push_back(i % 2 ? 90 : 110);  // mean 100 over any whole cycle
  }
  const LoopAnalysis a = Analyze(s);
  ASSERT_EQ(a.cycles.size(), 4u);
  ASSERT_EQ(a.reversals.size(), 9u);
  for (std::size_t k = 0; k < 4; ++k) {
    const CycleMetrics& c = a.cycles[k];
    EXPECT_EQ(c.first_sample, 25 + 100 * k);
    EXPECT_EQ(c.lower_reversal, 75 + 100 * k);
    EXPECT_EQ(c.last_sample, 125 + 100 * k);
    EXPECT_DOUBLE_EQ(c.start_time, 1e-3 * static_cast<double>(c.first_sample));
    EXPECT_DOUBLE_EQ(c.normal_force, 100);
    if (k > 0) {
      EXPECT_EQ(c.first_sample, a.cycles[k - 1].last_sample);
    }
  }
  EXPECT_EQ(a.friction_drift, 0);
  EXPECT_FALSE(a.friction_drifts);
}

// ---- (4) Flags --------------------------------------------------------------------------------

// A gross-slip loop with a linear stick part of slope k (k_dec on the way back) and sliding at
// +-Q, plus hook(u), a force rising toward the stroke ends.
Loop CoulombLoop(double amplitude, double q, double k_inc, double k_dec, double hook = 0) {
  auto rise = [=](double u) {
    const double beyond = std::max(std::abs(u) - amplitude / 2, 0.0) / (amplitude / 2);
    return std::copysign(hook * q * beyond * beyond, u);
  };
  return {[=](double u, bool inc) {
            return (inc ? std::min(-q + k_inc * (u + amplitude), q)
                        : std::max(q - k_dec * (amplitude - u), -q)) +
                   rise(u);
          },
          amplitude,
          {}};
}

void ExpectNoFlag(const LoopAnalysis& a) {
  EXPECT_FALSE(a.friction_drifts);
  for (const CycleMetrics& c : a.cycles) {
    EXPECT_FALSE(c.flags.not_closed);
    EXPECT_FALSE(c.flags.asymmetric);
    EXPECT_FALSE(c.flags.hooked);
  }
}

TEST(LoopsTest, CleanLoopsRaiseNoFlag) {
  for (double s : {0.05, 0.5, 0.95}) {
    const LoopAnalysis a = Analyze(Sample(HertzLoop(Hertz::AtRatio(s)), 5));
    ExpectNoFlag(a);
    EXPECT_EQ(a.friction_drift, 0);
    for (const CycleMetrics& c : a.cycles) {
      EXPECT_LT(c.flags.closure_error, 1e-12);
      EXPECT_LT(c.flags.asymmetry, 1e-9);
      EXPECT_EQ(c.flags.hook_ratio, 0) << "partial slip never slides through the middle";
    }
  }
  // Gross slip, plain Coulomb: it slides through the middle, flat.
  const double q = 30, amplitude = 1e-6;
  const LoopAnalysis coulomb =
      Analyze(Sample(CoulombLoop(amplitude, q, 5 * q / amplitude, 5 * q / amplitude), 5));
  ExpectNoFlag(coulomb);
  for (const CycleMetrics& c : coulomb.cycles) {
    EXPECT_NEAR(c.flags.hook_ratio, 0, 1e-9);
    ExpectRelative(c.stiffness_increasing, 5 * q / amplitude, 1e-9, "stick slope");
    // A parallelogram: Ed = 2 Q (2 delta* - 2 Q / k), so A = 1 - Q / (k delta*) = 0.8.
    ExpectRelative(c.energy_ratio, 0.8, 1e-3, "A");
  }
}

TEST(LoopsTest, DriftingLoopIsNotClosed) {
  const Hertz hz = Hertz::AtRatio(0.5);
  const int per_cycle = 500;
  LoopSamples u_drift = Sample(HertzLoop(hz), 5, per_cycle);
  LoopSamples f_drift = u_drift;
  for (std::size_t i = 0; i < u_drift.displacement.size(); ++i) {
    const double cycles = static_cast<double>(i) / per_cycle;
    u_drift.displacement[i] += 0.2 * 2 * hz.amplitude * cycles;  // 20 % of 2 delta* per cycle
    f_drift.tangential_force[i] += 0.2 * 2 * hz.Q() * cycles;
  }
  for (const LoopSamples* s : {&u_drift, &f_drift}) {
    const LoopAnalysis a = Analyze(*s);
    ASSERT_EQ(a.cycles.size(), 5u);
    for (const CycleMetrics& c : a.cycles) {
      EXPECT_TRUE(c.flags.not_closed);
      EXPECT_GT(c.flags.closure_error, 0.15);
      EXPECT_LT(c.flags.closure_error, 0.25);
      // Ed is the area of the polygon closed from the last sample back to the first (the
      // shoelace formula, negative: the loop runs clockwise).
      double twice_area = 0;
      for (std::size_t i = c.first_sample; i <= c.last_sample; ++i) {
        const std::size_t j = i == c.last_sample ? c.first_sample : i + 1;
        twice_area += s->displacement[i] * s->tangential_force[j] -
                      s->displacement[j] * s->tangential_force[i];
      }
      ExpectRelative(c.dissipated_energy, -twice_area / 2, 1e-9, "Ed of the open loop");
    }
  }
  LoopOptions lenient;
  lenient.closure_tolerance = 0.3;
  for (const CycleMetrics& c : Analyze(u_drift, lenient).cycles) EXPECT_FALSE(c.flags.not_closed);
}

TEST(LoopsTest, AsymmetricLoops) {
  const Hertz hz = Hertz::AtRatio(0.5);
  LoopSamples offset = Sample(HertzLoop(hz), 3);
  for (double& f : offset.tangential_force) f += 0.3 * hz.Q();
  const double half_opening = Analyze(Sample(HertzLoop(hz), 3)).cycles[0].half_opening;
  for (const CycleMetrics& c : Analyze(offset).cycles) {
    EXPECT_NEAR(c.flags.asymmetry, 0.3, 1e-12);
    EXPECT_NEAR(c.force_offset, 0.3 * hz.Q(), 1e-12 * hz.Q());
    EXPECT_TRUE(c.flags.asymmetric);
    EXPECT_FALSE(c.flags.not_closed || c.flags.hooked);
    ExpectRelative(c.half_opening, half_opening, 1e-9, "delta_0 at the offset");
  }
  // Different slopes after the two reversals: |k1 - k2| / (k1 + k2) = 1/3.
  const double q = 30, amplitude = 1e-6;
  const Loop slopes = CoulombLoop(amplitude, q, 10 * q / amplitude, 5 * q / amplitude);
  for (const CycleMetrics& c : Analyze(Sample(slopes, 3)).cycles) {
    EXPECT_NEAR(c.flags.asymmetry, 1.0 / 3, 1e-9);
    EXPECT_TRUE(c.flags.asymmetric);
    EXPECT_FALSE(c.flags.hooked);
  }
}

TEST(LoopsTest, HookedGrossSlipLoop) {
  const double q = 30, amplitude = 1e-6, k = 5 * q / amplitude;
  const LoopAnalysis a = Analyze(Sample(CoulombLoop(amplitude, q, k, k, 0.3), 3));
  for (const CycleMetrics& c : a.cycles) {
    EXPECT_NEAR(c.flags.hook_ratio, 0.3 / 1.3, 1e-9);
    EXPECT_TRUE(c.flags.hooked);
    EXPECT_FALSE(c.flags.asymmetric || c.flags.not_closed);
  }
  LoopOptions lenient;
  lenient.hook_tolerance = 0.25;
  for (const CycleMetrics& c :
       Analyze(Sample(CoulombLoop(amplitude, q, k, k, 0.3), 3), lenient).cycles) {
    EXPECT_FALSE(c.flags.hooked);
  }
  // Hooked at the negative end only (the decreasing branch): Q* = 1.15 q, hook 0.3 q / Q*.
  const Loop two_sided = CoulombLoop(amplitude, q, k, k, 0.3);
  const Loop one_sided{[&](double u, bool inc) {
                         return u < 0 ? two_sided.force(u, inc)
                                      : std::min(two_sided.force(u, inc), q);
                       },
                       amplitude,
                       {}};
  for (const CycleMetrics& c : Analyze(Sample(one_sided, 3)).cycles) {
    EXPECT_NEAR(c.flags.hook_ratio, 0.3 / 1.15, 1e-9);
    EXPECT_TRUE(c.flags.hooked);
  }
  // The same rise on a partial-slip loop: it does not slide through its middle, no hook.
  const Hertz hz = Hertz::AtRatio(0.5);
  const Loop partial{[hz](double u, bool inc) {
                       const double beyond = std::max(std::abs(u) / hz.amplitude - 0.5, 0.0) * 2;
                       return hz.Force(u, inc) + std::copysign(0.3 * hz.Q() * beyond * beyond, u);
                     },
                     hz.amplitude,
                     {}};
  for (const CycleMetrics& c : Analyze(Sample(partial, 3)).cycles) {
    EXPECT_EQ(c.flags.hook_ratio, 0);
  }
}

TEST(LoopsTest, FrictionDriftOverCycles) {
  const Hertz hz = Hertz::AtRatio(0.5);
  const int cycles = 10, per_cycle = 500;
  LoopSamples s = Sample(HertzLoop(hz), cycles, per_cycle);
  for (std::size_t i = 0; i < s.displacement.size(); ++i) {
    const double scale = 1 + 0.03 * static_cast<double>(i) / per_cycle;  // Q* +3 % per cycle
    s.tangential_force[i] *= scale;
    s.normal_force.push_back(kNormalForce * scale);  // and P with it: mu constant
  }
  // Without P, Q* drifts: Q*_k = Q (1 + 0.03 (k + 1)) (F_max at each cycle's end, 125 samples of
  // lead-in), slope 0.03 Q times 10 cycles over a mean of 1.165 Q.
  LoopSamples no_p = s;
  no_p.normal_force.clear();
  const LoopAnalysis q_drift = Analyze(no_p);
  ASSERT_EQ(q_drift.cycles.size(), static_cast<std::size_t>(cycles));
  EXPECT_NEAR(q_drift.friction_drift, 0.3 / 1.165, 1e-9);
  EXPECT_TRUE(q_drift.friction_drifts);
  for (const CycleMetrics& c : q_drift.cycles) EXPECT_FALSE(c.flags.not_closed);
  // With a constant P given as an option, mu drifts alike.
  LoopOptions constant_p;
  constant_p.normal_force = kNormalForce;
  EXPECT_NEAR(Analyze(no_p, constant_p).friction_drift, q_drift.friction_drift, 1e-12);
  // With the measured P, mu = Q*/P barely moves.
  const LoopAnalysis mu = Analyze(s);
  EXPECT_LT(std::abs(mu.friction_drift), 0.01);
  EXPECT_FALSE(mu.friction_drifts);
  LoopOptions strict;
  strict.drift_tolerance = 1e-6;
  EXPECT_TRUE(Analyze(s, strict).friction_drifts);
}

// ---- (5) Refused inputs -----------------------------------------------------------------------

LoopSamples Valid() {
  LoopSamples s = Sample(HertzLoop(Hertz::AtRatio(0.5)), 3, 40);
  s.normal_force.assign(s.displacement.size(), kNormalForce);
  return s;
}

void ExpectError(const Result<LoopAnalysis>& r, StatusCode code, const std::string& field,
                 const std::string& in_message = "") {
  ASSERT_FALSE(r.ok()) << "expected an error for " << field;
  EXPECT_EQ(r.status().code(), code) << r.status().ToString();
  EXPECT_EQ(r.status().field(), field) << r.status().ToString();
  EXPECT_NE(r.status().message().find(in_message), std::string::npos) << r.status().ToString();
}

TEST(LoopsTest, RefusesNonFiniteSamples) {
  ASSERT_TRUE(AnalyzeLoops(Valid(), {}).ok());
  const double nan = std::nan(""), inf = INFINITY;
  struct Case {
    std::vector<double> LoopSamples::*column;
    const char* name;
    std::size_t at;
    double value;
    const char* message;
  };
  for (const Case& c : std::vector<Case>{
           {&LoopSamples::displacement, "displacement", 12, nan, "must be in [-1, 1], got nan"},
           {&LoopSamples::displacement, "displacement", 0, -inf, "must be in [-1, 1]"},
           {&LoopSamples::displacement, "displacement", 4, 1.7e308, "must be in [-1, 1]"},
           {&LoopSamples::tangential_force, "tangential_force", 3, inf, "[-1000000000, 1000000000]"},
           {&LoopSamples::tangential_force, "tangential_force", 2, -2e9, "[-1000000000, 1000000000]"},
           {&LoopSamples::normal_force, "normal_force", 7, nan, "[0, 1000000000]"},
           {&LoopSamples::normal_force, "normal_force", 5, -1, "[0, 1000000000]"},
           {&LoopSamples::time, "time", 9, inf, "finite"},
       }) {
    LoopSamples s = Valid();
    (s.*c.column)[c.at] = c.value;
    ExpectError(AnalyzeLoops(s, {}), StatusCode::kInvalidArgument,
                std::string(c.name) + "[" + std::to_string(c.at) + "]", c.message);
  }
  // Time must increase strictly: equal and decreasing.
  for (double dt : {0.0, -1e-3}) {
    LoopSamples s = Valid();
    s.time[3] = s.time[2] + dt;
    ExpectError(AnalyzeLoops(s, {}), StatusCode::kInvalidArgument, "time[3]", "increase strictly");
  }
}

LoopSamples Scaled(LoopSamples s, double displacement_scale, double force_scale) {
  for (double& u : s.displacement) u *= displacement_scale;
  for (double& f : s.tangential_force) f *= force_scale;
  for (double& p : s.normal_force) p *= force_scale;
  return s;
}

// Finite samples whose figures would overflow or underflow (issue #48: |u| >= 1e160 m or a span
// of 1e-160 m gave NaN stiffnesses, 1.7e308 m an infinite amplitude, 1e-310 m an infinite
// secant stiffness) are refused naming the column and, for a sample, its index.
TEST(LoopsTest, RefusesSamplesBeyondTheirRanges) {
  const LoopSamples valid = Valid();  // |u| about 1e-6 m, forces about 10-100 N
  ExpectError(AnalyzeLoops(Scaled(valid, 1e166, 1), {}), StatusCode::kInvalidArgument,
              "displacement[1]", "must be in [-1, 1]");
  for (const double tiny : {1e-154, 1e-304}) {
    ExpectError(AnalyzeLoops(Scaled(valid, tiny, 1), {}), StatusCode::kInvalidArgument,
                "displacement", "spans only");
  }
  ExpectError(AnalyzeLoops(Scaled(valid, 1, 1e-300), {}), StatusCode::kInvalidArgument,
              "tangential_force", "spans only");
  ExpectError(AnalyzeLoops(Scaled(valid, 1, 1e10), {}), StatusCode::kInvalidArgument,
              "tangential_force[0]", "[-1000000000, 1000000000]");
  LoopSamples constant = valid;  // a constant force is no error: no span to resolve
  std::fill(constant.tangential_force.begin(), constant.tangential_force.end(), 0.0);
  EXPECT_NE(AnalyzeLoops(constant, {}).status().field(), "tangential_force");
}

// Over the whole admitted range of scales, from the least span to the largest sample in either
// column, every figure of a clean loop is finite.
TEST(LoopsTest, EveryFigureIsFiniteOverTheAdmittedScales) {
  const LoopSamples valid = Valid();
  double u_span = 0, f_span = 0, u_max = 0, f_max = 0;
  for (std::size_t i = 0; i < valid.displacement.size(); ++i) {
    u_max = std::max(u_max, std::abs(valid.displacement[i]));
    f_max = std::max({f_max, std::abs(valid.tangential_force[i]), valid.normal_force[i]});
  }
  const auto [u_lo, u_hi] =
      std::minmax_element(valid.displacement.begin(), valid.displacement.end());
  const auto [f_lo, f_hi] =
      std::minmax_element(valid.tangential_force.begin(), valid.tangential_force.end());
  u_span = *u_hi - *u_lo;
  f_span = *f_hi - *f_lo;
  const std::vector<double> u_scales = {kMinSampleSpan / u_span * 1.0000001, 1e-6, 1,
                                        kMaxSampleDisplacement / u_max};
  const std::vector<double> f_scales = {kMinSampleSpan / f_span * 1.0000001, 1e-3, 1,
                                        kMaxSampleForce / f_max};
  for (const double us : u_scales) {
    for (const double fs : f_scales) {
      LoopOptions options;
      options.rig_compliance = 1e-9 * us / fs;
      const Result<LoopAnalysis> r = AnalyzeLoops(Scaled(valid, us, fs), options);
      ASSERT_TRUE(r.ok()) << us << " " << fs << ": " << r.status().ToString();
      ASSERT_FALSE(r->cycles.empty());
      for (const CycleMetrics& c : r->cycles) {
        for (const double figure :
             {c.force_amplitude, c.force_offset, c.dissipated_energy, c.half_opening,
              c.system_free_ratio, c.normal_force, c.friction_coefficient,
              c.energy_friction_coefficient, c.displacement_amplitude, c.energy_ratio,
              c.sliding_ratio, c.secant_stiffness, c.stiffness_increasing,
              c.stiffness_decreasing}) {
          EXPECT_TRUE(std::isfinite(figure)) << "u x" << us << ", F x" << fs;
        }
        ASSERT_TRUE(c.contact.has_value());
        EXPECT_TRUE(std::isfinite(c.contact->secant_stiffness)) << "u x" << us << ", F x" << fs;
      }
    }
  }
}

TEST(LoopsTest, RefusesColumnsOfDifferentLength) {
  const std::size_t n = Valid().displacement.size();
  const std::string got = "got " + std::to_string(n - 1) + " for " + std::to_string(n);
  for (auto column :
       {&LoopSamples::tangential_force, &LoopSamples::normal_force, &LoopSamples::time}) {
    LoopSamples s = Valid();
    (s.*column).pop_back();
    const std::string name = column == &LoopSamples::tangential_force ? "tangential_force"
                             : column == &LoopSamples::normal_force   ? "normal_force"
                                                                      : "time";
    ExpectError(AnalyzeLoops(s, {}), StatusCode::kInvalidArgument, name, got);
  }
  LoopSamples no_force = Valid();
  no_force.tangential_force.clear();
  ExpectError(AnalyzeLoops(no_force, {}), StatusCode::kInvalidArgument, "tangential_force");
  // Optional columns may be empty.
  LoopSamples bare = Valid();
  bare.normal_force.clear();
  bare.time.clear();
  const Result<LoopAnalysis> r = AnalyzeLoops(bare, {});
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(std::isnan(r->cycles[0].normal_force));
  EXPECT_TRUE(std::isnan(r->cycles[0].friction_coefficient));
  EXPECT_TRUE(std::isnan(r->cycles[0].start_time));
}

TEST(LoopsTest, RefusesSamplesWithoutACompleteCycle) {
  const LoopSamples full = Sample(HertzLoop(Hertz::AtRatio(0.5)), 1, 40);
  // Lead-in (10), one cycle (40), tail (10): cut before the second upper reversal is confirmed.
  for (std::size_t n :
       {std::size_t{0}, std::size_t{1}, std::size_t{30}, std::size_t{50}, std::size_t{51}}) {
    LoopSamples s = full;
    for (auto* column : {&s.displacement, &s.tangential_force, &s.time}) column->resize(n);
    ExpectError(AnalyzeLoops(s, {}), StatusCode::kFailedPrecondition, "displacement",
                "no complete cycle");
  }
  LoopSamples s = full;
  for (auto* column : {&s.displacement, &s.tangential_force, &s.time}) column->resize(56);
  EXPECT_TRUE(AnalyzeLoops(s, {}).ok());
  // A constant displacement has no reversal at all.
  LoopSamples still;
  still.displacement.assign(1000, 1e-6);
  still.tangential_force.assign(1000, 1);
  ExpectError(AnalyzeLoops(still, {}), StatusCode::kFailedPrecondition, "displacement");
}

TEST(LoopsTest, RefusesInvalidOptions) {
  const double nan = std::nan(""), inf = INFINITY;
  struct Case {
    std::function<void(LoopOptions&)> set;
    const char* field;
    const char* range;
  };
  const std::vector<Case> cases = {
      {[&](LoopOptions& o) { o.reversal_threshold = -1e-9; }, "reversal_threshold", ">= 0"},
      {[&](LoopOptions& o) { o.reversal_threshold = nan; }, "reversal_threshold", ">= 0"},
      {[&](LoopOptions& o) { o.rig_compliance = -1e-8; }, "rig_compliance", ">= 0"},
      {[&](LoopOptions& o) { o.rig_compliance = inf; }, "rig_compliance", ">= 0"},
      {[&](LoopOptions& o) { o.normal_force = 0; }, "normal_force", "> 0"},
      {[&](LoopOptions& o) { o.normal_force = nan; }, "normal_force", "> 0"},
      {[&](LoopOptions& o) { o.closure_tolerance = 0; }, "closure_tolerance", "> 0"},
      {[&](LoopOptions& o) { o.asymmetry_tolerance = -0.1; }, "asymmetry_tolerance", "> 0"},
      {[&](LoopOptions& o) { o.hook_tolerance = nan; }, "hook_tolerance", "> 0"},
      {[&](LoopOptions& o) { o.drift_tolerance = inf; }, "drift_tolerance", "> 0"},
      {[&](LoopOptions& o) { o.displacement_resolution = -1e-9; }, "displacement_resolution",
       ">= 0"},
      {[&](LoopOptions& o) { o.displacement_resolution = inf; }, "displacement_resolution", ">= 0"},
  };
  for (const Case& c : cases) {
    LoopOptions o;
    c.set(o);
    ExpectError(AnalyzeLoops(Valid(), o), StatusCode::kInvalidArgument, c.field, c.range);
  }
  LoopOptions zero_rig;
  zero_rig.rig_compliance = 0;
  EXPECT_TRUE(AnalyzeLoops(Valid(), zero_rig).ok());
}

TEST(LoopsTest, StopsWhenCancelled) {
  std::atomic<bool> cancelled{true};
  const Interrupt interrupt(Interrupt::Clock::time_point::max(), &cancelled);
  const Result<LoopAnalysis> r = AnalyzeLoops(Valid(), {}, interrupt);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kCancelled);
}

// ---- (6) Labels -------------------------------------------------------------------------------

TEST(LoopsTest, MeasuresOfLabelsEveryFigure) {
  for (const char* contact :
       {"force_amplitude", "force_offset", "dissipated_energy", "half_opening", "system_free_ratio",
        "normal_force", "friction_coefficient", "energy_friction_coefficient", "friction_drift",
        "contact.displacement_amplitude", "contact.energy_ratio", "contact.sliding_ratio",
        "contact.secant_stiffness", "contact.stiffness_increasing",
        "contact.stiffness_decreasing"}) {
    EXPECT_EQ(MeasuresOf(contact), Measures::kContact) << contact;
  }
  for (const char* rig : {"displacement_amplitude", "energy_ratio", "sliding_ratio",
                          "secant_stiffness", "stiffness_increasing", "stiffness_decreasing",
                          "closure_error", "asymmetry", "hook_ratio", "no_such_figure", ""}) {
    EXPECT_EQ(MeasuresOf(rig), Measures::kContactAndRig) << rig;
  }
  EXPECT_EQ(MeasuresOf(nullptr), Measures::kContactAndRig);
}

}  // namespace
}  // namespace mdr::analysis
