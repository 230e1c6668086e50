// Inline steps (docs/operations.md, "Inline steps"): only a batch whose cost is bounded a priori
// (one straight step on a single exact contact of at most --max-inline-vertices vertices, no
// journal) runs on the transport's thread, counted by mdr_inline_batches_total; every other one
// goes to the workers; and both give the same bits.
#include <filesystem>
#include <thread>

#include "mdr/service/metrics.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using Stream = grpc::ClientReaderWriter<v1::StreamApplyRequest, v1::StreamApplyResponse>;

class InlineStepsTest : public ServiceTest {
 protected:
  static std::uint64_t InlineBatches() { return service::ProcessMetrics().inline_batches.value(); }

  // Waits until no worker holds a call: a worker answers its call before it lets go of the
  // session, so a batch sent right after a worker's answer may find the session busy and go to
  // the workers too.
  void WaitUntilNoWorkerHoldsACall() {
    for (int waited_ms = 0; server_->busy_calls() > 0; ++waited_ms) {
      ASSERT_LT(waited_ms, 10000) << "a worker still holds a call after 10 s";
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  // Applies `steps` as one batch (it must succeed) on an idle session and says whether it ran
  // inline.
  bool RanInline(const std::string& session, const std::vector<v1::Step>& steps) {
    WaitUntilNoWorkerHoldsACall();
    const std::uint64_t before = InlineBatches();
    v1::ApplyResponse response;
    const grpc::Status status = Apply(session, steps, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return InlineBatches() == before + 1;
  }

  // A history that nests reversals: the memory grows by a few vertices per reversal.
  static std::vector<std::vector<v1::Step>> NestedReversals() {
    std::vector<std::vector<v1::Step>> batches = {{DepthStep(kDepth)}};
    double amplitude = 4e-7;
    for (int k = 0; k < 10; ++k, amplitude *= 0.7) {
      batches.push_back({DisplacementStep(k % 2 ? -amplitude : amplitude)});
    }
    return batches;
  }
};

TEST_F(InlineStepsTest, OnlyOneStraightStepOnASmallExactContactRunsInline) {
  const std::string session = CreateOrDie();
  EXPECT_TRUE(RanInline(session, {DepthStep(kDepth)}));
  EXPECT_TRUE(RanInline(session, {DisplacementStep(1e-7)}));
  EXPECT_TRUE(RanInline(session, {DisplacementIncrementStep(-2e-8)}));
  EXPECT_TRUE(RanInline(session, {TangentialForceStep(5)})) << "a force at a held depth";
  v1::Step both = DepthStep(0.9 * kDepth);
  both.set_displacement(2e-8);
  EXPECT_TRUE(RanInline(session, {both})) << "both channels displacements: one straight step";
  // A normal force target, or a tangential one while the depth moves, may be a curved path of
  // many substeps; two steps are two; they all go to the workers.
  EXPECT_FALSE(RanInline(session, {NormalForceStep(90)}));
  v1::Step curved = DepthStep(kDepth);
  curved.set_tangential_force(4);
  EXPECT_FALSE(RanInline(session, {curved}));
  EXPECT_FALSE(RanInline(session, {DisplacementStep(0), DisplacementStep(1e-8)}));
}

TEST_F(InlineStepsTest, AMemoryBeyondTheBoundGoesToTheWorkers) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_inline_vertices = 8;
  Restart(options);
  const std::string session = CreateOrDie();
  bool beyond = false;
  for (const std::vector<v1::Step>& batch : NestedReversals()) {
    const std::uint64_t vertices = StateOf(session).memory_vertices();
    EXPECT_EQ(RanInline(session, batch), vertices <= 8) << vertices << " vertices";
    beyond = beyond || vertices > 8;
  }
  EXPECT_TRUE(beyond) << "the history should outgrow the bound";
  options.limits.max_inline_vertices = 0;  // off
  Restart(options);
  const std::string off = CreateOrDie();
  EXPECT_FALSE(RanInline(off, {DepthStep(kDepth)}));
}

TEST_F(InlineStepsTest, GridsInterfacesAndJournaledSessionsGoToTheWorkers) {
  v1::Scene grid = SteelSphereOnSteelFlat();
  grid.set_method(v1::METHOD_GRID);
  grid.mutable_grid()->set_size(64);
  grid.mutable_grid()->set_max_radius(1e-3);
  EXPECT_FALSE(RanInline(CreateScene(grid), {DepthStep(kDepth)}));
  v1::Scene rough = SteelSphereOnSteelFlat();
  rough.mutable_interface()->set_kind(v1::Interface::KIND_SHARED_MOTION);
  rough.mutable_interface()->mutable_generated()->set_count(3);
  rough.mutable_interface()->mutable_generated()->set_height_scale(1e-6);
  EXPECT_FALSE(RanInline(CreateScene(rough), {DepthStep(kDepth)}));

  const std::filesystem::path journal =
      std::filesystem::temp_directory_path() / "mdr_inline_steps_test.db";
  for (const char* suffix : {"", "-wal", "-shm", ".commit"}) {
    std::filesystem::remove(journal.string() + suffix);
  }
  service::ServerOptions options = LocalServerOptions();
  options.journal.path = journal.string();
  Restart(options);
  EXPECT_FALSE(RanInline(CreateOrDie(), {DepthStep(kDepth)})) << "a journal write per batch";
}

// The same history through inline steps, through the workers, and as StreamApply messages (read
// and applied on the transport's thread): the same state, bit for bit.
TEST_F(InlineStepsTest, InlineAndWorkerBatchesGiveTheSameBits) {
  std::vector<std::vector<v1::Step>> history = NestedReversals();
  history.push_back({TangentialForceStep(3)});
  history.push_back({NormalForceStep(80)});
  history.push_back({TangentialForceStep(-2)});
  auto run = [&](const std::string& session) {
    v1::ApplyResponse response;
    for (const std::vector<v1::Step>& batch : history) {
      WaitUntilNoWorkerHoldsACall();
      const grpc::Status status = Apply(session, batch, &response);
      EXPECT_TRUE(status.ok()) << status.error_message();
    }
    return ExportOrDie(session).contact().SerializeAsString();
  };
  const std::uint64_t before = InlineBatches();
  const std::string inline_bits = run(CreateOrDie());
  EXPECT_GE(InlineBatches() - before, history.size() - 1) << "all but the normal force target";

  const std::string streamed = CreateOrDie();
  auto context = Context();
  std::unique_ptr<Stream> stream = stub_->StreamApply(context.get());
  for (const std::vector<v1::Step>& batch : history) {
    v1::StreamApplyRequest message;
    *message.mutable_apply() = ApplyRequestFor(streamed, batch);
    ASSERT_TRUE(stream->Write(message));
  }
  stream->WritesDone();
  v1::StreamApplyResponse answer;
  std::uint64_t applied = 0;
  while (stream->Read(&answer)) {
    ASSERT_EQ(answer.status().code(), 0) << answer.status().message();
    EXPECT_EQ(answer.result().state().applied_steps(), ++applied) << "in order";
  }
  ASSERT_TRUE(stream->Finish().ok());
  EXPECT_EQ(ExportOrDie(streamed).contact().SerializeAsString(), inline_bits);

  service::ServerOptions options = LocalServerOptions();
  options.limits.max_inline_vertices = 0;
  Restart(options);
  const std::uint64_t off = InlineBatches();
  EXPECT_EQ(run(CreateOrDie()), inline_bits);
  EXPECT_EQ(InlineBatches(), off);
}

}  // namespace
}  // namespace mdr::service_testing
