// The cost of a step through libmdr_c's C boundary beside the C++ engine's own step, for the same
// history and the same work on both sides: H1 (steel sphere on steel, F_N = 100 N) in
// Mindlin-Deresiewicz fretting by displacement targets, a triangle wave of amplitude
// 0.4 mu kappa delta, 1000 steps a cycle, each variant on its own contact.
//   build/release/tests/capi/capi_bench --benchmark_counters_tabular=true  (docs/capi.md, "Timing")
// Pairs of equal work:
//   cpp_apply        Contact::Apply of the step, nothing read   | c_step        mdr_contact_step
//   cpp_apply_state  Apply, then every field of mdr_state read   | c_step_state  mdr_contact_step,
//                    from the contact (what mdr_contact_state does)                then
//                    mdr_contact_state
// and, for reference, cpp_move_to: Contact::MoveTo (the exact linear step without validation).
// BM_StepOverhead times whole cycles (no clock call per step), the variants alternating cycle by
// cycle, and reports each variant's median ns per step and each pair's median ratio over the
// rounds. BM_FrettingStep times every step on its own (steady_clock, ~20 ns that each variant
// carries) for the percentiles a real-time loop cares about. MDR_CAPI_BENCH_STEPS sets the steps
// per variant (10^7 by default).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
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

// The C record of a contact's state read in C++, as mdr_contact_state fills it (capi/src/inputs.cc,
// ReadState): the same work as the C call behind the boundary.
mdr_state ReadState(const mdr::Contact& c, std::uint64_t steps) {
  return mdr_state{.depth = c.depth(),
                   .tangential_displacement = c.tangential_displacement(),
                   .contact_radius = c.contact_radius(),
                   .normal_force = c.normal_force(),
                   .tangential_force = c.tangential_force(),
                   .dissipated_energy = c.dissipated_energy(),
                   .friction_limit = c.friction_limit(),
                   .actuator_displacement = c.actuator_displacement(),
                   .actuator_depth = c.actuator_depth(),
                   .last_step_dissipation = c.last_step_dissipation(),
                   .applied_steps = steps,
                   .memory_vertices = c.memory().vertex_count()};
}

// The five variants, each with its own contact loaded to F_N = 100 N.
class Variants {
 public:
  static constexpr int kCount = 5;
  static constexpr const char* kNames[kCount] = {"cpp_move_to", "cpp_apply", "c_step",
                                                 "cpp_apply_state", "c_step_state"};

  Variants()
      : move_to_(mdr::reference::LoadedH1Contact()),
        apply_(mdr::reference::LoadedH1Contact()),
        apply_state_(mdr::reference::LoadedH1Contact()) {
    for (mdr_contact*& handle : handles_) {
      if (mdr_contact_create_from_text(kH1, "h1", &handle) != MDR_OK ||
          mdr_contact_step(handle, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, nullptr) !=
              MDR_OK) {
        error_ = mdr_last_error_message();
      }
    }
    amplitude_ = 0.4 * move_to_.mu_kappa() * move_to_.depth();
  }
  ~Variants() {
    for (mdr_contact* handle : handles_) mdr_contact_destroy(handle);
    benchmark::DoNotOptimize(sink_);
  }
  const std::string& error() const { return error_; }
  // Both sides of each pair did the same work: their contacts are in the same state, bit for bit.
  bool PairsAgree() const {
    mdr_state c_step, c_step_state;
    mdr_contact_state(handles_[0], &c_step);
    mdr_contact_state(handles_[1], &c_step_state);
    auto same = [](const mdr::Contact& cpp, const mdr_state& c) {
      return cpp.tangential_force() == c.tangential_force &&
             cpp.dissipated_energy() == c.dissipated_energy &&
             cpp.tangential_displacement() == c.tangential_displacement &&
             cpp.memory().vertex_count() == c.memory_vertices;
    };
    return same(apply_, c_step) && same(apply_state_, c_step_state);
  }
  double TargetAt(int k) const {
    return mdr::reference::TriangleWave(amplitude_, k, kStepsPerHalf);
  }

  // Step k of the cycle by variant v.
  void Step(int v, double ux) {
    switch (v) {
      case 0:
        if (!move_to_.MoveTo(move_to_.depth(), ux).ok()) std::abort();
        break;
      case 1:
        ApplyTo(apply_, ux);
        break;
      case 2:
        StepHandle(handles_[0], ux);
        break;
      case 3: {
        ApplyTo(apply_state_, ux);
        const mdr_state s = ReadState(apply_state_, ++apply_state_steps_);
        sink_ += s.tangential_force;
        break;
      }
      case 4: {
        StepHandle(handles_[1], ux);
        mdr_state s;
        mdr_contact_state(handles_[1], &s);
        sink_ += s.tangential_force;
        break;
      }
    }
  }

 private:
  static void ApplyTo(mdr::Contact& contact, double ux) {
    const mdr::Step step{.normal_value = 0,
                         .tangential = mdr::TangentialControl::kDisplacement,
                         .tangential_value = ux};
    if (!contact.Apply(step).ok()) std::abort();
  }
  static void StepHandle(mdr_contact* handle, double ux) {
    if (mdr_contact_step(handle, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, ux, nullptr) !=
        MDR_OK) {
      std::abort();
    }
  }

  mdr::Contact move_to_, apply_, apply_state_;
  std::uint64_t apply_state_steps_ = 1;
  mdr_contact* handles_[2] = {nullptr, nullptr};
  double amplitude_ = 0;
  double sink_ = 0;
  std::string error_;
};

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double Quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(q * static_cast<double>(values.size() - 1))];
}

// Whole cycles per variant in rounds, the variants alternating within a round (in an order that
// rotates from round to round, so that none always follows the same one); the ratio of a pair is
// taken round by round, so that both sides of a ratio saw the same machine.
void BM_StepOverhead(benchmark::State& state) {
  Variants variants;
  if (!variants.error().empty()) {
    state.SkipWithError(variants.error().c_str());
    return;
  }
  const std::int64_t rounds = std::max<std::int64_t>(1, state.range(0) / (2 * kStepsPerHalf));
  std::vector<double> ns[Variants::kCount];
  for (int v = 0; v < Variants::kCount; ++v) {  // warm-up: one cycle each
    for (int k = 0; k < 2 * kStepsPerHalf; ++k) variants.Step(v, variants.TargetAt(k));
  }
  for (auto _ : state) {
    for (std::int64_t round = 0; round < rounds; ++round) {
      for (int i = 0; i < Variants::kCount; ++i) {
        const int v = static_cast<int>((i + round) % Variants::kCount);
        const auto begin = std::chrono::steady_clock::now();
        for (int k = 0; k < 2 * kStepsPerHalf; ++k) variants.Step(v, variants.TargetAt(k));
        const auto end = std::chrono::steady_clock::now();
        ns[v].push_back(std::chrono::duration<double, std::nano>(end - begin).count() /
                        (2 * kStepsPerHalf));
      }
    }
  }
  for (int v = 0; v < Variants::kCount; ++v) {
    state.counters[std::string(Variants::kNames[v]) + "_ns"] = Median(ns[v]);
  }
  auto ratio = [&](int c, int cpp, const std::string& name) {
    std::vector<double> r(ns[c].size());
    for (std::size_t i = 0; i < r.size(); ++i) r[i] = ns[c][i] / ns[cpp][i];
    state.counters[name] = Median(r);
    state.counters[name + "_p10"] = Quantile(r, 0.1);
    state.counters[name + "_p90"] = Quantile(r, 0.9);
  };
  if (!variants.PairsAgree()) {
    state.SkipWithError("the two sides of a pair ended in different states: not the same work");
    return;
  }
  ratio(2, 1, "c_step/cpp_apply");
  ratio(4, 3, "c_step_state/cpp_apply_state");
  state.SetItemsProcessed(rounds * 2 * kStepsPerHalf * Variants::kCount);
}

// Step time percentiles in ns, every step timed on its own; the variants take turns cycle by
// cycle, so that they share the machine's state (frequency, other load).
void BM_FrettingStep(benchmark::State& state) {
  Variants variants;
  if (!variants.error().empty()) {
    state.SkipWithError(variants.error().c_str());
    return;
  }
  Histogram times[Variants::kCount];
  const std::int64_t cycles = state.range(0) / (2 * kStepsPerHalf);
  for (int v = 0; v < Variants::kCount; ++v) {  // warm-up: one cycle each
    for (int k = 0; k < 2 * kStepsPerHalf; ++k) variants.Step(v, variants.TargetAt(k));
  }
  for (auto _ : state) {
    for (std::int64_t c = 0; c < cycles; ++c) {
      for (int v = 0; v < Variants::kCount; ++v) {
        for (int k = 0; k < 2 * kStepsPerHalf; ++k) {
          const double ux = variants.TargetAt(k);
          const auto begin = std::chrono::steady_clock::now();
          variants.Step(v, ux);
          const auto end = std::chrono::steady_clock::now();
          times[v].Add(std::chrono::duration_cast<std::chrono::nanoseconds>(end - begin).count());
        }
      }
    }
  }
  for (int v = 0; v < Variants::kCount; ++v) {
    const std::string name = Variants::kNames[v];
    state.counters[name + "_p50"] = times[v].Percentile(0.5);
    state.counters[name + "_p99"] = times[v].Percentile(0.99);
    state.counters[name + "_p99.9"] = times[v].Percentile(0.999);
    state.counters[name + "_max"] = times[v].Max();
  }
  state.SetItemsProcessed(cycles * 2 * kStepsPerHalf * Variants::kCount);
}

const std::int64_t kSteps = [] {
  const char* steps = std::getenv("MDR_CAPI_BENCH_STEPS");  // per variant; 10^7 unless set
  return steps != nullptr ? std::atoll(steps) : std::int64_t{10'000'000};
}();

BENCHMARK(BM_StepOverhead)->Arg(kSteps)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_FrettingStep)->Arg(kSteps)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
