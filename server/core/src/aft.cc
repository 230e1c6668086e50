#include "mdr/core/aft.h"

#include <fftw3.h>

#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>

#include "mdr/base/validate.h"

namespace mdr {
namespace {

constexpr int kMinSamples = 8, kMaxSamples = 65536;

// FFTW's real transforms of one length, planned once per process (FFTW's planner is not
// thread-safe; executing a plan on arrays of one's own is), with the length's cosine and sine
// table for the Jacobian's basis. The plans live as long as the process: the cache is never
// destroyed, so no thread can find a plan gone while exit runs static destructors.
class Transforms {
 public:
  static const Transforms& Of(int n) {
    static std::mutex mutex;
    static auto& plans = *new std::map<int, std::unique_ptr<Transforms>>;
    std::lock_guard lock(mutex);
    std::unique_ptr<Transforms>& plan = plans[n];
    if (!plan) plan.reset(new Transforms(n));
    return *plan;
  }
  // Samples from the half spectrum X_0 .. X_{n/2}: u_j = sum_k X_k e^(2 pi i j k / n) over the
  // whole (Hermitian) spectrum.
  void ToSamples(std::vector<std::complex<double>> spectrum, double* samples) const {
    fftw_execute_dft_c2r(to_samples_, reinterpret_cast<fftw_complex*>(spectrum.data()), samples);
  }
  // The half spectrum Y_k = sum_j f_j e^(-2 pi i j k / n) of real samples.
  void ToSpectrum(const double* samples, std::complex<double>* spectrum) const {
    fftw_execute_dft_r2c(to_spectrum_, const_cast<double*>(samples),
                         reinterpret_cast<fftw_complex*>(spectrum));
  }
  // cos and sin of 2 pi m / n (n a power of two).
  double Cos(long m) const { return cos_[m & (n_ - 1)]; }
  double Sin(long m) const { return sin_[m & (n_ - 1)]; }

 private:
  explicit Transforms(int n) : n_(n), cos_(n), sin_(n) {
    std::vector<double> real(n);
    std::vector<std::complex<double>> complex(n / 2 + 1);
    auto* c = reinterpret_cast<fftw_complex*>(complex.data());
    constexpr unsigned kFlags = FFTW_ESTIMATE | FFTW_UNALIGNED;
    to_samples_ = fftw_plan_dft_c2r_1d(n, c, real.data(), kFlags);
    to_spectrum_ = fftw_plan_dft_r2c_1d(n, real.data(), c, kFlags);
    for (int m = 0; m < n; ++m) {
      const double angle = 2 * std::numbers::pi * m / n;
      cos_[m] = std::cos(angle), sin_[m] = std::sin(angle);
    }
  }
  int n_;
  fftw_plan to_samples_ = nullptr, to_spectrum_ = nullptr;
  std::vector<double> cos_, sin_;
};

Status CheckHarmonics(std::span<const int> harmonics, int samples) {
  if (samples < kMinSamples || samples > kMaxSamples || (samples & (samples - 1)) != 0) {
    return InvalidArgument("samples", "must be a power of two in [" + std::to_string(kMinSamples) +
                                          ", " + std::to_string(kMaxSamples) + "], got " +
                                          std::to_string(samples));
  }
  if (harmonics.empty()) return InvalidArgument("harmonics", "needs at least one harmonic");
  for (std::size_t k = 0; k < harmonics.size(); ++k) {
    const int h = harmonics[k];
    if (h < 0 || 2 * static_cast<long>(h) >= samples || (k > 0 && h <= harmonics[k - 1])) {
      return InvalidArgument(Indexed("harmonics", k),
                             "must increase, be >= 0 and below samples / 2 = " +
                                 std::to_string(samples / 2) + ", got " + std::to_string(h));
    }
  }
  return OkStatus();
}

// The derivative of u(tau_j) by coefficient b of harmonic h (cosine or sine): the basis.
struct Basis {
  int harmonic;
  bool sine;
};
std::vector<Basis> BasisOf(std::span<const int> harmonics) {
  std::vector<Basis> basis;
  for (const int h : harmonics) {
    basis.push_back({h, false});
    if (h > 0) basis.push_back({h, true});
  }
  return basis;
}

// The coefficients of samples: F_0 = Y_0 / N, F_h^c = 2 Re(Y_h) / N, F_h^s = -2 Im(Y_h) / N.
void Coefficients(const Transforms& t, const double* samples, int n,
                  const std::vector<Basis>& basis, std::vector<std::complex<double>>& spectrum,
                  double* out) {
  t.ToSpectrum(samples, spectrum.data());
  for (std::size_t b = 0; b < basis.size(); ++b) {
    const std::complex<double> y = spectrum[basis[b].harmonic];
    out[b] =
        basis[b].harmonic == 0 ? y.real() / n : (basis[b].sine ? -2 * y.imag() : 2 * y.real()) / n;
  }
}

}  // namespace

std::size_t CoefficientCount(std::span<const int> harmonics) {
  std::size_t count = 0;
  for (const int h : harmonics) count += h == 0 ? 1 : 2;
  return count;
}

Result<std::vector<double>> SamplesOf(std::span<const double> coefficients,
                                      std::span<const int> harmonics, int samples) {
  if (Status s = CheckHarmonics(harmonics, samples); !s.ok()) return s;
  const std::size_t count = CoefficientCount(harmonics);
  if (coefficients.size() != count) {
    return InvalidArgument("coefficients", "needs " + std::to_string(count) +
                                               " values for these harmonics, got " +
                                               std::to_string(coefficients.size()));
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (Status s = RequireFinite(Indexed("coefficients", i), coefficients[i]); !s.ok()) return s;
  }
  // X_0 = U_0, X_h = (U_h^c - i U_h^s) / 2: then u_j = U_0 + sum U^c cos + U^s sin.
  std::vector<std::complex<double>> spectrum(samples / 2 + 1);
  const std::vector<Basis> basis = BasisOf(harmonics);
  for (std::size_t b = 0; b < basis.size(); ++b) {
    const int h = basis[b].harmonic;
    if (h == 0) {
      spectrum[0] += coefficients[b];
    } else if (basis[b].sine) {
      spectrum[h] += std::complex<double>(0, -coefficients[b] / 2);
    } else {
      spectrum[h] += coefficients[b] / 2;
    }
  }
  std::vector<double> u(samples);
  Transforms::Of(samples).ToSamples(std::move(spectrum), u.data());
  return u;
}

Result<AftResponse> ContactAft(const std::vector<Contact>& pressed,
                               std::span<const double> coefficients, std::span<const int> harmonics,
                               const AftOptions& options, const Interrupt& interrupt) {
  Result<std::vector<double>> u = SamplesOf(coefficients, harmonics, options.samples);
  if (!u.ok()) return u.status();
  PeriodicOptions periodic = options.periodic;
  periodic.jacobian = options.jacobian;
  Result<PeriodicResponse> period = SteadyPeriod(pressed, *u, periodic, interrupt);
  if (!period.ok()) return period.status();
  const int n = options.samples;
  const Transforms& t = Transforms::Of(n);
  const std::vector<Basis> basis = BasisOf(harmonics);
  const std::size_t m = basis.size();
  AftResponse out;
  out.dissipated_energy = period->dissipated_energy;
  out.steady = period->steady;
  out.periods = period->periods;
  std::vector<std::complex<double>> spectrum(n / 2 + 1);
  out.force.resize(m);
  Coefficients(t, period->force.data(), n, basis, spectrum, out.force.data());
  if (options.jacobian) {
    // dF/dU = (the coefficients of) J B, B(j, b) = du_j/dU_b: the sparse rows times the basis,
    // column by column, then each column's coefficients.
    const PeriodicJacobian& j = period->jacobian;
    std::vector<double> column(n);
    std::vector<double> coefficients_of(m);
    out.jacobian.assign(m * m, 0);
    for (std::size_t b = 0; b < m; ++b) {
      const long h = basis[b].harmonic;
      for (int i = 0; i < n; ++i) {
        double sum = 0;
        for (std::uint32_t k = j.row_begin[i]; k < j.row_begin[i + 1]; ++k) {
          const long phase = h * j.column[k];
          sum += j.value[k] * (h == 0 ? 1 : basis[b].sine ? t.Sin(phase) : t.Cos(phase));
        }
        column[i] = sum;
      }
      Coefficients(t, column.data(), n, basis, spectrum, coefficients_of.data());
      for (std::size_t a = 0; a < m; ++a) out.jacobian[a * m + b] = coefficients_of[a];
    }
  }
  out.displacement_samples = std::move(u).value();
  out.force_samples = std::move(period->force);
  return out;
}

Result<AftResponse> ContactAft(const ContactConfig& config, double normal_force,
                               std::span<const double> coefficients, std::span<const int> harmonics,
                               const AftOptions& options, const Interrupt& interrupt) {
  Result<Contact> contact = PressForPeriod(config, normal_force);
  if (!contact.ok()) return contact.status();
  Result<AftResponse> response = ContactAft(std::vector<Contact>{std::move(contact).value()},
                                            coefficients, harmonics, options, interrupt);
  if (!response.ok()) return AsSingleContact(response.status());
  return response;
}

}  // namespace mdr
