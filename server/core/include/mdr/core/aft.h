// The alternating frequency-time (AFT) evaluation of exact contacts for harmonic balance (issue
// #51; docs/dynamics.md): the harmonic coefficients of a tangential displacement to those of the
// steady contact force, with the exact Jacobian of the one to the other.
//
// Convention (tmdsimpy's and NLvib's sine-cosine form): with tau = omega t and harmonics h,
//   u(tau) = U_0 + sum_{h > 0} U_h^c cos(h tau) + U_h^s sin(h tau),
// the coefficients ordered [U_0, U_h1^c, U_h1^s, U_h2^c, U_h2^s, ...] for the harmonics given
// (0 first when present; NLvib's harmonics are 0 .. H, tmdsimpy takes any increasing list). The
// force is the contact's F_x, an internal force that resists the motion (positive for a positive
// displacement), in the same form. The samples are tau_j = 2 pi j / N, j = 0 .. N - 1; the
// transforms are FFTW's. The element is rate-independent: dF/d omega = 0.
#pragma once

#include <span>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/periodic.h"

namespace mdr {

struct AftOptions {
  // Time samples N per period: a power of two in [8, 65536], above twice the highest harmonic.
  int samples = 128;
  bool jacobian = true;
  PeriodicOptions periodic;  // how the steady period is reached (its jacobian flag is ours)
};

struct AftResponse {
  std::vector<double> force;  // the force's coefficients, one per displacement coefficient
  // dF_a / dU_b, row-major, (coefficients x coefficients); with AftOptions::jacobian.
  std::vector<double> jacobian;
  double dissipated_energy = 0;  // J per period
  bool steady = false;           // PeriodicResponse::steady
  int periods = 0;
  std::vector<double> displacement_samples, force_samples;  // u(tau_j) (m), F(tau_j) (N)
};

// The number of coefficients of a harmonic list (tmdsimpy's Nhc): 1 for harmonic 0, 2 for each
// other one.
std::size_t CoefficientCount(std::span<const int> harmonics);

// The displacement samples u(tau_j) of the coefficients. Errors name "harmonics", "harmonics[k]"
// (increasing, >= 0, 0 only first, below samples / 2), "coefficients" (one per coefficient),
// "coefficients[i]" (finite) and "samples".
Result<std::vector<double>> SamplesOf(std::span<const double> coefficients,
                                      std::span<const int> harmonics, int samples);

// A contact of `config` pressed to `normal_force` (N, > 0, constant) at u = 0, as SteadyPeriod
// takes it.
Result<AftResponse> ContactAft(const ContactConfig& config, double normal_force,
                               std::span<const double> coefficients, std::span<const int> harmonics,
                               const AftOptions& options = {}, const Interrupt& interrupt = {});

// Contacts already pressed (an interface's asperities under a shared approach), driven together.
Result<AftResponse> ContactAft(const std::vector<Contact>& pressed,
                               std::span<const double> coefficients, std::span<const int> harmonics,
                               const AftOptions& options = {}, const Interrupt& interrupt = {});

}  // namespace mdr
