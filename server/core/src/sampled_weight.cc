#include "mdr/core/sampled_weight.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "jager_terms.h"
#include "mdr/base/validate.h"

namespace mdr {
namespace {

using internal::BasisDisplacement;
using internal::CheckMuKappa;
using internal::SegmentWeight;

// One cell [x_j, x_{j+1}] of a sampled u(x): its depths and the mean weight over them.
struct Cell {
  double x_begin, x_end, z_begin, z_end, weight;
};

// A plateau of F over cells first..last (a run of weights inside a band 2 * tolerance wide),
// with its extent, which a jump inside a neighbouring cell may shift into that cell.
struct Plateau {
  std::size_t first, last;
  double low, high;       // band of the cell weights
  double weighted, span;  // sum of weight * depth extent, and of depth extent
  double x_begin, x_end, z_begin, z_end;
  std::size_t cells() const { return last - first + 1; }
  // The mean of F over the plateau's depths, so u is reproduced exactly at its ends.
  double weight() const { return weighted / span; }
};

Status ValidateSamples(const std::vector<double>& x, const std::vector<double>& u,
                       const Profile& profile, double mu_kappa,
                       const SampledWeightOptions& options) {
  if (Status s = CheckMuKappa("mu_kappa", mu_kappa); !s.ok()) return s;
  if (Status s = RequireInRange("options.tolerance", options.tolerance, 0, 1, /*lo_open=*/true);
      !s.ok()) {
    return s;
  }
  if (options.max_plateaus < 1) return InvalidArgument("options.max_plateaus", "must be >= 1");
  if (u.size() != x.size()) return InvalidArgument("u", "needs one value per sample of x");
  if (x.size() < 3) return InvalidArgument("x", "needs at least 3 samples");
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (Status s = RequireNonNegative(Indexed("x", i), x[i]); !s.ok()) return s;
    if (Status s = RequireFinite(Indexed("u", i), u[i]); !s.ok()) return s;
    if (i > 0 && !(x[i] > x[i - 1])) {
      return InvalidArgument(Indexed("x", i), "must increase strictly");
    }
  }
  const double depth = profile.G(x.back());
  if (!(std::isfinite(depth) && depth > 0)) {
    return InvalidArgument("x",
                           "the last sample must be the contact edge, where g is finite and "
                           "> 0 (a flat punch's edge weight comes from its memory)");
  }
  if (std::abs(u.back()) > options.tolerance * mu_kappa * depth) {
    return InvalidArgument(Indexed("u", u.size() - 1),
                           "must vanish at the contact edge (within tolerance * mu kappa g)");
  }
  return OkStatus();
}

// Cells with their weights by finite differences in g; cells where g is constant (a flat bottom)
// hold no weight and are skipped, but u must not change there.
Result<std::vector<Cell>> SampleCells(const std::vector<double>& x, const std::vector<double>& u,
                                      const Profile& profile, double mu_kappa, double tolerance) {
  const double depth = profile.G(x.back());
  std::vector<Cell> cells;
  for (std::size_t j = 0; j + 1 < x.size(); ++j) {
    const double rise = profile.Rise(x[j + 1], x[j]);
    if (!(rise > 0)) {
      if (std::abs(u[j + 1] - u[j]) > tolerance * mu_kappa * depth) {
        return InvalidArgument(Indexed("u", j + 1),
                               "changes where g is constant: not an MDR state");
      }
      continue;
    }
    cells.push_back({x[j], x[j + 1], profile.G(x[j]), profile.G(x[j + 1]),
                     SegmentWeight(u[j], u[j + 1], rise, mu_kappa)});
  }
  return cells;
}

std::vector<Plateau> GroupIntoRuns(const std::vector<Cell>& cells, double tolerance) {
  std::vector<Plateau> runs;
  for (std::size_t j = 0; j < cells.size(); ++j) {
    const Cell& cell = cells[j];
    const double span = cell.z_end - cell.z_begin;
    if (!runs.empty()) {
      Plateau& run = runs.back();
      const double low = std::min(run.low, cell.weight), high = std::max(run.high, cell.weight);
      if (high - low <= 2 * tolerance) {
        run.last = j;
        run.low = low;
        run.high = high;
        run.weighted += cell.weight * span;
        run.span += span;
        run.x_end = cell.x_end;
        run.z_end = cell.z_end;
        continue;
      }
    }
    runs.push_back({j, j, cell.weight, cell.weight, cell.weight * span, span, cell.x_begin,
                    cell.x_end, cell.z_begin, cell.z_end});
  }
  return runs;
}

// Resolves runs into plateaus: a lone cell between two plateaus of two or more cells whose weight
// lies between theirs holds the jump from one to the other; its position follows from the cell
// mean, F_cell = (F_left (z* - z_j) + F_right (z_{j+1} - z*)) / (z_{j+1} - z_j). Any other run
// is a plateau of its own.
std::vector<Plateau> ResolveJumps(const std::vector<Plateau>& runs, const std::vector<Cell>& cells,
                                  const Profile& profile, double tolerance) {
  std::vector<Plateau> plateaus;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const Plateau& run = runs[i];
    if (run.cells() == 1 && i > 0 && i + 1 < runs.size() && runs[i - 1].cells() >= 2 &&
        runs[i + 1].cells() >= 2) {
      const double left = runs[i - 1].weight(), right = runs[i + 1].weight();
      const double f = run.weight();
      if (left != right && f >= std::min(left, right) - tolerance &&
          f <= std::max(left, right) + tolerance) {
        const Cell& cell = cells[run.first];
        const double theta = std::clamp((f - right) / (left - right), 0.0, 1.0);
        const double z_jump = cell.z_begin + theta * (cell.z_end - cell.z_begin);
        const double x_jump = std::clamp(profile.RadiusAtDepth(z_jump), cell.x_begin, cell.x_end);
        Plateau& previous = plateaus.back();
        previous.weighted += left * (z_jump - cell.z_begin);
        previous.span += z_jump - cell.z_begin;
        previous.x_end = x_jump;
        previous.z_end = z_jump;
        Plateau next = runs[i + 1];
        next.weighted += right * (cell.z_end - z_jump);
        next.span += cell.z_end - z_jump;
        next.x_begin = x_jump;
        next.z_begin = z_jump;
        plateaus.push_back(next);
        ++i;
        continue;
      }
    }
    plateaus.push_back(run);
  }
  return plateaus;
}

// max_j |u_terms(x_j) - u_j| / (mu kappa g(x_N)): how well the terms reproduce the samples.
double MaxResidual(const std::vector<CattaneoMindlinTerm>& terms, const std::vector<double>& x,
                   const std::vector<double>& u, const Profile& profile, double mu_kappa) {
  const double scale = mu_kappa * profile.G(x.back());
  double residual = 0;
  for (std::size_t j = 0; j < x.size(); ++j) {
    const double z = profile.G(x[j]);
    long double sum = 0;
    for (const CattaneoMindlinTerm& t : terms) sum += BasisDisplacement(t, z, mu_kappa);
    residual = std::max(residual, std::abs(static_cast<double>(sum) - u[j]) / scale);
  }
  return residual;
}

}  // namespace

Result<SampledWeight> AnalyzeSampledDisplacement(const std::vector<double>& x,
                                                 const std::vector<double>& u,
                                                 const Profile& profile, double mu_kappa,
                                                 const SampledWeightOptions& options) {
  if (Status s = ValidateSamples(x, u, profile, mu_kappa, options); !s.ok()) return s;
  Result<std::vector<Cell>> cells = SampleCells(x, u, profile, mu_kappa, options.tolerance);
  if (!cells.ok()) return cells.status();

  SampledWeight out;
  out.tolerance = options.tolerance;
  for (const Cell& cell : *cells) {
    out.midpoints.push_back(0.5 * (cell.x_begin + cell.x_end));
    out.weights.push_back(cell.weight);
  }
  const std::vector<Plateau> plateaus =
      ResolveJumps(GroupIntoRuns(*cells, options.tolerance), *cells, profile, options.tolerance);
  if (plateaus.size() > static_cast<std::size_t>(options.max_plateaus)) return out;

  out.kind = WeightKind::kStepFunction;
  for (const Plateau& plateau : plateaus) {
    const double weight = plateau.weight();
    if (std::abs(weight) <= options.tolerance) continue;  // a stick zone, within tolerance
    out.terms.push_back({weight, plateau.x_end, plateau.x_begin, plateau.z_end, plateau.z_begin});
  }
  out.max_residual = MaxResidual(out.terms, x, u, profile, mu_kappa);
  return out;
}

}  // namespace mdr
