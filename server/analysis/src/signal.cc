#include "mdr/analysis/signal.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace mdr::analysis {
namespace {

constexpr double kMadFactor = 1.4826;  // MAD of a standard normal: 1 / 1.4826

double ThirdDifference(std::span<const double> y, std::size_t i) {
  return y[i + 3] - 3 * y[i + 2] + 3 * y[i + 1] - y[i];
}

}  // namespace

double NoiseFromDifferences(std::span<const double> y) {
  if (y.size() < 4) return 0;
  std::vector<double> d(y.size() - 3);
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = std::abs(ThirdDifference(y, i));
  auto middle = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), middle, d.end());
  return kMadFactor * *middle / std::sqrt(20.0);
}

double NoiseCorrelation(std::span<const double> y) {
  if (y.size() < 5) return std::numeric_limits<double>::quiet_NaN();
  double s00 = 0, s01 = 0, s11 = 0;
  for (std::size_t i = 0; i + 4 < y.size(); ++i) {
    const double a = ThirdDifference(y, i), b = ThirdDifference(y, i + 1);
    s00 += a * a, s01 += a * b, s11 += b * b;
  }
  return s00 > 0 && s11 > 0 ? s01 / std::sqrt(s00 * s11) : std::numeric_limits<double>::quiet_NaN();
}

std::vector<double> LocalPolynomial(std::span<const double> x, std::span<const double> y,
                                    std::size_t begin, std::size_t end, std::size_t half_width,
                                    int degree, int derivative) {
  std::vector<double> out;
  if (end <= begin) return out;
  out.reserve(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    const std::size_t lo = i - std::min(i - begin, half_width);
    const std::size_t hi = std::min(end - 1, i + half_width);
    const auto count = static_cast<int>(hi - lo + 1);
    const int d = std::min(degree, count - 1);
    if (derivative > d) {
      out.push_back(0);
      continue;
    }
    // Centred and scaled abscissae keep the normal equations well conditioned; fixed-size
    // storage keeps the loop free of allocations.
    using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 5, 5>;
    using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 5, 1>;
    const double scale = std::max(x[hi] - x[i], x[i] - x[lo]);
    Small normal = Small::Zero(d + 1, d + 1);
    SmallVector right = SmallVector::Zero(d + 1);
    for (std::size_t j = lo; j <= hi; ++j) {
      const double s = scale > 0 ? (x[j] - x[i]) / scale : 0;
      double powers[5];
      powers[0] = 1;
      for (int c = 1; c <= d; ++c) powers[c] = powers[c - 1] * s;
      for (int r = 0; r <= d; ++r) {
        right[r] += powers[r] * y[j];
        for (int c = 0; c <= d; ++c) normal(r, c) += powers[r] * powers[c];
      }
    }
    const SmallVector coefficients = normal.ldlt().solve(right);
    double factorial = 1;
    for (int k = 2; k <= derivative; ++k) factorial *= k;
    out.push_back(coefficients[derivative] * factorial /
                  (derivative > 0 ? std::pow(scale, derivative) : 1.0));
  }
  return out;
}

void MakeMonotone(std::span<double> v, bool increasing) {
  const double sign = increasing ? 1 : -1;
  std::vector<double> mean;
  std::vector<std::size_t> count;
  for (double value : v) {
    mean.push_back(sign * value);
    count.push_back(1);
    while (mean.size() > 1 && mean[mean.size() - 2] > mean.back()) {
      const std::size_t c = count.back() + count[count.size() - 2];
      const double m = (mean.back() * static_cast<double>(count.back()) +
                        mean[mean.size() - 2] * static_cast<double>(count[count.size() - 2])) /
                       static_cast<double>(c);
      mean.pop_back(), count.pop_back();
      mean.back() = m, count.back() = c;
    }
  }
  std::size_t i = 0;
  for (std::size_t b = 0; b < mean.size(); ++b) {
    for (std::size_t k = 0; k < count[b]; ++k) v[i++] = sign * mean[b];
  }
}

}  // namespace mdr::analysis
