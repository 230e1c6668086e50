// The model FitLoops fits (internal to mdr_analysis; docs/analysis.md, "Identification"): every
// set replayed through the exact engine along an actuator path made of its smoothed measured
// displacement between fitted turning points, its residuals weighed by their effective variance,
// the parameters laid out for the sparse least-squares solver.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "least_squares.h"
#include "mdr/analysis/identify.h"
#include "mdr/core/contact.h"

namespace mdr::analysis::internal {

// A bounded parameter in the solver's unbounded coordinate phi: theta = lo + (hi - lo) / (1 +
// exp(-phi)), so every trial value lies strictly inside the bounds.
struct Bounded {
  double lo, hi;
  double Value(double phi) const;
  double Phi(double value) const;
  double Derivative(double phi) const;  // d theta / d phi
};

// The contact a fit replays at one point of its parameters: the tangential contact's config,
// and for a torsional fit the torsional modulus and compliance beside it.
struct FitScene {
  ContactConfig contact;
  std::optional<TorsionalFitScene> torsion;
};

// A set with everything the fit needs that does not depend on the parameters.
struct PreparedSet {
  const LoopSet* set = nullptr;
  std::size_t samples = 0;
  std::size_t first_residual = 0;  // the first counted sample
  std::size_t row_offset = 0;      // the residual row of that sample
  // The reversals (refined where a flat peak leaves the extreme sample to the noise), whether
  // each is a maximum, and the smoothed displacement's value there (sensor coordinates).
  std::vector<std::size_t> reversals;
  std::vector<bool> upper;
  std::vector<double> turning;
  std::size_t first_free_turning = 0;  // the turning points from this one on are fitted
  std::vector<double> smoothed;        // the displacement smoothed within each half-cycle
  std::vector<double> drift_abscissa;  // 0 at the first sample, 1 at the last
  std::vector<double> normal;  // the column's normal force smoothed per sample; empty: none
  // Whether `normal` is replayed (a tangential set's column); else every sample is replayed at
  // constant_normal (the declared load, or a torsional set's column mean).
  bool replay_normal = false;
  double constant_normal = 0;  // N
  std::vector<double> acceleration;    // d^2u/dt^2 per sample (moving mass); else empty
  double displacement_noise = 0, force_noise = 0;  // the weights' standard deviations
  double normal_noise = 0;                         // of the normal-force column (estimated)
  double default_offset = 0;  // where the contact is pressed without an offset parameter
  double stroke = 0;          // m: half the displacement's range (a scale)
  double force_scale = 0;     // N: half the force's range (a scale)
};

// Prepares set `index` (errors name "sets[index]..."). `displacement_noise` and `force_noise` are
// the options' (unset: estimated).
Result<PreparedSet> PrepareSet(const LoopSet& set, std::size_t index, const FitOptions& options,
                               const Interrupt& interrupt);

// Where each parameter sits in the solver's vector: the free parameters (in phi), the moving
// mass, then per set its offsets, drift and turning points.
struct Layout {
  struct Block {
    std::optional<std::size_t> force_offset, displacement_offset, drift;
    std::size_t turning_begin = 0;  // the coordinate of the first fitted turning point
    std::size_t turning_count = 0;
  };
  std::size_t free = 0;
  std::optional<std::size_t> mass;
  std::vector<Block> blocks;
  std::size_t size = 0;
};
Layout MakeLayout(const std::vector<PreparedSet>& sets, const FitOptions& options);

// One set's model at a point, sample by sample.
struct SetEvaluation {
  std::vector<double> path, normal, contact_force, stiffness, predicted;
};

class FitModel final : public LeastSquaresProblem {
 public:
  FitModel(const ContactConfig& scene, std::vector<PreparedSet> sets, const FitOptions& options,
           std::vector<Bounded> bounds, const Interrupt& interrupt, int threads);
  // The replayed contact, tangential or torsional (fit_model.cc).
  class ReplayContact;

  std::size_t residuals() const override { return residuals_; }
  std::size_t parameters() const override { return layout_.size; }
  Status Residuals(const std::vector<double>& x, std::vector<double>* r) const override;
  Status Jacobian(const std::vector<double>& x, const std::vector<double>& r,
                  std::vector<SparseColumn>* columns) const override;

  // One reweighting stage: the model's slopes along its branches at x, with which each counted
  // sample's force is carried to its measured displacement (and, with a normal-force column, its
  // slope against the normal force, to the measured one), and the effective-variance weights
  // 1 / sqrt(force_noise^2 + (slope * displacement_noise)^2 + (normal slope * normal_noise)^2).
  // Both stay fixed until the next stage (iteratively reweighted least squares). `uniform`: all
  // weights 1 (the first stage: far from the solution the noise estimates of noise-free or
  // nearly noise-free sets say little, and one set must not steer the fit alone).
  Status Reweigh(const std::vector<double>& x, bool uniform = false);
  const std::vector<double>& weights() const { return weights_; }

  const Layout& layout() const { return layout_; }
  const std::vector<PreparedSet>& sets() const { return sets_; }
  const std::vector<Bounded>& bounds() const { return bounds_; }
  // The starting point: free parameters at their initial values, nuisances at zero.
  std::vector<double> Start(const std::vector<double>& initial) const;
  // The free parameters' values at x.
  std::vector<double> Values(const std::vector<double>& x) const;
  Result<FitScene> SceneAt(const std::vector<double>& values) const;
  // A nuisance's value in its own unit from its coordinate, and the scale between them.
  double Scale(std::size_t coordinate) const;
  // Set r's model at x.
  Result<SetEvaluation> Evaluate(const std::vector<double>& x, std::size_t r) const;
  // The fitted turning points of set r at x (sensor coordinates), for the shift's RMS.
  std::vector<double> TurningPoints(const std::vector<double>& x, std::size_t r) const;

 private:
  struct Inputs;  // the parameters as one set sees them
  Inputs InputsFor(const std::vector<double>& x, const FitScene& scene, std::size_t r) const;
  class Replayer;

  const ContactConfig& scene_;
  std::vector<PreparedSet> sets_;
  const FitOptions& options_;
  std::vector<Bounded> bounds_;
  const Interrupt& interrupt_;
  int threads_;
  Layout layout_;
  std::size_t residuals_ = 0;
  std::vector<double> weights_;        // per residual row
  std::vector<double> slopes_;         // per residual row: dF_x/du along the branch, N/m
  std::vector<double> normal_slopes_;  // per residual row: dF_x/dF_N of the step
};

}  // namespace mdr::analysis::internal
