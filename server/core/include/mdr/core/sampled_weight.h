// Jäger weights recovered from a sampled u(x) (another MDR code, an experiment's fit): finite
// differences in g, grouped into plateaus, and the plateaus as Cattaneo-Mindlin terms when there
// are a few (docs/physics.md, "Jäger picture and the transformation").
#pragma once

#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/jager.h"
#include "mdr/core/profile.h"

namespace mdr {

// Weight recovered from a sampled u(x) (another MDR code, an experiment's fit).
enum class WeightKind {
  kStepFunction,  // finite superposition: a few plateaus, `terms` reproduce the samples
  kContinuous,    // infinite superposition: only the sampled F is meaningful
};

struct SampledWeightOptions {
  // Plateau tolerance on F (dimensionless, |F| <= 1): cells whose F lies within a band of width
  // 2 * tolerance form one plateau. Exact MDR data needs ~1e-9; noisy data more.
  double tolerance = 1e-6;
  // "A few": more plateaus than this is read as a continuous weight. The grid needs more than
  // 2 * max_plateaus cells to tell the two apart.
  int max_plateaus = 8;
};

struct SampledWeight {
  WeightKind kind = WeightKind::kContinuous;
  double tolerance = 0;  // the plateau tolerance used
  // F at the cell midpoints (x_j + x_{j+1})/2, by finite differences in g:
  // F_j = -(u_{j+1} - u_j) / (mu kappa (g(x_{j+1}) - g(x_j))), the exact mean of F over the
  // cell's depths. Cells where g is constant (inside a flat bottom) carry no weight and are
  // left out.
  std::vector<double> midpoints, weights;
  // kStepFunction: the decomposition (c of the first term may be x_0 when the grid starts off
  // the axis); a jump inside a cell is placed where the cell mean requires it.
  std::vector<CattaneoMindlinTerm> terms;
  // kStepFunction: max |u_terms(x_j) - u_j| / (mu kappa g(x_N)) over the samples.
  double max_residual = 0;
};

// x strictly increasing, x_0 >= 0, at least 3 samples, the last at the contact edge (g(x_N)
// finite and > 0, |u_N| <= tolerance * mu_kappa * g(x_N)); u finite, and constant where g is.
// mu_kappa = 0: FailedPrecondition as for ComputeJagerWeights.
Result<SampledWeight> AnalyzeSampledDisplacement(const std::vector<double>& x,
                                                 const std::vector<double>& u,
                                                 const Profile& profile, double mu_kappa,
                                                 const SampledWeightOptions& options = {});

}  // namespace mdr
