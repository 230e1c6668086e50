// The cost of a step through libmdr_c's C boundary beside the C++ engine's own step, for the same
// history: H1 (steel sphere on steel, F_N = 100 N) in Mindlin-Deresiewicz fretting by displacement
// targets, a triangle wave of amplitude 0.4 mu kappa delta, 1000 steps a cycle. Every step is
// timed on its own (steady_clock, whose ~20 ns of overhead every variant carries); the counters
// are its percentiles in ns over the run (10^7 steps after one warm-up cycle).
//   build/cli/tests/capi/capi_bench            (docs/capi.md, "Timing")
// Variants: cpp_move_to  Contact::MoveTo (the exact linear step, no validation);
//           cpp_apply    Contact::Apply of the same step (validation, undo buffer);
//           c_step       mdr_contact_step (Apply behind the C boundary);
//           c_step_state mdr_contact_step then mdr_contact_state (what a rig loop does).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/core/contact.h"
#include "mdr/mdr.h"

namespace {

constexpr int kStepsPerHalf = 500;

constexpr char kH1[] = R"(
scene:
  sphere: {radius: 0.01}
  elastic_pair:
    youngs_modulus_1: 210e9
    poisson_ratio_1: 0.3
    youngs_modulus_2: 210e9
    poisson_ratio_2: 0.3
  friction: 0.3
)";

enum Variant { kMoveTo, kApply, kCStep, kCStepState };

void ReportPercentiles(benchmark::State& state, std::vector<std::uint32_t>& ns) {
  auto at = [&](double q) {
    auto nth = ns.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(ns.size() - 1));
    std::nth_element(ns.begin(), nth, ns.end());
    return static_cast<double>(*nth);
  };
  state.counters["p50_ns"] = at(0.5);
  state.counters["p99_ns"] = at(0.99);
  state.counters["p99.9_ns"] = at(0.999);
  state.counters["max_ns"] = static_cast<double>(*std::max_element(ns.begin(), ns.end()));
}

// Times `step(ux)` for every step of the history; returns the last tangential force.
template <typename StepFunction>
double TimeSteps(benchmark::State& state, double amplitude, StepFunction step) {
  const auto steps = static_cast<std::size_t>(state.range(0));
  std::vector<std::uint32_t> ns(steps);
  for (int k = 0; k < 2 * kStepsPerHalf; ++k) {  // warm-up: one cycle
    step(mdr::reference::TriangleWave(amplitude, k, kStepsPerHalf));
  }
  double fx = 0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < steps; ++i) {
      const double ux =
          mdr::reference::TriangleWave(amplitude, static_cast<int>(i % (2 * kStepsPerHalf)),
                                       kStepsPerHalf);
      const auto begin = std::chrono::steady_clock::now();
      fx = step(ux);
      const auto end = std::chrono::steady_clock::now();
      ns[i] = static_cast<std::uint32_t>(
          std::chrono::duration_cast<std::chrono::nanoseconds>(end - begin).count());
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(steps));
  ReportPercentiles(state, ns);
  return fx;
}

void BM_FrettingStep(benchmark::State& state, Variant variant) {
  mdr::Contact contact = mdr::reference::LoadedH1Contact();
  const double amplitude = 0.4 * contact.mu_kappa() * contact.depth();
  mdr_contact* handle = nullptr;
  if (mdr_contact_create_from_text(kH1, "h1", &handle) != MDR_OK ||
      mdr_contact_step(handle, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, nullptr) != MDR_OK) {
    state.SkipWithError(mdr_last_error_message());
    return;
  }
  double fx = 0;
  switch (variant) {
    case kMoveTo:
      fx = TimeSteps(state, amplitude, [&](double ux) {
        if (!contact.MoveTo(contact.depth(), ux).ok()) std::abort();
        return contact.tangential_force();
      });
      break;
    case kApply:
      fx = TimeSteps(state, amplitude, [&](double ux) {
        mdr::Step step{.normal_value = 0,
                       .tangential = mdr::TangentialControl::kDisplacement,
                       .tangential_value = ux};
        if (!contact.Apply(step).ok()) std::abort();
        return contact.tangential_force();
      });
      break;
    case kCStep:
    case kCStepState:
      fx = TimeSteps(state, amplitude, [&](double ux) {
        if (mdr_contact_step(handle, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, ux,
                             nullptr) != MDR_OK) {
          std::abort();
        }
        if (variant == kCStep) return 0.0;
        mdr_state s;
        mdr_contact_state(handle, &s);
        return s.tangential_force;
      });
      break;
  }
  benchmark::DoNotOptimize(fx);
  mdr_contact_destroy(handle);
}

const std::int64_t kSteps = [] {
  const char* steps = std::getenv("MDR_CAPI_BENCH_STEPS");  // 10^7 unless set
  return steps != nullptr ? std::atoll(steps) : std::int64_t{10'000'000};
}();

BENCHMARK_CAPTURE(BM_FrettingStep, cpp_move_to, kMoveTo)->Arg(kSteps)->Iterations(1);
BENCHMARK_CAPTURE(BM_FrettingStep, cpp_apply, kApply)->Arg(kSteps)->Iterations(1);
BENCHMARK_CAPTURE(BM_FrettingStep, c_step, kCStep)->Arg(kSteps)->Iterations(1);
BENCHMARK_CAPTURE(BM_FrettingStep, c_step_state, kCStepState)->Arg(kSteps)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
