#include "mdr/core/material.h"

#include "mdr/base/validate.h"

namespace mdr {
namespace {

// -1 < nu <= 0.5: the range in which the elastic energy is positive (0.5: incompressible).
Status ValidatePoissonRatio(const std::string& field, double nu) {
  return RequireInRange(field, nu, -1.0, 0.5, /*lo_open=*/true);
}

}  // namespace

Result<EffectiveMaterial> RigidOnHalfSpace(double shear_modulus, double poisson_ratio) {
  if (Status s = RequireSceneScale("shear_modulus", shear_modulus); !s.ok()) return s;
  if (Status s = ValidatePoissonRatio("poisson_ratio", poisson_ratio); !s.ok()) return s;
  return EffectiveMaterial{2 * shear_modulus / (1 - poisson_ratio),
                           4 * shear_modulus / (2 - poisson_ratio)};
}

Result<EffectiveMaterial> ElasticPair(double youngs_modulus_1, double poisson_ratio_1,
                                      double youngs_modulus_2, double poisson_ratio_2) {
  if (Status s = RequireSceneScale("youngs_modulus_1", youngs_modulus_1); !s.ok()) return s;
  if (Status s = ValidatePoissonRatio("poisson_ratio_1", poisson_ratio_1); !s.ok()) return s;
  if (Status s = RequireSceneScale("youngs_modulus_2", youngs_modulus_2); !s.ok()) return s;
  if (Status s = ValidatePoissonRatio("poisson_ratio_2", poisson_ratio_2); !s.ok()) return s;
  auto normal_compliance = [](double e, double nu) { return (1 - nu * nu) / e; };
  auto shear_compliance = [](double e, double nu) {
    const double g = e / (2 * (1 + nu));
    return (2 - nu) / (4 * g);
  };
  return EffectiveMaterial{1 / (normal_compliance(youngs_modulus_1, poisson_ratio_1) +
                                normal_compliance(youngs_modulus_2, poisson_ratio_2)),
                           1 / (shear_compliance(youngs_modulus_1, poisson_ratio_1) +
                                shear_compliance(youngs_modulus_2, poisson_ratio_2))};
}

Result<double> TorsionalModulusOfPair(double youngs_modulus_1, double poisson_ratio_1,
                                      double youngs_modulus_2, double poisson_ratio_2) {
  Result<EffectiveMaterial> checked =
      ElasticPair(youngs_modulus_1, poisson_ratio_1, youngs_modulus_2, poisson_ratio_2);
  if (!checked.ok()) return checked.status();
  auto compliance = [](double e, double nu) { return 2 * (1 + nu) / e; };
  return 1 / (compliance(youngs_modulus_1, poisson_ratio_1) +
              compliance(youngs_modulus_2, poisson_ratio_2));
}

}  // namespace mdr
