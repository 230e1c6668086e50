// CreateSession, GetSession, DeleteSession, Apply and Query through the generated stub against a
// real server on a free port.
#include "mdr/service/contact_service.h"

#include <google/protobuf/util/message_differencer.h>

#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using bridge::Output;
using google::protobuf::util::MessageDifferencer;
using ::testing::HasSubstr;

using ContactServiceTest = ServiceTest;

TEST_F(ContactServiceTest, CreateSessionReturnsUnloadedSessionResource) {
  v1::Session session;
  grpc::Status status = Create(SteelSphereOnSteelFlat(), &session);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(session.name().starts_with("sessions/")) << session.name();
  EXPECT_TRUE(MessageDifferencer::Equals(session.scene(), SteelSphereOnSteelFlat()));
  EXPECT_EQ(session.state().depth(), 0);
  EXPECT_EQ(session.state().normal_force(), 0);
  EXPECT_EQ(session.state().applied_steps(), 0u);
  EXPECT_GT(session.create_time().seconds(), 0);
  // The server's limits (defaults: 10000 steps per batch, one hour idle).
  EXPECT_EQ(session.limits().max_steps_per_batch(), 10000u);
  EXPECT_EQ(session.limits().idle_timeout().seconds(), 3600);
  EXPECT_NEAR(session.expire_time().seconds() - session.create_time().seconds(), 3600, 2);

  v1::GetSessionRequest get;
  get.set_name(session.name());
  v1::Session fetched;
  ASSERT_TRUE(stub_->GetSession(Context().get(), get, &fetched).ok());
  EXPECT_TRUE(MessageDifferencer::Equals(fetched.state(), session.state()));
  EXPECT_TRUE(MessageDifferencer::Equals(fetched.limits(), session.limits()));
  EXPECT_EQ(fetched.name(), session.name());
}

TEST_F(ContactServiceTest, CreateSessionRejectsInvalidSceneNamingTheField) {
  const auto expect_invalid = [&](const v1::Scene& scene, const std::string& field) {
    v1::Session session;
    ExpectInvalidArgument(Create(scene, &session), field);
  };
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(-1);
  expect_invalid(scene, "session.scene.sphere.radius");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(std::nan(""));
  expect_invalid(scene, "session.scene.sphere.radius");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_elastic_pair()->set_poisson_ratio_2(0.7);
  expect_invalid(scene, "session.scene.elastic_pair.poisson_ratio_2");

  scene = SteelSphereOnSteelFlat();
  scene.set_friction(-0.1);
  expect_invalid(scene, "session.scene.friction");

  scene = SteelSphereOnSteelFlat();
  scene.set_friction(INFINITY);
  expect_invalid(scene, "session.scene.friction");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_power_law()->set_coefficient(1);
  scene.mutable_power_law()->set_exponent(20);
  expect_invalid(scene, "session.scene.power_law.exponent");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_force_path_tolerance(0.5);
  expect_invalid(scene, "session.scene.options.force_path_tolerance");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_max_memory_vertices(0);
  expect_invalid(scene, "session.scene.options.max_memory_vertices");

  // Above the server's --max-memory-vertices (default 2^20).
  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_max_memory_vertices(uint64_t{1} << 21);
  expect_invalid(scene, "session.scene.options.max_memory_vertices");

  scene = SteelSphereOnSteelFlat();
  scene.clear_sphere();
  expect_invalid(scene, "session.scene.profile");

  scene = SteelSphereOnSteelFlat();
  scene.clear_elastic_pair();
  expect_invalid(scene, "session.scene.material");
}

TEST_F(ContactServiceTest, CreateSessionResolvesAndChecksSessionLimits) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  request.mutable_session()->mutable_limits()->set_max_steps_per_batch(5);
  request.mutable_session()->mutable_limits()->mutable_idle_timeout()->set_seconds(60);
  v1::Session session;
  ASSERT_TRUE(stub_->CreateSession(Context().get(), request, &session).ok());
  EXPECT_EQ(session.limits().max_steps_per_batch(), 5u);
  EXPECT_EQ(session.limits().idle_timeout().seconds(), 60);

  // The session's own limit applies to its batches.
  v1::ApplyResponse response;
  grpc::Status status =
      Apply(session.name(), std::vector<v1::Step>(6, DepthStep(kDepth)), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("steps: 6 steps exceed the session's limit of 5"));

  request.mutable_session()->mutable_limits()->set_max_steps_per_batch(20000);
  status = stub_->CreateSession(Context().get(), request, &session);
  ExpectInvalidArgument(status, "session.limits.max_steps_per_batch");
  EXPECT_THAT(status.error_message(), HasSubstr("[1, 10000]"));

  request.mutable_session()->mutable_limits()->set_max_steps_per_batch(0);
  request.mutable_session()->mutable_limits()->mutable_idle_timeout()->set_seconds(7200);
  ExpectInvalidArgument(stub_->CreateSession(Context().get(), request, &session),
                        "session.limits.idle_timeout");
  request.mutable_session()->mutable_limits()->mutable_idle_timeout()->set_seconds(0);
  ExpectInvalidArgument(stub_->CreateSession(Context().get(), request, &session),
                        "session.limits.idle_timeout");
}

TEST_F(ContactServiceTest, CreateSessionWithChosenIdRejectsDuplicatesAndBadIds) {
  v1::Session session;
  ASSERT_TRUE(Create(SteelSphereOnSteelFlat(), &session, "rig-1").ok());
  EXPECT_EQ(session.name(), "sessions/rig-1");
  EXPECT_EQ(Create(SteelSphereOnSteelFlat(), &session, "rig-1").error_code(),
            grpc::StatusCode::ALREADY_EXISTS);
  ExpectInvalidArgument(Create(SteelSphereOnSteelFlat(), &session, "Rig/1"), "session_id");
}

TEST_F(ContactServiceTest, HertzDisplacementStepsMatchCattaneoMindlin) {
  const std::string session = CreateOrDie();
  std::vector<v1::Step> steps = {DepthStep(kDepth)};
  for (int k = 1; k <= 3; ++k) steps.push_back(DisplacementStep(kDisplacementAt15N * k / 3));
  v1::ApplyResponse response;
  grpc::Status status = Apply(session, steps, &response, {"state"});
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.step_results_size(), 4);

  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE("step " + std::to_string(i));
    const v1::ContactState& state = response.step_results(i).state();
    EXPECT_EQ(state.depth(), kDepth);
    ExpectRelativelyNear(state.normal_force(), HertzNormalForce(kDepth), 1e-10);
    ExpectRelativelyNear(state.contact_radius(), std::sqrt(kRadius * kDepth), 1e-10);
    const double displacement = i == 0 ? 0 : steps[i].displacement();
    EXPECT_EQ(state.tangential_displacement(), displacement);
    if (i == 0) {
      EXPECT_EQ(state.tangential_force(), 0);
    } else {
      ExpectRelativelyNear(state.tangential_force(),
                           CattaneoMindlinTangentialForce(kDepth, displacement), 1e-10);
    }
    EXPECT_EQ(state.applied_steps(), static_cast<std::uint64_t>(i + 1));
  }
  // The tabulated H1 values themselves (rounded to 11 digits there).
  ExpectRelativelyNear(response.state().normal_force(), 100, 1e-9);
  ExpectRelativelyNear(response.state().tangential_force(), 15, 1e-9);
  ExpectRelativelyNear(response.state().contact_radius(), 1.8662555784e-4, 1e-9);
  EXPECT_TRUE(MessageDifferencer::Equals(response.state(), response.step_results(3).state()));
  // Displacement steps are exact.
  EXPECT_EQ(response.error_estimate().path_error(), 0);
  EXPECT_GT(response.compute_seconds(), 0);
  EXPECT_FALSE(response.replayed());
}

TEST_F(ContactServiceTest, ForceControlledStepsReachTheirTargetsAndReportPathError) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session,
                    {NormalForceStep(100), TangentialForceStep(5), TangentialForceStep(15)},
                    &response)
                  .ok());
  ExpectRelativelyNear(response.state().normal_force(), 100, 1e-9);
  ExpectRelativelyNear(response.state().tangential_force(), 15, 1e-9);
  ExpectRelativelyNear(response.state().depth(), kDepth, 1e-9);
  ExpectRelativelyNear(response.state().tangential_displacement(), kDisplacementAt15N, 1e-9);
  EXPECT_EQ(response.error_estimate().path_error(), 0);  // straight paths: exact

  // Both forces changing at once: a curved path in (depth, ux), followed by exact sub-steps.
  v1::Step curved = NormalForceStep(150);
  curved.set_tangential_force(30);
  ASSERT_TRUE(Apply(session, {curved}, &response, {"substeps", "path_error"}).ok());
  ASSERT_EQ(response.step_results_size(), 1);
  EXPECT_GT(response.step_results(0).substeps(), 1);
  EXPECT_GT(response.step_results(0).path_error(), 0);
  EXPECT_LE(response.step_results(0).path_error(), 1e-6);
  EXPECT_EQ(response.error_estimate().path_error(), response.step_results(0).path_error());
  ExpectRelativelyNear(response.state().normal_force(), 150, 1e-9);
  ExpectRelativelyNear(response.state().tangential_force(), 30, 1e-9);
}

TEST_F(ContactServiceTest, StepMaskSelectsPerStepFields) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
  EXPECT_EQ(response.step_results_size(), 0);  // empty mask: final state only
  EXPECT_EQ(response.state().applied_steps(), 2u);

  ASSERT_TRUE(Apply(session, {DisplacementStep(2e-7), DisplacementStep(3e-7)}, &response,
                    {"state.tangential_force", "dissipated_energy"})
                  .ok());
  ASSERT_EQ(response.step_results_size(), 2);
  for (const v1::StepResult& result : response.step_results()) {
    EXPECT_GT(result.state().tangential_force(), 0);
    EXPECT_GT(result.dissipated_energy(), 0);  // partial slip dissipates
    EXPECT_EQ(result.state().depth(), 0);      // not selected
    EXPECT_EQ(result.state().normal_force(), 0);
    EXPECT_EQ(result.substeps(), 0);
  }
  EXPECT_EQ(response.step_results(1).state().tangential_force(),
            response.state().tangential_force());

  grpc::Status status =
      Apply(session, {DisplacementStep(1e-7)}, &response, {"state", "state.no_such_field"});
  ExpectInvalidArgument(status, "step_mask.paths[1]");
  EXPECT_EQ(StateOf(session).applied_steps(), 4u);
}

// The fields of `whole` that `paths` name, and nothing else.
v1::ContactState SelectedFields(const v1::ContactState& whole,
                                const std::vector<std::string>& paths) {
  v1::ContactState selected;
  const google::protobuf::Reflection* reflection = whole.GetReflection();
  for (const std::string& path : paths) {
    const google::protobuf::FieldDescriptor* field =
        v1::ContactState::descriptor()->FindFieldByName(path);
    EXPECT_NE(field, nullptr) << path;
    if (field == nullptr) continue;
    if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE) {
      reflection->SetDouble(&selected, field, reflection->GetDouble(whole, field));
    } else {
      reflection->SetUInt64(&selected, field, reflection->GetUInt64(whole, field));
    }
  }
  return selected;
}

// ApplyRequest.state_mask (issue #54): the answer holds the selected fields, bit for bit as a
// whole-state answer holds them, and nothing else; GetSession shows the whole state either way.
// For every kind of session, on the inline path (one straight step) and on the workers (a
// batch), with a rig whose actuator fields GetSession derives from the kept ones.
TEST_F(ContactServiceTest, StateMaskAnswersOnlyTheSelectedFieldsAndGetSessionTheWholeState) {
  v1::Scene rig = SteelSphereOnSteelFlat();
  rig.mutable_rig()->set_tangential_compliance(2e-9);
  rig.mutable_rig()->set_normal_compliance(1e-9);
  v1::Scene grid = SteelSphereOnSteelFlat();
  grid.set_method(v1::METHOD_GRID);
  grid.mutable_grid()->set_size(300);
  grid.mutable_grid()->set_max_radius(3e-4);
  v1::Scene interface = SteelSphereOnSteelFlat();
  interface.mutable_interface()->set_kind(v1::Interface::KIND_SHARED_MOTION);
  interface.mutable_interface()->mutable_explicit_list()->mutable_heights()->Add(0);
  interface.mutable_interface()->mutable_explicit_list()->mutable_heights()->Add(0.4 * kDepth);
  interface.mutable_interface()->mutable_explicit_list()->mutable_radii()->Add(kRadius);
  interface.mutable_interface()->mutable_explicit_list()->mutable_radii()->Add(2 * kRadius);
  const std::vector<v1::Step> tangential = {DisplacementStep(2e-7), DisplacementStep(-1e-7),
                                            DisplacementStep(3e-8)};
  const std::vector<v1::Step> twists = {bridge_testing::TwistStep(2e-3),
                                        bridge_testing::TwistStep(-1e-3),
                                        bridge_testing::TwistStep(5e-4)};
  struct Case {
    const char* name;
    v1::Scene scene;
    const std::vector<v1::Step>& steps;
    std::vector<std::string> mask;
  };
  const std::vector<Case> cases = {
      {"sphere", SteelSphereOnSteelFlat(), tangential, {"tangential_force"}},
      {"sphere, derived fields",
       SteelSphereOnSteelFlat(),
       tangential,
       {"normal_force", "contact_radius", "applied_steps"}},
      {"rig", rig, tangential, {"actuator_displacement", "tangential_force", "friction_limit"}},
      {"grid", grid, tangential, {"tangential_force", "memory_vertices"}},
      {"interface", interface, tangential, {"tangential_force"}},
      {"torsion", bridge_testing::TwistedSteelSphere(), twists, {"twisting_moment", "twist"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string masked = CreateScene(c.scene), whole = CreateScene(c.scene);
    // One step at a time (the inline path where it applies), then all of them as one batch.
    std::vector<std::vector<v1::Step>> batches = {{NormalForceStep(100)}};
    for (const v1::Step& step : c.steps) batches.push_back({step});
    batches.push_back(c.steps);
    for (const std::vector<v1::Step>& batch : batches) {
      v1::ApplyResponse from_whole, from_masked;
      ASSERT_TRUE(Apply(whole, batch, &from_whole).ok());
      v1::ApplyRequest request = ApplyRequestFor(masked, batch);
      *request.mutable_state_mask() = Mask(c.mask);
      const grpc::Status status = stub_->Apply(Context().get(), request, &from_masked);
      ASSERT_TRUE(status.ok()) << status.error_message();
      EXPECT_EQ(from_masked.state().SerializeAsString(),
                SelectedFields(from_whole.state(), c.mask).SerializeAsString())
          << from_masked.state().ShortDebugString() << " against "
          << from_whole.state().ShortDebugString();
      v1::GetSessionRequest get;
      v1::Session got_masked, got_whole;
      get.set_name(masked);
      ASSERT_TRUE(stub_->GetSession(Context().get(), get, &got_masked).ok());
      get.set_name(whole);
      ASSERT_TRUE(stub_->GetSession(Context().get(), get, &got_whole).ok());
      EXPECT_EQ(got_masked.state().SerializeAsString(), from_whole.state().SerializeAsString())
          << got_masked.state().ShortDebugString() << " against "
          << from_whole.state().ShortDebugString();
      EXPECT_EQ(got_whole.state().SerializeAsString(), from_whole.state().SerializeAsString());
    }
  }
}

TEST_F(ContactServiceTest, AStateMaskOfAnUnknownFieldOrAnotherReplayIsRefusedChangingNothing) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  v1::ApplyRequest request = ApplyRequestFor(session, {DisplacementStep(1e-7)});
  *request.mutable_state_mask() = Mask({"tangential_force", "state.normal_force"});
  grpc::Status status = stub_->Apply(Context().get(), request, &response);
  ExpectInvalidArgument(status, "state_mask.paths[1]");
  EXPECT_THAT(status.error_message(), HasSubstr("not a field of ContactState"));
  EXPECT_EQ(StateOf(session).applied_steps(), 1u);

  // A request id remembers the answer to its mask: a retry with another mask is another request.
  request = ApplyRequestFor(session, {DisplacementStep(1e-7)}, {}, "masked-once");
  *request.mutable_state_mask() = Mask({"tangential_force"});
  ASSERT_TRUE(stub_->Apply(Context().get(), request, &response).ok());
  const v1::ApplyResponse first = response;
  ASSERT_TRUE(stub_->Apply(Context().get(), request, &response).ok());
  EXPECT_TRUE(response.replayed());
  EXPECT_EQ(response.state().SerializeAsString(), first.state().SerializeAsString());
  *request.mutable_state_mask() = Mask({"normal_force"});
  ExpectInvalidArgument(stub_->Apply(Context().get(), request, &response), "request_id");
  EXPECT_EQ(StateOf(session).applied_steps(), 2u);
}

// Apply's messages are reused from call to call: nothing of an earlier call shows in a later one.
TEST_F(ContactServiceTest, LaterCallsCarryNothingOfEarlierOnes) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  for (int i = 0; i < 4; ++i) {  // the server's message pool hands the messages around
    ASSERT_TRUE(Apply(session, {DisplacementStep(1e-7), DisplacementStep(2e-7)}, &response,
                      {"state"}, "masked-" + std::to_string(i))
                    .ok());
    ASSERT_EQ(response.step_results_size(), 2);
    ExpectInvalidArgument(Apply(session, {DepthStep(std::nan(""))}, &response), "steps[0].depth");
    ASSERT_TRUE(Apply(session, {DisplacementStep(0)}, &response).ok());
    EXPECT_EQ(response.step_results_size(), 0) << "per-step results of an earlier call";
    EXPECT_FALSE(response.replayed());
    EXPECT_EQ(response.state().applied_steps(), 1u + 3u * (i + 1));
  }
}

TEST(ApplyMessagePoolTest, ReusesClearedMessagesAndKeepsABoundedAmount) {
  service::ApplyMessagePool pool;
  auto* first = pool.AllocateMessages();
  first->request()->set_session("sessions/a");
  first->request()->add_steps()->set_depth(1e-6);
  first->response()->add_step_results()->set_substeps(1);
  const v1::Step* step = &first->request()->steps(0);
  first->Release();
  EXPECT_EQ(pool.kept(), 1u);

  auto* again = pool.AllocateMessages();
  EXPECT_EQ(again, first) << "the kept pair is reused";
  EXPECT_EQ(again->request()->ByteSizeLong(), 0u) << "and cleared";
  EXPECT_EQ(again->response()->ByteSizeLong(), 0u);
  again->request()->add_steps()->set_displacement(2e-7);
  EXPECT_EQ(&again->request()->steps(0), step) << "its parsed steps are reused";
  EXPECT_FALSE(again->request()->steps(0).has_depth());

  // A request above kMaxKeptSteps is freed, not kept.
  for (int i = 0; i < service::ApplyMessagePool::kMaxKeptSteps; ++i) {
    again->request()->add_steps();
  }
  again->Release();
  EXPECT_EQ(pool.kept(), 0u);

  std::vector<grpc::MessageHolder<v1::ApplyRequest, v1::ApplyResponse>*> many;
  for (std::size_t i = 0; i < service::ApplyMessagePool::kMaxKept + 3; ++i) {
    many.push_back(pool.AllocateMessages());
  }
  for (auto* messages : many) messages->Release();
  EXPECT_EQ(pool.kept(), service::ApplyMessagePool::kMaxKept);
}

TEST_F(ContactServiceTest, FailingBatchLeavesSessionUnchanged) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
  const v1::SessionSnapshot before = ExportOrDie(session);

  grpc::Status status = Apply(session, {DisplacementStep(2e-7), NormalForceStep(-1)}, &response);
  ExpectInvalidArgument(status, "steps[1].normal_force");
  EXPECT_THAT(status.error_message(), HasSubstr(">= 0, got -1"));

  status = Apply(session, {DisplacementStep(2e-7), DepthStep(std::nan(""))}, &response);
  ExpectInvalidArgument(status, "steps[1].depth");

  // |F_x| = 40 N > mu F_N = 30 N cannot be reached; the message states the limit.
  status = Apply(session, {DisplacementStep(2e-7), TangentialForceStep(40)}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), HasSubstr("steps[1].tangential_force: "));
  EXPECT_THAT(status.error_message(), HasSubstr("mu F_N = 30"));

  const v1::SessionSnapshot after = ExportOrDie(session);
  EXPECT_EQ(before.SerializeAsString(), after.SerializeAsString());
}

// A step can fail after it moved the contact (here an increment of 1e308 m makes the dissipated
// energy overflow, found after the step). Alone, it is undone in place (a grid's step too); in a
// longer batch it leaves the batch's copy moved, and the copy is dropped. Either way the session
// is unchanged, and the next batch gives bit for bit what a twin session that never saw the
// failure gives.
TEST_F(ContactServiceTest, AStepFailingAfterItMovedLeavesNoTrace) {
  v1::Scene grid = SteelSphereOnSteelFlat();
  grid.set_method(v1::METHOD_GRID);
  grid.mutable_grid()->set_size(256);
  grid.mutable_grid()->set_max_radius(1e-3);
  for (const v1::Scene& scene : {SteelSphereOnSteelFlat(), grid}) {
    for (const bool batched : {false, true}) {
      SCOPED_TRACE(std::string(scene.method() == v1::METHOD_GRID ? "grid" : "exact") +
                   (batched ? ", batched" : ", alone"));
      const std::string session = CreateScene(scene), twin = CreateScene(scene);
      v1::ApplyResponse response, twin_response;
      for (const std::string& name : {session, twin}) {
        ASSERT_TRUE(Apply(name, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
      }
      const v1::SessionSnapshot before = ExportOrDie(session);
      std::vector<v1::Step> failing = {DisplacementIncrementStep(1e308)};
      if (batched) failing.insert(failing.begin(), DisplacementStep(2e-7));
      const grpc::Status status = Apply(session, failing, &response);
      ExpectInvalidArgument(
          status, batched ? "steps[1].displacement_increment" : "steps[0].displacement_increment");
      EXPECT_THAT(status.error_message(), HasSubstr("overflows a double"));
      EXPECT_EQ(before.SerializeAsString(), ExportOrDie(session).SerializeAsString());

      const std::vector<v1::Step> next = {DisplacementStep(-2e-7), DisplacementIncrementStep(3e-7)};
      ASSERT_TRUE(Apply(session, next, &response).ok());
      ASSERT_TRUE(Apply(twin, next, &twin_response).ok());
      EXPECT_EQ(response.state().SerializeAsString(), twin_response.state().SerializeAsString());
      EXPECT_EQ(ExportOrDie(session).contact().SerializeAsString(),
                ExportOrDie(twin).contact().SerializeAsString());
    }
  }
}

TEST_F(ContactServiceTest, ApplyRejectsEmptyBatchOversizedBatchAndBadRequestId) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ExpectInvalidArgument(Apply(session, {}, &response), "steps");

  grpc::Status status =
      Apply(session, std::vector<v1::Step>(10001, DisplacementIncrementStep(0)), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("limit of 10000 per batch"));

  ExpectInvalidArgument(Apply(session, {DepthStep(kDepth)}, &response, {}, std::string(129, 'x')),
                        "request_id");
  ExpectInvalidArgument(Apply(session, {DepthStep(kDepth)}, &response, {}, "tab\there"),
                        "request_id");
  EXPECT_EQ(StateOf(session).applied_steps(), 0u);
}

TEST_F(ContactServiceTest, RetriedRequestIdReturnsStoredResponseWithoutApplyingAgain) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse first, retried;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &first).ok());
  const std::vector<v1::Step> batch = {DisplacementIncrementStep(1e-8),
                                       DisplacementIncrementStep(1e-8)};
  ASSERT_TRUE(Apply(session, batch, &first, {"state"}, "rig-7/batch-1").ok());
  EXPECT_FALSE(first.replayed());
  ASSERT_TRUE(Apply(session, batch, &retried, {"state"}, "rig-7/batch-1").ok());
  EXPECT_TRUE(retried.replayed());
  retried.set_replayed(false);
  EXPECT_EQ(first.SerializeAsString(), retried.SerializeAsString());
  EXPECT_EQ(StateOf(session).applied_steps(), 3u);
  EXPECT_EQ(StateOf(session).tangential_displacement(), first.state().tangential_displacement());

  // The same id for other steps is a client bug.
  ExpectInvalidArgument(
      Apply(session, {DisplacementIncrementStep(5e-8)}, &retried, {"state"}, "rig-7/batch-1"),
      "request_id");

  // A failed batch is not remembered: its retry runs (and fails) again.
  EXPECT_EQ(Apply(session, {TangentialForceStep(40)}, &retried, {}, "bad").error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(Apply(session, {TangentialForceStep(40)}, &retried, {}, "bad").error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);

  // Ids are remembered per session, for the last 64 successful batches.
  for (int i = 0; i < 64; ++i) {
    ASSERT_TRUE(
        Apply(session, {DisplacementIncrementStep(0)}, &retried, {}, "id-" + std::to_string(i))
            .ok());
  }
  ASSERT_TRUE(Apply(session, {DisplacementIncrementStep(0)}, &retried, {}, "id-0").ok());
  EXPECT_TRUE(retried.replayed());
  ASSERT_TRUE(Apply(session, batch, &retried, {"state"}, "rig-7/batch-1").ok());
  EXPECT_FALSE(retried.replayed());  // forgotten: applied again
  EXPECT_EQ(StateOf(session).applied_steps(), 3u + 64u + 2u);
}

TEST_F(ContactServiceTest, QueryComputesOnlyTheSelectedOutputs) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(1e-7)}, &applied).ok());

  v1::QueryResponse response;
  ASSERT_TRUE(Query(session, &response, {"state.normal_force"}).ok());
  EXPECT_EQ(response.state().normal_force(), applied.state().normal_force());
  EXPECT_EQ(response.state().tangential_force(), 0);
  EXPECT_EQ(response.state().depth(), 0);
  EXPECT_FALSE(response.has_tangential_stiffness());
  EXPECT_EQ(response.slip_intervals_size(), 0);
  EXPECT_FALSE(response.has_springs());
  EXPECT_EQ(response.memory_pieces_size(), 0);
  EXPECT_FALSE(response.has_energy());
  EXPECT_GT(response.compute_seconds(), 0);
  EXPECT_EQ(counters_[Output::kNormalForce], 1u);
  for (Output unselected :
       {Output::kTangentialForce, Output::kContactRadius, Output::kMemoryPieces,
        Output::kSlipIntervals, Output::kStiffnessPositive, Output::kSpringTangentialDisplacement,
        Output::kSpringNormalDisplacement, Output::kEnergyDissipatedEnergy, Output::kJagerWeights,
        Output::kJagerDecomposition, Output::kTractions, Output::kPressure}) {
    EXPECT_EQ(counters_[unselected], 0u) << static_cast<int>(unselected);
  }

  // Empty mask: the whole state, nothing else.
  ASSERT_TRUE(Query(session, &response).ok());
  EXPECT_TRUE(MessageDifferencer::Equals(response.state(), applied.state()));
  EXPECT_EQ(counters_[Output::kMemoryPieces], 0u);
  EXPECT_EQ(counters_[Output::kTangentialForce], 1u);

  ASSERT_TRUE(Query(session, &response, {"memory_pieces", "tangential_stiffness.negative"}).ok());
  EXPECT_FALSE(response.has_state());
  EXPECT_GT(response.memory_pieces_size(), 0);
  EXPECT_GT(response.tangential_stiffness().negative(), 0);
  EXPECT_EQ(response.tangential_stiffness().positive(), 0);
  EXPECT_EQ(counters_[Output::kMemoryPieces], 1u);
  EXPECT_EQ(counters_[Output::kStiffnessPositive], 0u);
}

TEST_F(ContactServiceTest, QueryOutputsMatchCattaneoMindlin) {
  const std::string session = CreateOrDie();
  const double ux = kDisplacementAt15N;
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth), DisplacementStep(ux)}, &applied).ok());
  const double a = std::sqrt(kRadius * kDepth);
  const double fx = applied.state().tangential_force(), fn = applied.state().normal_force();
  const double c = a * std::cbrt(1 - fx / (kFriction * fn));  // stick radius
  const double k = 2 * EffectiveShearModulus();

  const std::vector<double> radii = {0, 0.5 * c, 0.5 * (c + a), 2 * a};
  v1::QueryResponse response;
  grpc::Status status = Query(session, &response,
                              {"tangential_stiffness", "slip_intervals", "springs", "energy",
                               "memory_pieces", "state.contact_radius"},
                              radii);
  ASSERT_TRUE(status.ok()) << status.error_message();
  // Reversing sticks everywhere; moving on slides the annulus c < r < a.
  ExpectRelativelyNear(response.tangential_stiffness().negative(), k * a, 1e-10);
  ExpectRelativelyNear(response.tangential_stiffness().positive(), k * c, 1e-9);
  ASSERT_EQ(response.slip_intervals_size(), 1);
  ExpectRelativelyNear(response.slip_intervals(0).r_begin(), c, 1e-9);
  ExpectRelativelyNear(response.slip_intervals(0).r_end(), a, 1e-12);
  EXPECT_EQ(response.slip_intervals(0).direction(), 1);
  ASSERT_EQ(response.springs().tangential_displacement_size(), 4);
  ASSERT_EQ(response.springs().normal_displacement_size(), 4);
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE("radius " + std::to_string(radii[i]));
    const double r = radii[i];
    const double w = r < a ? kDepth - r * r / kRadius : 0;
    ExpectRelativelyNear(response.springs().normal_displacement(i), w, 1e-12);
    const double u = r < c ? ux : kFriction * Kappa() * w;  // stick: ux; slip: on the bound
    EXPECT_NEAR(response.springs().tangential_displacement(i), u, 1e-12 * ux);
  }
  EXPECT_GT(response.energy().dissipated_energy(), 0);
  EXPECT_EQ(response.energy().dissipated_energy(), applied.state().dissipated_energy());
  EXPECT_GT(response.energy().last_step_dissipated_energy(), 0);
  ASSERT_GT(response.memory_pieces_size(), 0);
  ExpectRelativelyNear(response.memory_pieces(response.memory_pieces_size() - 1).x_end(), a, 1e-12);
  ExpectRelativelyNear(response.state().contact_radius(), a, 1e-12);
}

TEST_F(ContactServiceTest, QueryValidatesReadMaskAndRadii) {
  const std::string session = CreateOrDie();
  v1::QueryResponse response;
  ExpectInvalidArgument(Query(session, &response, {"state", "state.no_such_field"}),
                        "read_mask.paths[1]");
  ExpectInvalidArgument(Query(session, &response, {"slip_intervals.r_begin"}),
                        "read_mask.paths[0]");
  ExpectInvalidArgument(Query(session, &response, {"springs"}), "radii");
  grpc::Status status = Query(session, &response, {"springs"}, {0, -1e-6});
  ExpectInvalidArgument(status, "radii[1]");
  EXPECT_THAT(status.error_message(), HasSubstr("must be finite and >= 0"));
  ExpectInvalidArgument(Query(session, &response, {"springs"}, {std::nan("")}), "radii[0]");
  ExpectInvalidArgument(Query(session, &response, {"springs.normal_displacement"}, {INFINITY}),
                        "radii[0]");
}

TEST_F(ContactServiceTest, UnknownSessionIsNotFoundAndMalformedNameInvalid) {
  v1::ApplyResponse applied;
  EXPECT_EQ(Apply("sessions/unknown", {DepthStep(kDepth)}, &applied).error_code(),
            grpc::StatusCode::NOT_FOUND);
  v1::QueryResponse queried;
  EXPECT_EQ(Query("sessions/unknown", &queried).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::GetSessionRequest get;
  get.set_name("sessions/unknown");
  v1::Session session;
  EXPECT_EQ(stub_->GetSession(Context().get(), get, &session).error_code(),
            grpc::StatusCode::NOT_FOUND);
  v1::ExportSessionRequest export_request;
  export_request.set_name("sessions/unknown");
  v1::SessionSnapshot snapshot;
  EXPECT_EQ(stub_->ExportSession(Context().get(), export_request, &snapshot).error_code(),
            grpc::StatusCode::NOT_FOUND);

  ExpectInvalidArgument(Query("unknown", &queried), "session");
  get.set_name("sessions/");
  ExpectInvalidArgument(stub_->GetSession(Context().get(), get, &session), "name");
}

TEST_F(ContactServiceTest, DeleteRemovesSessionOnce) {
  const std::string session = CreateOrDie();
  v1::DeleteSessionRequest request;
  request.set_name(session);
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), request, &empty).ok());
  EXPECT_EQ(stub_->DeleteSession(Context().get(), request, &empty).error_code(),
            grpc::StatusCode::NOT_FOUND);
  v1::QueryResponse response;
  EXPECT_EQ(Query(session, &response).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(server_->session_count(), 0u);
}

TEST_F(ContactServiceTest, ConcurrentBatchesOnOneSessionAreSerialised) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &response).ok());
  constexpr int kThreads = 4;
  constexpr int kBatchesPerThread = 25;
  const v1::Step increment = DisplacementIncrementStep(1e-9);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&] {
      for (int b = 0; b < kBatchesPerThread; ++b) {
        v1::ApplyResponse ignored;
        EXPECT_TRUE(Apply(session, {increment, increment}, &ignored).ok());
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  const v1::ContactState state = StateOf(session);
  EXPECT_EQ(state.applied_steps(), 1u + 2u * kThreads * kBatchesPerThread);
  ExpectRelativelyNear(state.tangential_displacement(), 2 * kThreads * kBatchesPerThread * 1e-9,
                       1e-12);
}

}  // namespace
}  // namespace mdr::service_testing
