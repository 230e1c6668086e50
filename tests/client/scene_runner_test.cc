// The scene runner on interface scenes, against the in-process service: contact-list segments
// reach every contact with its own values, the per-step interface outputs come from one query per
// step, options are checked by the service before any step, and a refused run leaves no session.
#include "mdr/client/scene_runner.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "mdr/service/server.h"

namespace {

using mdr::bridge::SceneDocument;
using mdr::client::RunOptions;
using ::testing::HasSubstr;

// Three Hertz contacts (R = 0.1, 0.1, 0.2 mm) on a rigid-on-half-space steel: pressed by their
// own depth increments, then three tangential cycles of their own amplitudes.
constexpr char kContactList[] = R"(scene:
  sphere: {radius: 1e-4}
  rigid_on_half_space: {shear_modulus: 80e9, poisson_ratio: 0.3}
  friction: 0.3
  interface:
    kind: KIND_CONTACT_LIST
    explicit_list: {heights: [0, 0, 0], radii: [1e-4, 1e-4, 2e-4]}
path:
  - contact_ramp:
      depth_increments: {values: [1e-6, 2e-6, 3e-6]}
      steps: 4
  - contact_cycles:
      quantity: TANGENTIAL_DISPLACEMENT
      amplitudes: {linear: {first: 1e-8, last: 3e-8}}
      count: 3
      steps_per_quarter: 5
)";

constexpr char kSharedMotion[] = R"(scene:
  sphere: {radius: 1e-4}
  rigid_on_half_space: {shear_modulus: 80e9, poisson_ratio: 0.3}
  friction: 0.3
  interface:
    kind: KIND_SHARED_MOTION
    generated: {count: 50, height_scale: 1e-6, seed: 3}
path:
  - ramp: {target: {normal_force: 500}, steps: 2}
  - hold: {record: loaded}
)";

class SceneRunnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto started = mdr::service::ContactServer::Start({});
    ASSERT_TRUE(started.ok()) << started.status().ToString();
    server_ = std::move(started).value();
    client_ = std::make_unique<mdr::client::ContactClient>(server_->InProcessChannel());
  }
  mdr::client::RpcResult<mdr::v1::RunReport> Run(const char* text, const RunOptions& options) {
    auto document = SceneDocument::Parse(text, "scene.yaml");
    EXPECT_TRUE(document.ok()) << document.status().ToString();
    return mdr::client::RunScene(*client_, *document, options);
  }
  std::size_t SessionCount() { return client_->ListAllSessions()->size(); }

  std::unique_ptr<mdr::service::ContactServer> server_;
  std::unique_ptr<mdr::client::ContactClient> client_;
};

TEST_F(SceneRunnerTest, ContactListSegmentsMoveEachContactByItsOwnValues) {
  RunOptions options;
  options.contact_index = 2;
  options.slip_histogram_bins = 4;
  auto report = Run(kContactList, options);
  ASSERT_TRUE(report.ok()) << report.status().error_message();
  ASSERT_EQ(report->rows_size(), 4 + 3 * 20);
  // After the ramp: the sum of Hertz forces 4/3 E* sqrt(R) d^(3/2), E* = 2G / (1 - nu).
  const double e_star = 2 * 80e9 / 0.7;
  const double radii[] = {1e-4, 1e-4, 2e-4};
  double hertz = 0;
  for (int i = 0; i < 3; ++i) {
    hertz += 4.0 / 3 * e_star * std::sqrt(radii[i]) * std::pow((i + 1) * 1e-6, 1.5);
  }
  const auto& loaded = report->rows(3);
  EXPECT_NEAR(loaded.state().normal_force(), hertz, 1e-12 * hertz);
  EXPECT_NEAR(loaded.contact().depth(), 3e-6, 1e-20);
  EXPECT_NEAR(loaded.contact().normal_force(),
              4.0 / 3 * e_star * std::sqrt(2e-4) * std::pow(3e-6, 1.5), 1e-12 * hertz);
  for (const auto& row : report->rows()) {
    EXPECT_EQ(row.interface_totals().in_contact(), 3u) << "step " << row.step();
    ASSERT_EQ(row.slip_histogram_size(), 4);
    std::uint64_t binned = 0;
    for (const auto count : row.slip_histogram()) binned += count;
    EXPECT_EQ(binned, 3u);
  }
  // Contact 2 at the first peak of its cycle: ux = +3e-8 m.
  EXPECT_NEAR(report->rows(3 + 5).contact().tangential_displacement(), 3e-8, 1e-22);
  // Mindlin-Deresiewicz: the steady cycles dissipate equal energies; a list's ux is 0.
  ASSERT_EQ(report->cycle_energies_size(), 3);
  const double steady = report->cycle_energies(1).dissipated_energy();
  EXPECT_GT(steady, 0);
  EXPECT_NEAR(report->cycle_energies(2).dissipated_energy(), steady, 1e-12 * steady);
  EXPECT_EQ(report->cycle_energies(2).tangential_work(), 0);
  EXPECT_EQ(SessionCount(), 0u);
}

TEST_F(SceneRunnerTest, ALargeContactListIsSplitIntoBatchesWithinTheMessageLimit) {
  // 5 x 10^4 values per step (0.4 MB): twelve steps in one Apply would exceed the 4 MiB message
  // limit, so they go two per Apply, and every step arrives.
  constexpr char kLarge[] = R"(scene:
  sphere: {radius: 1e-4}
  rigid_on_half_space: {shear_modulus: 80e9, poisson_ratio: 0.3}
  friction: 0.3
  interface: {kind: KIND_CONTACT_LIST, generated: {count: 25000, seed: 1}}
path:
  - contact_ramp:
      depth_increments: {linear: {first: 1e-6, last: 1e-6}}
      displacement_increments: {linear: {first: 0, last: 1e-8}}
      steps: 12
outputs: [NORMAL_FORCE, TANGENTIAL_FORCE]
)";
  auto report = Run(kLarge, {});
  ASSERT_TRUE(report.ok()) << report.status().error_message();
  ASSERT_EQ(report->rows_size(), 12);
  EXPECT_EQ(report->rows(11).state().applied_steps(), 12u);
  const double one = 4.0 / 3 * (2 * 80e9 / 0.7) * std::sqrt(1e-4) * std::pow(1e-6, 1.5);
  EXPECT_NEAR(report->rows(11).state().normal_force(), 25000 * one, 1e-9 * 25000 * one);
  EXPECT_GT(report->rows(11).state().tangential_force(), 0);
}

TEST_F(SceneRunnerTest, AnInterfaceHoldRecordsTheContactOfTheIndex) {
  auto refused = Run(kSharedMotion, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().error_message(),
            "path[1].hold: records the profiles of one contact of the interface: give its "
            "--contact-index (scene.yaml:10)");
  RunOptions options;
  options.contact_index = 0;
  auto report = Run(kSharedMotion, options);
  ASSERT_TRUE(report.ok()) << report.status().error_message();
  ASSERT_EQ(report->records_size(), 1);
  const auto& record = report->records(0);
  EXPECT_EQ(record.state().depth(), report->rows(1).contact().depth());
  EXPECT_GT(record.state().contact_radius(), 0);
  EXPECT_EQ(record.radii(100), record.state().contact_radius());
  EXPECT_EQ(record.springs().normal_displacement_size(), 101);
  EXPECT_NEAR(report->rows(1).state().normal_force(), 500, 1e-9);
}

TEST_F(SceneRunnerTest, BadOptionsFailBeforeAnyStepAndLeaveNoSession) {
  RunOptions options;
  options.contact_index = 3;
  auto report = Run(kContactList, options);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(report.status().error_message(),
              HasSubstr("--contact-index: must be in [0, 2] (the interface's contacts), got 3"));
  options.contact_index.reset();
  options.slip_histogram_bins = 1001;
  report = Run(kContactList, options);
  ASSERT_FALSE(report.ok());
  EXPECT_THAT(report.status().error_message(), HasSubstr("--histogram-bins: must be in [1, 1000]"));
  EXPECT_EQ(SessionCount(), 0u);

  constexpr char kSingle[] = R"(scene:
  sphere: {radius: 1e-4}
  rigid_on_half_space: {shear_modulus: 80e9, poisson_ratio: 0.3}
path: [{step: {depth: 1e-6}}]
)";
  options.slip_histogram_bins = 3;
  EXPECT_EQ(Run(kSingle, options).status().error_message(),
            "--histogram-bins: needs an interface scene (scene.interface)");
  EXPECT_EQ(SessionCount(), 0u);
}

}  // namespace
