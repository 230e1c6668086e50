// Torsion through the service (issue #49): a session with scene.torsion is twisted by angle,
// increment or moment target and answers the core's exact values bit for bit (the Hertz closed
// forms to 1e-12); what it cannot do is refused naming the field and changes nothing (a
// tangential channel, a combined step, a load decrease that would break |F| <= 1, tangential
// outputs, scenes torsion does not cover); an export continues bit for bit after an import.
#include <random>

#include "mdr/core/material.h"
#include "mdr/core/profile.h"
#include "mdr/core/torsion.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using bridge_testing::HertzContactRadius;
using bridge_testing::HertzFullSlipMoment;
using bridge_testing::HertzTorsionalStiffness;
using bridge_testing::RandomTorsionStep;
using bridge_testing::TwistedSteelSphere;
using bridge_testing::TwistIncrementStep;
using bridge_testing::TwistingMomentStep;
using bridge_testing::TwistStep;

TorsionStep Normal(double force) {
  TorsionStep step;
  step.normal = NormalControl::kForce;
  step.normal_value = force;
  return step;
}

TorsionStep Twist(TwistControl control, double value) {
  TorsionStep step;
  step.twist = control;
  step.twist_value = value;
  return step;
}

class TorsionServiceTest : public ServiceTest {
 protected:
  grpc::Status ImportAs(const v1::SessionSnapshot& snapshot, const std::string& id,
                        v1::Session* session) {
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = snapshot;
    request.set_session_id(id);
    return stub_->ImportSession(Context().get(), request, session);
  }

  // The same history on the core's own contact, of the moduli the core derives from the
  // scene's, for a bit-for-bit comparison.
  static TorsionalContact CoreContact() {
    Result<ProfilePtr> sphere = MakeSphere(bridge_testing::kRadius);
    EXPECT_TRUE(sphere.ok());
    Result<EffectiveMaterial> material =
        ElasticPair(kYoungsModulus, kPoissonRatio, kYoungsModulus, kPoissonRatio);
    Result<double> modulus =
        TorsionalModulusOfPair(kYoungsModulus, kPoissonRatio, kYoungsModulus, kPoissonRatio);
    EXPECT_TRUE(material.ok() && modulus.ok());
    Result<TorsionalContact> contact =
        TorsionalContact::Create(*sphere, bridge_testing::kFriction, material->e_star, *modulus);
    EXPECT_TRUE(contact.ok()) << contact.status().ToString();
    return std::move(contact).value();
  }
};

TEST_F(TorsionServiceTest, AMonotoneTwistGivesTheHertzClosedForms) {
  const std::string session = CreateScene(TwistedSteelSphere());
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {NormalForceStep(100)}, &response).ok());
  const v1::ContactState loaded = response.state();
  ExpectRelativelyNear(loaded.contact_radius(), HertzContactRadius(100), 1e-12);
  ExpectRelativelyNear(loaded.full_slip_moment(), HertzFullSlipMoment(100), 1e-12);
  EXPECT_EQ(loaded.twist(), 0);
  EXPECT_EQ(loaded.twisting_moment(), 0);
  v1::QueryResponse query;
  ASSERT_TRUE(Query(session, &query, {"torsion.stiffness"}).ok());
  ExpectRelativelyNear(query.torsion().stiffness_positive(), HertzTorsionalStiffness(100), 1e-12);
  ExpectRelativelyNear(query.torsion().stiffness_negative(), HertzTorsionalStiffness(100), 1e-12);
  EXPECT_FALSE(query.has_state());  // only what was asked

  // To half the full-slip moment: reached exactly, the twist positive, a slip annulus outside.
  const double target = 0.5 * loaded.full_slip_moment();
  ASSERT_TRUE(Apply(session, {TwistingMomentStep(target)}, &response, {"state.twist"}).ok());
  ExpectRelativelyNear(response.state().twisting_moment(), target, 1e-12);
  EXPECT_GT(response.state().twist(), 0);
  EXPECT_EQ(response.step_results(0).state().twist(), response.state().twist());
  ASSERT_TRUE(Query(session, &query, {"torsion.slip_intervals", "torsion.stiffness"}).ok());
  ASSERT_EQ(query.torsion().slip_intervals_size(), 1);
  EXPECT_EQ(query.torsion().slip_intervals(0).direction(), 1);
  EXPECT_GT(query.torsion().slip_intervals(0).r_begin(), 0);
  EXPECT_EQ(query.torsion().slip_intervals(0).r_end(), loaded.contact_radius());
  // Stiffer backwards (Masing: the whole contact sticks after a reversal).
  ExpectRelativelyNear(query.torsion().stiffness_negative(), HertzTorsionalStiffness(100), 1e-12);
  EXPECT_LT(query.torsion().stiffness_positive(), query.torsion().stiffness_negative());
}

// scene.torsion.torsional_modulus replaces the material's G_t (what FitLoops identified): the
// stiffness 16 G_t a^3 / 3 scales with it, the normal problem (E*) does not change.
TEST_F(TorsionServiceTest, TheScenesTorsionalModulusReplacesTheMaterials) {
  v1::Scene scene = TwistedSteelSphere();
  const double material = *TorsionalModulusOfPair(kYoungsModulus, kPoissonRatio, kYoungsModulus,
                                                   kPoissonRatio);
  scene.mutable_torsion()->set_torsional_modulus(0.5 * material);
  const std::string session = CreateScene(scene);
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {NormalForceStep(100)}, &response).ok());
  ExpectRelativelyNear(response.state().contact_radius(), HertzContactRadius(100), 1e-12);
  v1::QueryResponse query;
  ASSERT_TRUE(Query(session, &query, {"torsion.stiffness"}).ok());
  ExpectRelativelyNear(query.torsion().stiffness_positive(), 0.5 * HertzTorsionalStiffness(100),
                       1e-12);
  scene.mutable_torsion()->set_torsional_modulus(0);
  v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = scene;
  v1::Session created;
  ExpectInvalidArgument(stub_->CreateSession(Context().get(), create, &created),
                        "session.scene.torsion.torsional_modulus");
}

TEST_F(TorsionServiceTest, EveryAnswerIsTheCoresBitForBit) {
  const std::string session = CreateScene(TwistedSteelSphere());
  TorsionalContact core = CoreContact();
  const std::vector<v1::Step> steps = {NormalForceStep(100),      TwistStep(3e-3),
                                       TwistIncrementStep(-4e-3), NormalForceStep(140),
                                       TwistingMomentStep(1e-3),  TwistStep(0)};
  const std::vector<TorsionStep> core_steps = {
      Normal(100), Twist(TwistControl::kAngle, 3e-3),  Twist(TwistControl::kAngleIncrement, -4e-3),
      Normal(140), Twist(TwistControl::kMoment, 1e-3), Twist(TwistControl::kAngle, 0)};
  for (std::size_t i = 0; i < steps.size(); ++i) {
    v1::ApplyResponse response;
    ASSERT_TRUE(Apply(session, {steps[i]}, &response, {"dissipated_energy"}).ok()) << i;
    ASSERT_TRUE(core.Apply(core_steps[i]).ok()) << i;
    const TorsionalMemory& memory = core.memory();
    const v1::ContactState& state = response.state();
    EXPECT_TRUE(SameBits(state.twist(), memory.twist())) << i;
    EXPECT_TRUE(SameBits(state.twisting_moment(), memory.Moment())) << i;
    EXPECT_TRUE(SameBits(state.full_slip_moment(), memory.FullSlipMoment())) << i;
    EXPECT_TRUE(SameBits(state.depth(), core.depth())) << i;
    EXPECT_TRUE(SameBits(state.normal_force(), core.normal_force())) << i;
    EXPECT_TRUE(SameBits(state.dissipated_energy(), memory.dissipated_energy())) << i;
    EXPECT_TRUE(
        SameBits(response.step_results(0).dissipated_energy(), memory.last_step_dissipation()))
        << i;
    EXPECT_EQ(state.memory_vertices(), memory.pieces().size()) << i;
    EXPECT_EQ(state.applied_steps(), i + 1);
    EXPECT_EQ(state.tangential_force(), 0);
  }
  // The tractions of both routes and the rest of the outputs, at radii in and out of contact.
  const double a = core.memory().contact_radius();
  const std::vector<double> radii = {0, 0.25 * a, 0.5 * a, 0.9 * a, a, 2 * a};
  v1::QueryResponse query;
  ASSERT_TRUE(Query(session, &query, {"torsion", "energy"}, radii).ok());
  ASSERT_EQ(query.torsion().tractions_size(), static_cast<int>(radii.size()));
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const TorsionTraction expected = core.memory().Traction(radii[i]);
    const v1::TorsionTraction& traction = query.torsion().tractions(static_cast<int>(i));
    EXPECT_EQ(traction.radius(), radii[i]);
    EXPECT_TRUE(SameBits(traction.value(), expected.value)) << i;
    EXPECT_TRUE(SameBits(traction.route_difference(), expected.route_difference)) << i;
  }
  EXPECT_TRUE(SameBits(query.torsion().stored_energy(), core.memory().StoredEnergy()));
  ASSERT_EQ(query.torsion().memory_pieces_size(), static_cast<int>(core.memory().pieces().size()));
  for (int i = 0; i < query.torsion().memory_pieces_size(); ++i) {
    const TorsionPiece& piece = core.memory().pieces()[static_cast<std::size_t>(i)];
    EXPECT_TRUE(SameBits(query.torsion().memory_pieces(i).end(), piece.end));
    EXPECT_EQ(query.torsion().memory_pieces(i).sign(), piece.sign);
    EXPECT_TRUE(SameBits(query.torsion().memory_pieces(i).radius(), piece.radius));
    EXPECT_TRUE(SameBits(query.torsion().memory_pieces(i).offset(), piece.offset));
  }
  EXPECT_TRUE(SameBits(query.energy().dissipated_energy(), core.memory().dissipated_energy()));
  EXPECT_EQ(query.error_estimate().profile_tolerance(), 0);
}

TEST_F(TorsionServiceTest, WhatTorsionCannotDoIsRefusedNamingTheFieldAndChangesNothing) {
  const std::string session = CreateScene(TwistedSteelSphere());
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {NormalForceStep(100), TwistStep(3e-3)}, &response).ok());
  const v1::SessionSnapshot before = ExportOrDie(session);

  // A tangential channel, alone or with a twist; a twist with the normal channel; per-contact
  // values; a second step of a batch failing.
  ExpectInvalidArgument(Apply(session, {DisplacementStep(1e-7)}, &response),
                        "steps[0].displacement");
  v1::Step combined = TwistStep(1e-3);
  combined.set_tangential_force(1);
  ExpectInvalidArgument(Apply(session, {combined}, &response), "steps[0].tangential_force");
  v1::Step both = TwistStep(1e-3);
  both.set_normal_force(120);
  ExpectInvalidArgument(Apply(session, {both}, &response), "steps[0].twist");
  v1::Step listed = TwistStep(1e-3);
  listed.add_contact_normal_values(1);
  ExpectInvalidArgument(Apply(session, {listed}, &response), "steps[0].contact_normal_values");
  ExpectInvalidArgument(Apply(session, {TwistStep(1e-3), TwistStep(NAN)}, &response),
                        "steps[1].twist");
  // A moment at or beyond the full-slip moment is reached by no finite twist.
  const double full_slip = HertzFullSlipMoment(100);
  EXPECT_EQ(Apply(session, {TwistingMomentStep(1.01 * full_slip)}, &response).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  // Twist to c = 0.1 a, reverse 30 %, drop the load to a fifth: |F| <= 1 would break.
  ASSERT_TRUE(
      Apply(session, {TwistStep(0), TwistingMomentStep(0.999 * full_slip)}, &response).ok());
  const double twisted = response.state().twist();
  ASSERT_TRUE(Apply(session, {TwistStep(0.7 * twisted)}, &response).ok());
  const v1::SessionSnapshot reversed = ExportOrDie(session);
  grpc::Status decrease = Apply(session, {NormalForceStep(20)}, &response);
  EXPECT_EQ(decrease.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(decrease.error_message(), ::testing::StartsWith("steps[0].normal_force: "));
  EXPECT_EQ(ExportOrDie(session).SerializeAsString(), reversed.SerializeAsString());

  // Tangential outputs are not a torsional session's; torsion outputs not a tangential one's.
  v1::QueryResponse query;
  for (const char* path : {"tangential_stiffness", "jager_weights", "memory_pieces", "pressure"}) {
    grpc::Status status = Query(session, &query, {path}, {0.0});
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << path;
    EXPECT_THAT(status.error_message(), ::testing::StartsWith("read_mask: ")) << path;
  }
  const std::string tangential = CreateOrDie();
  EXPECT_EQ(Query(tangential, &query, {"torsion.stiffness"}).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  ExpectInvalidArgument(Apply(tangential, {TwistStep(1e-3)}, &response), "steps[0].twist");
  ExpectInvalidArgument(Apply(tangential, {DepthStep(kDepth), TwistingMomentStep(1e-3)}, &response),
                        "steps[1].twisting_moment");
  EXPECT_EQ(StateOf(tangential).applied_steps(), 0u);
}

TEST_F(TorsionServiceTest, ScenesTorsionDoesNotCoverAreRefusedNamingTheField) {
  v1::Session session;
  v1::Scene scene = TwistedSteelSphere();
  scene.mutable_interface()->set_kind(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->mutable_generated()->set_count(3);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface");
  scene = TwistedSteelSphere();
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_max_radius(1e-3);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.method");
  scene = TwistedSteelSphere();
  scene.mutable_rig()->set_tangential_compliance(1e-9);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.rig");
  scene = TwistedSteelSphere();
  scene.mutable_flat_punch()->set_radius(1e-3);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.flat_punch");
  scene = TwistedSteelSphere();
  scene.set_friction(0);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.friction");
  // Each profile torsion supports, with either material.
  scene = TwistedSteelSphere();
  scene.mutable_cone()->set_slope_angle(0.1);
  EXPECT_TRUE(Create(scene, &session).ok());
  scene.mutable_power_law()->set_coefficient(1e8);
  scene.mutable_power_law()->set_exponent(4);
  scene.mutable_rigid_on_half_space()->set_shear_modulus(1e9);
  scene.mutable_rigid_on_half_space()->set_poisson_ratio(0.5);
  EXPECT_TRUE(Create(scene, &session).ok());
}

// Every torsional state a random history reaches exports and imports bit for bit, and the
// import goes on exactly like the original (the same answers, refusals included).
TEST_F(TorsionServiceTest, AnImportContinuesBitForBit) {
  const std::string original = CreateScene(TwistedSteelSphere());
  std::mt19937_64 random(49);
  v1::ApplyResponse response;
  int refused = 0;
  for (int round = 0; round < 12; ++round) {
    for (int i = 0; i < 6; ++i) {
      if (!Apply(original, {RandomTorsionStep(random)}, &response).ok()) ++refused;
    }
    const v1::SessionSnapshot snapshot = ExportOrDie(original);
    v1::Session imported;
    ASSERT_TRUE(ImportAs(snapshot, "copy-" + std::to_string(round), &imported).ok());
    EXPECT_EQ(ExportOrDie(imported.name()).torsion().SerializeAsString(),
              snapshot.torsion().SerializeAsString());
    std::mt19937_64 same(round), again(round);
    for (int i = 0; i < 6; ++i) {
      v1::ApplyResponse first, second;
      const grpc::Status a = Apply(original, {RandomTorsionStep(same)}, &first);
      const grpc::Status b = Apply(imported.name(), {RandomTorsionStep(again)}, &second);
      ASSERT_EQ(a.error_code(), b.error_code()) << a.error_message();
      EXPECT_EQ(first.state().SerializeAsString(), second.state().SerializeAsString());
    }
    EXPECT_EQ(ExportOrDie(original).torsion().SerializeAsString(),
              ExportOrDie(imported.name()).torsion().SerializeAsString());
  }
  EXPECT_GT(ExportOrDie(original).torsion().pieces_size(), 2);
  EXPECT_LT(refused, 36);  // most steps of the history are exact steps, not refusals
}

TEST_F(TorsionServiceTest, ACraftedSnapshotIsRefusedNamingTheField) {
  const std::string session = CreateScene(TwistedSteelSphere());
  v1::ApplyResponse response;
  ASSERT_TRUE(
      Apply(session, {NormalForceStep(100), TwistStep(3e-3), TwistStep(1e-3)}, &response).ok());
  const v1::SessionSnapshot good = ExportOrDie(session);
  ASSERT_GE(good.torsion().pieces_size(), 2);
  v1::Session imported;
  v1::SessionSnapshot bad = good;
  bad.mutable_torsion()->mutable_pieces(1)->set_sign(2);
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.torsion.pieces[1].sign");
  bad = good;
  bad.mutable_torsion()->set_contact_radius(good.torsion().contact_radius() * (1 + 1e-15));
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.torsion.contact_radius");
  bad = good;
  bad.mutable_torsion()->set_twist(std::numeric_limits<double>::infinity());
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.torsion.twist");
  bad = good;
  bad.mutable_torsion()->set_dissipated_energy(-1);
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.torsion.dissipated_energy");
  bad = good;
  bad.mutable_contact()->set_depth(1e-6);
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.contact");
  bad = good;
  bad.mutable_scene()->clear_torsion();
  ExpectInvalidArgument(ImportAs(bad, "", &imported), "snapshot.torsion");
  EXPECT_TRUE(ImportAs(good, "", &imported).ok());
}

}  // namespace
}  // namespace mdr::service_testing
