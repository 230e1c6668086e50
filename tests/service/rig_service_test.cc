// A test rig in series through the service (issue #24): scene.rig makes every depth and
// displacement of a step the actuator's, the state reports both positions, invalid compliances
// and a rig on an interface are refused naming the field, and the rig travels with an export.
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

constexpr double kCompliance = 2e-8;  // m/N

v1::Scene RigScene() {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_rig()->set_tangential_compliance(kCompliance);
  scene.mutable_rig()->set_normal_compliance(1e-9);
  return scene;
}

class RigServiceTest : public ServiceTest {};

TEST_F(RigServiceTest, StepsDriveTheActuatorAndTheStateShowsBothPositions) {
  const std::string session = CreateScene(RigScene());
  v1::ApplyResponse response;
  ASSERT_TRUE(
      Apply(session, {NormalForceStep(100), DisplacementStep(7.6949658143e-7)}, &response).ok());
  const v1::ContactState state = StateOf(session);
  // 15 N on the virgin curve with the contact at u0 = 4.6949658143e-7 m (H1): the rig takes
  // the rest of the actuator's stroke.
  ExpectRelativelyNear(state.tangential_force(), 15, 1e-9);
  ExpectRelativelyNear(state.tangential_displacement(), 4.6949658143e-7, 1e-9);
  ExpectRelativelyNear(state.actuator_displacement(), 7.6949658143e-7, 1e-12);
  ExpectRelativelyNear(state.actuator_depth(), state.depth() + 1e-9 * 100, 1e-12);
  // An export carries the rig: the imported session goes on like the original.
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = ExportOrDie(session);
  v1::Session copy;
  ASSERT_TRUE(stub_->ImportSession(Context().get(), request, &copy).ok());
  for (const std::string& each : {session, copy.name()}) {
    ASSERT_TRUE(Apply(each, {DisplacementStep(-7.6949658143e-7)}, &response).ok());
  }
  EXPECT_EQ(StateOf(session).tangential_force(), StateOf(copy.name()).tangential_force());
  EXPECT_EQ(StateOf(session).actuator_displacement(), StateOf(copy.name()).actuator_displacement());
}

TEST_F(RigServiceTest, InvalidRigsAreRefusedNamingTheField) {
  v1::Session session;
  v1::Scene scene = RigScene();
  scene.mutable_rig()->set_tangential_compliance(-1e-9);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.rig.tangential_compliance");
  scene = RigScene();
  scene.mutable_rig()->set_normal_compliance(std::numeric_limits<double>::infinity());
  ExpectInvalidArgument(Create(scene, &session), "session.scene.rig.normal_compliance");
  scene = RigScene();
  scene.mutable_interface()->set_kind(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->mutable_generated()->set_count(3);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.rig");
}

}  // namespace
}  // namespace mdr::service_testing
