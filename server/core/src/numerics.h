// Numerical building blocks shared by the core's source files: constants, linear interpolation and
// the Gauss-Legendre rules. Internal to mdr_core.
#pragma once

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

}  // namespace mdr::internal
