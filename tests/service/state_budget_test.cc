// Bounded state: the server-wide budget of session state bytes (--max-state-bytes) and the rule
// that every accepted session can be exported within the message limit (--max-message-bytes).
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

v1::Scene GridScene(std::uint32_t springs) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_size(springs);
  scene.mutable_grid()->set_max_radius(1e-3);
  return scene;
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
  Start(/*max_state_bytes=*/40000, 4 << 20);  // two grids of 1024 springs (16 KiB each)
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

TEST_F(StateBudgetTest, ImportBeyondTheBudgetFails) {
  Start(/*max_state_bytes=*/20000, 4 << 20);
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
  // The largest grid the server accepts under this message limit, by bisection.
  std::uint32_t accepted = 2, refused = kMessageLimit;  // 8 bytes per spring: above the limit
  v1::Session session;
  ASSERT_TRUE(CreateGrid(accepted, &session).ok());
  const grpc::Status too_large = CreateGrid(refused, &session);
  ASSERT_EQ(too_large.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(too_large.error_message(), testing::HasSubstr("--max-message-bytes"));
  std::string largest;
  while (refused - accepted > 1) {
    const std::uint32_t middle = accepted + (refused - accepted) / 2;
    if (CreateGrid(middle, &session).ok()) {
      accepted = middle;
      largest = session.name();
    } else {
      refused = middle;
    }
  }
  ASSERT_FALSE(largest.empty());
  EXPECT_GT(accepted, 7000u) << "the bound is not needlessly strict";
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(largest, {DepthStep(kDepth), DisplacementStep(1e-7)}, &response).ok());
  const v1::SessionSnapshot snapshot = ExportOrDie(largest);
  EXPECT_EQ(snapshot.contact().grid_u_size(), static_cast<int>(accepted));
  EXPECT_LE(snapshot.ByteSizeLong(), static_cast<std::size_t>(kMessageLimit));
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  v1::Session imported;
  const grpc::Status status = stub_->ImportSession(Context().get(), request, &imported);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

}  // namespace
}  // namespace mdr::service_testing
