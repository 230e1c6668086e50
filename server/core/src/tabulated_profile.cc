#include "mdr/core/tabulated_profile.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>
#include <gsl/gsl_interp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <utility>

#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::kEps;
using internal::kInf;
using internal::kPi;
constexpr std::size_t kMinSamples = 4;

// The cubic with values y0, y1 and slopes d0, d1 at the ends of [x0, x0 + h], in monomial form
// in t = (x - x0)/h. Both f (between samples) and g (between grid nodes) are such cubics.
struct Cubic {
  double x0, h, a0, a1, a2, a3;
  Cubic(double x_begin, double x_end, double y0, double y1, double d0, double d1)
      : x0(x_begin), h(x_end - x_begin), a0(y0), a1(h * d0) {
    const double rise = y1 - y0;
    a2 = 3 * rise - h * (2 * d0 + d1);
    a3 = -2 * rise + h * (d0 + d1);
  }
  double T(double x) const { return (x - x0) / h; }
  double Value(double x) const {
    const double t = T(x);
    return a0 + t * (a1 + t * (a2 + t * a3));
  }
  double Slope(double x) const {
    const double t = T(x);
    return (a1 + t * (2 * a2 + 3 * t * a3)) / h;
  }
  double Curvature(double x) const { return (2 * a2 + 6 * T(x) * a3) / (h * h); }
  // Value(xb) - Value(xa), factored so that close points do not cancel.
  double Difference(double xa, double xb) const {
    const double ta = T(xa), tb = T(xb);
    return (tb - ta) * (a1 + a2 * (tb + ta) + a3 * (tb * tb + tb * ta + ta * ta));
  }
};

// The Hermite cubic of grid interval i.
Cubic GridCubic(const TabulatedProfile::Grid& grid, std::size_t i) {
  return Cubic(grid.x[i], grid.x[i + 1], grid.g[i], grid.g[i + 1], grid.slope[i],
               grid.slope[i + 1]);
}

// Solves v(x) = 0 for v increasing on [lo, hi] with v(lo) <= 0 <= v(hi) by Newton steps kept
// inside the shrinking bracket (bisection when a step leaves it). value_and_slope(x) -> {v, v'}.
template <typename F>
double SolveIncreasing(F value_and_slope, double lo, double hi, double guess) {
  double x = std::clamp(guess, lo, hi);
  for (int iteration = 0; iteration < 200; ++iteration) {
    const auto [v, slope] = value_and_slope(x);
    if (v == 0) return x;
    (v > 0 ? hi : lo) = x;
    double next = slope > 0 ? x - v / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 2 * kEps * std::abs(x) || hi - lo <= 2 * kEps * hi) return next;
    x = next;
  }
  return x;
}

// 4-point Gauss-Legendre on [-1, 1]: exact for degree 7, so for g^2 of a cubic g.
constexpr double kGaussNodes4[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                    0.8611363115940526};
constexpr double kGaussWeights4[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                      0.3478548451374538};

const internal::GaussLegendreRule kGauss12(12);

// Sums of integral_{r_a}^{r_b} w(r) / sqrt(x^2 - r^2) dr over sample pieces far below x, for
// w = f' and w = r f'' (the two parts of g and g', see SampledShape). A binary tree over the pieces
// keeps, per node of centre c and half-width h, the moments integral w(r) s^n dr with
// s = (r - c)/h; for x - c >= 3 h the kernel's Taylor series in s converges at least like 3^-n,
// so such a node costs kTerms products instead of a quadrature per piece. An evaluation of g then
// visits O(log N) nodes for samples whose spacing varies smoothly (O(N) before: the N^2 cost of
// building a profile from N samples).
class FarField {
 public:
  static constexpr int kTerms = 36;  // 3^-36 < 1e-17
  using Moments = std::array<double, kTerms>;

  FarField(const std::vector<double>& radii, const std::vector<Cubic>& pieces)
      : radii_(radii), pieces_(pieces) {
    if (!pieces.empty()) Build(0, pieces.size());
  }

  // Adds the far field of pieces [0, end) at x to *first (w = f') and *second (w = r f''); calls
  // near(k) for each piece k < end that is too close to x for the series.
  template <typename Near>
  void Add(double x, std::size_t end, double* first, double* second, Near near) const {
    if (end > 0) Visit(0, x, end, first, second, near);
  }

 private:
  static constexpr std::size_t kLeafPieces = 8;
  struct Node {
    std::size_t begin, end;  // pieces
    double centre, half;
    Moments slope{}, curvature{};     // moments of f' and of r f''
    std::size_t left = 0, right = 0;  // children; 0: a leaf
  };

  std::size_t Build(std::size_t begin, std::size_t end) {
    const std::size_t index = nodes_.size();
    nodes_.push_back({.begin = begin,
                      .end = end,
                      .centre = 0.5 * (radii_[begin] + radii_[end]),
                      .half = 0.5 * (radii_[end] - radii_[begin])});
    if (end - begin <= kLeafPieces) {
      for (std::size_t k = begin; k < end; ++k) AddPieceMoments(k, nodes_[index]);
      return index;
    }
    const std::size_t middle = begin + (end - begin) / 2;
    const std::size_t left = Build(begin, middle);
    const std::size_t right = Build(middle, end);
    Node& node = nodes_[index];
    node.left = left;
    node.right = right;
    for (const std::size_t child : {left, right}) AddShifted(nodes_[child], node);
    return index;
  }

  // Exact moments of one piece: f' and r f'' are quadratics in s there.
  void AddPieceMoments(std::size_t k, Node& node) const {
    const Cubic& f = pieces_[k];
    const double c = node.centre, h = node.half;
    const double t0 = (c - f.x0) / f.h, tau = h / f.h;  // t = t0 + tau s
    const double slope[3] = {(f.a1 + 2 * f.a2 * t0 + 3 * f.a3 * t0 * t0) / f.h,
                             (2 * f.a2 + 6 * f.a3 * t0) * tau / f.h, 3 * f.a3 * tau * tau / f.h};
    const double w0 = (2 * f.a2 + 6 * f.a3 * t0) / (f.h * f.h), w1 = 6 * f.a3 * tau / (f.h * f.h);
    const double curvature[3] = {c * w0, c * w1 + h * w0, h * w1};  // (c + h s)(w0 + w1 s)
    const double sa = (radii_[k] - c) / h, sb = (radii_[k + 1] - c) / h;
    double pa = sa, pb = sb;  // s^(m+1) at both ends, m = n + i
    double powers_a[kTerms + 3], powers_b[kTerms + 3];
    for (int m = 0; m < kTerms + 2; ++m) {
      powers_a[m] = pa;
      powers_b[m] = pb;
      pa *= sa;
      pb *= sb;
    }
    for (int n = 0; n < kTerms; ++n) {
      for (int i = 0; i < 3; ++i) {
        const double integral = h * (powers_b[n + i] - powers_a[n + i]) / (n + i + 1);
        node.slope[n] += slope[i] * integral;
        node.curvature[n] += curvature[i] * integral;
      }
    }
  }

  // Adds a child's moments re-expanded about its parent: s_parent = a s_child + b.
  static void AddShifted(const Node& child, Node& parent) {
    const double a = child.half / parent.half, b = (child.centre - parent.centre) / parent.half;
    // binomial[k] = C(n, k) a^k b^(n-k), row n built from row n - 1.
    double binomial[kTerms] = {1};
    for (int n = 0; n < kTerms; ++n) {
      if (n > 0) {
        for (int k = n; k > 0; --k) binomial[k] = binomial[k] * b + binomial[k - 1] * a;
        binomial[0] *= b;
      }
      for (int k = 0; k <= n; ++k) {
        parent.slope[n] += binomial[k] * child.slope[k];
        parent.curvature[n] += binomial[k] * child.curvature[k];
      }
    }
  }

  template <typename Near>
  void Visit(std::size_t index, double x, std::size_t end, double* first, double* second,
             Near near) const {
    const Node& node = nodes_[index];
    if (node.begin >= end) return;
    if (node.end <= end && x - node.centre >= 3 * node.half) {
      AddSeries(node, x, first, second);
    } else if (node.left == 0) {
      for (std::size_t k = node.begin; k < std::min(node.end, end); ++k) near(k);
    } else {
      Visit(node.left, x, end, first, second, near);
      Visit(node.right, x, end, first, second, near);
    }
  }

  // 1/sqrt(q(s)), q = x^2 - (c + h s)^2 = q0 + q1 s + q2 s^2: its Taylor coefficients y_n follow
  // from q y' = -q' y / 2.
  // Terms follow the convergence ratio h/(x - c) <= 1/3: fewer for nodes farther away.
  static void AddSeries(const Node& node, double x, double* first, double* second) {
    const double c = node.centre, h = node.half;
    const double q0 = (x - c) * (x + c), q1 = -2 * c * h, q2 = -h * h;
    const double ratio = h / (x - c);
    const int terms =
        ratio > 0 ? std::min(kTerms, static_cast<int>(std::ceil(-39.2 / std::log(ratio))) + 1)
                  : 1;  // 39.2 = -ln(1e-17)
    const double inverse_q0 = 1 / q0;
    double previous = 0, y = std::sqrt(inverse_q0);
    for (int n = 0; n < terms; ++n) {
      *first += y * node.slope[n];
      *second += y * node.curvature[n];
      const double next = ((-0.5 - n) * q1 * y - n * q2 * previous) * inverse_q0 * kInverse[n + 1];
      previous = y;
      y = next;
    }
  }
  static constexpr std::array<double, kTerms + 1> kInverse = [] {
    std::array<double, kTerms + 1> inverse{};
    for (int n = 1; n <= kTerms; ++n) inverse[n] = 1.0 / n;
    return inverse;
  }();

  const std::vector<double>& radii_;
  const std::vector<Cubic>& pieces_;
  std::vector<Node> nodes_;
};

// The interpolated f as one cubic per sample interval.
class SampledShape {
 public:
  SampledShape(const std::vector<double>& radii, const std::vector<double>& heights,
               const std::vector<double>& slopes)
      : radii_(radii), pieces_(Pieces(radii, heights, slopes)), far_field_(radii_, pieces_) {}
  const std::vector<double>& radii() const { return radii_; }

  // g(x) = x integral_0^{pi/2} f'(x sin t) dt and
  // g'(x) = integral_0^{pi/2} [f'(x sin t) + x sin t f''(x sin t)] dt: the pieces far below x by
  // the FarField series, the others split at the sample radii so each part integrates one smooth
  // function (12-point Gauss-Legendre per part).
  std::pair<double, double> EquivalentAt(double x) const {
    if (!(x > 0)) return {0.0, kPi / 2 * pieces_.front().Slope(0)};
    const std::size_t last = std::min<std::size_t>(
        std::lower_bound(radii_.begin(), radii_.end(), x) - radii_.begin() - 1, pieces_.size() - 1);
    double first_moment = 0, second_moment = 0;
    const auto near = [&](std::size_t k) {
      const double t_begin = std::asin(radii_[k] / x);
      const double t_end = k == last ? kPi / 2 : std::asin(radii_[k + 1] / x);
      const double half = 0.5 * (t_end - t_begin), centre = 0.5 * (t_end + t_begin);
      for (std::size_t i = 0; i < kGauss12.size; ++i) {
        const double r = x * std::sin(centre + half * kGauss12.nodes[i]);
        const double w = half * kGauss12.weights[i];
        first_moment += w * pieces_[k].Slope(r);
        second_moment += w * r * pieces_[k].Curvature(r);
      }
    };
    far_field_.Add(x, last, &first_moment, &second_moment, near);
    near(last);
    return {x * first_moment, first_moment + second_moment};
  }

 private:
  static std::vector<Cubic> Pieces(const std::vector<double>& radii,
                                   const std::vector<double>& heights,
                                   const std::vector<double>& slopes) {
    std::vector<Cubic> pieces;
    for (std::size_t k = 0; k + 1 < radii.size(); ++k) {
      pieces.emplace_back(radii[k], radii[k + 1], heights[k], heights[k + 1], slopes[k],
                          slopes[k + 1]);
    }
    return pieces;
  }

  std::vector<double> radii_;
  std::vector<Cubic> pieces_;
  FarField far_field_;  // after radii_ and pieces_, which it reads
};

Status ValidateSamples(const std::vector<double>& radii, const std::vector<double>& heights) {
  if (radii.size() < kMinSamples) {
    return InvalidArgument("radii", "needs at least " + std::to_string(kMinSamples) +
                                        " samples, got " + std::to_string(radii.size()));
  }
  if (radii.size() > kMaxTabulatedSamples) {
    return InvalidArgument("radii", "allows at most " + std::to_string(kMaxTabulatedSamples) +
                                        " samples, got " + std::to_string(radii.size()));
  }
  if (heights.size() != radii.size()) {
    return InvalidArgument("heights",
                           "needs one height per radius: " + std::to_string(heights.size()) +
                               " heights for " + std::to_string(radii.size()) + " radii");
  }
  for (std::size_t i = 0; i < radii.size(); ++i) {
    std::string index = "[";  // (not "[" + ...: GCC 12 warns falsely on that form)
    index += std::to_string(i);
    index += ']';
    if (Status s = RequireFinite("radii" + index, radii[i]); !s.ok()) return s;
    if (Status s = RequireFinite("heights" + index, heights[i]); !s.ok()) return s;
    if (i > 0 && !(radii[i] > radii[i - 1])) {
      return InvalidArgument("radii" + index, "must be > radii[" + std::to_string(i - 1) +
                                                  "] = " + FormatNumber(radii[i - 1]) +
                                                  " (strictly increasing), got " +
                                                  FormatNumber(radii[i]));
    }
  }
  if (radii[0] != 0) {
    return InvalidArgument(
        "radii[0]", "must be 0 (the profile starts on the axis), got " + FormatNumber(radii[0]));
  }
  if (heights[0] != 0) {
    return InvalidArgument("heights[0]", "f(0) must be 0, got " + FormatNumber(heights[0]));
  }
  return OkStatus();
}

// f'(r_k) of GSL's interpolant at the samples: with the values they fix its cubic pieces.
Result<std::vector<double>> SampleSlopes(const std::vector<double>& radii,
                                         const std::vector<double>& heights,
                                         TabulatedOptions::Interpolation interpolation) {
  const gsl_interp_type* type = interpolation == TabulatedOptions::Interpolation::kSteffen
                                    ? gsl_interp_steffen
                                    : gsl_interp_cspline;
  internal::ReturnGslErrorCodes();
  std::unique_ptr<gsl_interp, decltype(&gsl_interp_free)> interp(
      gsl_interp_alloc(type, radii.size()), &gsl_interp_free);
  std::vector<double> slopes(radii.size(), 0.0);
  int status = gsl_interp_init(interp.get(), radii.data(), heights.data(), radii.size());
  for (std::size_t k = 0; k < radii.size() && status == GSL_SUCCESS; ++k) {
    status = gsl_interp_eval_deriv_e(interp.get(), radii.data(), heights.data(), radii[k], nullptr,
                                     &slopes[k]);
  }
  if (status != GSL_SUCCESS) {
    return InvalidArgument("heights", std::string("interpolation failed: ") + gsl_strerror(status));
  }
  return slopes;
}

// The internal grid, refined by bisection where the Hermite cubic between two nodes misses g
// at the midpoint by more than the tolerance (relative to g there; relative to g(r_max) next to
// a flat centre, where g starts like (x - b)^(3/2) and no finite grid is relatively accurate).
// Nodes gather where g is not smooth: just beyond each sample radius f'' may jump, which puts
// a (x - r_k)^(3/2) term into g.
class GridBuilder {
 public:
  GridBuilder(const SampledShape& shape, const TabulatedOptions& options)
      : shape_(shape),
        tolerance_(options.tolerance),
        max_nodes_(options.max_grid_nodes),
        interrupt_(options.interrupt),
        g_max_(shape.EquivalentAt(shape.radii().back()).first) {}

  // ResourceExhausted when max_nodes would be exceeded; the interrupt's status when it fired.
  Status Build() {
    const std::vector<double>& radii = shape_.radii();
    Node left = At(0);
    for (std::size_t k = 0; k + 1 < radii.size(); ++k) {
      const Node right = At(radii[k + 1]);
      if (!Refine(left, right, 0)) return stop_;
      left = right;
    }
    Append(left);
    return OkStatus();
  }
  TabulatedProfile::Grid& grid() { return grid_; }
  double worst_error() const { return worst_error_; }

 private:
  struct Node {
    double x, g, slope;
  };
  Node At(double x) const {
    const auto [g, slope] = shape_.EquivalentAt(x);
    return {x, g, slope};
  }
  void Append(const Node& node) {
    grid_.x.push_back(node.x);
    grid_.g.push_back(node.g);
    grid_.slope.push_back(node.slope);
  }
  // Appends the nodes of [left, right) after refining it; false (and stop_ set) to stop.
  bool Refine(const Node& left, const Node& right, int depth) {
    if (Status s = interrupt_.Check(); !s.ok()) {
      stop_ = s;
      return false;
    }
    const Node mid = At(0.5 * (left.x + right.x));
    const Cubic cubic(left.x, right.x, left.g, right.g, left.slope, right.slope);
    const double error = std::abs(cubic.Value(mid.x) - mid.g);
    const bool next_to_flat_centre = left.x > 0 && left.g == 0;
    const double scale = next_to_flat_centre ? g_max_ : std::abs(mid.g);
    constexpr int kMaxDepth = 48;  // widths down to 2^-48 of a sample interval
    if (error <= tolerance_ * scale || depth == kMaxDepth) {
      if (error > 0) worst_error_ = std::max(worst_error_, error / scale);
      Append(left);
      if (grid_.x.size() < max_nodes_) return true;
      stop_ = ResourceExhausted(
          "max_grid_nodes", "g needs more than " + std::to_string(max_nodes_) +
                                " grid nodes to reach the tolerance " + FormatNumber(tolerance_) +
                                "; ask for a larger tolerance");
      return false;
    }
    return Refine(left, mid, depth + 1) && Refine(mid, right, depth + 1);
  }

  const SampledShape& shape_;
  double tolerance_;
  std::size_t max_nodes_;
  Interrupt interrupt_;
  double g_max_;
  TabulatedProfile::Grid grid_;
  double worst_error_ = 0;
  Status stop_;  // why Refine stopped
};

// g must not decrease (the contact must stay a disc, docs/physics.md "MDR"). Slopes within
// round-off of zero are set to zero so the interpolant stays monotone.
Status RequireIncreasing(TabulatedProfile::Grid& grid) {
  double slope_scale = 0;
  for (double s : grid.slope) slope_scale = std::max(slope_scale, std::abs(s));
  const double slack = 64 * kEps * slope_scale;
  for (std::size_t i = 0; i < grid.x.size(); ++i) {
    const bool falls = grid.slope[i] < -slack || (i > 0 && grid.g[i] < grid.g[i - 1]);
    if (falls || !std::isfinite(grid.g[i])) {
      return InvalidArgument(
          "heights", "the equivalent profile g(x) decreases at x = " + FormatNumber(grid.x[i]) +
                         ": the contact would not be a disc");
    }
    grid.slope[i] = std::max(grid.slope[i], 0.0);
  }
  if (!(grid.slope.back() > 0)) {
    return InvalidArgument("heights",
                           "the equivalent profile must still rise at the last "
                           "sample (g'(r_max) > 0) so deeper contacts can be "
                           "extrapolated");
  }
  return OkStatus();
}

std::string Description(const std::vector<double>& radii, TabulatedOptions options,
                        std::size_t nodes) {
  std::ostringstream out;
  out.precision(6);
  out << "tabulated profile, " << radii.size() << " samples to r = " << radii.back() << " m ("
      << (options.interpolation == TabulatedOptions::Interpolation::kSteffen ? "Steffen"
                                                                             : "cubic spline")
      << ", " << nodes << " grid nodes)";
  return out.str();
}

}  // namespace

std::size_t TabulatedProfile::MemoryBytes() const {
  std::size_t bytes =
      sizeof(*this) + description_.capacity() + 1 + sample_radii_.capacity() * sizeof(double);
  for (const auto* table :
       {&grid_.x, &grid_.g, &grid_.slope, &grid_.moment1, &grid_.moment2, &grid_.force}) {
    bytes += table->capacity() * sizeof(double);
  }
  return bytes;
}

TabulatedProfile::TabulatedProfile(Grid grid, double tolerance_estimate, std::string description,
                                   std::vector<double> sample_radii)
    : grid_(std::move(grid)),
      flat_radius_(0),
      tolerance_estimate_(tolerance_estimate),
      description_(std::move(description)),
      sample_radii_(std::move(sample_radii)) {
  for (std::size_t i = 1; i < grid_.x.size() && grid_.g[i] == 0; ++i) flat_radius_ = grid_.x[i];
  const std::size_t n = grid_.x.size();
  grid_.moment1.assign(n, 0.0);
  grid_.moment2.assign(n, 0.0);
  grid_.force.assign(n, 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    grid_.moment1[i + 1] = grid_.moment1[i] + PartialMoment(1, i, grid_.x[i + 1]);
    grid_.moment2[i + 1] = grid_.moment2[i] + PartialMoment(2, i, grid_.x[i + 1]);
    grid_.force[i + 1] = 2 * (grid_.g[i + 1] * grid_.x[i + 1] - grid_.moment1[i + 1]);
  }
}

std::size_t TabulatedProfile::IntervalOf(double x) const {
  const auto after = std::upper_bound(grid_.x.begin(), grid_.x.end(), x);
  const auto index = static_cast<std::size_t>(std::max<std::ptrdiff_t>(after - grid_.x.begin(), 1));
  return std::min(index - 1, grid_.x.size() - 2);
}

double TabulatedProfile::G(double x) const {
  if (!(x > 0)) return 0;
  const double x_end = max_radius();
  if (x >= x_end) return max_depth() + grid_.slope.back() * (x - x_end);
  return GridCubic(grid_, IntervalOf(x)).Value(x);
}

double TabulatedProfile::Slope(double x) const {
  if (!(x > 0)) return grid_.slope.front();
  if (x >= max_radius()) return grid_.slope.back();
  return GridCubic(grid_, IntervalOf(x)).Slope(x);
}

double TabulatedProfile::Rise(double x, double x_ref) const {
  if (!(x_ref > 0)) return G(x);
  const double x_end = max_radius();
  if (x_ref >= x_end) return grid_.slope.back() * (x - x_ref);
  // Within interval i of x_ref, whole nodes in between, then within the interval of x.
  const std::size_t i = IntervalOf(x_ref);
  if (x <= grid_.x[i + 1]) return GridCubic(grid_, i).Difference(x_ref, x);
  double rise = GridCubic(grid_, i).Difference(x_ref, grid_.x[i + 1]);
  if (x >= x_end) return rise + (max_depth() - grid_.g[i + 1]) + grid_.slope.back() * (x - x_end);
  const std::size_t j = IntervalOf(x);
  return rise + (grid_.g[j] - grid_.g[i + 1]) + GridCubic(grid_, j).Difference(grid_.x[j], x);
}

double TabulatedProfile::RadiusAtDepth(double z) const {
  if (!(z > 0)) return flat_radius_;
  const double x_end = max_radius();
  if (z >= max_depth()) return x_end + (z - max_depth()) / grid_.slope.back();
  const auto above = std::lower_bound(grid_.g.begin(), grid_.g.end(), z);
  const std::size_t i = static_cast<std::size_t>(above - grid_.g.begin()) - 1;
  if (grid_.g[i + 1] == z) return grid_.x[i + 1];
  const Cubic cubic = GridCubic(grid_, i);
  const double guess =
      grid_.x[i] + (grid_.x[i + 1] - grid_.x[i]) * (z - grid_.g[i]) / (grid_.g[i + 1] - grid_.g[i]);
  return SolveIncreasing(
      [&](double x) {
        return std::pair{cubic.Value(x) - z, cubic.Slope(x)};
      },
      grid_.x[i], grid_.x[i + 1], guess);
}

double TabulatedProfile::PartialMoment(int j, std::size_t i, double x) const {
  const Cubic cubic = GridCubic(grid_, i);
  const double half = 0.5 * (x - grid_.x[i]), centre = 0.5 * (x + grid_.x[i]);
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    sum += kGaussWeights4[k] * std::pow(cubic.Value(centre + half * kGaussNodes4[k]), j);
  }
  return half * sum;
}

double TabulatedProfile::Moment(int j, double x) const {
  if (!(x > 0)) return 0;
  if (j == 0) return x;
  const double x_end = max_radius();
  const std::vector<double>& cumulative = j == 1 ? grid_.moment1 : grid_.moment2;
  if (x >= x_end) {
    // integral of (g_end + s t)^j over t in [0, x - x_end].
    const double t = x - x_end, g = max_depth(), s = grid_.slope.back();
    const double tail =
        j == 1 ? t * (g + 0.5 * s * t) : t * (g * g + g * s * t + s * s * t * t / 3);
    return cumulative.back() + tail;
  }
  const std::size_t i = IntervalOf(x);
  return cumulative[i] + PartialMoment(j, i, x);
}

double TabulatedProfile::PressurePerModulus(double r, double depth) const {
  const double a = RadiusAtDepth(depth);
  if (!(r < a) || !(depth > 0)) return 0;
  r = std::abs(r);
  if (r == 0 && Slope(0) > 0) return kInf;  // g'(x)/x ~ 1/x at the axis, like a cone
  // x = sqrt(r^2 + s^2): p/E* = (1/pi) integral_0^S g'(x)/x ds, S = sqrt(a^2 - r^2), with the
  // layer of width r near s = 0 integrated separately (ForEachAbelInterval).
  const double r2 = r * r;
  auto integrand = [&](double s) {
    const double x = std::sqrt(r2 + s * s);
    return Slope(x) / x;
  };
  internal::Quadrature quadrature(512);
  double total = 0, error = 0;
  internal::ForEachAbelInterval(r, 0.0, std::sqrt((a - r) * (a + r)), [&](double lo, double hi) {
    quadrature.AddWithRule(integrand, lo, hi, 0, 1e-12, GSL_INTEG_GAUSS21, &total, &error);
  });
  return total / kPi;
}

double TabulatedProfile::DepthAtNormalForcePerModulus(double force_per_modulus) const {
  if (!(force_per_modulus > 0)) return 0;
  // F_N/E*(a) = 2 (g(a) a - M_1(a)) increases with a (its slope is 2 a g'(a)).
  auto residual = [&](double a) {
    return std::pair{2 * (G(a) * a - Moment(1, a)) - force_per_modulus, 2 * a * Slope(a)};
  };
  const std::vector<double>& force = grid_.force;
  double lo = 0, hi = 0;
  if (force_per_modulus >= force.back()) {
    lo = max_radius();
    hi = 2 * lo;
    while (residual(hi).first < 0) lo = hi, hi *= 2;
  } else {
    const auto above = std::lower_bound(force.begin(), force.end(), force_per_modulus);
    const std::size_t i = static_cast<std::size_t>(above - force.begin()) - 1;
    lo = grid_.x[i];
    hi = grid_.x[i + 1];
  }
  return G(SolveIncreasing(residual, lo, hi, 0.5 * (lo + hi)));
}

Result<ProfilePtr> MakeTabulatedProfile(std::vector<double> radii, std::vector<double> heights,
                                        TabulatedOptions options) {
  if (Status s = ValidateSamples(radii, heights); !s.ok()) return s;
  if (Status s = RequireInRange("tolerance", options.tolerance, 0, 1e-2, /*lo_open=*/true);
      !s.ok()) {
    return s;
  }
  Result<std::vector<double>> slopes = SampleSlopes(radii, heights, options.interpolation);
  if (!slopes.ok()) return slopes.status();
  const SampledShape shape(radii, heights, *slopes);

  GridBuilder builder(shape, options);
  if (Status s = builder.Build(); !s.ok()) return s;
  TabulatedProfile::Grid& grid = builder.grid();
  if (Status s = RequireIncreasing(grid); !s.ok()) return s;
  const std::size_t nodes = grid.x.size();
  std::string description = Description(radii, options, nodes);
  return ProfilePtr(std::make_shared<TabulatedProfile>(std::move(grid), builder.worst_error(),
                                                       std::move(description), std::move(radii)));
}

}  // namespace mdr
