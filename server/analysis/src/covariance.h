// The covariance of a fit's coordinates (internal to mdr_analysis), up to the residual variance
// s^2, from the block-arrow structure of its normal matrix: the coordinates every residual sees
// (the free parameters, the moving mass) and each set's own (offsets, drift, turning points),
// which no other set's residuals see. Each set's block is inverted on the directions its data
// determine (an eigendecomposition: a partial-slip set fixes the sum of its force offset and its
// press point's effect, not each), and the shared coordinates' covariance is the inverse of the
// Schur complement. A direction the data do not see is never allowed to leak rounding into the
// others, as a plain inverse of a nearly singular matrix would.
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <vector>

#include "fit_model.h"
#include "least_squares.h"

namespace mdr::analysis::internal {

class BlockCovariance {
 public:
  BlockCovariance(const std::vector<SparseColumn>& jacobian, const Layout& layout);

  // The shared coordinates (the free parameters, then the mass): their covariance, infinite
  // where the data leave a combination of them undetermined (singular()).
  const Eigen::MatrixXd& shared() const { return shared_; }
  bool singular() const { return singular_; }
  // A set's own coordinate: whether the data determine it, its variance, and its covariance with
  // the shared coordinates.
  bool determined(std::size_t coordinate) const { return determined_[coordinate]; }
  double Variance(std::size_t coordinate) const;
  // Of two coordinates of the same set (infinite for coordinates of different sets).
  double Covariance(std::size_t a, std::size_t b) const;
  Eigen::VectorXd WithShared(std::size_t coordinate) const;
  // How many independent combinations the data determine (the degrees of freedom used).
  std::size_t rank() const { return rank_; }

  // The cluster-robust (sandwich) covariance of the shared coordinates, clusters the residual
  // rows from each of `starts` (ascending) to the next: S^-1 (sum over clusters of g g^T) S^-1
  // times G / (G - 1), g a cluster's score on the shared coordinates once each set's own are
  // profiled out (J_shared - J_own P H_own,shared) against its residuals. What the residuals' own
  // scatter says where s^2 (J^T J)^-1 assumes them independent. Infinite where singular().
  Eigen::MatrixXd ClusterRobust(const std::vector<SparseColumn>& jacobian,
                                const std::vector<double>& residuals,
                                const std::vector<std::size_t>& starts) const;

 private:
  struct Block {
    std::vector<std::size_t> coordinates;
    Eigen::MatrixXd pseudo_inverse;  // of the block, on its determined directions
    Eigen::MatrixXd coupling;        // H_shared,block P (shared x block)
  };
  const Block* BlockOf(std::size_t coordinate, std::size_t* position) const;

  std::vector<std::size_t> shared_coordinates_;
  std::vector<Block> blocks_;
  Eigen::MatrixXd shared_;
  std::vector<bool> determined_;
  bool singular_ = false;
  std::size_t rank_ = 0;
};

}  // namespace mdr::analysis::internal
