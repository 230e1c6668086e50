// A test rig in series with the contact (issue #24; docs/physics.md, "The rig in series"): steps
// drive the actuator, u_act = u_x + C_t F_x and delta_act = delta + C_n F_N, and the contact
// follows exactly where the engine is exact.
#include <gtest/gtest.h>

#include <cmath>

#include "fixtures/reference_scenes.h"
#include "mdr/core/contact.h"
#include "test_util.h"

namespace mdr {
namespace {

Step Actuator(double displacement) {
  Step s;
  s.tangential = TangentialControl::kDisplacement;
  s.tangential_value = displacement;
  return s;
}

Contact H1WithRig(double tangential, double normal = 0) {
  ContactConfig config = reference::H1Config();
  config.rig = {tangential, normal};
  Contact c = std::move(Contact::Create(config)).value();
  Step load;
  load.normal = NormalControl::kForce;
  load.normal_value = reference::H1::kNormalForce;
  EXPECT_TRUE(c.Apply(load).ok());
  return c;
}

// At constant normal force an actuator move is one exact step: the contact sits where
// u_x + C_t F_x(u_x) = u_act, with F_x the Cattaneo-Mindlin force of u_x, and the loop through
// the rig is the contact's own loop: same forces at the same contact displacements, same energy.
TEST(RigTest, AnActuatorMoveIsTheContactMoveThroughTheSpring) {
  const double compliance = 2e-8;  // m/N: a rig of 50 N/um against the contact's ~35 N/um
  Contact rig = H1WithRig(compliance);
  Contact free = reference::LoadedH1Contact();
  const double mk = rig.mu_kappa() * rig.depth();
  for (double u_act : {0.3 * mk, 1e-3 * mk, -0.7 * mk, 0.2 * mk, 2.5 * mk, -3 * mk}) {
    StepReport report;
    ASSERT_TRUE(rig.Apply(Actuator(u_act), &report).ok());
    EXPECT_EQ(report.substeps, 1) << "one exact step";
    EXPECT_NEAR(rig.actuator_displacement(), u_act, 1e-13 * mk);
    EXPECT_NEAR(rig.tangential_displacement() + compliance * rig.tangential_force(), u_act,
                1e-13 * mk);
    ASSERT_TRUE(free.MoveTo(free.depth(), rig.tangential_displacement()).ok());
    EXPECT_NEAR(rig.tangential_force(), free.tangential_force(), 1e-12 * rig.friction_limit());
    EXPECT_NEAR(rig.dissipated_energy(), free.dissipated_energy(),
                1e-12 * free.dissipated_energy() + 1e-30);
  }
  // Beyond gross slip the spring carries mu F_N and the contact slides the rest.
  EXPECT_NEAR(rig.tangential_force(), -rig.friction_limit(), 1e-12 * rig.friction_limit());
}

TEST(RigTest, ANormalRigSetsTheContactDepthFromTheActuatorDepth) {
  const double compliance = 1e-8;  // m/N
  Contact c = H1WithRig(0, compliance);
  const double depth = c.depth();
  EXPECT_NEAR(c.actuator_depth(), depth + compliance * 100, 1e-12 * depth);
  Step deeper;
  deeper.normal = NormalControl::kDepth;
  deeper.normal_value = c.actuator_depth() + 1e-6;
  ASSERT_TRUE(c.Apply(deeper).ok());
  EXPECT_NEAR(c.depth() + compliance * c.normal_force(), deeper.normal_value, 1e-15);
  Step hold;  // an unset normal channel holds the actuator, and with it the contact depth
  const double held = c.depth();
  ASSERT_TRUE(c.Apply(hold).ok());
  EXPECT_EQ(c.depth(), held);
}

// A depth change while the tangential rig deforms is a curved path: at the end the actuator is
// where the step said, within the path error bound.
TEST(RigTest, DepthAndActuatorTogetherFollowTheCurvedPath) {
  const double compliance = 2e-8;
  Contact c = H1WithRig(compliance);
  const double mk = c.mu_kappa() * c.depth();
  ASSERT_TRUE(c.Apply(Actuator(0.4 * mk)).ok());
  Step both;
  both.normal = NormalControl::kDepthIncrement;
  both.normal_value = -0.2 * c.depth();
  StepReport report;
  ASSERT_TRUE(c.Apply(both, &report).ok());  // the actuator holds: the contact moves
  EXPECT_GT(report.substeps, 1);
  EXPECT_NEAR(c.actuator_displacement(), 0.4 * mk, 1e-12 * mk);
  EXPECT_LE(report.path_error, 1e-6);
}

}  // namespace
}  // namespace mdr
