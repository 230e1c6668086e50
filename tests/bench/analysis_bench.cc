// Loop analysis throughput (issue #24): AnalyzeLoops on 10^6 samples, 2000 cycles of 500 samples
// of the H1 engine's Mindlin-Deresiewicz loop with a little noise on u and F_x; and a fit of 10
// loops of 600 samples (5 loads, 2 cycles each) with 4 free parameters.
//   build/analysis/tests/bench/mdr_analysis_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "fixtures/reference_scenes.h"
#include "mdr/analysis/identify.h"
#include "mdr/analysis/loops.h"
#include "mdr/core/contact.h"

namespace mdr::analysis {
namespace {

constexpr int kCycles = 2000, kPerCycle = 500;

// One steady loop from the engine (H1 at half the slip displacement), repeated with Gaussian
// noise of 0.2 % of the amplitudes; F_N measured too.
LoopSamples RigRecord() {
  Contact contact = reference::LoadedH1Contact(false);
  const double amplitude = 0.5 * contact.mu_kappa() * contact.depth();
  const int half = kPerCycle / 2;
  for (int k = half / 2; k <= half; ++k) {  // virgin loading to the first upper reversal
    (void)contact.MoveTo(contact.depth(), reference::TriangleWave(amplitude, k, half));
  }
  std::vector<double> u, f;
  for (int k = half + 1; k <= half + kPerCycle; ++k) {
    u.push_back(reference::TriangleWave(amplitude, k, half));
    (void)contact.MoveTo(contact.depth(), u.back());
    f.push_back(contact.tangential_force());
  }
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 2e-3);
  LoopSamples s;
  for (int c = 0; c < kCycles; ++c) {
    for (int i = 0; i < kPerCycle; ++i) {
      s.displacement.push_back(u[i] + amplitude * noise(rng));
      s.tangential_force.push_back(f[i] + f[half - 1] * noise(rng));
      s.normal_force.push_back(reference::H1::kNormalForce * (1 + noise(rng)));
      s.time.push_back(1e-4 * static_cast<double>(s.time.size()));
    }
  }
  return s;
}

// Arg: 0 the automatic reversal threshold (two coarse passes more), 1 a given one; with the
// rig's compliance known (contact figures too).
void BM_AnalyzeLoops(benchmark::State& state) {
  static const LoopSamples samples = RigRecord();
  LoopOptions options;
  if (state.range(0) != 0) {
    const auto [lo, hi] =
        std::minmax_element(samples.displacement.begin(), samples.displacement.end());
    options.reversal_threshold = 0.05 * (*hi - *lo);
  }
  options.rig_compliance = 1e-8;
  std::size_t cycles = 0;
  for (auto _ : state) {
    Result<LoopAnalysis> r = AnalyzeLoops(samples, options);
    if (!r.ok()) {
      state.SkipWithError(r.status().ToString().c_str());
      return;
    }
    cycles = r->cycles.size();
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations() *
                          static_cast<std::int64_t>(samples.displacement.size()));
  state.counters["cycles"] = static_cast<double>(cycles);
}
BENCHMARK(BM_AnalyzeLoops)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// A campaign as a rig writes it: H1 behind 50 N/um at 5 normal forces, the actuator on a
// triangle wave from the virgin state (2 cycles of 600 samples), noise of 0.05 N on F_x.
std::vector<LoopSet> Campaign() {
  ContactConfig scene = reference::H1Config();
  scene.rig.tangential = 2e-8;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.05);
  std::vector<LoopSet> sets;
  for (double load : {20.0, 50.0, 100.0, 200.0, 400.0}) {
    Contact c = std::move(Contact::Create(scene)).value();
    Step press, move;
    press.normal = NormalControl::kForce;
    press.normal_value = load;
    move.tangential = TangentialControl::kDisplacement;
    (void)c.Apply(press);
    LoopSet set;
    set.normal_force = load;
    for (int k = 0; k <= 2 * 600; ++k) {
      move.tangential_value = reference::TriangleWave(2e-6, k + 150, 300);  // from 0, rising
      (void)c.Apply(move);
      set.samples.displacement.push_back(move.tangential_value);
      set.samples.tangential_force.push_back(c.tangential_force() + noise(rng));
    }
    sets.push_back(std::move(set));
  }
  return sets;
}

// Arg: threads. Free: mu, E*, the rig's compliance and the displacement offset (from the first
// sample on, so that the virgin loading shows where the contact was pressed).
void BM_FitTenLoops(benchmark::State& state) {
  static const std::vector<LoopSet> sets = Campaign();
  const ContactConfig scene = reference::H1Config();
  FitOptions options;
  options.free = {{Parameter::kFriction, 0.4, 0.05, 2},
                  {Parameter::kEffectiveModulus, 0.8e11, 1e9, 1e13},
                  {Parameter::kRigCompliance, 1e-8, 0, 1e-6},
                  {Parameter::kDisplacementOffset, 1e-8, -1e-6, 1e-6}};
  options.burn_in_reversals = 0;
  options.threads = static_cast<int>(state.range(0));
  int iterations = 0;
  for (auto _ : state) {
    Result<FitResult> fit = FitLoops(scene, sets, options);
    if (!fit.ok() || !fit->converged) {
      state.SkipWithError(fit.ok() ? "did not converge" : fit.status().ToString().c_str());
      return;
    }
    iterations = fit->iterations;
  }
  state.counters["iterations"] = iterations;
  state.counters["samples"] = 10 * 600;
}
BENCHMARK(BM_FitTenLoops)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace mdr::analysis

BENCHMARK_MAIN();
