// The universal function of the Hertz torsional bound and what a torsional step needs of it,
// tabulated once per process to round-off (docs/physics.md, "Torsion", "Cost"). Internal to
// mdr_core.
//
// For Hertz, B(x; a) = scale a h(x / a) with h(t) = K(1 - t^2) - E(1 - t^2): one function of one
// variable for every sphere, load and material. A twist step at constant load needs h, its
// inverse (where a spring meets the bound) and the integrals of u^2 h and u^2 h^2 (moment,
// stored and dissipated energy), so each is kept as Chebyshev series on panels where every one
// of them is analytic: the dyadic bands t in [2^-(k+1), 2^-k], k < kBands, each cut into
// kPanelsPerBand equal panels. The only singularity, h's logarithm at t = 0, then lies at least
// nine half-widths from a panel's centre, and the series converge like 18^-n. Below the bands
// the centre's expansions are exact to far below round-off. The tables are built from Carlson's
// integrals in long double at first use.
#pragma once

#include <array>

namespace mdr::internal {

class HertzTorsionTable {
 public:
  static constexpr int kBands = 24;  // t down to 2^-24; below, the centre's expansions
  static constexpr int kPanelsPerBand = 4;
  static constexpr int kPanels = kBands * kPanelsPerBand;
  static constexpr int kDegree = 13;  // coefficients per series (12 already reach round-off)
  static const HertzTorsionTable& Get();

  // t in (0, 1) with w = 1 - t given by the caller to its own accuracy (from (a - x) / a), which
  // near the edge is better than 1 - t: every value below is relative to it there.
  // h(t) = (1 - t^2) q(t) (q = R_D(0, t^2, 1) / 3), to a few ulps.
  double H(double t, double w) const;
  // E(1 - t^2) = -t h'(t), to a few ulps.
  double E(double t, double w) const;
  // integral_t^1 u^2 h(u) du and integral_t^1 u^2 h(u)^2 du; both vanish at the edge (as w^2
  // and w^3) and keep their relative accuracy there.
  struct Tails {
    double first = 0, second = 0;
  };
  Tails Integrals(double t, double w) const;
  // The t with h(t) = y, y > 0, and w = 1 - t to its relative accuracy (near the edge t rounds
  // to 1 but w does not).
  struct Point {
    double t = 0, w = 0;
  };
  Point Inverse(double y) const;

  // The tails at t = 0 (the first is pi^2 / 64), as the tables hold them.
  Tails WholeIntegrals() const { return whole_; }

 private:
  HertzTorsionTable();
  using Series = std::array<double, kDegree>;
  struct Panel {
    Series q, e;           // q and E(1 - t^2)
    Series first, second;  // the edge panel: the tails over w^2 and w^3; else over the panel
    Series inverse;        // the edge panel: w(y) / y; else t(y), y in [y_lo, y_hi]
    double first_above = 0, second_above = 0;  // the tails at the panel's upper end
    double y_lo = 0, y_hi = 0;                 // h at the panel's upper and lower ends
  };
  // The panel holding t and t's coordinate in it, s in [-1, 1]; kPanels below the bands.
  static int PanelOf(double t, double w, double* s);
  std::array<Panel, kPanels> panels_;
  Tails whole_;
  Tails below_;  // the tails at the lowest band's lower end, 2^-kBands
};

}  // namespace mdr::internal
