// Numerical building blocks shared by the core's source files: constants, linear interpolation,
// the Gauss-Legendre rules and GSL's adaptive quadrature with the Abel layer split. Internal to
// mdr_core.
#pragma once

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include <cstddef>
#include <limits>
#include <numbers>
#include <vector>

namespace mdr::internal {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kEps = std::numeric_limits<double>::epsilon();

// The value at z of the straight line through (za, ua) and (zb, ub), from the end a.
inline double Interpolate(double za, double ua, double zb, double ub, double z) {
  return ua + (ub - ua) * ((z - za) / (zb - za));
}

// The n-point Gauss-Legendre rule on [-1, 1], nodes and weights taken from GSL once.
struct GaussLegendreRule {
  explicit GaussLegendreRule(std::size_t n) : size(n), nodes(n), weights(n) {
    gsl_integration_glfixed_table* table = gsl_integration_glfixed_table_alloc(n);
    for (std::size_t i = 0; i < n; ++i) {
      gsl_integration_glfixed_point(-1, 1, i, &nodes[i], &weights[i], table);
    }
    gsl_integration_glfixed_table_free(table);
  }
  std::size_t size;
  std::vector<double> nodes, weights;
};

// GSL's default error handler aborts the process. The core checks GSL's return codes and error
// estimates itself, so the handler is switched off once per process: it is a global, and
// switching it around each call would race between sessions served on different threads.
inline void ReturnGslErrorCodes() {
  static const bool kSwitchedOff = (gsl_set_error_handler_off(), true);
  (void)kSwitchedOff;
}

// GSL's adaptive Gauss-Kronrod over one workspace: QAGS (endpoint extrapolation, for integrands
// with integrable end singularities) or QAG with a fixed Kronrod rule. A tolerance that round-off
// prevents is reported through the error estimate and status(), never by aborting.
class Quadrature {
 public:
  explicit Quadrature(std::size_t limit)
      : limit_(limit), workspace_(gsl_integration_workspace_alloc(limit)) {
    ReturnGslErrorCodes();
  }
  ~Quadrature() { gsl_integration_workspace_free(workspace_); }
  Quadrature(const Quadrature&) = delete;
  Quadrature& operator=(const Quadrature&) = delete;

  // Adds integral_lo^hi f to *value and its error estimate to *error, by QAGS.
  template <typename F>
  void AddWithExtrapolation(F& f, double lo, double hi, double abs_tolerance, double rel_tolerance,
                            double* value, double* error) {
    gsl_function function = Function(f);
    double result = 0, abserr = 0;
    Record(gsl_integration_qags(&function, lo, hi, abs_tolerance, rel_tolerance, limit_, workspace_,
                                &result, &abserr));
    *value += result;
    *error += abserr;
  }
  // The same by QAG with the Kronrod rule `key` (GSL_INTEG_GAUSS15 ... GAUSS61).
  template <typename F>
  void AddWithRule(F& f, double lo, double hi, double abs_tolerance, double rel_tolerance, int key,
                   double* value, double* error) {
    gsl_function function = Function(f);
    double result = 0, abserr = 0;
    Record(gsl_integration_qag(&function, lo, hi, abs_tolerance, rel_tolerance, limit_, key,
                               workspace_, &result, &abserr));
    *value += result;
    *error += abserr;
  }
  // The first GSL error code of the integrations so far (GSL_SUCCESS if none).
  int status() const { return status_; }

 private:
  template <typename F>
  static gsl_function Function(F& f) {
    return gsl_function{[](double x, void* p) { return (*static_cast<F*>(p))(x); }, &f};
  }
  void Record(int status) {
    if (status_ == GSL_SUCCESS) status_ = status;
  }

  std::size_t limit_;
  gsl_integration_workspace* workspace_;
  int status_ = GSL_SUCCESS;
};

// The Abel integrals of the pressure and the tractions, integral_r^a h(x)/sqrt(x^2 - r^2) dx,
// become smooth in s after x = sqrt(r^2 + s^2), but vary on the scale r near s = 0. So
// [lo, hi] in s is integrated as [lo, r] and [r, hi] when r lies inside: integrate(lo, hi) is
// called once or twice.
template <typename Integrate>
void ForEachAbelInterval(double r, double lo, double hi, Integrate integrate) {
  if (lo < r && r < hi) {
    integrate(lo, r);
    integrate(r, hi);
  } else if (lo < hi) {
    integrate(lo, hi);
  }
}

}  // namespace mdr::internal
