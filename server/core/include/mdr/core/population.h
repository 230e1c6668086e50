// Asperity populations of a rough interface (docs/interfaces.md): summit heights and radii,
// generated from a seed or given as an explicit list (a measured surface). No gRPC in here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mdr/base/status.h"

namespace mdr {

// Largest number of contacts an interface or population may hold (about 5 GB of state).
inline constexpr std::size_t kMaxInterfaceContacts = 10'000'000;

// Seed offset of the radius stream (the golden-ratio constant of splitmix64).
inline constexpr std::uint64_t kRadiusStreamSalt = 0x9e3779b97f4a7c15ULL;

enum class HeightDistribution {
  kGaussian,     // s = scale * Z, Z standard normal (Box-Muller)
  kExponential,  // s = scale * E, E standard exponential (inverse CDF), s >= 0
};

enum class RadiusDistribution {
  kFixed,      // every summit has radius `radius`
  kLognormal,  // R = radius * exp(log_sigma * Z): `radius` is the median
  kNone,       // no radii (Population.radii empty): the contacts share one profile
};

struct PopulationSpec {
  std::size_t count = 0;  // in [1, kMaxInterfaceContacts]
  HeightDistribution heights = HeightDistribution::kGaussian;
  double height_scale = 0;  // m, finite, in [0, 1e100]: standard deviation or exponential scale
  RadiusDistribution radii = RadiusDistribution::kFixed;
  double radius = 0;     // m, in [1e-100, 1e100]; not used by kNone
  double log_sigma = 0;  // lognormal only, in [0, 3]
  std::uint64_t seed = 0;
};

// Summit heights s_i above the reference plane (higher summits touch first) and radii R_i, or no
// radii when every contact has the same profile (SharedProfileInterfaceConfig).
struct Population {
  std::vector<double> heights;
  std::vector<double> radii;
};

// Deterministic: the same spec gives the same population on every machine whose libm rounds
// log, cos and sin alike (glibc does so on every architecture; docs/interfaces.md). Heights come
// from std::mt19937_64(seed), radii from a second std::mt19937_64(seed ^ kRadiusStreamSalt), so
// the heights do not depend on the radius distribution. Fields: count, height_scale, radius,
// log_sigma.
Result<Population> GeneratePopulation(const PopulationSpec& spec);

// A measured population, validated: 1 to kMaxInterfaceContacts heights, each finite with
// |s| <= 1e100, and either no radii or one per height, each in [1e-100, 1e100]. Fields:
// heights[i], radii[i], radii (length).
Result<Population> ExplicitPopulation(std::vector<double> heights, std::vector<double> radii);

// The transforms of GeneratePopulation, exposed so that tests can check them: a uniform in
// [0, 1) from the top 53 bits of a 64-bit draw, and a Box-Muller pair of standard normals from
// two such uniforms.
double UniformFrom64(std::uint64_t bits);
void BoxMuller(double uniform_1, double uniform_2, double* normal_1, double* normal_2);

}  // namespace mdr
