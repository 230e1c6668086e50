// Many-contact throughput (issue #17): an interface of 10^4 Hertz asperities under
// Mindlin-Deresiewicz cycling with energy, in contact-increments per second, beside the
// single-contact step of the same run; force-target steps of the whole interface; memory.
//   build/release/tests/bench/mdr_interface_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "mdr/core/interface.h"

namespace mdr {
namespace {

constexpr std::size_t kAsperities = 10000;
constexpr double kHeightSigma = 1e-6;  // m
constexpr double kRadius = 1e-4;       // m
constexpr double kFriction = 0.3;
constexpr int kStepsPerHalfCycle = 8;

// Steel on steel, R = 0.1 mm summits with Gaussian heights (sigma 1 um), pressed to 3 sigma
// above the summits' mean plane: nearly all asperities in contact, the lowest barely.
Interface RoughSteelInterface(bool track_energy) {
  PopulationSpec spec;
  spec.count = kAsperities;
  spec.height_scale = kHeightSigma;
  spec.radius = kRadius;
  spec.seed = 2026;
  Interface interface =
      std::move(Interface::Create(*HertzInterfaceConfig(*GeneratePopulation(spec),
                                                        *ElasticPair(210e9, 0.3, 210e9, 0.3),
                                                        kFriction, track_energy)))
          .value();
  (void)interface.Apply({NormalControl::kDepth, 3 * kHeightSigma});
  return interface;
}

// The tangential displacement of step k of a cycle of amplitude `amplitude`.
double CycleDisplacement(int k, double amplitude) {
  const int phase = k % (2 * kStepsPerHalfCycle);
  const double s = phase < kStepsPerHalfCycle ? phase : 2 * kStepsPerHalfCycle - phase;
  return amplitude * (2.0 * s / kStepsPerHalfCycle - 1.0);
}

// The slip distance mu kappa delta of a contact at the mean depth, times 0.4.
double Amplitude(const Contact& contact) { return 0.4 * contact.mu_kappa() * 3 * kHeightSigma; }

long ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * 4096;
}

// One Hertz asperity of the population, stepped alone (the same engine call per increment).
void BM_SingleContactCycling(benchmark::State& state) {
  ContactConfig config;
  config.profile = *MakeSphere(kRadius);
  config.material = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  config.friction = kFriction;
  config.track_energy = state.range(0) != 0;
  Contact contact = std::move(Contact::Create(config)).value();
  (void)contact.MoveTo(3 * kHeightSigma, 0);
  const double amplitude = Amplitude(contact);
  int k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(contact.MoveTo(contact.depth(), CycleDisplacement(k++, amplitude)));
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["energy"] = config.track_energy;
}
BENCHMARK(BM_SingleContactCycling)->Arg(0)->Arg(1);

// The interface: each iteration is one step of the shared motion, kAsperities increments.
// Args: energy on/off, workers.
void BM_InterfaceCycling(benchmark::State& state) {
  const long rss_before = ResidentBytes();
  Interface interface = RoughSteelInterface(state.range(0) != 0);
  const int workers = static_cast<int>(state.range(1));
  if (workers > 1) interface.set_parallel(*MakeThreadParallelFor(workers));
  const double amplitude = Amplitude(interface.contact(0));
  int k = 0;
  for (int warm = 0; warm < 2 * kStepsPerHalfCycle; ++warm) {
    (void)interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement,
                           CycleDisplacement(k++, amplitude)});
  }
  for (auto _ : state) {
    const Status s =
        interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement,
                         CycleDisplacement(k++, amplitude)});
    if (!s.ok()) state.SkipWithError(s.ToString().c_str());
  }
  const InterfaceTotals totals = *interface.Totals();
  state.SetItemsProcessed(state.iterations() * static_cast<long>(interface.size()));
  state.counters["contacts"] = static_cast<double>(interface.size());
  state.counters["in_contact"] = static_cast<double>(totals.in_contact);
  state.counters["partial_slip"] = static_cast<double>(totals.partial_slip);
  state.counters["gross_slip"] = static_cast<double>(totals.gross_slip);
  state.counters["bytes_per_contact"] =
      static_cast<double>(interface.MemoryBytes()) / static_cast<double>(interface.size());
  state.counters["rss_bytes_per_contact"] =
      static_cast<double>(ResidentBytes() - rss_before) / static_cast<double>(interface.size());
  state.counters["energy"] = state.range(0) != 0;
  state.counters["workers"] = workers;
}
BENCHMARK(BM_InterfaceCycling)
    ->Args({1, 1})
    ->Args({1, 2})
    ->Args({0, 1})
    ->Args({0, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// A contact list of the same asperities, each stepped by its own packed values (the
// discrete-element use): depth held, tangential displacement of the same cycle. Args: energy,
// workers.
void BM_ContactListCycling(benchmark::State& state) {
  Interface shared = RoughSteelInterface(state.range(0) != 0);
  InterfaceConfig config;
  config.kind = InterfaceKind::kContactList;
  for (std::size_t i = 0; i < shared.size(); ++i)
    config.contacts.push_back(shared.contact(i).config());
  Interface list = std::move(Interface::Create(config)).value();
  const int workers = static_cast<int>(state.range(1));
  if (workers > 1) list.set_parallel(*MakeThreadParallelFor(workers));
  std::vector<double> depth(list.size()), ux(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) depth[i] = shared.contact(i).depth();
  (void)list.ApplyEach({NormalControl::kDepth, depth, TangentialControl::kDisplacement, ux});
  const std::vector<double> hold(list.size(), 0.0);
  const double amplitude = Amplitude(list.contact(0));
  int k = 0;
  for (auto _ : state) {
    std::fill(ux.begin(), ux.end(), CycleDisplacement(k++, amplitude));
    const Status s = list.ApplyEach(
        {NormalControl::kDepthIncrement, hold, TangentialControl::kDisplacement, ux});
    if (!s.ok()) state.SkipWithError(s.ToString().c_str());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(list.size()));
  state.counters["energy"] = state.range(0) != 0;
  state.counters["workers"] = workers;
}
BENCHMARK(BM_ContactListCycling)
    ->Args({1, 1})
    ->Args({0, 1})
    ->Args({0, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// A total force target, alternating between two values. Arg: 0 normal, 1 tangential; workers.
void BM_InterfaceForceTarget(benchmark::State& state) {
  Interface interface = RoughSteelInterface(true);
  const int workers = static_cast<int>(state.range(1));
  if (workers > 1) interface.set_parallel(*MakeThreadParallelFor(workers));
  const bool tangential = state.range(0) != 0;
  const InterfaceTotals totals = *interface.Totals();
  int k = 0, iterations = 0;
  for (auto _ : state) {
    const double sign = k++ % 2 ? 1 : -1;
    InterfaceStepReport report;
    const Status s =
        tangential ? interface.Apply({NormalControl::kDepthIncrement, 0, TangentialControl::kForce,
                                      0.5 * sign * totals.friction_limit},
                                     &report)
                   : interface.Apply(
                         {NormalControl::kForce, (1 + 0.1 * sign) * totals.normal_force}, &report);
    if (!s.ok()) state.SkipWithError(s.ToString().c_str());
    iterations += report.solver_iterations;
  }
  state.counters["solver_iterations"] =
      static_cast<double>(iterations) / static_cast<double>(state.iterations());
  state.counters["workers"] = workers;
}
BENCHMARK(BM_InterfaceForceTarget)
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({1, 1})
    ->Args({1, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mdr

BENCHMARK_MAIN();
