// The service's own cost of one step, without the transport: ContactOperations::Apply of a
// one-step batch on an H1 session (Mindlin-Deresiewicz cycling at 0.6 of the slip limit, partial
// slip, as mdr_load), beside the engine's Contact::MoveTo of the same steps. The difference is
// what the service adds per message of a stream or per call (validation, session lookup, the
// batch's atomicity, budget, response):
//   build/release/tests/bench/mdr_operations_bench [--benchmark_repetitions=3]
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/core/contact.h"
#include "mdr/core/material.h"
#include "mdr/service/operations.h"

namespace {

using H1 = mdr::reference::H1;
constexpr int kStepsPerHalfCycle = 8;
constexpr double kNormalForce = H1::kNormalForce;

[[noreturn]] void Fail(const mdr::Status& status) {
  std::fprintf(stderr, "mdr_operations_bench: %s\n", status.ToString().c_str());
  std::exit(EXIT_FAILURE);
}

// Displacements of one triangle-wave cycle between -amplitude and +amplitude.
std::vector<double> CycleDisplacements(double amplitude) {
  std::vector<double> displacements;
  for (int phase = 0; phase < 2 * kStepsPerHalfCycle; ++phase) {
    const int rise = phase < kStepsPerHalfCycle ? phase : 2 * kStepsPerHalfCycle - phase;
    displacements.push_back(amplitude * (2.0 * rise / kStepsPerHalfCycle - 1.0));
  }
  return displacements;
}

// A service with one H1 session loaded to F_N; returns the session's name.
std::string LoadedSession(mdr::service::ContactOperations& operations, bool track_energy,
                          double* amplitude) {
  mdr::v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = mdr::reference::H1Scene<mdr::v1::Scene>();
  create.mutable_session()->mutable_scene()->mutable_options()->set_track_energy(track_energy);
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
  const auto material = mdr::ElasticPair(H1::kYoungsModulus, H1::kPoissonRatio, H1::kYoungsModulus,
                                         H1::kPoissonRatio);
  *amplitude = 0.6 * H1::kFriction * material->kappa() * loaded.state().depth();
  return session.name();
}

void BM_ServiceApplyOneStep(benchmark::State& state) {
  const bool track_energy = state.range(0) != 0;
  mdr::service::ContactOperations operations(mdr::service::ServiceLimits{}, {});
  double amplitude = 0;
  const std::string name = LoadedSession(operations, track_energy, &amplitude);
  std::vector<mdr::v1::ApplyRequest> requests;
  for (const double displacement : CycleDisplacements(amplitude)) {
    mdr::v1::ApplyRequest& request = requests.emplace_back();
    request.set_session(name);
    request.add_steps()->set_displacement(displacement);
  }
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

// The reference: the same steps on the engine's contact, no service around it.
void BM_EngineOneStep(benchmark::State& state) {
  const bool track_energy = state.range(0) != 0;
  auto contact = mdr::Contact::Create(mdr::reference::H1Config(track_energy));
  if (!contact.ok()) Fail(contact.status());
  mdr::Step load;
  load.normal = mdr::NormalControl::kForce;
  load.normal_value = kNormalForce;
  if (auto status = contact->Apply(load); !status.ok()) Fail(status);
  const double amplitude = 0.6 * contact->mu_kappa() * contact->depth();
  const std::vector<double> displacements = CycleDisplacements(amplitude);
  std::size_t i = 0;
  for (auto _ : state) {
    const mdr::Status status =
        contact->MoveTo(contact->depth(), displacements[i++ % displacements.size()]);
    if (!status.ok()) Fail(status);
    benchmark::DoNotOptimize(*contact);
  }
  state.SetLabel(track_energy ? "energy on" : "energy off");
}
BENCHMARK(BM_EngineOneStep)->Arg(0)->Arg(1);

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);  // the service logs every session created at info
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return EXIT_FAILURE;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return EXIT_SUCCESS;
}
