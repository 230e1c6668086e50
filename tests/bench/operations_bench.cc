// The service's own cost of one step, without the transport: ContactOperations::Apply of a
// one-step batch on an H1 session (Mindlin-Deresiewicz cycling at 0.6 of the slip limit, partial
// slip, as mdr_load), beside the engine's Contact::MoveTo of the same steps. The difference is
// what the service adds per message of a stream or per call (validation, session lookup, the
// batch's atomicity, budget, response). Beside them, batches of 1000 steps (exact) and 20 steps
// (a grid of 2^16 springs), where the per-step part of that cost shows:
//   build/release/tests/bench/mdr_operations_bench [--benchmark_repetitions=3]
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/core/contact.h"
#include "mdr/service/limits.h"
#include "mdr/service/operations.h"

namespace {

using H1 = mdr::reference::H1;
constexpr int kStepsPerHalfCycle = 8;
constexpr double kNormalForce = H1::kNormalForce;

[[noreturn]] void Fail(const mdr::Status& status) {
  std::fprintf(stderr, "mdr_operations_bench: %s\n", status.ToString().c_str());
  std::exit(EXIT_FAILURE);
}

// The displacements of one cycle at 0.6 of the slip limit of H1 at F_N (as mdr_load).
std::vector<double> CycleDisplacements(const mdr::Contact& loaded) {
  const double amplitude = 0.6 * loaded.mu_kappa() * loaded.depth();
  std::vector<double> displacements;
  for (int phase = 0; phase < 2 * kStepsPerHalfCycle; ++phase) {
    displacements.push_back(mdr::reference::TriangleWave(amplitude, phase, kStepsPerHalfCycle));
  }
  return displacements;
}

// A service with one H1 session loaded to F_N (exact, or on a grid of grid_springs springs over
// 1 mm); returns the session's name.
std::string LoadedSession(mdr::service::ContactOperations& operations, bool track_energy,
                          std::uint32_t grid_springs = 0) {
  mdr::v1::CreateSessionRequest create;
  mdr::v1::Scene& scene = *create.mutable_session()->mutable_scene();
  scene = mdr::reference::H1Scene<mdr::v1::Scene>();
  scene.mutable_options()->set_track_energy(track_energy);
  if (grid_springs > 0) {
    scene.set_method(mdr::v1::METHOD_GRID);
    scene.mutable_grid()->set_size(grid_springs);
    scene.mutable_grid()->set_max_radius(1e-3);
  }
  mdr::v1::Session session;
  if (auto status = operations.CreateSession(std::nullopt, create, &session); !status.ok()) {
    Fail(status);
  }
  mdr::v1::ApplyRequest load;
  load.set_session(session.name());
  load.add_steps()->set_normal_force(kNormalForce);
  mdr::v1::ApplyResponse loaded;
  const auto no_interruption = [] { return mdr::OkStatus(); };
  if (auto status = operations.Apply(std::nullopt, load, no_interruption, &loaded); !status.ok()) {
    Fail(status);
  }
  return session.name();
}

// One request per step of the cycle, each a single displacement step on `session`.
std::vector<mdr::v1::ApplyRequest> OneStepCycleRequests(const std::string& session,
                                                        bool track_energy) {
  std::vector<mdr::v1::ApplyRequest> requests;
  for (const double displacement :
       CycleDisplacements(mdr::reference::LoadedH1Contact(track_energy))) {
    mdr::v1::ApplyRequest& request = requests.emplace_back();
    request.set_session(session);
    request.add_steps()->set_displacement(displacement);
  }
  return requests;
}

void BM_ServiceApplyOneStep(benchmark::State& state) {
  const bool track_energy = state.range(0) != 0;
  mdr::service::ContactOperations operations(mdr::service::ServiceLimits{}, {});
  const std::vector<mdr::v1::ApplyRequest> requests =
      OneStepCycleRequests(LoadedSession(operations, track_energy), track_energy);
  const auto no_interruption = [] { return mdr::OkStatus(); };
  mdr::v1::ApplyResponse response;
  std::size_t i = 0;
  for (auto _ : state) {
    response.Clear();
    const mdr::Status status =
        operations.Apply(std::nullopt, requests[i++ % requests.size()], no_interruption, &response);
    if (!status.ok()) Fail(status);
    benchmark::DoNotOptimize(response);
  }
  state.SetLabel(track_energy ? "energy on" : "energy off");
}
BENCHMARK(BM_ServiceApplyOneStep)->Arg(0)->Arg(1);

// The same step as a StreamApply message answered inline (ContactOperations::ApplyIfBounded,
// the session found again through the stream's RecentSessions): what a stream message costs the
// transport's thread beside the engine's step. Arguments: energy off/on, and the sessions the
// stream cycles through (13: mdr_load's 100 sessions over 8 streams).
void BM_ServiceInlineOneStep(benchmark::State& state) {
  const bool track_energy = state.range(0) != 0;
  const auto sessions = static_cast<std::size_t>(state.range(1));
  mdr::service::ContactOperations operations(mdr::service::ServiceLimits{}, {});
  std::vector<std::vector<mdr::v1::ApplyRequest>> requests;  // per session, one cycle
  for (std::size_t s = 0; s < sessions; ++s) {
    requests.push_back(OneStepCycleRequests(LoadedSession(operations, track_energy), track_energy));
  }
  mdr::service::RecentSessions recent_sessions;
  mdr::v1::ApplyResponse response;
  std::size_t i = 0;
  for (auto _ : state) {
    response.Clear();
    const std::vector<mdr::v1::ApplyRequest>& cycle = requests[i % sessions];
    const std::optional<mdr::Status> status = operations.ApplyIfBounded(
        std::nullopt, cycle[(i / sessions) % cycle.size()], &response, &recent_sessions);
    ++i;
    if (!status) Fail(mdr::Internal("", "the step was not bounded"));
    if (!status->ok()) Fail(*status);
    benchmark::DoNotOptimize(response);
  }
  state.SetLabel(std::string(track_energy ? "energy on" : "energy off") + ", " +
                 std::to_string(sessions) + (sessions == 1 ? " session" : " sessions"));
}
BENCHMARK(BM_ServiceInlineOneStep)->ArgsProduct({{0, 1}, {1, 13}});

// What a StreamApply message asking for one force costs against one asking for the whole state
// (ApplyRequest.state_mask, issue #54): the inline step and the serialization of its answer,
// which the transport's thread also pays. Energy on, one session per side, M-D cycling.
struct InlineAnswers {
  explicit InlineAnswers(bool one_force)
      : operations(mdr::service::ServiceLimits{}, {}),
        requests(OneStepCycleRequests(LoadedSession(operations, true), true)) {
    for (mdr::v1::ApplyRequest& request : requests) {
      if (one_force) request.mutable_state_mask()->add_paths("tangential_force");
    }
  }
  // Every message of the process, over every run of a benchmark (instructions.sh divides
  // callgrind's count of Next by it).
  static inline std::size_t messages = 0;
  // One message: the step, its answer serialized; returns the answer's bytes.
  [[gnu::noinline]] std::size_t Next() {
    ++messages;
    response.Clear();
    const std::optional<mdr::Status> status = operations.ApplyIfBounded(
        std::nullopt, requests[i++ % requests.size()], response.mutable_result(), &recent);
    if (!status) Fail(mdr::Internal("", "the step was not bounded"));
    if (!status->ok()) Fail(*status);
    response.SerializeToString(&bytes);
    return bytes.size();
  }
  mdr::service::ContactOperations operations;
  std::vector<mdr::v1::ApplyRequest> requests;
  mdr::service::RecentSessions recent;
  mdr::v1::StreamApplyResponse response;
  std::string bytes;
  std::size_t i = 0;
};

// Arg 0: the whole state, 1: state_mask "tangential_force". For callgrind (instructions.sh).
void BM_InlineAnswer(benchmark::State& state) {
  InlineAnswers answers(state.range(0) != 0);
  std::size_t bytes = 0;
  for (auto _ : state) bytes = answers.Next();
  state.counters["answer_bytes"] = static_cast<double>(bytes);
  state.counters["messages_in_process"] = static_cast<double>(InlineAnswers::messages);
  state.SetLabel(std::string("inline message, ") +
                 (state.range(0) != 0 ? "one force" : "whole state") + " (" +
                 std::to_string(bytes) + " bytes)");
}
BENCHMARK(BM_InlineAnswer)->Arg(0)->Arg(1);

// Both in one run, alternated in rounds of kRound messages: the median ns per message of each
// and one_force_over_whole, the ratio of the medians.
void BM_OneForceOverWholeState(benchmark::State& state) {
  constexpr int kRound = 512;
  InlineAnswers whole(false), one(true);
  std::vector<double> whole_ns, one_ns;
  const auto round = [](InlineAnswers& answers) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < kRound; ++k) benchmark::DoNotOptimize(answers.Next());
    return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start)
               .count() /
           kRound;
  };
  for (auto _ : state) {
    whole_ns.push_back(round(whole));
    one_ns.push_back(round(one));
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["whole_ns"] = median(whole_ns);
  state.counters["one_force_ns"] = median(one_ns);
  state.counters["one_force_over_whole"] = median(one_ns) / median(whole_ns);
}
BENCHMARK(BM_OneForceOverWholeState)->Iterations(200);

// Applies a batch of `steps` steps of the cycle (energy on or off) to a loaded H1 session, exact
// or on a grid of grid_springs springs, once per iteration.
void RunCyclingBatches(benchmark::State& state, int steps, bool track_energy,
                       std::uint32_t grid_springs = 0) {
  mdr::service::ContactOperations operations(mdr::service::ServiceLimits{}, {});
  mdr::v1::ApplyRequest request;
  request.set_session(LoadedSession(operations, track_energy, grid_springs));
  const std::vector<double> cycle =
      CycleDisplacements(mdr::reference::LoadedH1Contact(track_energy));
  for (int i = 0; i < steps; ++i) request.add_steps()->set_displacement(cycle[i % cycle.size()]);
  const auto no_interruption = [] { return mdr::OkStatus(); };
  mdr::v1::ApplyResponse response;
  for (auto _ : state) {
    response.Clear();
    const mdr::Status status = operations.Apply(std::nullopt, request, no_interruption, &response);
    if (!status.ok()) Fail(status);
    benchmark::DoNotOptimize(response);
  }
  state.SetItemsProcessed(state.iterations() * steps);
  state.SetLabel(track_energy ? "energy on" : "energy off");
}

// A batch of 1000 of the same steps in one call (mdr_load's "apply batch 1000"): what the
// service adds per step of a long batch (the batch runs on a copy committed at its end).
void BM_ServiceApplyBatch(benchmark::State& state) {
  RunCyclingBatches(state, 1000, state.range(0) != 0);
}
BENCHMARK(BM_ServiceApplyBatch)->Arg(0)->Arg(1);

// A batch of 20 steps on a grid of 2^16 springs, energy on: a grid's batch runs on a copy too,
// so its steps need no undo copy of their own (Contact::OnFailure::kDiscarded).
void BM_ServiceApplyGridBatch(benchmark::State& state) {
  constexpr std::uint32_t kSprings = 1 << 16;
  RunCyclingBatches(state, 20, true, kSprings);
  state.counters["springs"] = kSprings;
}
BENCHMARK(BM_ServiceApplyGridBatch);

// The reference: the same steps on the engine's contact, no service around it.
void BM_EngineOneStep(benchmark::State& state) {
  const bool track_energy = state.range(0) != 0;
  mdr::Contact contact = mdr::reference::LoadedH1Contact(track_energy);
  const std::vector<double> displacements = CycleDisplacements(contact);
  std::size_t i = 0;
  for (auto _ : state) {
    const mdr::Status status =
        contact.MoveTo(contact.depth(), displacements[i++ % displacements.size()]);
    if (!status.ok()) Fail(status);
    benchmark::DoNotOptimize(contact);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(track_energy ? "energy on" : "energy off");
}
BENCHMARK(BM_EngineOneStep)->Arg(0)->Arg(1);

// The costliest message the service runs inline (docs/operations.md, "Inline steps"): one step
// on an exact contact at the bound of ServiceLimits::max_inline_vertices, made by nested
// reversals of decreasing amplitude; a tangential force target across the whole memory (its
// solve walks every breakpoint) or a displacement to the other side, energy on. Each iteration
// restores the prepared contact first (a copy into the same vectors, included in the time).
// Arg: 0 displacement, 1 tangential force.
void BM_InlineBoundStep(benchmark::State& state) {
  const std::size_t bound = mdr::service::ServiceLimits{}.max_inline_vertices;
  mdr::Contact prepared = mdr::reference::LoadedH1Contact(true);
  const double slip = prepared.mu_kappa() * prepared.depth();
  double amplitude = 0.9 * slip;
  for (int k = 0; prepared.memory().vertex_count() + 2 < bound && k < 200; ++k) {
    const mdr::Status status = prepared.MoveTo(prepared.depth(), k % 2 ? -amplitude : amplitude);
    if (!status.ok()) Fail(status);
    amplitude *= 0.93;
  }
  const bool force = state.range(0) != 0;
  const mdr::Step step =
      force ? mdr::Step{mdr::NormalControl::kDepthIncrement, 0, mdr::TangentialControl::kForce,
                        -0.95 * prepared.friction_limit()}
            : mdr::Step{mdr::NormalControl::kDepthIncrement, 0,
                        mdr::TangentialControl::kDisplacement, -0.95 * slip};
  mdr::Contact trial = prepared;
  for (auto _ : state) {
    trial = prepared;
    const mdr::Status status = trial.Apply(step);
    if (!status.ok()) Fail(status);
    benchmark::DoNotOptimize(trial);
  }
  state.counters["vertices"] = static_cast<double>(prepared.memory().vertex_count());
  state.SetLabel(force ? "tangential force" : "displacement");
}
BENCHMARK(BM_InlineBoundStep)->Arg(0)->Arg(1);

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);  // the service logs every session created at info
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return EXIT_FAILURE;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return EXIT_SUCCESS;
}
