// Helpers shared by the exact Jäger picture (jager.cc) and the analysis of sampled weights
// (sampled_weight.cc). Internal to the core.
#pragma once

#include <cstddef>
#include <string>

#include "mdr/base/status.h"
#include "mdr/core/jager.h"

namespace mdr::internal {

// Jäger's weight of a memory segment, F = -(du/dz)/(mu kappa) (docs/physics.md), from the spring
// displacements at its inner and outer ends and its extent in depth.
double SegmentWeight(double u_inner, double u_outer, double depth_span, double mu_kappa);

// u of one weighted basis solution at depth z: weight * mu kappa (z_a - max(z, z_c)), z <= z_a,
// in long double so that the terms of a decomposition telescope back without a visible loss.
long double BasisDisplacement(const CattaneoMindlinTerm& term, double z, double mu_kappa);

// InvalidArgument unless mu_kappa >= 0 and finite; FailedPrecondition for mu_kappa = 0, where
// every spring is at the bound and F = 0/0.
Status CheckMuKappa(const std::string& field, double mu_kappa);

}  // namespace mdr::internal
