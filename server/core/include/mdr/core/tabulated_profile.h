// An indenter profile f(r) given as samples (measured or designed shapes).
//
// f is interpolated by a C1 piecewise cubic (GSL's monotone Steffen spline, or a natural cubic
// spline); its MDR form g(x) = x integral_0^{pi/2} f'(x sin t) dt (docs/physics.md, "MDR"; the
// substitution r = x sin t removes the 1/sqrt singularity) is evaluated by Gauss-Legendre
// quadrature split at the sample radii, where f' is one quadratic, over the sample intervals
// near x, and by a convergent series of exact moments over groups of intervals far below x
// (a tree over the intervals: O(log N) per evaluation), so it is exact to round-off for the
// interpolated f. g and g' are stored on an internal grid and interpolated between grid
// nodes by cubic Hermite polynomials; the grid starts at the sample radii and is bisected where
// that interpolation misses g at an interval midpoint by more than TabulatedOptions::tolerance.
// What no grid can remove is the difference between the interpolated f and the true shape
// between samples (e.g. Steffen's end condition f'(0) = first secant slope, which turns a
// sampled sphere into one with a slight conical tip: g is then relatively inaccurate for
// x below a few sample spacings).
//
// Beyond the last sample radius the contact is extrapolated: g continues along its tangent
// there (max_depth() tells where the data end).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/profile.h"

namespace mdr {

struct TabulatedOptions {
  enum class Interpolation {
    // Monotone between samples, C1, no overshoot of the data. Its end condition sets f'(0) from the
    // first secant, a slight conical tip on a smooth profile (sampled sphere, relative error of g:
    // 4e-4, 1e-7, 2e-10 for 50, 200, 1000 samples).
    kSteffen,
    kCubicSpline,  // natural cubic spline, C2; may overshoot noisy data
  };
  Interpolation interpolation = Interpolation::kSteffen;
  // Target relative accuracy of the internal g grid (interpolation between grid nodes against
  // the quadrature of the interpolated f, checked at every interval midpoint), in (0, 1e-2].
  double tolerance = 1e-10;
  // Largest internal grid; ResourceExhausted if the tolerance needs more nodes.
  std::size_t max_grid_nodes = 1 << 18;
  // Checked before every evaluation of g while the grid is built: DeadlineExceeded / Cancelled
  // abandon the construction.
  Interrupt interrupt{};
};

class TabulatedProfile final : public Profile {
 public:
  // Internal grid: nodes x_i with g(x_i), g'(x_i) and the running moments integral_0^{x_i} g^j.
  struct Grid {
    std::vector<double> x, g, slope, moment1, moment2, force;  // force: F_N/E* at depth g(x_i)
  };
  TabulatedProfile(Grid grid, double tolerance_estimate, std::string description,
                   std::vector<double> sample_radii = {});

  double G(double x) const override;
  double Slope(double x) const override;
  double RadiusAtDepth(double z) const override;
  double Rise(double x, double x_ref) const override;
  double Moment(int j, double x) const override;
  double PressurePerModulus(double r, double depth) const override;
  double DepthAtNormalForcePerModulus(double force_per_modulus) const override;
  std::string Describe() const override { return description_; }

  // Achieved max relative error of g between grid nodes, measured at every interval midpoint
  // against the direct quadrature (relative to g there; relative to max_depth() in the interval
  // next to a flat centre, where g starts like (x - b)^(3/2)). <= TabulatedOptions::tolerance.
  double ToleranceEstimate() const override { return tolerance_estimate_; }
  std::size_t MemoryBytes() const override;
  // g at the last sample radius: deeper contacts are extrapolated.
  double max_depth() const { return grid_.g.back(); }
  double max_radius() const { return grid_.x.back(); }
  std::size_t grid_nodes() const { return grid_.x.size(); }
  // The radii of the samples: where the interpolant's pieces meet, g' is continuous but not
  // smooth (its slope jumps like a square root there), so quadratures over g' split there.
  const std::vector<double>& sample_radii() const { return sample_radii_; }

 private:
  // Index i of the grid interval [x_i, x_{i+1}] that holds x (x inside the grid).
  std::size_t IntervalOf(double x) const;
  // integral_{x_i}^{x} g^j dt inside interval i (4-point Gauss-Legendre: exact for the cubic).
  double PartialMoment(int j, std::size_t i, double x) const;

  Grid grid_;
  double flat_radius_;  // radius of the centre where g = 0 (a flat-ended indenter), else 0
  double tolerance_estimate_;
  std::string description_;
  std::vector<double> sample_radii_;
};

// Most samples a profile may have. The construction costs O(N log N) for samples whose spacing
// varies smoothly (a sampled sphere on one core of the development machine: 1000 samples 0.014 s,
// 10 000 samples 0.09 s, 100 000 samples 1.0 s; it was O(N^2): 17.6 s for 10 000 samples).
inline constexpr std::size_t kMaxTabulatedSamples = 100000;

// Samples r_i (radii[0] = 0, strictly increasing, finite) and f(r_i) (heights[0] = 0, finite),
// at least 4 and at most kMaxTabulatedSamples of each. Errors name the field and index; a profile
// whose g(x) decreases somewhere is rejected (the contact would not be a disc).
Result<ProfilePtr> MakeTabulatedProfile(std::vector<double> radii, std::vector<double> heights,
                                        TabulatedOptions options = {});

}  // namespace mdr
