#include "hertz_torsion_table.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "carlson.h"

namespace mdr::internal {
namespace {

using Long = long double;
constexpr int kN = HertzTorsionTable::kDegree;

// The Chebyshev points of the first kind on [-1, 1] (no end point: the top panel's tails are
// divided by powers of w, which vanishes at s = 1).
Long Node(int i) { return std::cos(std::numbers::pi_v<Long> * (i + Long(0.5)) / kN); }

// T_j at the nodes, cos(pi j (i + 1/2) / kN): computed once, every series needs them.
const std::array<std::array<Long, kN>, kN>& ChebyshevAtNodes() {
  static const auto table = [] {
    std::array<std::array<Long, kN>, kN> t{};
    for (int j = 0; j < kN; ++j) {
      for (int i = 0; i < kN; ++i) {
        t[j][i] = std::cos(std::numbers::pi_v<Long> * j * (i + Long(0.5)) / kN);
      }
    }
    return t;
  }();
  return table;
}

// The coefficients of the interpolant through the values at the nodes.
std::array<Long, kN> Coefficients(const std::array<Long, kN>& values) {
  const auto& chebyshev = ChebyshevAtNodes();
  std::array<Long, kN> c{};
  for (int j = 0; j < kN; ++j) {
    Long sum = 0;
    for (int i = 0; i < kN; ++i) sum += values[i] * chebyshev[j][i];
    c[j] = sum * 2 / kN;
  }
  c[0] /= 2;
  return c;
}

template <typename T, std::size_t n>
T Clenshaw(const std::array<T, n>& c, T s) {
  T b1 = 0, b2 = 0;
  for (std::size_t j = n - 1; j > 0; --j) {
    const T b0 = 2 * s * b1 - b2 + c[j];
    b2 = b1, b1 = b0;
  }
  return s * b1 - b2 + c[0];
}

// Two series at one point, interleaved (their recurrences are independent).
inline void Clenshaw2(const std::array<double, kN>& c, const std::array<double, kN>& d, double s,
                      double* first, double* second) {
  double b1 = 0, b2 = 0, e1 = 0, e2 = 0;
  const double s2 = 2 * s;
  for (int j = kN - 1; j > 0; --j) {
    const double b0 = s2 * b1 - b2 + c[j];
    const double e0 = s2 * e1 - e2 + d[j];
    b2 = b1, b1 = b0, e2 = e1, e1 = e0;
  }
  *first = s * b1 - b2 + c[0];
  *second = s * e1 - e2 + d[0];
}

std::array<double, kN> ToDouble(const std::array<Long, kN>& c) {
  std::array<double, kN> out{};
  for (int j = 0; j < kN; ++j) out[j] = static_cast<double>(c[j]);
  return out;
}

// The n-point Gauss-Legendre rule on [-1, 1] in long double (Newton on P_n from Chebyshev's
// guesses): the tables' integrals of their own interpolants, which it integrates exactly.
struct LongGaussRule {
  explicit LongGaussRule(int n) : nodes(n), weights(n) {
    for (int i = 0; i < n; ++i) {
      Long x = std::cos(std::numbers::pi_v<Long> * (i + Long(0.75)) / (n + Long(0.5)));
      Long derivative = 0;
      for (int iteration = 0; iteration < 100; ++iteration) {
        Long p0 = 1, p1 = x;
        for (int k = 2; k <= n; ++k) {
          const Long p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
          p0 = p1, p1 = p2;
        }
        derivative = n * (x * p1 - p0) / (x * x - 1);
        const Long step = p1 / derivative;
        x -= step;
        if (std::abs(step) < 1e-21L) break;
      }
      nodes[i] = x;
      weights[i] = 2 / ((1 - x * x) * derivative * derivative);
    }
  }
  std::vector<Long> nodes, weights;
};

// h, E and the integrands at t (w = 1 - t), in long double from Carlson's integrals.
struct Exact {
  Long h, e;
};
Exact ExactAt(Long t, Long w) {
  const Long y = t * t, m = w * (2 - w);
  const Long rd = CarlsonRD<Long>(0, y, 1), rf = CarlsonRF<Long>(0, y, 1);
  return {m * rd / 3, rf - m * rd / 3};
}

using Table = HertzTorsionTable;
constexpr int kS = Table::kPanelsPerBand;

// Panel p = k kS + j: band k (t in [2^-(k+1), 2^-k], u = t 2^(k+1) in [1, 2]) and its j-th panel
// from the top, u in [2 - (j+1)/kS, 2 - j/kS]; s in [-1, 1] across it. Panel 0 holds the edge.
struct PanelPoint {
  Long t, w;
};
PanelPoint PointOf(int p, Long s) {
  const int k = p / kS, j = p % kS;
  const Long u = (s - 2 * j - 1 + 4 * kS) / (2 * kS);
  // In band 0, w = 1 - u / 2 directly, which near the edge keeps its digits.
  const Long t = std::ldexp(u, -k - 1), w = k == 0 ? (2 * j + 1 - s) / (4 * kS) : 1 - t;
  return {t, w};
}

}  // namespace

HertzTorsionTable::HertzTorsionTable() {
  const LongGaussRule gauss(kN);
  Long first_above = 0, second_above = 0;
  for (int p = 0; p < kPanels; ++p) {
    Panel& panel = panels_[p];
    const bool edge = p == 0;
    // The width of the panel in t per unit of s.
    const Long dt_ds = std::ldexp(Long(1), -(p / kS) - 1) / (2 * kS);
    std::array<Long, kN> q{}, e{}, integrand1{}, integrand2{};
    for (int i = 0; i < kN; ++i) {
      const PanelPoint at = PointOf(p, Node(i));
      const Exact exact = ExactAt(at.t, at.w);
      q[i] = exact.h / (at.w * (2 - at.w));
      e[i] = exact.e;
      // The edge panel's integrands over w and w^2 (they vanish there like these): interpolated
      // to their relative accuracy up to the edge.
      const Long scale = edge ? at.w : 1;
      integrand1[i] = at.t * at.t * exact.h / scale;
      integrand2[i] = at.t * at.t * exact.h * exact.h / (scale * scale);
    }
    const std::array<Long, kN> c1 = Coefficients(integrand1), c2 = Coefficients(integrand2);
    // The integrand's interpolant at s, with the edge panel's powers of w put back.
    auto integrands = [&](Long s, Long* first, Long* second) {
      const Long scale = edge ? PointOf(p, s).w : 1;
      *first = Clenshaw(c1, s) * scale;
      *second = Clenshaw(c2, s) * scale * scale;
    };
    // The tails at each node to the panel's upper end: the interpolant's integral over [s, 1],
    // by the Gauss rule on it, which is exact for it and adds no cancellation.
    std::array<Long, kN> tail1{}, tail2{};
    for (int i = 0; i < kN; ++i) {
      const Long s = Node(i), half = (1 - s) / 2, mid = (1 + s) / 2;
      Long sum1 = 0, sum2 = 0;
      for (int g = 0; g < kN; ++g) {
        Long first = 0, second = 0;
        integrands(mid + half * gauss.nodes[g], &first, &second);
        sum1 += gauss.weights[g] * first, sum2 += gauss.weights[g] * second;
      }
      tail1[i] = sum1 * half * dt_ds, tail2[i] = sum2 * half * dt_ds;
      if (edge) {  // over w^2 and w^3: finite, analytic and relative at the edge
        const Long w = PointOf(p, s).w;
        tail1[i] /= w * w, tail2[i] /= w * w * w;
      }
    }
    panel.q = ToDouble(Coefficients(q));
    panel.e = ToDouble(Coefficients(e));
    panel.first = ToDouble(Coefficients(tail1));
    panel.second = ToDouble(Coefficients(tail2));
    panel.first_above = static_cast<double>(first_above);
    panel.second_above = static_cast<double>(second_above);
    Long whole1 = 0, whole2 = 0;
    for (int g = 0; g < kN; ++g) {
      Long first = 0, second = 0;
      integrands(gauss.nodes[g], &first, &second);
      whole1 += gauss.weights[g] * first, whole2 += gauss.weights[g] * second;
    }
    first_above += whole1 * dt_ds;
    second_above += whole2 * dt_ds;
    // The inverse on [h(upper end), h(lower end)].
    const PanelPoint upper = PointOf(p, 1), lower = PointOf(p, -1);
    const Long y_lo = edge ? 0 : ExactAt(upper.t, upper.w).h;
    const Long y_hi = ExactAt(lower.t, lower.w).h;
    panel.y_lo = static_cast<double>(y_lo);
    panel.y_hi = static_cast<double>(y_hi);
    std::array<Long, kN> inverse{};
    // Newton (dh/dt = -E / t) from the panel's middle, then from the previous node's root, on w
    // in band 0, where w carries the digits, and on t below it.
    const bool on_w = p < kS;
    PanelPoint at = PointOf(p, 0);
    for (int i = 0; i < kN; ++i) {
      const Long y = y_lo + (y_hi - y_lo) * (Node(i) + 1) / 2;
      for (int iteration = 0; iteration < 200; ++iteration) {
        const Exact exact = ExactAt(at.t, at.w);
        const Long step = (exact.h - y) * at.t / exact.e;
        if (on_w) {
          at.w -= step, at.t = 1 - at.w;
        } else {
          at.t += step, at.w = 1 - at.t;
        }
        if (std::abs(step) <= 1e-20L * (on_w ? at.w : at.t)) break;
      }
      inverse[i] = edge ? at.w / y : on_w ? at.w : at.t;
    }
    panel.inverse = ToDouble(Coefficients(inverse));
  }
  below_ = {static_cast<double>(first_above), static_cast<double>(second_above)};
  // Below the bands: integral_0^T u^2 (L - 1) du = (T^3 / 3)(L - 2/3) and
  // integral_0^T u^2 (L - 1)^2 du = (T^3 / 3)(L^2 - 4L/3 + 5/9), L = ln(4 / T).
  const Long bottom = std::ldexp(Long(1), -kBands), l = std::log(4 / bottom);
  const Long cube = bottom * bottom * bottom / 3;
  whole_ = {static_cast<double>(first_above + cube * (l - Long(2) / 3)),
            static_cast<double>(second_above + cube * (l * l - 4 * l / 3 + Long(5) / 9))};
}

const HertzTorsionTable& HertzTorsionTable::Get() {
  static const HertzTorsionTable table;
  return table;
}

int HertzTorsionTable::PanelOf(double t, double w, double* s) {
  if (w < 0.5) {  // band 0, from w: u = 2 - 2w
    const int j = std::min(static_cast<int>(2 * kS * w), kS - 1);
    *s = 2 * j + 1 - 4 * kS * w;
    return j;
  }
  if (!(t > 0)) return kPanels;  // no panel (the centre's expansions answer, or NaN does)
  const int k = -std::ilogb(t) - 1;  // t in [2^-(k+1), 2^-k)
  if (k >= kBands) return kPanels;
  const double u = std::ldexp(t, k + 1);  // in [1, 2)
  const int j = std::min(static_cast<int>((2 - u) * kS), kS - 1);
  *s = 2 * kS * u - 4 * kS + 2 * j + 1;
  return k * kS + j;
}

double HertzTorsionTable::H(double t, double w) const {
  double s = 0;
  const int p = PanelOf(t, w, &s);
  if (p >= kPanels) {  // the centre: h = L - 1 - (t^2 / 4) L, L = ln(4 / t)
    const double l = std::log(4 / t);
    return l - 1 - t * t * l / 4;
  }
  return w * (1 + t) * Clenshaw(panels_[p].q, s);
}

double HertzTorsionTable::E(double t, double w) const {
  double s = 0;
  const int p = PanelOf(t, w, &s);
  if (p >= kPanels) return 1 + t * t * (std::log(4 / t) - 0.5) / 2;
  return Clenshaw(panels_[p].e, s);
}

HertzTorsionTable::Tails HertzTorsionTable::Integrals(double t, double w) const {
  double s = 0;
  const int p = PanelOf(t, w, &s);
  if (p >= kPanels) {
    const double l = std::log(4 / t), cube = t * t * t / 3;
    const double bottom = std::ldexp(1.0, -kBands), lb = std::log(4 / bottom);
    const double cube_b = bottom * bottom * bottom / 3;
    return {below_.first + cube_b * (lb - 2.0 / 3) - cube * (l - 2.0 / 3),
            below_.second + cube_b * (lb * lb - 4 * lb / 3 + 5.0 / 9) -
                cube * (l * l - 4 * l / 3 + 5.0 / 9)};
  }
  const Panel& panel = panels_[p];
  double first = 0, second = 0;
  Clenshaw2(panel.first, panel.second, s, &first, &second);
  if (p == 0) return {first * w * w, second * w * w * w};
  return {panel.first_above + first, panel.second_above + second};
}

HertzTorsionTable::Point HertzTorsionTable::Inverse(double y) const {
  if (!(y > 0)) return {1, 0};  // h = 0 at the edge (and no NaN goes further)
  // h(2^-k) grows about like (k + 2) ln 2 - 1: start in that band and walk to the panel (the
  // band clamped as a double: y may be far beyond an int's range, or infinite).
  const double band = std::clamp((y + 1) / std::numbers::ln2 - 2, 0.0, double{kBands - 1});
  int p = kS * static_cast<int>(band);
  while (p > 0 && y < panels_[p].y_lo) --p;
  while (p < kPanels && y >= panels_[p].y_hi) ++p;
  if (p >= kPanels) {  // the centre: L = (y + 1)(1 + t0^2 / 4), t0 = 4 e^-(y + 1)
    const double t0 = 4 * std::exp(-(y + 1));
    const double t = 4 * std::exp(-(y + 1) * (1 + t0 * t0 / 4));
    return {t, 1 - t};
  }
  const Panel& panel = panels_[p];
  const double s = 2 * (y - panel.y_lo) / (panel.y_hi - panel.y_lo) - 1;
  const double value = Clenshaw(panel.inverse, s);
  if (p == 0) return {1 - y * value, y * value};
  if (p < kS) return {1 - value, value};
  return {value, 1 - value};
}

}  // namespace mdr::internal
