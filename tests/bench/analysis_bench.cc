// Loop analysis throughput (issue #24): AnalyzeLoops on 10^6 samples, 2000 cycles of 500 samples
// of the H1 engine's Mindlin-Deresiewicz loop with a little noise on u and F_x; and a fit of 10
// loops of 600 samples (5 loads, 2 cycles each) with 3 free parameters, per-run nuisances and
// every turning point fitted (issue #47).
//   build/release/tests/bench/mdr_analysis_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "fixtures/identify_campaigns.h"
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

// A campaign as a rig writes it (tests/fixtures/identify_campaigns.h): a steel ball on titanium
// behind 50 N/um at 5 normal forces, the actuator on a sine of 3 um from the press point, 2 cycles
// of 600 samples each; 5 nm of noise on the displacement and 0.1 N on the force, a force offset
// of 0.8 N, displacement offsets of +-0.5 um and a drift of 50 nm per run.
std::vector<LoopSet> Campaign() {
  identify_campaigns::Spec spec;
  spec.loads = {20, 50, 100, 200, 400};
  spec.amplitudes = {3e-6};
  spec.cycles = 2;
  spec.samples_per_cycle = 600;
  spec.displacement_noise = 5e-9;
  spec.force_noise = 0.1;
  spec.force_offset = 0.8;
  spec.displacement_offset = 0.5e-6;
  spec.displacement_drift = 50e-9;
  return identify_campaigns::Make(identify_campaigns::SteelOnTitanium(), spec);
}

// Arg: threads. Free: mu, E* and the rig's compliance; per run its force offset, drift, press
// point and every turning point (from the virgin loading on, so that the offsets are separable).
void BM_FitTenLoops(benchmark::State& state) {
  static const std::vector<LoopSet> sets = Campaign();
  const ContactConfig scene = identify_campaigns::SteelOnTitanium();
  FitOptions options = identify_campaigns::ThreeFree();
  options.nuisances.force_offset = options.nuisances.displacement_drift = true;
  options.burn_in_reversals = 0;
  options.threads = static_cast<int>(state.range(0));
  int iterations = 0;
  std::size_t parameters = 0;
  for (auto _ : state) {
    Result<FitResult> fit = FitLoops(scene, sets, options);
    if (!fit.ok() || !fit->converged) {
      state.SkipWithError(fit.ok() ? "did not converge" : fit.status().ToString().c_str());
      return;
    }
    iterations = fit->iterations;
    parameters = fit->parameters;
  }
  state.counters["iterations"] = iterations;
  state.counters["parameters"] = static_cast<double>(parameters);
  state.counters["samples"] = 10 * 600;
}
BENCHMARK(BM_FitTenLoops)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace mdr::analysis

BENCHMARK_MAIN();
