// Signal tools for measured channels (issue #47; docs/analysis.md, "Identification"): the noise
// of a densely sampled channel estimated from the channel itself, local polynomial smoothing and
// differentiation, and the least-squares monotone fit. No physics here; the fit and a rig's own
// software use them alike.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace mdr::analysis {

// The standard deviation of white noise on a densely sampled, smooth signal, from the signal
// itself: the third differences y[i+3] - 3 y[i+2] + 3 y[i+1] - y[i] of white noise of standard
// deviation s have standard deviation sqrt(20) s, while a smooth signal's third differences are
// of the order of its third derivative times the sampling step cubed. The median of their
// magnitudes (times 1.4826, the normal distribution's MAD factor) makes the estimate insensitive
// to the few samples where the signal has a kink (a reversal, the onset of sliding). 0 for fewer
// than 4 samples. The estimate assumes noise independent from sample to sample: a filtered sensor
// whose noise is correlated over several samples reads as quieter than it is
// (NoiseCorrelation tells).
double NoiseFromDifferences(std::span<const double> y);

// The lag-1 correlation of the third differences of y, against the -0.75 of white noise: near
// -0.75 where noise independent from sample to sample dominates the differences, toward +1 where
// the noise (or the signal) is smooth over several samples. NaN for fewer than 5 samples.
double NoiseCorrelation(std::span<const double> y);

// Local polynomial regression of y against x over [begin, end): at each i, the least-squares
// polynomial of `degree` (0 to 4) through the samples j in [max(begin, i - half_width),
// min(end - 1, i + half_width)] (the window is cut at the range's ends, never reaches outside it),
// and its `derivative`-th derivative (0 to degree) at x[i]. With fewer samples in a window than
// the degree needs, the degree drops to what they fix. x must increase strictly over the range.
// Returns end - begin values.
std::vector<double> LocalPolynomial(std::span<const double> x, std::span<const double> y,
                                    std::size_t begin, std::size_t end, std::size_t half_width,
                                    int degree, int derivative = 0);

// The least-squares non-decreasing (increasing = true) or non-increasing fit of v, in place
// (pool adjacent violators). A sequence already monotone that way is left unchanged.
void MakeMonotone(std::span<double> v, bool increasing);

}  // namespace mdr::analysis
