#include "mdr/core/material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_util.h"

namespace mdr {
namespace {

using testing::RelNear;

TEST(MaterialTest, SteelPairMatchesReferenceH1) {
  Result<EffectiveMaterial> m = ElasticPair(210e9, 0.3, 210e9, 0.3);
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(RelNear(m->e_star, 1.1538461538e11, 1e-10));
  EXPECT_TRUE(RelNear(m->g_star, 9.5022624434e10, 1e-10));
  EXPECT_TRUE(RelNear(m->kappa(), 1.2142857143, 1e-10));
}

TEST(MaterialTest, RigidIndenterClosedForms) {
  for (double nu : {0.0, 0.25, 0.5, -0.9}) {
    Result<EffectiveMaterial> m = RigidOnHalfSpace(1e9, nu);
    ASSERT_TRUE(m.ok()) << nu;
    EXPECT_TRUE(RelNear(m->e_star, 2e9 / (1 - nu), 1e-15));
    EXPECT_TRUE(RelNear(m->kappa(), (2 - nu) / (2 - 2 * nu), 1e-15));
  }
}

TEST(MaterialTest, RigidLimitOfElasticPairEqualsRigidIndenter) {
  Result<EffectiveMaterial> pair = ElasticPair(1e30, 0.2, 3e9, 0.35);
  Result<EffectiveMaterial> rigid = RigidOnHalfSpace(3e9 / (2 * 1.35), 0.35);
  ASSERT_TRUE(pair.ok() && rigid.ok());
  EXPECT_TRUE(RelNear(pair->e_star, rigid->e_star, 1e-12));
  EXPECT_TRUE(RelNear(pair->g_star, rigid->g_star, 1e-12));
}

TEST(MaterialTest, RejectsOutOfRangeWithFieldAndRange) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    Result<EffectiveMaterial> result;
    const char* field;
  } cases[] = {
      {RigidOnHalfSpace(0, 0.3), "shear_modulus"},
      {RigidOnHalfSpace(-1, 0.3), "shear_modulus"},
      {RigidOnHalfSpace(nan, 0.3), "shear_modulus"},
      {RigidOnHalfSpace(1e9, 0.51), "poisson_ratio"},
      {RigidOnHalfSpace(1e9, -1), "poisson_ratio"},
      {ElasticPair(1e9, 0.3, std::numeric_limits<double>::infinity(), 0.3), "youngs_modulus_2"},
      {ElasticPair(1e9, nan, 1e9, 0.3), "poisson_ratio_1"},
  };
  for (const Case& c : cases) {
    ASSERT_FALSE(c.result.ok()) << c.field;
    EXPECT_EQ(c.result.status().code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(c.result.status().field(), c.field);
  }
  EXPECT_NE(RigidOnHalfSpace(1e9, 0.6).status().message().find("(-1, 0.5]"), std::string::npos);
}

// Moduli whose effective E* or G* would not be finite and normal are refused under their own
// field, with the usable range; every modulus in that range gives finite, positive E* and G*.
TEST(MaterialTest, ModuliBeyondTheSceneScaleAreNamedNotTheirDerivedModuli) {
  const double tiny = 5e-324;
  for (const Status& s :
       {RigidOnHalfSpace(tiny, 0.3).status(), RigidOnHalfSpace(1e300, 0.3).status(),
        ElasticPair(tiny, 0.3, 1e9, 0.3).status(), ElasticPair(1e9, 0.3, 1e101, 0.3).status()}) {
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.field().find("modulus"), std::string::npos) << s.field();
    EXPECT_NE(s.message().find("must be in [1e-100, 1e+100]"), std::string::npos) << s.message();
  }
  EXPECT_EQ(ElasticPair(tiny, 0.3, 1e9, 0.3).status().field(), "youngs_modulus_1");
  const double nu_near_minus_one = std::nextafter(-1.0, 0.0);
  for (double modulus : {1e-100, 1e100}) {
    for (double nu : {nu_near_minus_one, 0.0, 0.5}) {
      for (const Result<EffectiveMaterial>& m :
           {RigidOnHalfSpace(modulus, nu), ElasticPair(modulus, nu, modulus, nu)}) {
        ASSERT_TRUE(m.ok());
        EXPECT_TRUE(std::isnormal(m->e_star) && m->e_star > 0) << modulus << " " << nu;
        EXPECT_TRUE(std::isnormal(m->g_star) && m->g_star > 0) << modulus << " " << nu;
      }
    }
  }
}

}  // namespace
}  // namespace mdr
