// Core engine throughput: increments per second and the cost of queries, with memory size.
//   build/release/tests/bench/mdr_core_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fixtures/contact_test_peer.h"
#include "fixtures/reference_scenes.h"
#include "mdr/core/aft.h"
#include "mdr/core/contact.h"
#include "mdr/core/tabulated_profile.h"
#include "mdr/core/torsion.h"

namespace mdr {
namespace {

// H1 of docs/reference-values.md: steel sphere R = 10 mm on steel, mu = 0.3, F_N = 100 N.
Contact HertzContact(bool track_energy) { return reference::LoadedH1Contact(track_energy); }

// Mindlin-Deresiewicz cycling at constant F_N, amplitude half the slip limit, `steps` per cycle.
void BM_MindlinDeresiewiczCycling(benchmark::State& state) {
  const bool energy = state.range(0) != 0;
  Contact contact = HertzContact(energy);
  const double amplitude = 0.4 * contact.mu_kappa() * contact.depth();
  const int steps_per_half = 8;
  std::size_t max_vertices = 0;
  int k = 0;
  for (auto _ : state) {
    const double ux = reference::TriangleWave(amplitude, k++, steps_per_half);
    benchmark::DoNotOptimize(contact.MoveTo(contact.depth(), ux));
    max_vertices = std::max(max_vertices, contact.memory().vertex_count());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["memory_vertices_max"] = static_cast<double>(max_vertices);
  state.counters["energy"] = energy;
}
BENCHMARK(BM_MindlinDeresiewiczCycling)->Arg(0)->Arg(1);

// Random piecewise-linear histories in (delta, ux) with loss of contact and re-contact.
void BM_RandomHistory(benchmark::State& state) {
  Contact contact = HertzContact(state.range(0) != 0);
  const double d0 = contact.depth(), slip = contact.mu_kappa() * d0;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> depth(-0.1 * d0, 1.5 * d0), ux(-2 * slip, 2 * slip);
  std::size_t max_vertices = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(contact.MoveTo(depth(rng), ux(rng)));
    max_vertices = std::max(max_vertices, contact.memory().vertex_count());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["memory_vertices_max"] = static_cast<double>(max_vertices);
}
BENCHMARK(BM_RandomHistory)->Arg(0)->Arg(1);

// Forces query after a fretting history with nested reversals.
void BM_ForcesQuery(benchmark::State& state) {
  Contact contact = HertzContact(false);
  const double slip = contact.mu_kappa() * contact.depth();
  for (int i = 0; i < state.range(0); ++i) {
    (void)contact.MoveTo(contact.depth(), (i % 2 ? -1 : 1) * slip * 0.9 / (1 + i));
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(contact.normal_force());
    benchmark::DoNotOptimize(contact.tangential_force());
  }
  state.counters["memory_vertices"] = static_cast<double>(contact.memory().vertex_count());
}
BENCHMARK(BM_ForcesQuery)->Arg(1)->Arg(8)->Arg(64);

// A force-controlled tangential step (root solve on the exact memory).
void BM_TangentialForceStep(benchmark::State& state) {
  Contact contact = HertzContact(false);
  const double limit = contact.friction_limit();
  int k = 0;
  for (auto _ : state) {
    Step step;
    step.tangential = TangentialControl::kForce;
    step.tangential_value = (k++ % 2 ? -0.5 : 0.5) * limit;
    benchmark::DoNotOptimize(contact.Apply(step));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TangentialForceStep);

// Contact::Apply of a displacement step in Mindlin-Deresiewicz cycling (H1, energy on), exact
// (Arg 0 = 0) or on a grid of 2^16 springs over 1 mm (1); Arg 1: 0 keeps the contact unchanged
// on failure (the step copies the memory to undo itself), 1 leaves it to be discarded (what a
// batch on a copy uses).
void BM_ApplyOnFailure(benchmark::State& state) {
  const bool grid = state.range(0) != 0;
  const auto on_failure =
      state.range(1) != 0 ? Contact::OnFailure::kDiscarded : Contact::OnFailure::kUnchanged;
  ContactConfig config = reference::H1Config(true);
  if (grid) {
    config.method = Method::kGrid;
    config.grid_size = 1 << 16;
    config.grid_max_radius = 1e-3;
  }
  Contact contact = std::move(Contact::Create(config)).value();
  Step load{NormalControl::kForce, reference::H1::kNormalForce,
            TangentialControl::kDisplacementIncrement, 0};
  if (!contact.Apply(load).ok()) state.SkipWithError("load");
  const double amplitude = 0.4 * contact.mu_kappa() * contact.depth();
  int k = 0;
  for (auto _ : state) {
    Step step{NormalControl::kDepthIncrement, 0, TangentialControl::kDisplacement,
              reference::TriangleWave(amplitude, k++, 8)};
    benchmark::DoNotOptimize(contact.Apply(step, nullptr, {}, on_failure));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(std::string(grid ? "grid of 2^16" : "exact") +
                 (state.range(1) != 0 ? ", discarded" : ", unchanged"));
}
BENCHMARK(BM_ApplyOnFailure)->ArgsProduct({{0, 1}, {0, 1}});

// A curved force path from out of contact: H1 pressed to F_N = 2.0625 N while the displacement
// moves by 10 nm. The depth goes as F^(2/3), and every accepted sub-step adds a vertex: thousands
// of sub-steps and vertices. Arg 0: 1 holds the springs that stick apart from the sub-steps (the
// default), 0 sub-steps every spring (the same state to round-off:
// ForcePathTest.HoldingStickingSpringsApart...); arg 1: -log10 of force_path_tolerance; arg 2: 1
// moves the actuator through a tangential rig of 1e-9 m/N (u_x solved at every sub-step).
void BM_CurvedForcePathFromZero(benchmark::State& state) {
  ContactConfig config = reference::H1Config(true);
  config.force_path_tolerance = std::pow(10.0, -static_cast<double>(state.range(1)));
  if (state.range(2) != 0) config.rig.tangential = 1e-9;
  Contact fresh = std::move(Contact::Create(config)).value();
  if (state.range(0) == 0) ContactTestPeer::SubStepEverySpring(fresh);
  const Step press{NormalControl::kForce, 2.0625, TangentialControl::kDisplacementIncrement, 1e-8};
  StepReport report;
  std::size_t vertices = 0;
  for (auto _ : state) {
    Contact contact = fresh;
    if (!contact.Apply(press, &report).ok()) state.SkipWithError("press");
    vertices = contact.memory().vertex_count();
  }
  state.counters["substeps"] = report.substeps;
  state.counters["vertices"] = static_cast<double>(vertices);
  state.counters["path_error"] = report.path_error;
  state.SetLabel(std::string(state.range(0) != 0 ? "sticking springs held apart"
                                                 : "every spring sub-stepped") +
                 (state.range(2) != 0 ? ", tangential rig" : ""));
}
BENCHMARK(BM_CurvedForcePathFromZero)
    ->Args({1, 8, 0})
    ->Args({0, 8, 0})
    ->Args({1, 12, 0})
    ->Args({1, 8, 1})
    ->Args({0, 8, 1})
    ->Unit(benchmark::kMillisecond);

// Torsional fretting of H1 (steel on steel, F_N = 100 N): a triangle wave in twist to the stick
// radius a/2, one twist step and the moment per item. Arg 0: the sphere's closed form; arg 1:
// the power-law quadrature at n = 2, the same physics; arg 2: the sphere sampled at 200 points
// to 2.7 a (a tabulated profile, its quadrature). Error against run time: after the timed loop
// both replay one steady cycle, and moment_rel_error is the largest |M - M_closed| / M_slip (for
// arg 2 it includes the sampled shape's own error).
void BM_TorsionalFretting(benchmark::State& state) {
  const double young = 210e9, poisson = 0.3, radius = 0.01, friction = 0.3;
  const double effective_modulus = young / (2 * (1 - poisson * poisson));
  const double torsional_modulus = young / (2 * (1 + poisson)) / 2;
  const double contact_radius = 1.8662555784e-4;
  auto closed = *MakeHertzTorsionBound(friction, effective_modulus, torsional_modulus, radius);
  auto quadrature =
      *MakePowerLawTorsionBound(friction, effective_modulus, torsional_modulus, 1 / radius, 2);
  std::vector<double> radii, heights;
  for (int i = 0; i < 200; ++i) {
    radii.push_back(2.7 * contact_radius * i / 199);
    heights.push_back(radii.back() * radii.back() / (2 * radius));
  }
  auto tabulated = *MakeTorsionBound(*MakeTabulatedProfile(radii, heights), friction,
                                     effective_modulus, torsional_modulus);
  const std::shared_ptr<const TorsionBound> measured_bound = state.range(0) == 0   ? closed
                                                             : state.range(0) == 1 ? quadrature
                                                                                   : tabulated;
  auto memory_of = [&](const std::shared_ptr<const TorsionBound>& bound) {
    return *TorsionalMemory::Create(bound, torsional_modulus, contact_radius);
  };
  TorsionalMemory memory = memory_of(measured_bound);
  const double amplitude = closed->Bound(contact_radius / 2, contact_radius);
  const int steps_per_half = 8;
  int k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        memory.TwistTo(reference::TriangleWave(amplitude, k++, steps_per_half)));
    benchmark::DoNotOptimize(memory.Moment());
  }
  state.SetItemsProcessed(state.iterations());
  TorsionalMemory exact = memory_of(closed), measured = memory_of(measured_bound);
  double error = 0;
  for (int i = 0; i < 4 * steps_per_half; ++i) {
    const double twist = reference::TriangleWave(amplitude, i, steps_per_half);
    (void)exact.TwistTo(twist);
    (void)measured.TwistTo(twist);
    if (i >= 2 * steps_per_half) {
      error =
          std::max(error, std::abs(measured.Moment() - exact.Moment()) / exact.FullSlipMoment());
    }
  }
  state.counters["moment_rel_error"] = error;
  state.counters["pieces"] = static_cast<double>(memory.pieces().size());
  const char* labels[] = {"sphere, closed form", "power law n = 2, quadrature",
                          "sphere sampled at 200 points, tabulated quadrature"};
  state.SetLabel(labels[state.range(0)]);
}
BENCHMARK(BM_TorsionalFretting)->Arg(0)->Arg(1)->Arg(2);

// A twist step against a tangential step of the same sphere (issue #49: at most 2x), in one run,
// alternated: each round times kSteps steps of H1's Mindlin-Deresiewicz cycle at constant load
// (MoveTo, energy on, then the tangential force) and kSteps of its torsional fretting cycle
// (TwistTo, whose loss is always kept, then the moment), both triangle waves of 8 steps per half
// to half the slip limit. Counters: the medians of the rounds, ns per step, and their ratio.
void BM_TwistStepOverTangentialStep(benchmark::State& state) {
  constexpr int kSteps = 4096, kRounds = 31;
  const double young = 210e9, poisson = 0.3, radius = 0.01, friction = 0.3;
  const double effective_modulus = young / (2 * (1 - poisson * poisson));
  const double torsional_modulus = young / (2 * (1 + poisson)) / 2;
  Contact contact = HertzContact(/*track_energy=*/true);
  const double contact_radius = contact.contact_radius();
  auto bound = *MakeHertzTorsionBound(friction, effective_modulus, torsional_modulus, radius);
  TorsionalMemory memory = *TorsionalMemory::Create(bound, torsional_modulus, contact_radius);
  const double slide = 0.4 * contact.mu_kappa() * contact.depth();
  const double twist = bound->Bound(contact_radius / 2, contact_radius);
  int k = 0, j = 0;
  double sink = 0;
  auto tangential = [&] {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kSteps; ++i) {
      (void)contact.MoveTo(contact.depth(), reference::TriangleWave(slide, k++, 8));
      sink += contact.tangential_force();
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto torsional = [&] {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kSteps; ++i) {
      (void)memory.TwistTo(reference::TriangleWave(twist, j++, 8));
      sink += memory.Moment();
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  for (auto _ : state) {
    (void)tangential(), (void)torsional();  // warm
    std::vector<double> tangential_s, torsional_s, ratio;
    for (int round = 0; round < kRounds; ++round) {
      const bool twist_first = round % 2 == 1;  // alternate who goes first
      const double a = twist_first ? torsional() : tangential();
      const double b = twist_first ? tangential() : torsional();
      tangential_s.push_back(twist_first ? b : a);
      torsional_s.push_back(twist_first ? a : b);
      ratio.push_back(torsional_s.back() / tangential_s.back());
    }
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    state.counters["tangential_ns"] = median(tangential_s) / kSteps * 1e9;
    state.counters["twist_ns"] = median(torsional_s) / kSteps * 1e9;
    state.counters["twist_over_tangential"] = median(ratio);
  }
  benchmark::DoNotOptimize(sink);
}
BENCHMARK(BM_TwistStepOverTangentialStep)->Iterations(1)->UseRealTime();

// One AFT evaluation of the harmonic-balance element (issue #51: under 50 us for a Hertz contact,
// Nt = 128, harmonics 0-5, with the Jacobian; an interface of 100 asperities under 3 ms): H1 driven
// by a fundamental at 0.6 of its slip distance with smaller higher harmonics (partial slip, inner
// reversals). Arg 0: one contact; arg 1: 100 Hertz asperities of R = 0.1 .. 10 mm at depths that
// put a third of them out of contact, each with its own normal load under the shared approach.
void BM_ContactAft(benchmark::State& state) {
  const bool interface = state.range(0) != 0;
  const std::vector<int> harmonics = {0, 1, 2, 3, 4, 5};
  ContactConfig config = reference::H1Config(true);
  std::vector<Contact> pressed;
  double slip = 0;
  if (interface) {
    std::mt19937_64 rng(51);
    std::uniform_real_distribution<double> unit(0, 1);
    for (int i = 0; i < 100; ++i) {
      ContactConfig asperity = config;
      asperity.profile = *MakeSphere(1e-4 * std::pow(100.0, unit(rng)));
      Contact c = *Contact::Create(asperity);
      (void)c.MoveTo(2e-6 * (unit(rng) - 0.33), 0);
      slip = std::max(slip, c.mu_kappa() * std::max(c.depth(), 0.0));
      pressed.push_back(std::move(c));
    }
  } else {
    pressed.push_back(*PressForPeriod(config, reference::H1::kNormalForce));
    slip = pressed[0].mu_kappa() * pressed[0].depth();
  }
  const double a = 0.6 * slip;
  const std::vector<double> u = {0.05 * a,  a,        0.2 * a,  0.03 * a, 0.02 * a, 0.1 * a,
                                 -0.05 * a, 0.02 * a, 0.01 * a, 0.01 * a, -0.01 * a};
  int nonzeros = 0, periods = 0;
  for (auto _ : state) {
    Result<AftResponse> r = ContactAft(pressed, u, harmonics);
    if (!r.ok()) {
      state.SkipWithError(r.status().ToString().c_str());
      return;
    }
    periods = r->periods;
    benchmark::DoNotOptimize(r->jacobian.data());
  }
  PeriodicResponse period = *SteadyPeriod(pressed, *SamplesOf(u, harmonics, 128));
  nonzeros = static_cast<int>(period.jacobian.value.size());
  state.counters["jacobian_nonzeros"] = nonzeros;
  state.counters["periods"] = periods;
  state.SetLabel(interface ? "100 asperities" : "one Hertz contact");
}
BENCHMARK(BM_ContactAft)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace mdr

BENCHMARK_MAIN();
