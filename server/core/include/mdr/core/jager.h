// The Jäger picture of a tangential contact state (docs/physics.md, "Jäger picture and the
// transformation"): the state as a superposition of Cattaneo-Mindlin basis solutions, and back.
//
// The MDR memory u is a polyline in z = g(x), so u'(x) = (du/dz) g'(x) and the Jäger weight
// F(x) = -u'(x)/(mu kappa g'(x)) = -(du/dz)/(mu kappa) is exactly a step function: one constant
// per memory segment. A segment [z_k, z_{k+1}] with weight F_k is the basis solution
// F_k * u_B(x; a = g^-1(z_{k+1}), c = g^-1(z_k)), and u vanishes at the contact edge, so the sum
// over segments is the state itself, with no truncation.
//
// Basis solutions are identified by depths (z_a = g(a), z_c = g(c)) as well as radii: for a flat
// punch g jumps at a0, so every basis solution has a = c = a0 and only the depths tell them
// apart. Round trips go through the depths and are exact to round-off.
#pragma once

#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/memory.h"
#include "mdr/core/profile.h"

namespace mdr {

// F = weight on the radial interval (r_begin, r_end), which holds the springs of depths
// (depth_begin, depth_end).
struct WeightInterval {
  double r_begin, r_end;
  double depth_begin, depth_end;
  double weight;
};

// The exact step function F of a contact state.
//
// Flat punch: g = 0 inside a0, so every spring sits at z = 0 and the springs of depth z > 0 have
// no radial extent; the weight is concentrated at the edge r = a0 (a point weight, like the
// pressure's 1/sqrt(a0^2 - r^2) edge singularity). It is reported as edge_weight =
// u_0/(mu kappa delta), the weight per unit depth of the memory averaged over the edge, with
// `intervals` empty: tau(r) = edge_weight * mu * p(r; delta), i.e. stick tau = G* u_0 /
// (pi sqrt(a0^2 - r^2)), and edge_weight = 1 at gross slip.
struct JagerWeights {
  double contact_radius = 0;  // 0 out of contact (then everything is empty/zero)
  // Consecutive intervals covering (first r_begin, contact_radius), one per maximal run of memory
  // segments of one weight (to round-off); zero weights (stick zones) included. They start at
  // RadiusAtDepth(0): 0 for profiles with g > 0 off the axis.
  std::vector<WeightInterval> intervals;
  double edge_weight = 0;  // flat punch only (see above), 0 otherwise

  // F(r): the weight of the interval with r_begin <= r < r_end; 0 where no interval is (outside
  // contact, inside a flat punch, where the weight is the point weight at the edge).
  double At(double r) const;
};

// Weights of a memory for mu*kappa = mu_kappa. FailedPrecondition (field "mu_kappa") if
// mu_kappa == 0: every spring is then at the bound u = 0 and F = 0/0. InvalidArgument if
// mu_kappa is negative or not finite.
Result<JagerWeights> ComputeJagerWeights(const PiecewiseLinearMemory& memory,
                                         const Profile& profile, double mu_kappa);
// Same for a contact; the mu = 0 error names the field "friction".
Result<JagerWeights> ComputeJagerWeights(const Contact& contact);

// F sampled at the given radii (|r| is used; each finite, field "radii[i]").
Result<std::vector<double>> SampleJagerWeights(const JagerWeights& weights,
                                               const std::vector<double>& radii);

// One Cattaneo-Mindlin basis solution with its weight (the kappa_i of docs/physics.md, named weight
// here to keep kappa = E*/G*): in MDR form
//   u = weight * mu kappa (depth_a - max(z, depth_c)) for z = g(x) <= depth_a, 0 beyond,
// i.e. weight * u_B(x; a, c) with u_B = mu kappa (g(a) - g(max(x, c))); its traction is
// weight * mu [p(r; a) - p(r; c)] for r <= c and weight * mu p(r; a) for c < r <= a.
// The depths are authoritative; a = g^-1(depth_a), c = g^-1(depth_c) are for reading.
struct CattaneoMindlinTerm {
  double weight;
  double a, c;
  double depth_a, depth_c;
};

// A term from radii (c <= a, both >= 0 and finite; weight finite), with depths from g. For a
// flat punch use depths: g is infinite at a0.
Result<CattaneoMindlinTerm> CattaneoMindlinTermFromRadii(double weight, double a, double c,
                                                         const Profile& profile);

// The shortest superposition equal to the memory: one term per maximal run of segments of one
// weight, i.e. whose inner vertices lie on one line to 4 eps of |u| (the superposition rule
// tau_B(a_i, a_j) + tau_B(a_j, a_k) = tau_B(a_i, a_k) merges them), ordered from the centre out,
// terms of weight 0 omitted. Errors as ComputeJagerWeights.
// Round trip: MemoryFromTerms(DecomposeMemory(m), depth, mu_kappa) has the vertices of m (the
// engine never leaves vertices that close to a line) and its u to a few eps of max |u| (the weights
// are rounded; a vertex where u nearly cancels keeps that absolute, not a relative, accuracy).
Result<std::vector<CattaneoMindlinTerm>> DecomposeMemory(const PiecewiseLinearMemory& memory,
                                                         const Profile& profile, double mu_kappa);
Result<std::vector<CattaneoMindlinTerm>> DecomposeMemory(const Contact& contact);

// The inverse: the memory at `depth` whose u is the sum of the terms (any terms, overlapping or
// not). Vertices at 0, depth and every term's depths. Fails (InvalidArgument, field "terms[i]...")
// unless 0 <= depth_c <= depth_a <= depth and the weight is finite, and (field "terms") unless
// the sum respects the Coulomb bound |u| <= mu_kappa (depth - z) and |du/dz| <= mu_kappa, to
// 8 eps mu_kappa depth (the engine's own round-off at bound crossings). Vertices within that
// distance of a bound are tagged as on it. depth <= 0 needs an empty list (out of contact).
// The memory has no loading history: it stands at its own tangential displacement 0, where its
// segments on a bound are anchored (memory.h, SegmentAnchor).
Result<PiecewiseLinearMemory> MemoryFromTerms(const std::vector<CattaneoMindlinTerm>& terms,
                                              double depth, double mu_kappa);

}  // namespace mdr
