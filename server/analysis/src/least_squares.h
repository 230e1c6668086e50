// Levenberg-Marquardt for large, sparse least-squares problems (internal to mdr_analysis): a fit
// of measured loops has a few parameters every residual depends on (the contact's) and many that
// touch a stretch of one set only (its offsets, its turning points), so the Jacobian is stored as
// one row range per column and the normal equations are solved by a sparse Cholesky (Eigen's
// SimplicialLDLT), never as a dense residuals x parameters matrix.
#pragma once

#include <Eigen/SparseCore>
#include <cstddef>
#include <functional>
#include <vector>

#include "mdr/base/status.h"

namespace mdr::analysis::internal {

// One column of the Jacobian: its values on the rows [begin, begin + values.size()), zero
// elsewhere.
struct SparseColumn {
  std::size_t begin = 0;
  std::vector<double> values;
};

// The problem, in the solver's coordinates x (each of order one over its plausible range: the
// problem scales its own parameters).
class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  virtual std::size_t residuals() const = 0;
  virtual std::size_t parameters() const = 0;
  // r(x), residuals() values.
  virtual Status Residuals(const std::vector<double>& x, std::vector<double>* r) const = 0;
  // dr/dx at x, where r(x) = r: parameters() columns.
  virtual Status Jacobian(const std::vector<double>& x, const std::vector<double>& r,
                          std::vector<SparseColumn>* columns) const = 0;
};

struct SolverOptions {
  int max_iterations = 200;
  // Converged when an accepted step changes no coordinate by more than this times (1 + |x_j|).
  double step_tolerance = 1e-10;
  // Coordinates held at their starting values (empty: none).
  std::vector<bool> fixed;
};

struct SolverOutcome {
  std::vector<double> x, r;
  std::vector<SparseColumn> jacobian;  // at x
  int iterations = 0;
  bool converged = false;
};

// Called after every accepted step with its number, the residuals and the point.
using SolverProgress =
    std::function<void(int iteration, const std::vector<double>& r, const std::vector<double>& x)>;

// Minimises |r(x)|^2 from x0 (trust-region Levenberg-Marquardt with Nielsen's damping update and
// Moré's scaling). Errors of the problem's functions end it. Reaching max_iterations is not an
// error (converged stays false); neither is a minimum where no step lowers the cost any more
// (converged: the cost cannot be lowered within rounding).
Result<SolverOutcome> SolveLeastSquares(const LeastSquaresProblem& problem, std::vector<double> x0,
                                        const SolverOptions& options,
                                        const SolverProgress& progress = {});

// The columns many orders (1e-8) below the largest in norm: rounding, a parameter the data do
// not see (a gross-slip set's press point moves its forces by a few ulps at most). The solver
// holds them; the covariance leaves them out as undetermined.
std::vector<bool> NegligibleColumns(const std::vector<SparseColumn>& columns);

// J^T J of the columns (upper and lower triangles).
Eigen::SparseMatrix<double> NormalMatrix(const std::vector<SparseColumn>& columns);
// J^T r.
Eigen::VectorXd Gradient(const std::vector<SparseColumn>& columns, const std::vector<double>& r);

}  // namespace mdr::analysis::internal
