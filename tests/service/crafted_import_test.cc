// Imports of states no loading history reaches (issue #27) are refused naming the snapshot's
// field, and create nothing: a memory that zigzags inside the Coulomb bound (its tractions reached
// 2.5 to 19 times mu p and its Jäger weights, read +-1, summed to 3.6 times the force), the same
// on the grid, and a depth whose normal force is not finite. States the engine reaches import as
// before (the stability suite and both fuzzers restore every state they reach).
#include "mdr/bridge/conversion.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

constexpr double kFriction = 0.3;

class CraftedImportTest : public ServiceTest {
 protected:
  // H1 pressed to 100 N and exported.
  v1::SessionSnapshot Pressed(const v1::Scene& scene) {
    const std::string session = CreateScene(scene);
    v1::ApplyResponse response;
    EXPECT_TRUE(Apply(session, {NormalForceStep(100)}, &response).ok());
    return ExportOrDie(session);
  }

  void ExpectRefused(const v1::SessionSnapshot& snapshot, const std::string& field) {
    const std::size_t before = server_->session_count();
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = snapshot;
    v1::Session imported;
    const grpc::Status status = stub_->ImportSession(Context().get(), request, &imported);
    ExpectInvalidArgument(status, field);
    EXPECT_EQ(server_->session_count(), before);
  }

  // mu kappa of the snapshot's scene, as the engine clamps with.
  static double MuKappa(const v1::SessionSnapshot& snapshot) {
    Result<ContactConfig> config =
        bridge::ToContactConfig(snapshot.scene(), 1'000'000, Interrupt());
    EXPECT_TRUE(config.ok());
    return config->friction * config->material.kappa();
  }
};

TEST_F(CraftedImportTest, AZigzagInsideTheCoulombBoundIsRefused) {
  v1::SessionSnapshot snapshot = Pressed(SteelSphereOnSteelFlat());
  ASSERT_EQ(snapshot.scene().friction(), kFriction);
  const double depth = snapshot.contact().depth(), mu_kappa = MuKappa(snapshot);
  // The export itself imports.
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  v1::Session imported;
  ASSERT_TRUE(stub_->ImportSession(Context().get(), request, &imported).ok());

  // Twenty teeth at half the bound: every vertex inside it, every segment 10 times too steep.
  v1::SessionSnapshot zigzag = snapshot;
  auto* memory = zigzag.mutable_contact()->mutable_memory();
  memory->Clear();
  constexpr int kVertices = 21;
  for (int k = 0; k < kVertices; ++k) {
    const double z = depth * k / (kVertices - 1);
    v1::MemoryVertex* vertex = memory->Add();
    vertex->set_z(k == kVertices - 1 ? depth : z);
    vertex->set_u(k == kVertices - 1 ? 0 : (k % 2 ? 0.5 : -0.5) * mu_kappa * (depth - z));
  }
  ExpectRefused(zigzag, "snapshot.contact.memory[0]");

  // A segment steeper than the cone by far less than any force shows is a rounding of the
  // engine's: a milder tooth, only 1e-6 of mu kappa delta beyond it, is still refused.
  v1::SessionSnapshot mild = snapshot;
  auto* vertices = mild.mutable_contact()->mutable_memory();
  vertices->Clear();
  for (double z : {0.0, 0.5 * depth, depth}) vertices->Add()->set_z(z);
  vertices->Mutable(0)->set_u(0);
  vertices->Mutable(1)->set_u(mu_kappa * 0.5 * depth * (1 - 1e-9));  // inside its bound
  vertices->Mutable(0)->set_u(-1e-6 * mu_kappa * depth);             // one micro-tooth
  ExpectRefused(mild, "snapshot.contact.memory[0]");
}

TEST_F(CraftedImportTest, AZigzagOnTheGridIsRefused) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_size(400);
  scene.mutable_grid()->set_max_radius(4e-4);
  v1::SessionSnapshot snapshot = Pressed(scene);
  const double mu_kappa = MuKappa(snapshot);
  const double depth = snapshot.contact().depth();
  // Every second spring at a fraction of the bound at the contact's centre: inside each spring's
  // bound, far steeper than the cone between neighbours.
  v1::SessionSnapshot zigzag = snapshot;
  auto* u = zigzag.mutable_contact()->mutable_grid_u();
  ASSERT_GT(u->size(), 100);
  for (int j = 1; j < 20; j += 2) u->Set(j, 0.5 * mu_kappa * depth * 0.5);
  ExpectRefused(zigzag, "snapshot.contact.grid_u[1]");
}

TEST_F(CraftedImportTest, ADepthWithoutAFiniteForceIsRefused) {
  v1::SessionSnapshot snapshot = Pressed(SteelSphereOnSteelFlat());
  v1::SessionSnapshot deep = snapshot;
  v1::ContactSnapshot* contact = deep.mutable_contact();
  contact->set_depth(1e200);
  contact->mutable_memory()->Clear();
  contact->add_memory()->set_z(0);
  contact->add_memory()->set_z(1e200);
  ExpectRefused(deep, "snapshot.contact.depth");
}

}  // namespace
}  // namespace mdr::service_testing
