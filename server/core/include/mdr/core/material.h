// Elastic constants of the contact in the Hertz-Mindlin approximation (docs/physics.md, "Symbols").
#pragma once

#include "mdr/base/status.h"

namespace mdr {

struct EffectiveMaterial {
  double e_star = 0;  // effective Young's modulus E*
  double g_star = 0;  // effective shear modulus G*
  double kappa() const { return e_star / g_star; }
};

// Rigid indenter on an elastic half-space: E* = 2G/(1-nu), G* = 4G/(2-nu).
// Fields: shear_modulus > 0, -1 < poisson_ratio <= 0.5.
Result<EffectiveMaterial> RigidOnHalfSpace(double shear_modulus, double poisson_ratio);

// Two elastic bodies: 1/E* = sum (1-nu_i^2)/E_i, 1/G* = sum (2-nu_i)/(4 G_i), G_i =
// E_i/(2(1+nu_i)). Fields: youngs_modulus_1/2 > 0, -1 < poisson_ratio_1/2 <= 0.5.
Result<EffectiveMaterial> ElasticPair(double youngs_modulus_1, double poisson_ratio_1,
                                      double youngs_modulus_2, double poisson_ratio_2);

// The torsional modulus G_t of two bodies, 1/G_t = 1/G_1 + 1/G_2 with G_i = E_i/(2(1+nu_i)):
// the only modulus of torsion about the contact's axis, which involves no Poisson coupling
// (docs/physics.md, "Torsion"). A rigid indenter on a half-space of shear modulus G has G_t = G.
// Fields as ElasticPair.
Result<double> TorsionalModulusOfPair(double youngs_modulus_1, double poisson_ratio_1,
                                      double youngs_modulus_2, double poisson_ratio_2);

}  // namespace mdr
