// Carlson's symmetric elliptic integrals R_F and R_D by the duplication theorem and the closing
// series of Carlson (1995, Numer. Algorithms 10, 13-26). Internal to mdr_core.
#pragma once

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace mdr::internal {

// The duplication's stopping tolerance for a floating type: the closing series' truncation is of
// order tolerance^6, below the type's round-off. Double: Numerical Recipes' (3rd ed., 6.12)
// values; long double (64-bit mantissa): smaller, for the tables built from these at start-up.
template <typename T>
struct CarlsonTolerance;
template <>
struct CarlsonTolerance<double> {
  static constexpr double kF = 0.0025, kD = 0.0015;
};
template <>
struct CarlsonTolerance<long double> {
  static constexpr long double kF = 0.0004L, kD = 0.00025L;
};

// Iterating without pow makes these several times cheaper than GSL's.
template <typename T>
T CarlsonRF(T x, T y, T z) {
  const T c1 = T(1) / 24, c2 = T(1) / 10, c3 = T(3) / 44, c4 = T(1) / 14;
  T ave = 0, dx = 0, dy = 0, dz = 0;
  for (int i = 0; i < 200; ++i) {
    const T sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const T lambda = sx * (sy + sz) + sy * sz;
    x = (x + lambda) / 4, y = (y + lambda) / 4, z = (z + lambda) / 4;
    ave = (x + y + z) / 3;
    dx = (ave - x) / ave, dy = (ave - y) / ave, dz = (ave - z) / ave;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) <= CarlsonTolerance<T>::kF) break;
  }
  const T e2 = dx * dy - dz * dz, e3 = dx * dy * dz;
  return (1 + (c1 * e2 - c2 - c3 * e3) * e2 + c4 * e3) / std::sqrt(ave);
}

template <typename T>
T CarlsonRD(T x, T y, T z) {
  const T c1 = T(3) / 14, c2 = T(1) / 6, c3 = T(9) / 22, c4 = T(3) / 26;
  const T c5 = c3 / 4, c6 = 3 * c4 / 2;
  // 0.2 as the double rounds it (the values the engine has always had), exact for wider types.
  const T kFifth = std::is_same_v<T, double> ? T(0.2) : T(1) / 5;
  T sum = 0, factor = 1, ave = 0, dx = 0, dy = 0, dz = 0;
  for (int i = 0; i < 200; ++i) {
    const T sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const T lambda = sx * (sy + sz) + sy * sz;
    sum += factor / (sz * (z + lambda));
    factor /= 4;
    x = (x + lambda) / 4, y = (y + lambda) / 4, z = (z + lambda) / 4;
    ave = (x + y + 3 * z) * kFifth;
    dx = (ave - x) / ave, dy = (ave - y) / ave, dz = (ave - z) / ave;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) <= CarlsonTolerance<T>::kD) break;
  }
  const T ea = dx * dy, eb = dz * dz, ec = ea - eb, ed = ea - 6 * eb, ee = ed + 2 * ec;
  return 3 * sum + factor *
                       (1 + ed * (-c1 + c5 * ed - c6 * dz * ee) +
                        dz * (c2 * ee + dz * (-c3 * ec + dz * c4 * ea))) /
                       (ave * std::sqrt(ave));
}

}  // namespace mdr::internal
