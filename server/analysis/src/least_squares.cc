#include "least_squares.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <numeric>

namespace mdr::analysis::internal {
namespace {

constexpr double kInitialDamping = 1e-3;
constexpr double kMaxDamping = 1e20;  // beyond: no step lowers the cost
constexpr int kMaxRejections = 60;
constexpr double kNegligibleColumn = 1e-8;  // of the largest column's norm
constexpr double kMaxStep = 1;              // in the solver's scaled coordinates

double SumOfSquares(const std::vector<double>& r) {
  double s = 0;
  for (double v : r) s += v * v;
  return s;
}

// The damped step: (H + mu D) delta = -g, fixed coordinates held.
Result<Eigen::VectorXd> DampedStep(const Eigen::SparseMatrix<double>& h, const Eigen::VectorXd& g,
                                   const Eigen::VectorXd& d, double mu,
                                   const std::vector<bool>& fixed) {
  Eigen::SparseMatrix<double> a = h;
  for (Eigen::Index j = 0; j < a.outerSize(); ++j) {
    a.coeffRef(j, j) += mu * d[j];
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(a);
  if (solver.info() != Eigen::Success) {
    return FailedPrecondition("free", "the fit's normal equations could not be factorised");
  }
  Eigen::VectorXd step = solver.solve(-g);
  for (std::size_t j = 0; j < fixed.size(); ++j) {
    if (fixed[j]) step[static_cast<Eigen::Index>(j)] = 0;
  }
  if (!step.allFinite()) {
    return FailedPrecondition("free", "the fit's normal equations have no finite solution");
  }
  return step;
}

}  // namespace

std::vector<bool> NegligibleColumns(const std::vector<SparseColumn>& columns) {
  std::vector<double> norms(columns.size(), 0);
  double largest = 0;
  for (std::size_t j = 0; j < columns.size(); ++j) {
    for (double v : columns[j].values) norms[j] += v * v;
    largest = std::max(largest, norms[j]);
  }
  std::vector<bool> negligible(columns.size());
  for (std::size_t j = 0; j < columns.size(); ++j) {
    negligible[j] = !(norms[j] > kNegligibleColumn * kNegligibleColumn * largest);
  }
  return negligible;
}

Eigen::SparseMatrix<double> NormalMatrix(const std::vector<SparseColumn>& columns) {
  const std::size_t p = columns.size();
  std::vector<std::size_t> order(p);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return columns[a].begin < columns[b].begin; });
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t oa = 0; oa < p; ++oa) {
    const SparseColumn& a = columns[order[oa]];
    const std::size_t end_a = a.begin + a.values.size();
    double square = 0;
    for (double v : a.values) square += v * v;
    const auto ia = static_cast<Eigen::Index>(order[oa]);
    entries.emplace_back(ia, ia, square);  // every diagonal entry, zero columns' too
    for (std::size_t ob = oa + 1; ob < p; ++ob) {
      const SparseColumn& b = columns[order[ob]];
      if (b.begin >= end_a) break;
      const std::size_t end = std::min(end_a, b.begin + b.values.size());
      double dot = 0;
      for (std::size_t i = b.begin; i < end; ++i)
        dot += a.values[i - a.begin] * b.values[i - b.begin];
      if (dot == 0) continue;
      const auto ib = static_cast<Eigen::Index>(order[ob]);
      entries.emplace_back(ia, ib, dot);
      entries.emplace_back(ib, ia, dot);
    }
  }
  Eigen::SparseMatrix<double> h(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(p));
  h.setFromTriplets(entries.begin(), entries.end());
  return h;
}

Eigen::VectorXd Gradient(const std::vector<SparseColumn>& columns, const std::vector<double>& r) {
  Eigen::VectorXd g(static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    double dot = 0;
    for (std::size_t i = 0; i < columns[k].values.size(); ++i) {
      dot += columns[k].values[i] * r[columns[k].begin + i];
    }
    g[static_cast<Eigen::Index>(k)] = dot;
  }
  return g;
}

Result<SolverOutcome> SolveLeastSquares(const LeastSquaresProblem& problem, std::vector<double> x0,
                                        const SolverOptions& options,
                                        const SolverProgress& progress) {
  const std::size_t p = problem.parameters();
  std::vector<bool> fixed = options.fixed;
  fixed.resize(p, false);
  SolverOutcome out;
  out.x = std::move(x0);
  if (Status s = problem.Residuals(out.x, &out.r); !s.ok()) return s;
  if (Status s = problem.Jacobian(out.x, out.r, &out.jacobian); !s.ok()) return s;
  double cost = SumOfSquares(out.r);
  // The normal matrix, gradient and Moré's scaling (the largest column norms seen so far).
  std::vector<bool> held_now(p, false);
  const auto normal_equations = [&](Eigen::SparseMatrix<double>* h, Eigen::VectorXd* g,
                                    Eigen::VectorXd* d) {
    std::vector<SparseColumn> held = out.jacobian;
    // A negligible column's coordinate is held, or rounding would drive it anywhere.
    const std::vector<bool> negligible = NegligibleColumns(held);
    for (std::size_t j = 0; j < p; ++j) {
      held_now[j] = fixed[j] || negligible[j];
      if (held_now[j]) held[j].values.assign(held[j].values.size(), 0);
    }
    *h = NormalMatrix(held);
    *g = Gradient(held, out.r);
    double largest = 0;
    for (std::size_t j = 0; j < p; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      (*d)[jj] = std::max((*d)[jj], h->coeff(jj, jj));
      largest = std::max(largest, (*d)[jj]);
    }
    for (std::size_t j = 0; j < p; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      if (held_now[j] || !((*d)[jj] > 1e-12 * largest))
        (*d)[jj] = std::max(1e-12 * largest, 1e-300);
    }
  };
  Eigen::SparseMatrix<double> h;
  Eigen::VectorXd g, d = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(p));
  normal_equations(&h, &g, &d);
  double mu = kInitialDamping, nu = 2;
  int rejections = 0;
  std::vector<double> trial_x(p), trial_r;
  while (out.iterations < options.max_iterations) {
    Result<Eigen::VectorXd> step = DampedStep(h, g, d, mu, held_now);
    if (!step.ok()) return step.status();
    // No coordinate moves by more than kMaxStep in one step (they are scaled to their plausible
    // range): a poorly determined one would otherwise leap where the model means nothing.
    const double longest = step->cwiseAbs().maxCoeff();
    if (longest > kMaxStep) *step *= kMaxStep / longest;
    bool small = true;
    for (std::size_t j = 0; j < p; ++j) {
      const double delta = (*step)[static_cast<Eigen::Index>(j)];
      trial_x[j] = out.x[j] + delta;
      small = small && std::abs(delta) <= options.step_tolerance * (1 + std::abs(out.x[j]));
    }
    if (small) {
      out.converged = true;
      break;
    }
    // A trial whose model cannot be evaluated (a replay outside what the engine takes) counts
    // as one that does not lower the cost.
    Status evaluated = problem.Residuals(trial_x, &trial_r);
    if (!evaluated.ok() && (evaluated.code() == StatusCode::kCancelled ||
                            evaluated.code() == StatusCode::kDeadlineExceeded)) {
      return evaluated;
    }
    const double trial_cost = evaluated.ok() ? SumOfSquares(trial_r) : HUGE_VAL;
    const Eigen::VectorXd& delta = *step;
    const double predicted = -2 * delta.dot(g) - delta.dot(h * delta);
    const double ratio = predicted > 0 ? (cost - trial_cost) / predicted : -1;
    if (evaluated.ok() && trial_cost < cost && ratio > 0) {
      out.x = trial_x;
      out.r = trial_r;
      cost = trial_cost;
      if (Status s = problem.Jacobian(out.x, out.r, &out.jacobian); !s.ok()) return s;
      normal_equations(&h, &g, &d);
      mu *= std::max(1.0 / 3, 1 - std::pow(2 * ratio - 1, 3));
      nu = 2;
      rejections = 0;
      ++out.iterations;
      if (progress) progress(out.iterations, out.r, out.x);
      continue;
    }
    mu *= nu;
    nu *= 2;
    if (mu > kMaxDamping || ++rejections > kMaxRejections) {
      out.converged = true;  // no step lowers the cost: a minimum to rounding
      break;
    }
  }
  return out;
}

}  // namespace mdr::analysis::internal
