#include "covariance.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

namespace mdr::analysis::internal {
namespace {

// Eigenvalues below this fraction of the largest (of a block scaled to a unit diagonal) are
// directions the data do not determine.
constexpr double kNullEigenvalue = 1e-10;
// A coordinate with more than this share of its unit vector in those directions is undetermined.
constexpr double kNullParticipation = 1e-6;
constexpr double kSingularShared = 1e-15;

double Entry(const Eigen::SparseMatrix<double>& h, std::size_t a, std::size_t b) {
  return h.coeff(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
}

std::vector<std::size_t> CoordinatesOf(const Layout::Block& block) {
  std::vector<std::size_t> c;
  if (block.force_offset) c.push_back(*block.force_offset);
  if (block.displacement_offset) c.push_back(*block.displacement_offset);
  if (block.drift) c.push_back(*block.drift);
  for (std::size_t t = 0; t < block.turning_count; ++t) c.push_back(block.turning_begin + t);
  return c;
}

}  // namespace

BlockCovariance::BlockCovariance(const std::vector<SparseColumn>& jacobian, const Layout& layout) {
  const std::size_t p = jacobian.size();
  const Eigen::SparseMatrix<double> h = NormalMatrix(jacobian);
  const std::vector<bool> negligible = NegligibleColumns(jacobian);
  determined_.assign(p, true);
  for (std::size_t j = 0; j < layout.free; ++j) shared_coordinates_.push_back(j);
  if (layout.mass) shared_coordinates_.push_back(*layout.mass);
  const auto ns = static_cast<Eigen::Index>(shared_coordinates_.size());
  Eigen::MatrixXd schur(ns, ns);
  for (Eigen::Index a = 0; a < ns; ++a) {
    for (Eigen::Index b = 0; b < ns; ++b) {
      schur(a, b) = Entry(h, shared_coordinates_[a], shared_coordinates_[b]);
    }
  }
  for (const Layout::Block& layout_block : layout.blocks) {
    Block block;
    block.coordinates = CoordinatesOf(layout_block);
    const auto m = static_cast<Eigen::Index>(block.coordinates.size());
    if (m == 0) continue;
    Eigen::MatrixXd own(m, m), with_shared(ns, m);
    Eigen::VectorXd scale(m);
    for (Eigen::Index a = 0; a < m; ++a) {
      const std::size_t ca = block.coordinates[a];
      const double diagonal = Entry(h, ca, ca);
      scale[a] = negligible[ca] || !(diagonal > 0) ? 0 : 1 / std::sqrt(diagonal);
      for (Eigen::Index b = 0; b < m; ++b) own(a, b) = Entry(h, ca, block.coordinates[b]);
      for (Eigen::Index g = 0; g < ns; ++g)
        with_shared(g, a) = Entry(h, shared_coordinates_[g], ca);
    }
    const Eigen::MatrixXd scaled = scale.asDiagonal() * own * scale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
    const Eigen::VectorXd lambda = eigen.eigenvalues();
    const Eigen::MatrixXd& v = eigen.eigenvectors();
    const double largest = lambda.size() > 0 ? lambda.maxCoeff() : 0;
    Eigen::VectorXd inverse = Eigen::VectorXd::Zero(m);
    Eigen::VectorXd participation = Eigen::VectorXd::Zero(m);
    for (Eigen::Index k = 0; k < m; ++k) {
      if (lambda[k] > kNullEigenvalue * largest && largest > 0) {
        inverse[k] = 1 / lambda[k];
        ++rank_;
      } else {
        participation += v.col(k).cwiseAbs2();
      }
    }
    block.pseudo_inverse =
        scale.asDiagonal() * (v * inverse.asDiagonal() * v.transpose()) * scale.asDiagonal();
    for (Eigen::Index a = 0; a < m; ++a) {
      determined_[block.coordinates[a]] = scale[a] > 0 && participation[a] <= kNullParticipation;
    }
    block.coupling = with_shared * block.pseudo_inverse;
    schur -= block.coupling * with_shared.transpose();
    blocks_.push_back(std::move(block));
  }
  // The shared coordinates' covariance: the Schur complement inverted, scaled to a unit
  // diagonal first (their units differ by many orders).
  shared_ = Eigen::MatrixXd::Constant(ns, ns, std::numeric_limits<double>::infinity());
  singular_ = true;
  if (ns == 0) {
    singular_ = false;
    return;
  }
  Eigen::VectorXd scale(ns);
  for (Eigen::Index a = 0; a < ns; ++a) {
    scale[a] = schur(a, a) > 0 ? 1 / std::sqrt(schur(a, a)) : 0;
  }
  if ((scale.array() > 0).all()) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scale.asDiagonal() * schur *
                                                         scale.asDiagonal());
    const Eigen::VectorXd lambda = eigen.eigenvalues();
    if (lambda.minCoeff() > kSingularShared * lambda.maxCoeff()) {
      singular_ = false;
      shared_ = scale.asDiagonal() *
                (eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() *
                 eigen.eigenvectors().transpose()) *
                scale.asDiagonal();
      rank_ += static_cast<std::size_t>(ns);
    }
  }
}

const BlockCovariance::Block* BlockCovariance::BlockOf(std::size_t coordinate,
                                                       std::size_t* position) const {
  for (const Block& b : blocks_) {
    for (std::size_t k = 0; k < b.coordinates.size(); ++k) {
      if (b.coordinates[k] == coordinate) {
        *position = k;
        return &b;
      }
    }
  }
  return nullptr;
}

double BlockCovariance::Variance(std::size_t coordinate) const {
  std::size_t k = 0;
  const Block* b = BlockOf(coordinate, &k);
  if (!b || !determined_[coordinate] || singular_) return std::numeric_limits<double>::infinity();
  const auto kk = static_cast<Eigen::Index>(k);
  const Eigen::VectorXd c = b->coupling.col(kk);
  return b->pseudo_inverse(kk, kk) + c.dot(shared_ * c);
}

Eigen::MatrixXd BlockCovariance::ClusterRobust(const std::vector<SparseColumn>& jacobian,
                                               const std::vector<double>& residuals,
                                               const std::vector<std::size_t>& starts) const {
  const auto ns = static_cast<Eigen::Index>(shared_coordinates_.size());
  const auto n = static_cast<Eigen::Index>(residuals.size());
  if (singular_ || starts.size() < 2 || ns == 0) {
    return Eigen::MatrixXd::Constant(ns, ns, std::numeric_limits<double>::infinity());
  }
  // The shared columns with each set's own coordinates profiled out, row by row.
  Eigen::MatrixXd profiled = Eigen::MatrixXd::Zero(n, ns);
  for (Eigen::Index g = 0; g < ns; ++g) {
    const SparseColumn& column = jacobian[shared_coordinates_[g]];
    for (std::size_t i = 0; i < column.values.size(); ++i) {
      profiled(static_cast<Eigen::Index>(column.begin + i), g) = column.values[i];
    }
  }
  for (const Block& block : blocks_) {
    for (std::size_t k = 0; k < block.coordinates.size(); ++k) {
      const SparseColumn& column = jacobian[block.coordinates[k]];
      const Eigen::VectorXd coupling = block.coupling.col(static_cast<Eigen::Index>(k));
      for (std::size_t i = 0; i < column.values.size(); ++i) {
        profiled.row(static_cast<Eigen::Index>(column.begin + i)) -=
            column.values[i] * coupling.transpose();
      }
    }
  }
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(ns, ns);
  for (std::size_t c = 0; c < starts.size(); ++c) {
    const auto begin = static_cast<Eigen::Index>(starts[c]);
    const Eigen::Index end = c + 1 < starts.size() ? static_cast<Eigen::Index>(starts[c + 1]) : n;
    Eigen::VectorXd score = Eigen::VectorXd::Zero(ns);
    for (Eigen::Index i = begin; i < end; ++i) {
      score += profiled.row(i).transpose() * residuals[static_cast<std::size_t>(i)];
    }
    meat += score * score.transpose();
  }
  const auto clusters = static_cast<double>(starts.size());
  return clusters / (clusters - 1) * shared_ * meat * shared_;
}

double BlockCovariance::Covariance(std::size_t a, std::size_t b) const {
  std::size_t ka = 0, kb = 0;
  const Block* block_a = BlockOf(a, &ka);
  const Block* block_b = BlockOf(b, &kb);
  if (!block_a || block_a != block_b || !determined_[a] || !determined_[b] || singular_) {
    return std::numeric_limits<double>::infinity();
  }
  const auto ia = static_cast<Eigen::Index>(ka), ib = static_cast<Eigen::Index>(kb);
  return block_a->pseudo_inverse(ia, ib) +
         block_a->coupling.col(ia).dot(shared_ * block_a->coupling.col(ib));
}

Eigen::VectorXd BlockCovariance::WithShared(std::size_t coordinate) const {
  std::size_t k = 0;
  const Block* b = BlockOf(coordinate, &k);
  const auto ns = static_cast<Eigen::Index>(shared_coordinates_.size());
  if (!b || !determined_[coordinate] || singular_) {
    return Eigen::VectorXd::Constant(ns, std::numeric_limits<double>::infinity());
  }
  return -shared_ * b->coupling.col(static_cast<Eigen::Index>(k));
}

}  // namespace mdr::analysis::internal
