#include "mdr/core/jager.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "jager_terms.h"
#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::BasisDisplacement;
using internal::CheckMuKappa;
using internal::SegmentWeight;

using internal::kEps;
// Slack of the Coulomb checks and bound tags, in units of mu_kappa * depth: the engine places
// bound crossings with round-off ~eps * depth in z (memory.cc), so its own vertices may sit that
// far outside a bound or off it.
constexpr double kBoundSlack = 8 * kEps;

// A run of memory segments of one weight, in depth.
struct DepthRun {
  double depth_begin, depth_end, weight;
  BoundTag bound;  // the tag both ends share (kInside: none)
};

// Vertex `middle` lies on the straight line from `first` to `last` to round-off (4 eps of the
// largest |u|): the segments on either side have one weight and are one basis solution. Weights
// computed from rounded u are seldom exactly equal, so this is the test of the superposition rule.
bool OnOneLine(const std::vector<double>& z, const std::vector<double>& u, std::size_t first,
               std::size_t middle, std::size_t last) {
  const double line =
      u[first] + (u[last] - u[first]) * ((z[middle] - z[first]) / (z[last] - z[first]));
  const double scale = std::max({std::abs(u[first]), std::abs(u[middle]), std::abs(u[last])});
  return std::abs(u[middle] - line) <= 4 * kEps * scale;
}

// The memory's maximal runs of segments of one weight, from the centre out. Each run's weight is
// the mean over its depths, so the run reproduces u at both of its ends: the decomposition's
// terms telescope back to the memory (MemoryFromTerms), which a clamp at +-1 would break by
// eps * mu kappa delta; the reported piece weights are clamped instead (PieceWeight).
std::vector<DepthRun> WeightRuns(const PiecewiseLinearMemory& memory, double mu_kappa) {
  const std::vector<double>& z = memory.z();
  const std::vector<double>& u = memory.u();
  const std::vector<std::uint8_t>& tags = memory.tags();
  std::vector<DepthRun> runs;
  std::size_t first = 0;
  for (std::size_t k = 1; k < z.size(); ++k) {
    // A run never spans a change of slip state: the weight of a piece on a bound is exactly +-1.
    if (k + 1 < z.size() && (tags[k - 1] & tags[k]) == (tags[k] & tags[k + 1]) &&
        OnOneLine(z, u, first, k, k + 1)) {
      continue;
    }
    const double mean = SegmentWeight(u[first], u[k], z[k] - z[first], mu_kappa);
    runs.push_back({z[first], z[k], mean, static_cast<BoundTag>(tags[first] & tags[k])});
    first = k;
  }
  return runs;
}

// The weight a piece reports: a run whose two ends are tagged on one bound line lies on it, so
// F = +1 (upper) or -1 (lower) exactly; the rounded u of a crossing vertex (memory.cc) would
// otherwise make it 1 +- 1e-10 on a thin slip annulus. Any other run sticks, |du/dz| <=
// mu kappa, so its mean is clamped to [-1, 1]: beyond is round-off of u and z.
double PieceWeight(const DepthRun& run) {
  if (run.bound == kOnUpper) return 1;
  if (run.bound == kOnLower) return -1;
  return std::clamp(run.weight, -1.0, 1.0);
}

JagerWeights WeightsOf(const PiecewiseLinearMemory& memory, const Profile& profile,
                       double mu_kappa) {
  JagerWeights weights;
  if (!memory.in_contact()) return weights;
  const double depth = memory.depth();
  weights.contact_radius = profile.RadiusAtDepth(depth);
  if (!(profile.RadiusAtDepth(0) < weights.contact_radius)) {
    // g jumps from 0 to beyond depth at the edge (flat punch): all weight is there, and its mean
    // over the depths telescopes to u_0 / (mu kappa delta).
    weights.edge_weight =
        std::clamp(SegmentWeight(memory.u().front(), 0, depth, mu_kappa), -1.0, 1.0);
    return weights;
  }
  for (const DepthRun& run : WeightRuns(memory, mu_kappa)) {
    const double r_begin = profile.RadiusAtDepth(run.depth_begin);
    const double r_end = profile.RadiusAtDepth(run.depth_end);
    // A run thinner than the radius' round-off has no radial extent and no traction; its
    // neighbours then meet, and merge if their weights are equal.
    if (!(r_end > r_begin)) continue;
    const double weight = PieceWeight(run);
    if (!weights.intervals.empty() && weights.intervals.back().weight == weight) {
      weights.intervals.back().r_end = r_end;
      weights.intervals.back().depth_end = run.depth_end;
    } else {
      weights.intervals.push_back({r_begin, r_end, run.depth_begin, run.depth_end, weight});
    }
  }
  return weights;
}

std::vector<CattaneoMindlinTerm> TermsOf(const PiecewiseLinearMemory& memory,
                                         const Profile& profile, double mu_kappa) {
  std::vector<CattaneoMindlinTerm> terms;
  if (!memory.in_contact()) return terms;
  for (const DepthRun& run : WeightRuns(memory, mu_kappa)) {
    if (run.weight == 0) continue;  // a stick zone adds nothing to the superposition
    terms.push_back({run.weight, profile.RadiusAtDepth(run.depth_end),
                     profile.RadiusAtDepth(run.depth_begin), run.depth_end, run.depth_begin});
  }
  return terms;
}

std::string TermField(std::size_t i, const char* name) { return Indexed("terms", i) + "." + name; }

Status ValidateTerms(const std::vector<CattaneoMindlinTerm>& terms, double depth) {
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const CattaneoMindlinTerm& t = terms[i];
    if (Status s = RequireFinite(TermField(i, "weight"), t.weight); !s.ok()) return s;
    if (Status s = RequireNonNegative(TermField(i, "depth_c"), t.depth_c); !s.ok()) return s;
    // depth_c <= depth_a <= depth: the message states the range.
    if (Status s = RequireInRange(TermField(i, "depth_a"), t.depth_a, t.depth_c, depth); !s.ok()) {
      return s;
    }
  }
  return OkStatus();
}

// Tag of a vertex against the bounds +-mu_kappa (depth - z), with the engine's round-off slack.
BoundTag TagVertex(double z, double u, double depth, double mu_kappa) {
  const double bound = CoulombBound(mu_kappa, depth, z);
  const double slack = kBoundSlack * mu_kappa * depth;
  if (bound <= 0) return kOnBoth;
  if (std::abs(u - bound) <= slack) return kOnUpper;
  if (std::abs(u + bound) <= slack) return kOnLower;
  return kInside;
}

// Coulomb admissibility of a polyline: |u| <= bound and |du/dz| <= mu_kappa, within the slack.
Status CheckCoulomb(const std::vector<double>& z, const std::vector<double>& u, double depth,
                    double mu_kappa) {
  const double slack = kBoundSlack * mu_kappa * depth;
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (std::abs(u[i]) > CoulombBound(mu_kappa, depth, z[i]) + slack) {
      return InvalidArgument("terms", "the superposition exceeds the Coulomb bound at z = " +
                                          std::to_string(z[i]) + " (|sum of weights| > 1 there)");
    }
    if (i > 0 && std::abs(u[i] - u[i - 1]) > mu_kappa * (z[i] - z[i - 1]) + slack) {
      return InvalidArgument("terms",
                             "the superposition has |F| > 1 below z = " + std::to_string(z[i]));
    }
  }
  return OkStatus();
}

}  // namespace

namespace internal {

// Jäger's weight of a memory segment, F = -(du/dz)/(mu kappa) (docs/physics.md), from the spring
// displacements at its inner and outer ends and its extent in depth.
double SegmentWeight(double u_inner, double u_outer, double depth_span, double mu_kappa) {
  return (u_inner - u_outer) / (mu_kappa * depth_span);
}

// u of one weighted basis solution at depth z: weight * mu kappa (z_a - max(z, z_c)), z <= z_a.
// In long double so that a superposition of many terms sums to the memory it came from without
// a visible loss (the terms of a decomposition telescope).
long double BasisDisplacement(const CattaneoMindlinTerm& term, double z, double mu_kappa) {
  if (!(z < term.depth_a)) return 0;
  const long double span =
      static_cast<long double>(term.depth_a) - std::max<long double>(z, term.depth_c);
  return static_cast<long double>(term.weight) * mu_kappa * span;
}

Status CheckMuKappa(const std::string& field, double mu_kappa) {
  if (Status s = RequireNonNegative(field, mu_kappa); !s.ok()) return s;
  if (mu_kappa == 0) {
    return FailedPrecondition(field,
                              "weights are undefined for mu = 0: every spring is at the bound");
  }
  return OkStatus();
}

}  // namespace internal

namespace {

// CheckMuKappa, and the same for a state in contact without a friction band (a depth of a few
// subnormals): decided by the bound the step clamps against, so exactly where every spring is on
// both bounds, as for mu = 0.
Status CheckFrictionBand(const std::string& field, const PiecewiseLinearMemory& memory,
                         double mu_kappa) {
  if (Status s = internal::CheckMuKappa(field, mu_kappa); !s.ok()) return s;
  if (memory.in_contact() && FrictionBandVanishes(mu_kappa, memory.depth())) {
    return FailedPrecondition(field, "weights are undefined at the depth " +
                                         FormatNumber(memory.depth()) +
                                         " m, where the friction band mu kappa delta rounds to 0: "
                                         "every spring is at both bounds");
  }
  return OkStatus();
}

}  // namespace

double JagerWeights::At(double r) const {
  for (const WeightInterval& interval : intervals) {
    if (r >= interval.r_begin && r < interval.r_end) return interval.weight;
  }
  return 0;
}

Result<JagerWeights> ComputeJagerWeights(const PiecewiseLinearMemory& memory,
                                         const Profile& profile, double mu_kappa) {
  if (Status s = CheckFrictionBand("mu_kappa", memory, mu_kappa); !s.ok()) return s;
  return WeightsOf(memory, profile, mu_kappa);
}

Result<JagerWeights> ComputeJagerWeights(const Contact& contact) {
  if (Status s = RequireExactMethod(contact, "method"); !s.ok()) return s;
  if (Status s = CheckFrictionBand("friction", contact.memory(), contact.mu_kappa()); !s.ok()) {
    return s;
  }
  return WeightsOf(contact.memory(), *contact.config().profile, contact.mu_kappa());
}

Result<std::vector<double>> SampleJagerWeights(const JagerWeights& weights,
                                               const std::vector<double>& radii) {
  std::vector<double> sampled;
  sampled.reserve(radii.size());
  for (std::size_t i = 0; i < radii.size(); ++i) {
    if (Status s = RequireFinite(Indexed("radii", i), radii[i]); !s.ok()) return s;
    sampled.push_back(weights.At(std::abs(radii[i])));
  }
  return sampled;
}

Result<CattaneoMindlinTerm> CattaneoMindlinTermFromRadii(double weight, double a, double c,
                                                         const Profile& profile) {
  if (Status s = RequireFinite("weight", weight); !s.ok()) return s;
  if (Status s = RequireNonNegative("c", c); !s.ok()) return s;
  if (Status s = RequireNonNegative("a", a); !s.ok()) return s;
  if (c > a) return InvalidArgument("c", "must not exceed a");
  const double depth_a = profile.G(a), depth_c = profile.G(c);
  if (!std::isfinite(depth_a)) {
    return InvalidArgument("a", "g is infinite there (flat punch edge): give the term by depths");
  }
  return CattaneoMindlinTerm{weight, a, c, depth_a, depth_c};
}

Result<std::vector<CattaneoMindlinTerm>> DecomposeMemory(const PiecewiseLinearMemory& memory,
                                                         const Profile& profile, double mu_kappa) {
  if (Status s = CheckFrictionBand("mu_kappa", memory, mu_kappa); !s.ok()) return s;
  return TermsOf(memory, profile, mu_kappa);
}

Result<std::vector<CattaneoMindlinTerm>> DecomposeMemory(const Contact& contact) {
  if (Status s = RequireExactMethod(contact, "method"); !s.ok()) return s;
  if (Status s = CheckFrictionBand("friction", contact.memory(), contact.mu_kappa()); !s.ok()) {
    return s;
  }
  return TermsOf(contact.memory(), *contact.config().profile, contact.mu_kappa());
}

Result<PiecewiseLinearMemory> MemoryFromTerms(const std::vector<CattaneoMindlinTerm>& terms,
                                              double depth, double mu_kappa) {
  if (Status s = RequireFinite("depth", depth); !s.ok()) return s;
  if (Status s = RequireNonNegative("mu_kappa", mu_kappa); !s.ok()) return s;
  if (depth <= 0) {
    if (!terms.empty()) return InvalidArgument("terms", "must be empty out of contact");
    return PiecewiseLinearMemory::Restore(depth, {}, {}, {});
  }
  if (Status s = ValidateTerms(terms, depth); !s.ok()) return s;
  std::vector<double> z = {0.0, depth};
  for (const CattaneoMindlinTerm& t : terms) {
    z.push_back(t.depth_a);
    z.push_back(t.depth_c);
  }
  std::sort(z.begin(), z.end());
  z.erase(std::unique(z.begin(), z.end()), z.end());
  std::vector<double> u(z.size());
  for (std::size_t i = 0; i < z.size(); ++i) {
    long double sum = 0;
    for (const CattaneoMindlinTerm& t : terms) sum += BasisDisplacement(t, z[i], mu_kappa);
    u[i] = static_cast<double>(sum);
  }
  if (Status s = CheckCoulomb(z, u, depth, mu_kappa); !s.ok()) return s;
  std::vector<std::uint8_t> tags(z.size());
  for (std::size_t i = 0; i < z.size(); ++i) tags[i] = TagVertex(z[i], u[i], depth, mu_kappa);
  return PiecewiseLinearMemory::Restore(depth, std::move(z), std::move(u), std::move(tags));
}
}  // namespace mdr
