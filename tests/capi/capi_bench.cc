// The cost of a step through libmdr_c's C boundary beside the C++ engine's own step, for the same
// history: H1 (steel sphere on steel, F_N = 100 N) in Mindlin-Deresiewicz fretting by displacement
// targets, a triangle wave of amplitude 0.4 mu kappa delta, 1000 steps a cycle. Every step is
// timed on its own (steady_clock, whose ~20 ns of overhead every variant carries); the counters
// are the percentiles in ns of each variant over 10^7 steps after a warm-up cycle, the variants
// taking turns cycle by cycle. MDR_CAPI_BENCH_STEPS sets the steps per variant.
//   build/cli/tests/capi/capi_bench --benchmark_counters_tabular=true   (docs/capi.md, "Timing")
// Variants: cpp_move_to  Contact::MoveTo (the exact linear step, no validation);
//           cpp_apply    Contact::Apply of the same step (validation, undo buffer);
//           c_step       mdr_contact_step (Apply behind the C boundary);
//           c_step_state mdr_contact_step then mdr_contact_state (what a rig loop does).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <string>
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

// Step times in ns: exact below kLinear ns, above it kept as they come (rare).
class Histogram {
 public:
  void Add(std::int64_t ns) {
    if (ns < kLinear) {
      ++counts_[static_cast<std::size_t>(ns)];
    } else {
      slow_.push_back(ns);
    }
    ++total_;
  }
  double Percentile(double q) {
    const auto rank = static_cast<std::int64_t>(q * static_cast<double>(total_ - 1));
    std::int64_t seen = 0;
    for (std::size_t ns = 0; ns < counts_.size(); ++ns) {
      seen += counts_[ns];
      if (seen > rank) return static_cast<double>(ns);
    }
    std::sort(slow_.begin(), slow_.end());
    return static_cast<double>(slow_[static_cast<std::size_t>(rank - seen)]);
  }
  double Max() {
    if (!slow_.empty()) return static_cast<double>(*std::max_element(slow_.begin(), slow_.end()));
    for (std::size_t ns = counts_.size(); ns-- > 0;) {
      if (counts_[ns] > 0) return static_cast<double>(ns);
    }
    return 0;
  }

 private:
  static constexpr std::int64_t kLinear = 100'000;
  std::vector<std::int64_t> counts_ = std::vector<std::int64_t>(kLinear);
  std::vector<std::int64_t> slow_;
  std::int64_t total_ = 0;
};

// One variant: its own contact on the same history, and its step times.
struct Variant {
  const char* name;
  std::function<void(double ux)> step;
  Histogram times{};
};

// The four variants in turn, one cycle each, so that they share the machine's state (frequency,
// other load) instead of running minutes apart.
void BM_FrettingStep(benchmark::State& state) {
  mdr::Contact move_to = mdr::reference::LoadedH1Contact();
  mdr::Contact apply = mdr::reference::LoadedH1Contact();
  const double amplitude = 0.4 * move_to.mu_kappa() * move_to.depth();
  mdr_contact* handles[2] = {nullptr, nullptr};
  for (mdr_contact*& handle : handles) {
    if (mdr_contact_create_from_text(kH1, "h1", &handle) != MDR_OK ||
        mdr_contact_step(handle, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, nullptr) !=
            MDR_OK) {
      state.SkipWithError(mdr_last_error_message());
      return;
    }
  }
  auto c_step = [](mdr_contact* handle, double ux) {
    if (mdr_contact_step(handle, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, ux, nullptr) !=
        MDR_OK) {
      std::abort();
    }
  };
  double sink = 0;
  Variant variants[] = {
      {"cpp_move_to",
       [&](double ux) {
         if (!move_to.MoveTo(move_to.depth(), ux).ok()) std::abort();
         sink += move_to.tangential_force();
       }},
      {"cpp_apply",
       [&](double ux) {
         const mdr::Step step{.normal_value = 0,
                              .tangential = mdr::TangentialControl::kDisplacement,
                              .tangential_value = ux};
         if (!apply.Apply(step).ok()) std::abort();
         sink += apply.tangential_force();
       }},
      {"c_step", [&](double ux) { c_step(handles[0], ux); }},
      {"c_step_state",
       [&](double ux) {
         c_step(handles[1], ux);
         mdr_state s;
         mdr_contact_state(handles[1], &s);
         sink += s.tangential_force;
       }},
  };
  const std::int64_t cycles = state.range(0) / (2 * kStepsPerHalf);
  auto ux_at = [&](int k) { return mdr::reference::TriangleWave(amplitude, k, kStepsPerHalf); };
  for (Variant& v : variants) {  // warm-up: one cycle each
    for (int k = 0; k < 2 * kStepsPerHalf; ++k) v.step(ux_at(k));
  }
  for (auto _ : state) {
    for (std::int64_t c = 0; c < cycles; ++c) {
      for (Variant& v : variants) {
        for (int k = 0; k < 2 * kStepsPerHalf; ++k) {
          const double ux = ux_at(k);
          const auto begin = std::chrono::steady_clock::now();
          v.step(ux);
          const auto end = std::chrono::steady_clock::now();
          v.times.Add(std::chrono::duration_cast<std::chrono::nanoseconds>(end - begin).count());
        }
      }
    }
  }
  benchmark::DoNotOptimize(sink);
  for (Variant& v : variants) {
    const std::string name = v.name;
    state.counters[name + "_p50"] = v.times.Percentile(0.5);
    state.counters[name + "_p99"] = v.times.Percentile(0.99);
    state.counters[name + "_p99.9"] = v.times.Percentile(0.999);
    state.counters[name + "_max"] = v.times.Max();
  }
  state.SetItemsProcessed(cycles * 2 * kStepsPerHalf * 4);
  for (mdr_contact* handle : handles) mdr_contact_destroy(handle);
}

const std::int64_t kSteps = [] {
  const char* steps = std::getenv("MDR_CAPI_BENCH_STEPS");  // per variant; 10^7 unless set
  return steps != nullptr ? std::atoll(steps) : std::int64_t{10'000'000};
}();

BENCHMARK(BM_FrettingStep)->Arg(kSteps)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
