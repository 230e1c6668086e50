// Force-controlled tangential steps on the exact memory: the increment whose linear step gives a
// tangential force, found on the piecewise closed form of F_x(dux) instead of by stepping copies.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "mdr/core/memory.h"
#include "monotone_solve.h"
#include "numerics.h"

namespace mdr {
namespace {

using internal::Interpolate;
using internal::ValueAndSlope;

using Vertex = ForceSolveBuffers::Vertex;

// integral_0^a1 u dx after a linear step from depth0 to depth1 with increment dux, as a function
// of dux, with its slope. As the step does it (memory.cc, ShiftAndResize and the clamp), a spring
// that stays in contact ends at clamp(u + dux, -b1, b1), b1 = CoulombBound(mu_kappa, depth1, z),
// and the entering springs end at clamp(dux, -L, L) (depth1 - z) / ddelta, L = mu_kappa ddelta.
// On a segment of the polyline, b1 - u - dux and -b1 - u - dux are linear in z, so each segment
// splits into at most three pieces (upper bound, stick, lower bound) where the end value is
// linear in z, hence in the piece's t = (z - z_begin) / (z_end - z_begin), and integrates
// exactly with Profile::IntegratePiece.
class IntegralAfterStep {
 public:
  IntegralAfterStep(const PiecewiseLinearMemory& memory, double depth1, double mu_kappa,
                    const Profile& profile, std::vector<Vertex>& vertices)
      : depth1_(depth1), mu_kappa_(mu_kappa), profile_(profile), vertices_(vertices) {
    vertices_.clear();
    AddStayingSprings(memory);
    AddEnteringSprings(memory.depth());
  }

  ValueAndSlope operator()(double dux) const {
    ValueAndSlope total{0, 0};
    if (!vertices_.empty() && vertices_[0].x > 0) {  // the z = 0 atom of a flat punch
      const Vertex& atom = vertices_[0];
      const double bound = Bound(0);
      total.value += atom.x * std::clamp(atom.u + dux, -bound, bound);
      if (atom.lo < dux && dux < atom.up) total.slope += atom.x;
    }
    for (std::size_t i = 0; i + 1 < vertices_.size(); ++i) AddSegment(i, dux, total);
    total.value += std::clamp(dux, -entering_limit_, entering_limit_) * entering_weight_;
    if (std::abs(dux) < entering_limit_) total.slope += entering_weight_;
    return total;
  }

  // The increments at which a vertex reaches a bound, and +-L: where the slope may jump.
  void Breakpoints(std::vector<double>& points) const {
    points.clear();
    for (const Vertex& v : vertices_) points.insert(points.end(), {v.up, v.lo});
    if (entering_weight_ > 0) points.insert(points.end(), {-entering_limit_, entering_limit_});
  }

 private:
  double Bound(double z) const { return CoulombBound(mu_kappa_, depth1_, z); }

  // Springs in [0, min(depth0, depth1)], the polyline cut at depth1 as the step cuts it.
  void AddStayingSprings(const PiecewiseLinearMemory& memory) {
    const std::vector<double>& z = memory.z();
    const std::vector<double>& u = memory.u();
    for (std::size_t i = 0; i < z.size(); ++i) {
      if (depth1_ < memory.depth() && z[i] >= depth1_) {
        AddVertex(depth1_,
                  z[i] == depth1_ ? u[i] : Interpolate(z[i - 1], u[i - 1], z[i], u[i], depth1_));
        break;
      }
      AddVertex(z[i], u[i]);
    }
  }

  void AddVertex(double z, double u) {
    const double bound = Bound(z);
    vertices_.push_back({z, u, profile_.RadiusAtDepth(z), bound, bound - u, -bound - u, {}});
    if (vertices_.size() < 2) return;
    Vertex& a = vertices_[vertices_.size() - 2];
    const Vertex& b = vertices_.back();
    a.piece = profile_.IntegratePiece(a.z, b.z, a.x, b.x, false);
  }

  // Springs in (max(depth0, 0), depth1] (all of [0, depth1] when out of contact before).
  void AddEnteringSprings(double depth0) {
    if (!(depth1_ > depth0)) return;
    const double ddelta = depth1_ - depth0, z_enter = std::max(depth0, 0.0);
    const PieceIntegrals piece = profile_.IntegratePiece(
        z_enter, depth1_, profile_.RadiusAtDepth(z_enter), profile_.RadiusAtDepth(depth1_), false);
    double weight = (depth1_ - z_enter) * (piece.j0 - piece.j1);     // integral (depth1 - z) dx
    if (depth0 <= 0) weight += profile_.RadiusAtDepth(0) * depth1_;  // a flat punch's atom
    entering_limit_ = mu_kappa_ * ddelta;
    entering_weight_ = weight / ddelta;
  }

  // integral over the piece of +-b1 (on a bound) or of u + dux (sticking; adds J_0 to the slope).
  void AddSegment(std::size_t i, double dux, ValueAndSlope& total) const {
    const Vertex& a = vertices_[i];
    const Vertex& b = vertices_[i + 1];
    const bool a_sticks = a.lo < dux && dux < a.up, b_sticks = b.lo < dux && dux < b.up;
    if (a_sticks && b_sticks) {
      AddPiece(a, b, 0, 1, dux, a.piece, +0, total);
      return;
    }
    if ((dux >= a.up && dux >= b.up) || (dux <= a.lo && dux <= b.lo)) {
      AddPiece(a, b, 0, 1, dux, a.piece, dux >= a.up ? +1 : -1, total);
      return;
    }
    // Split where the segment reaches a bound: up(t) = dux or lo(t) = dux, t in (0, 1).
    double t[3];
    int count = 0;
    if ((a.up - dux) * (b.up - dux) < 0) t[count++] = (dux - a.up) / (b.up - a.up);
    if ((a.lo - dux) * (b.lo - dux) < 0) t[count++] = (dux - a.lo) / (b.lo - a.lo);
    if (count == 2 && t[1] < t[0]) std::swap(t[0], t[1]);
    t[count++] = 1;
    double t_begin = 0, z_begin = a.z, x_begin = a.x;
    for (int k = 0; k < count; ++k) {
      const double z_end = t[k] == 1 ? b.z : a.z + t[k] * (b.z - a.z);
      if (!(z_end > z_begin)) continue;
      const double x_end = t[k] == 1 ? b.x : profile_.RadiusAtDepth(z_end);
      const double t_mid = 0.5 * (t_begin + t[k]);
      const double up = a.up + t_mid * (b.up - a.up), lo = a.lo + t_mid * (b.lo - a.lo);
      const int bound = dux >= up ? +1 : (dux <= lo ? -1 : 0);
      AddPiece(a, b, t_begin, t[k], dux,
               profile_.IntegratePiece(z_begin, z_end, x_begin, x_end, false), bound, total);
      t_begin = t[k], z_begin = z_end, x_begin = x_end;
    }
  }

  // The piece [t_begin, t_end] of the segment a-b: on the bound `bound` (+-1), or sticking (0).
  // Its end value is linear in the piece's own t, from its value at the begin to that at the end.
  void AddPiece(const Vertex& a, const Vertex& b, double t_begin, double t_end, double dux,
                const PieceIntegrals& piece, int bound, ValueAndSlope& total) const {
    auto at = [&](double ua, double ub, double t) { return t == 1 ? ub : ua + t * (ub - ua); };
    if (bound != 0) {
      const double begin = at(a.bound, b.bound, t_begin), end = at(a.bound, b.bound, t_end);
      total.value += bound * (begin * piece.j0 + (end - begin) * piece.j1);
      return;
    }
    const double begin = at(a.u, b.u, t_begin), end = at(a.u, b.u, t_end);
    total.value += (begin + dux) * piece.j0 + (end - begin) * piece.j1;
    total.slope += piece.j0;
  }

  double depth1_, mu_kappa_;
  const Profile& profile_;
  std::vector<Vertex>& vertices_;
  double entering_limit_ = 0, entering_weight_ = 0;  // L, integral (depth1 - z) / ddelta dx
};

}  // namespace

double PiecewiseLinearMemory::IncrementForIntegralU(double depth1, double mu_kappa,
                                                    const Profile& profile, double target,
                                                    ForceSolveBuffers& buffers,
                                                    double spring) const {
  const double lo = GrossSlipIncrement(depth1, mu_kappa, -1);
  const double hi = GrossSlipIncrement(depth1, mu_kappa, +1);
  if (!(depth1 > 0)) return spring > 0 ? target / spring : 0;
  const IntegralAfterStep integral(*this, depth1, mu_kappa, profile, buffers.vertices);
  integral.Breakpoints(buffers.breakpoints);
  return internal::SolveWithSpring(integral, buffers.breakpoints, lo, hi, target, spring);
}

}  // namespace mdr
