// Bounded state: the server-wide budget of session state bytes (--max-state-bytes) and the rule
// that every accepted session can be exported within the message limit (--max-message-bytes).
#include <vector>

#include "mdr/core/tabulated_profile.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

// What a grid session is charged per spring.
constexpr std::size_t kSpringBytes = GridMemory::kBytesPerSpring;

v1::Scene GridScene(std::uint32_t springs) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_size(springs);
  scene.mutable_grid()->set_max_radius(1e-3);
  return scene;
}

// A contact-list step: every contact's depth and displacement increments.
v1::Step PerContactStep(const std::vector<double>& depths,
                        const std::vector<double>& displacements) {
  v1::Step step;
  step.set_depth_increment(0);
  step.mutable_contact_normal_values()->Add(depths.begin(), depths.end());
  step.set_displacement_increment(0);
  step.mutable_contact_tangential_values()->Add(displacements.begin(), displacements.end());
  return step;
}

class StateBudgetTest : public ServiceTest {
 protected:
  void Start(std::size_t max_state_bytes, int max_message_bytes) {
    service::ServerOptions options = LocalServerOptions();
    options.limits.max_state_bytes = max_state_bytes;
    options.limits.max_message_bytes = max_message_bytes;
    Restart(options);
  }
  grpc::Status CreateGrid(std::uint32_t springs, v1::Session* session) {
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = GridScene(springs);
    return stub_->CreateSession(Context().get(), request, session);
  }
};

TEST_F(StateBudgetTest, CreateBeyondTheBudgetFailsUntilASessionIsDeleted) {
  Start(/*max_state_bytes=*/2500 * kSpringBytes, 4 << 20);  // two grids of 1024 springs
  v1::Session first, second, third;
  ASSERT_TRUE(CreateGrid(1024, &first).ok());
  ASSERT_TRUE(CreateGrid(1024, &second).ok());
  const grpc::Status refused = CreateGrid(1024, &third);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-state-bytes"));
  EXPECT_THAT(refused.error_message(), testing::HasSubstr("session.scene"));
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), {}, &list).ok());
  EXPECT_EQ(list.sessions_size(), 2) << "the refused create added nothing";

  v1::DeleteSessionRequest erase;
  erase.set_name(first.name());
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), erase, &empty).ok());
  EXPECT_TRUE(CreateGrid(1024, &third).ok()) << "deleting released its bytes";
}

// A session's profile is part of its state: a tabulated profile's tables (up to ~12 MB at the
// grid's node limit) are charged like a grid's springs.
TEST_F(StateBudgetTest, ATabulatedProfilesTablesAreCharged) {
  v1::CreateSessionRequest request;
  v1::Scene& scene = *request.mutable_session()->mutable_scene();
  scene = SteelSphereOnSteelFlat();
  std::vector<double> radii, heights;
  for (int i = 0; i <= 2000; ++i) {
    radii.push_back(1e-3 * i / 2000);
    heights.push_back(radii.back() * radii.back() / (2 * 0.01));
  }
  scene.mutable_tabulated()->mutable_radii()->Add(radii.begin(), radii.end());
  scene.mutable_tabulated()->mutable_heights()->Add(heights.begin(), heights.end());
  const std::size_t table_bytes = (*MakeTabulatedProfile(radii, heights))->MemoryBytes();
  ASSERT_GT(table_bytes, 100000u);
  v1::Session session;
  Start(/*max_state_bytes=*/table_bytes - 1, 4 << 20);
  const grpc::Status refused = stub_->CreateSession(Context().get(), request, &session);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-state-bytes"));
  Start(/*max_state_bytes=*/table_bytes + 4096, 4 << 20);
  EXPECT_TRUE(stub_->CreateSession(Context().get(), request, &session).ok());
}

TEST_F(StateBudgetTest, ImportBeyondTheBudgetFails) {
  Start(/*max_state_bytes=*/1500 * kSpringBytes, 4 << 20);
  v1::Session grid;
  ASSERT_TRUE(CreateGrid(1024, &grid).ok());
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = ExportOrDie(grid.name());
  v1::Session imported;
  const grpc::Status status = stub_->ImportSession(Context().get(), request, &imported);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), testing::HasSubstr("snapshot.contact"));
}

TEST_F(StateBudgetTest, LargestAcceptedGridExportsAndImports) {
  constexpr int kMessageLimit = 64 << 10;
  Start(/*max_state_bytes=*/0, kMessageLimit);
  // The largest grid that the server lets take this loading under the message limit, by
  // bisection (the bound counts the springs' anchors, so it depends on the state).
  auto loaded = [&](std::uint32_t springs, std::string* name) {
    v1::Session session;
    if (!CreateGrid(springs, &session).ok()) return false;
    v1::ApplyResponse response;
    *name = session.name();
    return Apply(session.name(), {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok();
  };
  std::uint32_t accepted = 2, refused = kMessageLimit;  // 8 bytes per spring: above the limit
  std::string largest, name;
  ASSERT_TRUE(loaded(accepted, &largest));
  v1::Session unused;
  const grpc::Status too_large = CreateGrid(refused, &unused);
  ASSERT_EQ(too_large.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(too_large.error_message(), testing::HasSubstr("--max-message-bytes"));
  while (refused - accepted > 1) {
    const std::uint32_t middle = accepted + (refused - accepted) / 2;
    if (loaded(middle, &name)) {
      accepted = middle;
      largest = name;
    } else {
      refused = middle;
    }
  }
  const v1::SessionSnapshot snapshot = ExportOrDie(largest);
  EXPECT_EQ(snapshot.contact().grid_u_size(), static_cast<int>(accepted));
  EXPECT_LE(snapshot.ByteSizeLong(), static_cast<std::size_t>(kMessageLimit));
  EXPECT_GT(snapshot.ByteSizeLong(), static_cast<std::size_t>(0.9 * kMessageLimit))
      << "the bound is not needlessly strict";
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  v1::Session imported;
  const grpc::Status status = stub_->ImportSession(Context().get(), request, &imported);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

// An interface session holds its interface and nothing else between calls (one-step batches run
// on it, a longer batch's copy lives only while it runs): the budget is charged exactly
// MemoryBytes, after steps in place as after batches on a copy. Measured by filling the rest of
// the budget with a grid of known size (kSpringBytes per spring).
TEST_F(StateBudgetTest, AnInterfaceIsChargedTheBytesItHolds) {
  constexpr std::size_t kContacts = 50;
  constexpr std::uint32_t kSprings = 4096;  // room for any one step's growth bound
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_interface()->set_kind(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->mutable_generated()->set_count(kContacts);
  auto run = [&]() -> std::uint64_t {
    v1::CreateSessionRequest create;
    *create.mutable_session()->mutable_scene() = scene;
    v1::Session session;
    EXPECT_TRUE(stub_->CreateSession(Context().get(), create, &session).ok());
    auto each = [](double value) { return std::vector<double>(kContacts, value); };
    for (const std::vector<v1::Step>& batch :
         {std::vector<v1::Step>{PerContactStep(each(kDepth), each(0))},
          std::vector<v1::Step>{PerContactStep(each(0), each(1e-7))},
          std::vector<v1::Step>{PerContactStep(each(0), each(-1e-7)),
                                PerContactStep(each(0), each(2e-8))},
          std::vector<v1::Step>{PerContactStep(each(0.1 * kDepth), each(0))}}) {
      v1::ApplyResponse response;
      EXPECT_TRUE(Apply(session.name(), batch, &response).ok());
    }
    v1::QueryRequest query;
    query.set_session(session.name());
    *query.mutable_read_mask() = Mask({"interface.memory_bytes"});
    v1::QueryResponse answer;
    EXPECT_TRUE(stub_->Query(Context().get(), query, &answer).ok());
    return answer.interface().memory_bytes();
  };
  Start(/*max_state_bytes=*/0, 4 << 20);
  const std::uint64_t held = run();
  // The same history under a budget of exactly what it holds plus one grid (its springs and its
  // sphere).
  const std::size_t sphere_bytes = (*MakeSphere(0.01))->MemoryBytes();
  Start(held + kSpringBytes * kSprings + sphere_bytes, 4 << 20);
  ASSERT_EQ(run(), held);
  v1::Session grid;
  EXPECT_TRUE(CreateGrid(kSprings, &grid).ok()) << "the interface is charged more than it holds";
  EXPECT_EQ(CreateGrid(2, &grid).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << "the interface is charged less than it holds";
}

}  // namespace
}  // namespace mdr::service_testing
