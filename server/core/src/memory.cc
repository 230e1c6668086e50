#include "mdr/core/memory.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "dissipation.h"
#include "mdr/base/validate.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::Interpolate;

using internal::Linear;
using internal::LinearStep;
using internal::Quadratic;

// integral over the piece [x(za), x(zb)] with radii xa, xb of q, a quadratic in the normalised
// depth t = (g(x) - za) / (zb - za), from the profile's piece integrals (exact to round-off also
// for thin pieces).
double IntegrateQuadratic(const Profile& profile, double za, double zb, double xa, double xb,
                          const Quadratic& q) {
  const PieceIntegrals piece = profile.IntegratePiece(za, zb, xa, xb, q.c2 != 0);
  return q.c0 * piece.j0 + q.c1 * piece.j1 + q.c2 * piece.j2;
}

// The anchor that marks, during a step, the segment entering contact (memory.h, SegmentAnchor).
constexpr SegmentAnchor kEntering{kOnBoth, 0, 0};

// Ulps a crossing vertex may move toward the inside before it is put on the bound line instead.
constexpr int kMaxCrossingNudges = 4;
struct Vertex {
  double z, u;
};

// The vertex where segment (za, ua)-(zb, ub) of v crosses the bound line sigma * bound(z), at
// parameter t, or nothing when rounding puts it outside (z_prev, zb). u = v(z), interpolated from
// the end inside the bound (from a far-outside end it would cost eps |v_outside| after a large
// dux): that keeps the sticking zone exact and puts the round-off of z (~eps * depth1) on the
// slip side, which is the thin one when slip starts. So that the vertex satisfies the bound as
// Restore evaluates it, exactly, z then moves by ulps toward the inside end until
// |v(z)| <= bound(z); if a few ulps do not do it, u = sigma * bound(z).
std::optional<Vertex> PlaceCrossing(double za, double ua, double zb, double ub, double t, int sigma,
                                    bool a_inside, double z_prev, double mu_kappa, double depth1) {
  double z = za + t * (zb - za);
  if (!(z > z_prev && z < zb)) return std::nullopt;  // rounding put it on a vertex
  auto v = [&](double at) {
    return a_inside ? Interpolate(za, ua, zb, ub, at) : Interpolate(zb, ub, za, ua, at);
  };
  // z > z_prev >= 0: the neighbouring double is one step of the bit pattern (std::nextafter
  // is a library call, and this runs at every crossing).
  const std::int64_t inward = a_inside ? -1 : 1;
  double u = v(z);
  double bound = CoulombBound(mu_kappa, depth1, z);
  for (int k = 0; k < kMaxCrossingNudges && std::abs(u) > bound; ++k) {
    const double next = std::bit_cast<double>(std::bit_cast<std::int64_t>(z) + inward);
    if (!(next > z_prev && next < zb)) break;
    z = next;
    u = v(z);
    bound = CoulombBound(mu_kappa, depth1, z);
  }
  if (std::abs(u) > bound) u = sigma * bound;
  return Vertex{z, u};
}

}  // namespace

double PiecewiseLinearMemory::ApplyLinearStep(const LinearMove& move, double mu_kappa,
                                              const Profile* profile) {
  const double depth0 = depth_, depth1 = move.depth1, dux = move.dux;
  double dissipated = 0;
  if (profile != nullptr && depth1 < depth0 && depth0 > 0) {
    dissipated += LeavingDissipation(depth1, dux, mu_kappa, *profile);
  }
  depth_ = depth1;
  if (depth1 <= 0) {
    z_.clear();
    u_.clear();
    tag_.clear();
    anchor_.clear();
    return dissipated;
  }
  ShiftAndResize(depth0, depth1, dux);
  dissipated += ClampToBounds(depth0, dux, mu_kappa, move.ux1, profile);
  MergeRedundantVertices();
  return dissipated;
}

void PiecewiseLinearMemory::ShiftAndResize(double depth0, double depth1, double dux) {
  if (depth0 <= 0) {
    // Everything enters during the step: u = (1 - s_e) dux, s_e = (z - depth0)/(depth1 - depth0).
    z_.assign({0.0, depth1});
    u_.assign({dux * (depth1 / (depth1 - depth0)), 0.0});
    tag_.assign(2, kInside);
    anchor_.assign(2, SegmentAnchor{});
    anchor_[0] = kEntering;
    return;
  }
  if (depth1 < depth0) {
    // Springs beyond depth1 leave; the polyline is cut at depth1.
    const auto j =
        static_cast<std::size_t>(std::lower_bound(z_.begin(), z_.end(), depth1) - z_.begin());
    if (z_[j] != depth1) {
      u_[j] = Interpolate(z_[j - 1], u_[j - 1], z_[j], u_[j], depth1);
      z_[j] = depth1;
    }
    z_.resize(j + 1);
    u_.resize(j + 1);
    tag_.resize(j + 1);
    anchor_.resize(j + 1);
    anchor_[j] = SegmentAnchor{};  // the new edge starts no segment
  }
  for (double& u : u_) u += dux;
  if (depth1 > depth0) {
    // Springs in (depth0, depth1] enter: u = (1 - s_e) dux, linear from dux at depth0 to 0.
    z_.push_back(depth1);
    u_.push_back(0.0);
    tag_.push_back(kInside);
    anchor_.back() = kEntering;
    anchor_.push_back(SegmentAnchor{});
  }
}

double PiecewiseLinearMemory::ClampToBounds(double depth0, double dux, double mu_kappa, double ux1,
                                            const Profile* profile) {
  InsertCrossings(depth0, dux, mu_kappa, ux1);
  const double dissipated = profile != nullptr && mu_kappa > 0
                                ? SlidingDissipation(depth0, dux, mu_kappa, *profile)
                                : 0.0;
  TagAndClampVertices(mu_kappa, ux1);
  return dissipated;
}

namespace {

// The bound sigma = +1 (kOnUpper) or -1 (kOnLower).
double Sign(BoundTag bound) { return bound == kOnUpper ? 1.0 : -1.0; }

// How far a refined vertex's unclamped value v lies beyond the upper and the lower bound b
// (sigma v - b); exactly 0 at a crossing of that bound.
struct Excess {
  double upper, lower;
};
Excess ExcessAt(double v, double b, std::uint8_t crossing) {
  return {crossing == kOnUpper ? 0.0 : v - b, crossing == kOnLower ? 0.0 : -v - b};
}

// A segment whose ends have the clamp excesses ea and eb over one bound: the clamp puts it on the
// bound if the excess is positive inside it (crossings split sign changes, so the sum decides
// where round-off put a crossing on a vertex) or zero at both ends (a segment lying on the bound
// line stays there).
bool ClampedOnto(double ea, double eb) { return (ea >= 0 && eb >= 0) || ea + eb > 0; }

// The bound a segment is clamped onto by its ends' excesses (the larger if both claim it); not
// the one its anchor has already decided it is inside of.
BoundTag ClampedBound(const Excess& a, const Excess& b, BoundTag anchored) {
  const bool upper = anchored != kOnUpper && ClampedOnto(a.upper, b.upper);
  const bool lower = anchored != kOnLower && ClampedOnto(a.lower, b.lower);
  if (upper && lower) return a.upper + b.upper >= a.lower + b.lower ? kOnUpper : kOnLower;
  return upper ? kOnUpper : lower ? kOnLower : kInside;
}

}  // namespace

void PiecewiseLinearMemory::InsertCrossings(double depth0, double dux, double mu_kappa,
                                            double ux1) {
  // The points where v crosses +bound or -bound (both linear in z) are marked with their bound.
  // Each refined segment is classified as it is built, by one decision (docs/engine.md, "Slip
  // state, decided structurally"): from the anchor of the old segment it lies in where it has one
  // (a segment that sticks moves rigidly, so its excess over the anchor's bound is AnchorExcess,
  // the same at every spring); for the segment entering contact from the step's sliding rate (its
  // excess over either bound is that rate times (1 - s_e), one sign along it); from the clamp's
  // excess at its ends otherwise. |F| <= 1 makes every spring beyond one on a bound lie on that
  // bound too (u(z) = mu kappa integral_z^delta F, the bound mu kappa (delta - z)): the slip zone
  // is one outer annulus, so the first segment on a bound decides for all beyond it, which only a
  // tie (a step at exactly the limiting ratio dux / ddelta = mu kappa) could set apart.
  const double depth1 = depth_;
  auto bound_at = [&](double z) { return CoulombBound(mu_kappa, depth1, z); };
  const internal::LinearStep step{depth0, depth1, dux, mu_kappa};
  const BoundTag entering = step.SlidingRate(+1) >= 0   ? kOnUpper
                            : step.SlidingRate(-1) >= 0 ? kOnLower
                                                        : kInside;
  auto& rz = next_.z;
  auto& rv = next_.u;
  auto& crossing = next_.crossing;
  auto& anchor = next_.anchor;
  const std::size_t n = z_.size();
  rz.clear();
  rv.clear();
  crossing.clear();
  anchor.clear();
  // At most two crossings per segment: one allocation per buffer at most (a copied memory starts
  // with empty ones), none once they have grown.
  rz.reserve(3 * n);
  rv.reserve(3 * n);
  crossing.reserve(3 * n);
  anchor.reserve(3 * n);
  BoundTag& slip = next_.slip;  // the bound of the slip annulus, once it has started
  slip = kInside;
  double b_a = bound_at(z_[0]);
  for (std::size_t i = 0; i < n; ++i) {
    rz.push_back(z_[i]);
    rv.push_back(u_[i]);
    crossing.push_back(kInside);
    if (i + 1 == n) break;
    const std::size_t first = rz.size() - 1;
    const double za = z_[i], zb = z_[i + 1], b_b = bound_at(zb);
    const double hi_a = u_[i] - b_a, hi_b = u_[i + 1] - b_b;
    const double lo_a = u_[i] + b_a, lo_b = u_[i + 1] + b_b;
    b_a = b_b;
    double t[2];
    int sign[2];
    int count = 0;
    if (hi_a * hi_b < 0) t[count] = hi_a / (hi_a - hi_b), sign[count++] = +1;
    if (lo_a * lo_b < 0) t[count] = lo_a / (lo_a - lo_b), sign[count++] = -1;
    if (count == 2 && t[1] < t[0]) std::swap(t[0], t[1]), std::swap(sign[0], sign[1]);
    for (int k = 0; k < count; ++k) {
      const bool a_inside = sign[k] > 0 ? hi_a < 0 : lo_a > 0;
      const std::optional<Vertex> at = PlaceCrossing(za, u_[i], zb, u_[i + 1], t[k], sign[k],
                                                     a_inside, rz.back(), mu_kappa, depth1);
      if (!at) continue;
      rz.push_back(at->z);
      rv.push_back(at->u);
      crossing.push_back(sign[k] > 0 ? kOnUpper : kOnLower);
    }
    // The refined segments from vertex i to vertex i + 1 (pushed next), in the old segment i.
    const SegmentAnchor& old = anchor_[i];
    const bool is_entering = old == kEntering;
    const std::size_t end = rz.size();
    for (std::size_t k = first; k < end; ++k) {
      if (slip == kInside) {
        next_.first_slipping = k;
        if (is_entering) {
          slip = entering;
        } else if (old.bound != kInside && AnchorExcess(old, mu_kappa, depth1, ux1) >= 0) {
          slip = old.bound;
        } else {
          const bool last = k + 1 == end;  // ends at old vertex i + 1
          slip =
              ClampedBound(ExcessAt(rv[k], bound_at(rz[k]), crossing[k]),
                           ExcessAt(last ? u_[i + 1] : rv[k + 1], last ? b_b : bound_at(rz[k + 1]),
                                    last ? std::uint8_t{kInside} : crossing[k + 1]),
                           old.bound);
        }
      }
      anchor.push_back(slip != kInside ? SegmentAnchor{slip, ux1, depth1}
                       : is_entering   ? SegmentAnchor{}
                                       : old);
    }
  }
  anchor.push_back(SegmentAnchor{});  // the last vertex starts no segment
}

double PiecewiseLinearMemory::SlidingDissipation(double depth0, double dux, double mu_kappa,
                                                 const Profile& profile) const {
  // Springs that slid along the bound (exact per spring, dissipation.h): e, the amount the clamp
  // removes, and the bound b1 are linear in z, so in t = (z - za)/(zb - za), on each refined
  // segment.
  const auto& rz = next_.z;
  const auto& rv = next_.u;
  const auto& crossing = next_.crossing;
  const LinearStep step{depth0, depth_, dux, mu_kappa};
  // Radius of the vertex last asked for: neighbouring sliding segments share a vertex.
  std::size_t known = rz.size();
  double known_radius = 0;
  auto radius = [&](std::size_t i) {
    if (i != known) known = i, known_radius = profile.RadiusAtDepth(rz[i]);
    return known_radius;
  };
  double dissipated = 0;
  for (int sigma : {+1, -1}) {
    auto excess = [&](std::size_t i) {  // crossings: exactly 0
      return crossing[i] != kInside ? 0.0 : sigma * rv[i] - step.BoundAtEnd(rz[i]);
    };
    double e_next = excess(0);
    if (e_next > 0 && radius(0) > 0) {  // the z = 0 atom of a flat punch
      dissipated +=
          radius(0) * internal::ClampedSpringDissipation(step, sigma, e_next, step.BoundAtEnd(0));
    }
    for (std::size_t i = 0; i + 1 < rz.size(); ++i) {
      // Sign changes of the excess were split at crossings, unless round-off put the crossing
      // on a vertex: then the segment slides if the crossing is at its non-positive end (the end
      // nearer zero), and sticks otherwise.
      double ea = e_next, eb = excess(i + 1);
      e_next = eb;
      if (ea <= 0 && eb <= 0) continue;
      if (ea < 0 || eb < 0) {
        if (std::min(ea, eb) + std::max(ea, eb) <= 0) continue;
        ea = std::max(ea, 0.0);
        eb = std::max(eb, 0.0);
      }
      const Linear e{ea, eb - ea};
      const Linear b1{step.BoundAtEnd(rz[i]), -mu_kappa * (rz[i + 1] - rz[i])};
      dissipated += IntegrateQuadratic(profile, rz[i], rz[i + 1], radius(i), radius(i + 1),
                                       internal::ClampedSpringDissipation(step, sigma, e, b1));
    }
  }
  return dissipated;
}

void PiecewiseLinearMemory::TagAndClampVertices(double mu_kappa, double ux1) {
  // A vertex is on the bound of the segments it ends (one bound at most: the slip zone is one
  // annulus); one that ends none sticks and is clamped only against round-off. A crossing keeps
  // its interpolated u (a few ulps inside the bound, so that the sticking side stays exact);
  // every other vertex on a bound takes the bound's value. Where the bound is 0 (the edge, or
  // everywhere for mu = 0) u = 0 on both bounds.
  const double depth1 = depth_;
  auto& rz = next_.z;
  auto& rv = next_.u;
  auto& tags = next_.tag;
  // Segments first_slipping .. m - 2 are on the bound `slip` (none if kInside).
  const BoundTag slip = next_.slip;
  const std::size_t first_slipping = next_.first_slipping;
  const std::size_t m = rz.size();
  tags.resize(m);
  bool zero_bound_inside = false;  // round-off or mu = 0: see below
  for (std::size_t k = 0; k < m; ++k) {
    const double b = CoulombBound(mu_kappa, depth1, rz[k]);
    if (!(b > 0)) {
      rv[k] = 0;
      tags[k] = kOnBoth;
      zero_bound_inside |= k + 1 < m;
      continue;
    }
    const BoundTag tag = slip != kInside && k >= first_slipping ? slip : kInside;
    tags[k] = tag;
    if (tag == kInside) {
      rv[k] = std::clamp(rv[k], -b, b);
    } else if (next_.crossing[k] != tag) {
      rv[k] = Sign(tag) * b;
    }
  }
  // A segment is on the bound both its ends are tagged with. That is its own bound, except
  // where round-off makes the bound 0 inside the contact (mu = 0, a subnormal depth): a vertex
  // there is on both bounds, and so are segments between two such vertices (anchored on
  // neither) and one from there to a vertex on a bound (anchored on that one).
  for (std::size_t k = 0; zero_bound_inside && k + 1 < m; ++k) {
    const auto on = static_cast<BoundTag>(tags[k] & tags[k + 1]);
    if (on == kOnBoth) {
      next_.anchor[k] = SegmentAnchor{};
    } else if (on != (slip != kInside && k >= first_slipping ? slip : kInside)) {
      next_.anchor[k] = {on, ux1, depth1};
    }
  }
  std::swap(z_, next_.z);
  std::swap(u_, next_.u);
  std::swap(tag_, next_.tag);
  std::swap(anchor_, next_.anchor);
}

void PiecewiseLinearMemory::MergeRedundantVertices() {
  // A vertex goes if the segments on both sides are one piece: the same slip state and anchor,
  // and the same bound line or (to round-off) one straight line; so memory grows only with the
  // nesting depth of reversals, and a merge never changes a segment's slip state.
  constexpr double kCollinear = 16 * std::numeric_limits<double>::epsilon();
  const std::size_t n = z_.size();
  if (n < 3) return;
  std::size_t kept = 1;  // vertex 0 always stays
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const std::size_t prev = kept - 1;
    bool redundant =
        (tag_[prev] & tag_[i]) == (tag_[i] & tag_[i + 1]) && anchor_[prev] == anchor_[i];
    if (redundant && (tag_[prev] & tag_[i] & tag_[i + 1]) == 0) {
      const double line = Interpolate(z_[prev], u_[prev], z_[i + 1], u_[i + 1], z_[i]);
      const double scale = std::max({std::abs(u_[prev]), std::abs(u_[i]), std::abs(u_[i + 1])});
      redundant = std::abs(u_[i] - line) <= kCollinear * scale;
    }
    if (redundant) continue;
    z_[kept] = z_[i];
    u_[kept] = u_[i];
    tag_[kept] = tag_[i];
    anchor_[kept] = anchor_[i];
    ++kept;
  }
  z_[kept] = z_[n - 1];
  u_[kept] = u_[n - 1];
  tag_[kept] = tag_[n - 1];
  anchor_[kept] = anchor_[n - 1];
  z_.resize(kept + 1);
  u_.resize(kept + 1);
  tag_.resize(kept + 1);
  anchor_.resize(kept + 1);
}

double PiecewiseLinearMemory::LeavingDissipation(double depth1, double dux, double mu_kappa,
                                                 const Profile& profile) const {
  // A spring at z leaves at s_l = (depth0 - z)/(depth0 - depth1), on the side sigma =
  // sign(u0 + s_l dux), and dissipates from the onset bound b* on (dissipation.h); b* is linear
  // in z (and in t) between sign changes of u0 + s_l dux.
  if (!(mu_kappa > 0)) return 0;
  const LinearStep step{depth_, depth1, dux, mu_kappa};
  const double depth0 = depth_;
  auto leave_value = [&](double z, double u0) { return u0 + (depth0 - z) / -step.ddelta() * dux; };
  auto add_piece = [&](double za, double ua, double zb, double ub) {
    const double wa = leave_value(za, ua), wb = leave_value(zb, ub);
    if (wa == 0 && wb == 0) return 0.0;
    const int sigma = (wa + wb) > 0 ? +1 : -1;
    if (!(step.SlidingRate(sigma) > 0)) return 0.0;  // the bound is never reached
    const double ba = step.SlideOnsetBound(za, ua, sigma), bb = step.SlideOnsetBound(zb, ub, sigma);
    const Linear b_star{ba, bb - ba};
    return IntegrateQuadratic(profile, za, zb, profile.RadiusAtDepth(za), profile.RadiusAtDepth(zb),
                              internal::LeavingSpringDissipation(step, sigma, b_star));
  };

  double dissipated = 0;
  const double z_low = std::max(depth1, 0.0);
  const double atom = profile.RadiusAtDepth(0);
  if (depth1 <= 0 && atom > 0) {
    const double w = leave_value(0, u_[0]);
    const int sigma = w > 0 ? +1 : -1;
    if (w != 0 && step.SlidingRate(sigma) > 0) {
      dissipated += atom * internal::LeavingSpringDissipation(
                               step, sigma, step.SlideOnsetBound(0, u_[0], sigma));
    }
  }
  for (std::size_t i = 0; i + 1 < z_.size(); ++i) {
    if (z_[i + 1] <= z_low) continue;
    double za = z_[i], ua = u_[i];
    const double zb = z_[i + 1], ub = u_[i + 1];
    if (za < z_low) {
      ua = Interpolate(za, ua, zb, ub, z_low);
      za = z_low;
    }
    const double wa = leave_value(za, ua), wb = leave_value(zb, ub);
    if (wa * wb < 0) {  // the sliding direction changes inside the piece
      const double zc = za + (zb - za) * (wa / (wa - wb));
      const double uc = Interpolate(za, ua, zb, ub, zc);
      dissipated += add_piece(za, ua, zc, uc) + add_piece(zc, uc, zb, ub);
    } else {
      dissipated += add_piece(za, ua, zb, ub);
    }
  }
  return dissipated;
}

void PiecewiseLinearMemory::MoveLeadingVertices(std::size_t count, VertexRun& run) {
  auto move = [count](auto& from, auto& to) {
    to.insert(to.end(), from.begin(), from.begin() + static_cast<std::ptrdiff_t>(count));
    from.erase(from.begin(), from.begin() + static_cast<std::ptrdiff_t>(count));
  };
  move(z_, run.z);
  move(u_, run.u);
  move(tag_, run.tag);
  move(anchor_, run.anchor);
}

void PiecewiseLinearMemory::RestoreLeadingVertices(VertexRun& run) {
  auto restore = [](auto& from, auto& to) {
    to.insert(to.begin(), from.begin(), from.end());
    from.clear();
  };
  restore(run.z, z_);
  restore(run.u, u_);
  restore(run.tag, tag_);
  restore(run.anchor, anchor_);
  // Apart, the first vertex kept could not merge with those in front of it; every step ends
  // with this pass, so the memory is what sub-stepping every spring would have left.
  MergeRedundantVertices();
}

double PiecewiseLinearMemory::UAtDepth(double z) const {
  if (z_.empty() || z < 0 || z > depth_) return 0;
  return UBeforeVertex(
      static_cast<std::size_t>(std::upper_bound(z_.begin(), z_.end(), z) - z_.begin()), z);
}

double PiecewiseLinearMemory::UAtIncreasingDepth(double z, std::size_t& next) const {
  if (z_.empty() || z < 0 || z > depth_) return 0;
  while (next < z_.size() && z_[next] <= z) ++next;  // upper_bound, from where the last one was
  return UBeforeVertex(next, z);
}

double PiecewiseLinearMemory::UBeforeVertex(std::size_t j, double z) const {
  if (j >= z_.size()) return u_.back();
  if (j == 0) return u_.front();
  return Interpolate(z_[j - 1], u_[j - 1], z_[j], u_[j], z);
}

double PiecewiseLinearMemory::IntegralU(const Profile& profile) const {
  if (z_.empty()) return 0;
  double xa = profile.RadiusAtDepth(0);
  double total = u_[0] * xa;  // flat punch: springs at z = 0
  for (std::size_t i = 0; i + 1 < z_.size(); ++i) {
    const double xb = profile.RadiusAtDepth(z_[i + 1]);
    const PieceIntegrals piece = profile.IntegratePiece(z_[i], z_[i + 1], xa, xb, false);
    total += u_[i] * piece.j0 + (u_[i + 1] - u_[i]) * piece.j1;
    xa = xb;
  }
  return total;
}

double PiecewiseLinearMemory::MeasureSticking(const Profile& profile, BoundTag bound) const {
  if (z_.empty()) return 0;
  const std::size_t n = z_.size();
  double measure = (tag_[0] & bound) ? 0 : profile.RadiusAtDepth(0);  // a flat punch's atom
  // Runs of segments off the bound, each measured as one difference of radii (the stick disc
  // [0, c] is then c exactly, with no cancellation however small c is), or piece by piece by J_0
  // where a run is a thin annulus and the difference would cancel.
  std::size_t i = 0;
  while (i + 1 < n) {
    if (tag_[i] & tag_[i + 1] & bound) {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j + 1 < n && !(tag_[j] & tag_[j + 1] & bound)) ++j;
    const double xa = profile.RadiusAtDepth(z_[i]), xb = profile.RadiusAtDepth(z_[j]);
    if (xa <= 0.5 * xb) {
      measure += xb - xa;
    } else {
      for (std::size_t k = i; k < j; ++k) {
        measure += profile
                       .IntegratePiece(z_[k], z_[k + 1], profile.RadiusAtDepth(z_[k]),
                                       profile.RadiusAtDepth(z_[k + 1]), false)
                       .j0;
      }
    }
    i = j;
  }
  return measure;
}

double PiecewiseLinearMemory::GrossSlipIncrement(double depth1, double mu_kappa,
                                                 int direction) const {
  // Springs that stay in contact reach the bound once sigma (u0 + dux) >= b1; springs that
  // enter do once |dux| >= mu_kappa (depth1 - depth0).
  const double sigma = direction >= 0 ? 1.0 : -1.0;
  const double depth0 = depth_;
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  double needed = depth1 > depth0 ? mu_kappa * (depth1 - depth0) : kNone;
  for (std::size_t i = 0; i < z_.size() && depth1 > 0; ++i) {
    double z = z_[i], u = u_[i];
    if (z > depth1) {
      z = depth1;
      u = UAtDepth(depth1);
    }
    needed = std::max(needed, CoulombBound(mu_kappa, depth1, z) - sigma * u);
    if (z == depth1) break;
  }
  return needed == kNone ? 0.0 : sigma * needed;
}

std::vector<MemoryPiece> PiecewiseLinearMemory::Pieces(const Profile& profile) const {
  std::vector<MemoryPiece> pieces;
  if (z_.empty()) return pieces;
  const double atom = profile.RadiusAtDepth(0);
  if (atom > 0) {
    pieces.push_back({0, atom, 0, 0, u_[0], 0, static_cast<BoundTag>(tag_[0])});
  }
  for (std::size_t i = 0; i + 1 < z_.size(); ++i) {
    const double xa = profile.RadiusAtDepth(z_[i]), xb = profile.RadiusAtDepth(z_[i + 1]);
    if (!(xb > xa)) continue;
    const double slope = (u_[i + 1] - u_[i]) / (z_[i + 1] - z_[i]);
    pieces.push_back({xa, xb, z_[i], z_[i + 1], u_[i] - slope * z_[i], slope,
                      static_cast<BoundTag>(tag_[i] & tag_[i + 1])});
  }
  return pieces;
}

Result<PiecewiseLinearMemory> PiecewiseLinearMemory::Restore(double depth, std::vector<double> z,
                                                             std::vector<double> u,
                                                             std::vector<std::uint8_t> tags,
                                                             std::vector<SegmentAnchor> anchors,
                                                             double tangential_displacement) {
  if (!std::isfinite(depth)) return InvalidArgument("depth", "must be finite");
  const std::size_t n = z.size();
  if (u.size() != n || tags.size() != n) {
    return InvalidArgument("memory", "z, u and tags must have the same length");
  }
  if (!anchors.empty() && anchors.size() != n) {
    return InvalidArgument("memory", "needs an anchor on every vertex or on none");
  }
  if (depth <= 0 ? n != 0 : n < 2) {
    return InvalidArgument("memory", depth <= 0 ? "must be empty out of contact"
                                                : "needs at least 2 vertices in contact");
  }
  for (std::size_t i = 0; i < n; ++i) {  // field names built only for an error
    if (!std::isfinite(z[i]) || !std::isfinite(u[i]) || tags[i] > kOnBoth) {
      return InvalidArgument(Indexed("memory", i), "z and u must be finite and the tag in 0..3");
    }
    if (i > 0 && !(z[i] > z[i - 1])) {
      return InvalidArgument(Indexed("memory", i), "z must increase strictly");
    }
  }
  if (n > 0 && (z.front() != 0 || z.back() != depth || u.back() != 0)) {
    return InvalidArgument("memory", "must start at z = 0 and end at z = depth with u = 0");
  }
  anchors.resize(n);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const auto on = static_cast<BoundTag>(tags[i] & tags[i + 1]);
    if (anchors[i].bound == kInside && (on == kOnUpper || on == kOnLower)) {
      anchors[i] = {on, tangential_displacement, depth};  // a snapshot without anchors
    }
  }
  PiecewiseLinearMemory memory;
  memory.depth_ = depth;
  memory.z_ = std::move(z);
  memory.u_ = std::move(u);
  memory.tag_ = std::move(tags);
  memory.anchor_ = std::move(anchors);
  return memory;
}

double PiecewiseLinearMemory::BoundTagTolerance(std::size_t i, double mu_kappa) const {
  // Steepest neighbouring segment: the crossing was placed on one of them (or on a segment
  // collinear with one to 16 eps, if a merge removed its inside end).
  double slope = 0;
  if (i > 0) slope = std::abs((u_[i] - u_[i - 1]) / (z_[i] - z_[i - 1]));
  if (i + 1 < z_.size()) {
    slope = std::max(slope, std::abs((u_[i + 1] - u_[i]) / (z_[i + 1] - z_[i])));
  }
  // z is off the exact crossing by the rounding of t (~3 eps mu_kappa depth / |v' + mu_kappa|),
  // of za + t (zb - za) (2 eps depth) and up to kMaxCrossingNudges ulps; u adds the interpolation
  // (eps (|u| + |v'| depth)) and bound(z) its own (eps bound). 32 covers the sum with margin.
  constexpr double kTagUlps = 32;
  return kTagUlps * std::numeric_limits<double>::epsilon() * depth_ * (mu_kappa + slope);
}

Status PiecewiseLinearMemory::CheckReachable(double mu_kappa,
                                             double tangential_displacement) const {
  if (Status s = CheckCoulomb(mu_kappa); !s.ok()) return s;
  if (Status s = CheckFrictionCone(mu_kappa); !s.ok()) return s;
  return CheckAnchors(mu_kappa, tangential_displacement);
}

Status PiecewiseLinearMemory::CheckFrictionCone(double mu_kappa) const {
  for (std::size_t i = 0; i + 1 < z_.size(); ++i) {
    if (WithinFrictionCone(z_[i], u_[i], z_[i + 1], u_[i + 1], mu_kappa, depth_)) continue;
    const double slope = (u_[i + 1] - u_[i]) / (z_[i + 1] - z_[i]);
    return InvalidArgument(Indexed("memory", i),
                           "the segment to the next vertex is steeper than the friction cone: "
                           "|du/dz| = " +
                               FormatNumber(std::abs(slope)) +
                               " > mu kappa = " + FormatNumber(mu_kappa) +
                               " (a Jager weight beyond +-1, which no loading history makes)");
  }
  return OkStatus();
}

Status PiecewiseLinearMemory::CheckCoulomb(double mu_kappa) const {
  for (std::size_t i = 0; i < z_.size(); ++i) {
    const double bound = CoulombBound(mu_kappa, depth_, z_[i]);
    const auto at = [i] { return Indexed("memory", i); };  // only for an error
    if (!(std::abs(u_[i]) <= bound)) {
      return InvalidArgument(
          at(), "|u| = " + FormatNumber(std::abs(u_[i])) +
                    " exceeds the Coulomb bound mu kappa (depth - z) = " + FormatNumber(bound) +
                    " by " + FormatNumber(std::abs(u_[i]) - bound));
    }
    if (tag_[i] == kOnBoth) {
      if (bound != 0) {
        return InvalidArgument(at(),
                               "tag 3 (on both bounds) needs a zero bound (z = depth or "
                               "mu = 0), got mu kappa (depth - z) = " +
                                   FormatNumber(bound));
      }
      continue;
    }
    const int sigma = tag_[i] == kOnUpper ? +1 : tag_[i] == kOnLower ? -1 : 0;
    if (sigma != 0 && sigma * u_[i] < bound - BoundTagTolerance(i, mu_kappa)) {
      return InvalidArgument(at(), std::string("is tagged on the ") +
                                       (sigma > 0 ? "upper" : "lower") +
                                       " bound but u = " + FormatNumber(u_[i]) +
                                       " is off it (bound " + FormatNumber(bound) + ", tolerance " +
                                       FormatNumber(BoundTagTolerance(i, mu_kappa)) + ")");
    }
  }
  return OkStatus();
}

Status CheckAnchor(const SegmentAnchor& anchor, BoundTag on, double mu_kappa, double depth,
                   double tangential_displacement, const std::string& field) {
  if (anchor.bound > kOnLower || !std::isfinite(anchor.tangential_displacement) ||
      !std::isfinite(anchor.depth)) {
    return InvalidArgument(field,
                           "needs bound INSIDE, UPPER or LOWER and a finite depth and "
                           "tangential_displacement");
  }
  if (on == kOnUpper || on == kOnLower) {
    if (anchor != SegmentAnchor{on, tangential_displacement, depth}) {
      return InvalidArgument(field,
                             "the springs lie on a bound, so they must be anchored on "
                             "that bound at the contact's current depth and displacement");
    }
    return OkStatus();
  }
  if (anchor.bound == kInside) return OkStatus();
  if (on == kOnBoth) return InvalidArgument(field, "must be empty where the bound is 0");
  const double excess = AnchorExcess(anchor, mu_kappa, depth, tangential_displacement);
  if (!(excess < 0)) {
    return InvalidArgument(field,
                           "the springs stick, so they must lie strictly inside the bound "
                           "they are anchored on; their excess over it is " +
                               FormatNumber(excess) + " m");
  }
  return OkStatus();
}

Status PiecewiseLinearMemory::CheckAnchors(double mu_kappa, double tangential_displacement) const {
  for (std::size_t i = 0; i < anchor_.size(); ++i) {
    const auto at = [i] { return Indexed("memory", i) + ".anchor"; };  // only for an error
    if (i + 1 == anchor_.size()) {
      if (anchor_[i] != SegmentAnchor{}) {
        return InvalidArgument(at(), "must be empty on the last vertex (it starts no segment)");
      }
      break;
    }
    const auto on = static_cast<BoundTag>(tag_[i] & tag_[i + 1]);
    if (!CheckAnchor(anchor_[i], on, mu_kappa, depth_, tangential_displacement, "").ok()) {
      return CheckAnchor(anchor_[i], on, mu_kappa, depth_, tangential_displacement, at());
    }
  }
  return OkStatus();
}

std::optional<double> NearestReturn(const std::vector<SegmentAnchor>& anchors, double depth,
                                    double ux, double tolerance) {
  std::optional<double> nearest;
  for (const SegmentAnchor& anchor : anchors) {
    if (anchor.bound == kInside || anchor.depth != depth) continue;
    const double distance = std::abs(anchor.tangential_displacement - ux);
    if (distance <= tolerance && (!nearest || distance < std::abs(*nearest - ux))) {
      nearest = anchor.tangential_displacement;
    }
  }
  return nearest;
}

}  // namespace mdr
