// Shared helpers for core tests: closed forms, random histories and scenes, snapshot comparison
// (contacts and interfaces), and the reference scenes of docs/reference-values.md
// (tests/fixtures/reference_scenes.h).
#pragma once

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "fixtures/slip_state_check.h"
#include "mdr/core/contact.h"
#include "mdr/core/interface.h"

namespace mdr::testing {

// |actual - expected| <= tolerance * |expected|.
inline ::testing::AssertionResult RelNear(double actual, double expected, double tolerance) {
  const double error = std::abs(actual - expected);
  if (error <= tolerance * std::abs(expected)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "actual " << actual << " vs expected " << expected << ": relative error "
         << error / std::abs(expected) << " > " << tolerance;
}

// mu [F_N(d) - F_N(d - h)] for a power law (F_N proportional to d^((n+1)/n)), h = ux/(mu kappa):
// the Cattaneo-Mindlin force, written without the cancellation of the plain difference.
inline double CattaneoMindlinPowerLaw(const Contact& c, double n, double d, double ux) {
  const double h = ux / c.mu_kappa(), p = (n + 1) / n;
  return -c.config().friction * c.NormalForceAtDepth(d) * std::expm1(p * std::log1p(-h / d));
}

// Energy per Mindlin-Deresiewicz cycle / (mu^2 F_N kappa d). The two terms of the closed form
// cancel to O(s^3) from O(s), so it is evaluated in long double with expm1/log1p: good to
// ~1e-19/s^2 relative, i.e. 1e-13 for s >= 1e-3.
inline double EnergyPerCycleRatio(double n, double s) {
  const long double N = n, log_rest = std::log1pl(-static_cast<long double>(s));
  const long double a = -8 * (N + 1) / (2 * N + 1) * std::expm1l((2 * N + 1) / (N + 1) * log_rest);
  const long double b = 4 * s * (2 + std::expm1l(N / (N + 1) * log_rest));
  return static_cast<double>(a - b);
}

// Random piecewise-linear (delta, ux) histories: lift-off, re-contact, reversals and gross slip,
// alternating with ring-downs (reversals of decaying amplitude at a slowly varying depth) that
// nest many memory vertices. `half_period` steps of each kind in turn.
struct RandomHistory {
  std::mt19937_64 rng;
  double d0, slip;
  int half_period = 20;
  int step = 0;
  double ring_depth = 0;
  std::pair<double, double> Next() {
    std::uniform_real_distribution<double> u(0, 1);
    const int phase = step++ % (2 * half_period);
    if (phase >= half_period) {
      const int k = phase - half_period;
      if (k == 0) ring_depth = d0 * (0.6 + 0.6 * u(rng));
      return {ring_depth * (1 + 0.05 * std::sin(k)), 1.2 * slip * std::pow(-0.8, k)};
    }
    const double depth = d0 * (u(rng) < 0.05 ? -0.1 * u(rng) : 0.3 + 1.2 * u(rng));
    return {depth, slip * (3 * u(rng) - 1.5)};
  }
};

// Random scenes over the engine's whole input range: every analytic profile kind, friction from
// 1e-9 to 1e6 (and 0), step amplitudes from 1e-12 to 2 of mu kappa delta.
struct RandomScene {
  std::mt19937_64 rng;
  double Uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  double LogUniform(double lo, double hi) { return lo * std::pow(hi / lo, Uniform(0, 1)); }
  double Sign() { return rng() % 2 ? 1.0 : -1.0; }

  ProfilePtr Profile() {
    switch (rng() % 5) {
      case 0:
        return *MakeSphere(LogUniform(1e-4, 1));
      case 1:
        return *MakeCone(Uniform(0.01, 1.4));
      case 2:
        return *MakePowerLaw(LogUniform(1e-2, 1e2), Uniform(0.5, 8));
      case 3:
        return *MakePowerLaw(LogUniform(1e-2, 1e2), Uniform(0.3, 0.6));
      default:
        return *MakeFlatPunch(LogUniform(1e-5, 1e-1));
    }
  }
  // mu: 0 one time in ten, else log-uniform in [1e-9, 1e6].
  double Friction() { return rng() % 10 == 0 ? 0.0 : LogUniform(1e-9, 1e6); }
  // A tangential increment relative to mu kappa delta: either sign, log-uniform in [1e-12, 2].
  double RelativeAmplitude() { return Sign() * LogUniform(1e-12, 2); }
};

// Two snapshots equal field by field, bit for bit (SameBits and SnapshotDifference:
// fixtures/slip_state_check.h).
inline ::testing::AssertionResult SameSnapshot(const ContactSnapshot& a, const ContactSnapshot& b) {
  const char* differs = SnapshotDifference(a, b);
  if (differs == nullptr) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "snapshots differ in " << differs;
}

// Two interface states equal bit for bit: approach, displacement and every contact's snapshot.
inline ::testing::AssertionResult SameInterfaceState(const InterfaceSnapshot& a,
                                                     const InterfaceSnapshot& b) {
  if (!SameBits(a.approach, b.approach)) return ::testing::AssertionFailure() << "approach";
  if (!SameBits(a.tangential_displacement, b.tangential_displacement)) {
    return ::testing::AssertionFailure() << "tangential_displacement";
  }
  if (a.contacts.size() != b.contacts.size()) return ::testing::AssertionFailure() << "size";
  for (std::size_t i = 0; i < a.contacts.size(); ++i) {
    ::testing::AssertionResult same = SameSnapshot(a.contacts[i], b.contacts[i]);
    if (!same) return same << " (contact " << i << ")";
  }
  return ::testing::AssertionSuccess();
}

inline Contact MakeContact(ProfilePtr profile, EffectiveMaterial material, double mu,
                           bool energy = true) {
  ContactConfig config;
  config.profile = std::move(profile);
  config.material = material;
  config.friction = mu;
  config.track_energy = energy;
  Result<Contact> contact = Contact::Create(config);
  EXPECT_TRUE(contact.ok()) << contact.status().ToString();
  return std::move(contact).value();
}

// H1: steel sphere R = 10 mm on steel (E = 210 GPa, nu = 0.3 both), mu = 0.3.
inline Contact SteelSphere(bool energy = true) {
  ContactConfig h1 = reference::H1Config(energy);
  return MakeContact(std::move(h1.profile), h1.material, h1.friction, energy);
}

inline Step NormalForceStep(double fn) {
  Step step;
  step.normal = NormalControl::kForce;
  step.normal_value = fn;
  return step;
}

inline Step TangentialForceStep(double fx) {
  Step step;
  step.tangential = TangentialControl::kForce;
  step.tangential_value = fx;
  return step;
}

}  // namespace mdr::testing
