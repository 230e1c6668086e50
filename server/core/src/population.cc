#include "mdr/core/population.h"

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <utility>

#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

constexpr double kMaxLogSigma = 3;

Status CheckCount(const char* field, std::size_t count) {
  if (count >= 1 && count <= kMaxInterfaceContacts) return OkStatus();
  return InvalidArgument(field, "must be in [1, " + std::to_string(kMaxInterfaceContacts) +
                                    "], got " + std::to_string(count));
}

// n standard normals from rng, in Box-Muller pairs (the second of the last pair is dropped
// when n is odd).
std::vector<double> StandardNormals(std::mt19937_64& rng, std::size_t n) {
  std::vector<double> z(n);
  for (std::size_t i = 0; i < n; i += 2) {
    const double u1 = UniformFrom64(rng()), u2 = UniformFrom64(rng());
    double z1 = 0, z2 = 0;
    BoxMuller(u1, u2, &z1, &z2);
    z[i] = z1;
    if (i + 1 < n) z[i + 1] = z2;
  }
  return z;
}

std::vector<double> Heights(const PopulationSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  if (spec.heights == HeightDistribution::kGaussian) {
    std::vector<double> s = StandardNormals(rng, spec.count);
    for (double& h : s) h *= spec.height_scale;
    return s;
  }
  // Inverse CDF of the exponential distribution: -log(1 - u), u in [0, 1).
  std::vector<double> s(spec.count);
  for (double& h : s) h = -spec.height_scale * std::log1p(-UniformFrom64(rng()));
  return s;
}

std::vector<double> Radii(const PopulationSpec& spec) {
  if (spec.radii == RadiusDistribution::kNone) return {};
  if (spec.radii == RadiusDistribution::kFixed) return std::vector<double>(spec.count, spec.radius);
  std::mt19937_64 rng(spec.seed ^ kRadiusStreamSalt);
  std::vector<double> r = StandardNormals(rng, spec.count);
  for (double& radius : r) radius = spec.radius * std::exp(spec.log_sigma * radius);
  return r;
}

}  // namespace

double UniformFrom64(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1p-53; }

void BoxMuller(double uniform_1, double uniform_2, double* normal_1, double* normal_2) {
  // 1 - u1 is in (0, 1], so the logarithm is finite; the radius is at most sqrt(2 ln 2^53) = 8.6.
  const double radius = std::sqrt(-2 * std::log(1 - uniform_1));
  const double angle = 2 * internal::kPi * uniform_2;
  *normal_1 = radius * std::cos(angle);
  *normal_2 = radius * std::sin(angle);
}

Result<Population> GeneratePopulation(const PopulationSpec& spec) {
  if (Status s = CheckCount("count", spec.count); !s.ok()) return s;
  if (Status s = RequireInRange("height_scale", spec.height_scale, 0, kMaxSceneScale); !s.ok()) {
    return s;
  }
  if (spec.radii != RadiusDistribution::kNone) {
    if (Status s = RequireSceneScale("radius", spec.radius); !s.ok()) return s;
  }
  if (spec.radii == RadiusDistribution::kLognormal) {
    if (Status s = RequireInRange("log_sigma", spec.log_sigma, 0, kMaxLogSigma); !s.ok()) return s;
  }
  return Population{Heights(spec), Radii(spec)};
}

Result<Population> ExplicitPopulation(std::vector<double> heights, std::vector<double> radii) {
  if (Status s = CheckCount("heights", heights.size()); !s.ok()) return s;
  if (!radii.empty() && radii.size() != heights.size()) {
    return InvalidArgument("radii", "must be empty or have one radius per height (" +
                                        std::to_string(heights.size()) + "), got " +
                                        std::to_string(radii.size()));
  }
  for (std::size_t i = 0; i < heights.size(); ++i) {
    if (Status s =
            RequireInRange(Indexed("heights", i), heights[i], -kMaxSceneScale, kMaxSceneScale);
        !s.ok()) {
      return s;
    }
  }
  for (std::size_t i = 0; i < radii.size(); ++i) {
    if (Status s = RequireSceneScale(Indexed("radii", i), radii[i]); !s.ok()) return s;
  }
  return Population{std::move(heights), std::move(radii)};
}

}  // namespace mdr
