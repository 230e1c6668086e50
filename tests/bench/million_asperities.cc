// mdr_million_asperities: an interface of 10^6 Hertz asperities through the service (issue #25):
// created, pressed, cycled, exported and imported by a client on loopback, within the server's
// default state budget:
//   build/release/tests/bench/mdr_million_asperities [--count N] [--workers W] [--cycles C]
//                                                    [--log-sigma S] [--default-allocator]
//
// Workload: steel on steel, mu = 0.3, Hertz summits R = 0.1 mm (or lognormal radii of that
// median with --log-sigma > 0: a sphere per summit) with Gaussian heights (sigma 1 um, seed
// 2026) under one shared motion: pressed to an approach of 3 sigma, then
// Mindlin-Deresiewicz cycling with energy (a triangle wave of amplitude 0.4 mu kappa 3 sigma, 8
// steps per half cycle, C cycles), one unary Apply per step. The server runs in this process
// with the default limits but --max-message-bytes at its largest (1 GiB: the export of 10^6
// contacts is about 200 MB, above the 4 MiB default), and the allocator set as mdrd sets it
// (ReturnLargeFreesToTheSystem; --default-allocator keeps glibc's dynamic thresholds). The
// export is imported as a second session, and one more step on both must give the same forces
// bit for bit. Prints the time of each phase, the state the server holds and charges
// (memory_bytes) per asperity, the process's resident size per asperity after the cycling, and
// the export's size; exits 1 if anything fails or differs, or if the state exceeds the default
// budget of one token (1 GiB).
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "mdr/core/contact.h"
#include "mdr/core/material.h"
#include "mdr/core/population.h"
#include "mdr/service/limits.h"
#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"
#include "process_memory.h"

namespace {

using mdr::bench::PeakResidentBytes;
using mdr::bench::ResidentBytes;

constexpr double kHeightSigma = 1e-6;  // m
constexpr double kRadius = 1e-4;       // m
constexpr double kFriction = 0.3;
constexpr double kModulus = 210e9, kPoisson = 0.3;
constexpr int kStepsPerHalfCycle = 8;

struct Options {
  std::size_t count = 1'000'000;
  int workers = 2;
  int cycles = 2;
  double log_sigma = 0;            // > 0: lognormal radii
  bool default_allocator = false;  // glibc's dynamic thresholds, not mdrd's setting
};

Options ParseOptions(int argc, char** argv) {
  Options options;
  CLI::App app{"mdr_million_asperities: an interface of 10^6 Hertz asperities through the service"};
  app.add_option("--count", options.count, "asperities")
      ->check(CLI::Range(std::size_t{1}, mdr::kMaxInterfaceContacts));
  app.add_option("--workers", options.workers, "the server's worker threads")
      ->check(CLI::Range(1, 64));
  app.add_option("--cycles", options.cycles, "Mindlin-Deresiewicz cycles")
      ->check(CLI::Range(1, 1000));
  app.add_option("--log-sigma", options.log_sigma,
                 "lognormal radii of this log_sigma (0: every summit of radius 0.1 mm)")
      ->check(CLI::Range(0.0, 3.0));
  app.add_flag("--default-allocator", options.default_allocator,
               "keep glibc's dynamic mmap threshold (mdrd fixes it: ReturnLargeFreesToTheSystem)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    std::exit(app.exit(e));
  }
  return options;
}

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void Require(const grpc::Status& status, const char* what) {
  if (status.ok()) return;
  std::fprintf(stderr, "%s: %s\n", what, status.error_message().c_str());
  std::exit(1);
}

mdr::v1::Scene RoughScene(std::size_t count, double log_sigma) {
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(kRadius);
  auto* pair = scene.mutable_elastic_pair();
  pair->set_youngs_modulus_1(kModulus);
  pair->set_poisson_ratio_1(kPoisson);
  pair->set_youngs_modulus_2(kModulus);
  pair->set_poisson_ratio_2(kPoisson);
  scene.set_friction(kFriction);
  scene.mutable_options()->set_track_energy(true);
  auto* interface = scene.mutable_interface();
  interface->set_kind(mdr::v1::Interface::KIND_SHARED_MOTION);
  interface->mutable_generated()->set_count(count);
  interface->mutable_generated()->set_height_scale(kHeightSigma);
  interface->mutable_generated()->set_seed(2026);
  if (log_sigma > 0) {
    interface->mutable_generated()->set_radius_distribution(
        mdr::v1::GeneratedPopulation::RADIUS_DISTRIBUTION_LOGNORMAL);
    interface->mutable_generated()->set_log_sigma(log_sigma);
  }
  return scene;
}

// 0.4 mu kappa (3 sigma): the slip distance at the mean depth, times 0.4.
double Amplitude() {
  const mdr::EffectiveMaterial material =
      mdr::ElasticPair(kModulus, kPoisson, kModulus, kPoisson).value();
  return 0.4 * kFriction * material.kappa() * 3 * kHeightSigma;
}

double CycleDisplacement(int k, double amplitude) {
  const int phase = k % (2 * kStepsPerHalfCycle);
  const double s = phase < kStepsPerHalfCycle ? phase : 2 * kStepsPerHalfCycle - phase;
  return amplitude * (2.0 * s / kStepsPerHalfCycle - 1.0);
}

class Client {
 public:
  explicit Client(int port)
      : stub_(mdr::v1::ContactService::NewStub(grpc::CreateChannel(
            "127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()))) {}

  mdr::v1::ApplyResponse Step(const std::string& session, const mdr::v1::Step& step) {
    mdr::v1::ApplyRequest request;
    request.set_session(session);
    *request.add_steps() = step;
    mdr::v1::ApplyResponse response;
    grpc::ClientContext context;
    Require(stub_->Apply(&context, request, &response), "apply");
    return response;
  }
  std::uint64_t MemoryBytes(const std::string& session) {
    mdr::v1::QueryRequest request;
    request.set_session(session);
    request.mutable_read_mask()->add_paths("interface.memory_bytes");
    mdr::v1::QueryResponse response;
    grpc::ClientContext context;
    Require(stub_->Query(&context, request, &response), "query");
    return response.interface().memory_bytes();
  }
  mdr::v1::ContactService::Stub& stub() { return *stub_; }

 private:
  std::unique_ptr<mdr::v1::ContactService::Stub> stub_;
};

}  // namespace

int main(int argc, char** argv) {
  const Options options = ParseOptions(argc, argv);
  if (!options.default_allocator) mdr::service::ReturnLargeFreesToTheSystem();  // as mdrd does
  spdlog::set_level(spdlog::level::warn);
  const long resident0 = ResidentBytes();
  mdr::service::ServerOptions server_options;
  server_options.listen_address = "127.0.0.1:0";
  server_options.execution.workers = static_cast<std::size_t>(options.workers);
  server_options.limits.max_message_bytes = 1 << 30;
  auto server = mdr::service::ContactServer::Start(server_options);
  if (!server.ok()) return 1;
  const mdr::service::ServiceLimits defaults;
  Client client((*server)->port());
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(1 << 30);
  auto stub = mdr::v1::ContactService::NewStub(
      grpc::CreateCustomChannel("127.0.0.1:" + std::to_string((*server)->port()),
                                grpc::InsecureChannelCredentials(), arguments));

  Clock::time_point start = Clock::now();
  mdr::v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = RoughScene(options.count, options.log_sigma);
  mdr::v1::Session session;
  {
    grpc::ClientContext context;
    Require(client.stub().CreateSession(&context, create, &session), "create");
  }
  const double create_seconds = Since(start);
  const long created_peak = PeakResidentBytes() - resident0;  // the population's transients
  const double amplitude = Amplitude();

  mdr::v1::Step press;
  press.set_depth(3 * kHeightSigma);
  start = Clock::now();
  client.Step(session.name(), press);
  const double press_seconds = Since(start);

  double cycle_seconds = 0, slowest = 0;
  const int steps = 4 * kStepsPerHalfCycle * options.cycles / 2;
  mdr::v1::ApplyResponse last;
  for (int k = 0; k < steps; ++k) {
    mdr::v1::Step step;
    step.set_depth_increment(0);
    step.set_displacement(CycleDisplacement(k, amplitude));
    start = Clock::now();
    last = client.Step(session.name(), step);
    const double seconds = Since(start);
    cycle_seconds += seconds;
    slowest = std::max(slowest, seconds);
  }
  const std::uint64_t held = client.MemoryBytes(session.name());
  const long resident = ResidentBytes() - resident0;

  start = Clock::now();
  mdr::v1::ExportSessionRequest export_request;
  export_request.set_name(session.name());
  mdr::v1::SessionSnapshot snapshot;
  {
    grpc::ClientContext context;
    Require(stub->ExportSession(&context, export_request, &snapshot), "export");
  }
  const double export_seconds = Since(start);
  const std::size_t export_bytes = snapshot.ByteSizeLong();

  start = Clock::now();
  mdr::v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = std::move(snapshot);
  mdr::v1::Session imported;
  {
    grpc::ClientContext context;
    Require(stub->ImportSession(&context, import_request, &imported), "import");
  }
  import_request.Clear();
  const double import_seconds = Since(start);

  mdr::v1::Step next;
  next.set_depth_increment(0);
  next.set_displacement(CycleDisplacement(steps, amplitude));
  const mdr::v1::ContactState a = client.Step(session.name(), next).state();
  const mdr::v1::ContactState b = client.Step(imported.name(), next).state();
  const bool same = mdr::SameBits(a.normal_force(), b.normal_force()) &&
                    mdr::SameBits(a.tangential_force(), b.tangential_force()) &&
                    mdr::SameBits(a.dissipated_energy(), b.dissipated_energy());

  const double n = static_cast<double>(options.count);
  char radii[64];
  if (options.log_sigma > 0) {
    std::snprintf(radii, sizeof radii, "lognormal radii, median 0.1 mm, log_sigma %g",
                  options.log_sigma);
  } else {
    std::snprintf(radii, sizeof radii, "R = 0.1 mm");
  }
  std::printf(
      "%zu Hertz asperities (%s), shared motion, energy on, %d worker(s), through the service\n"
      "  create %.2f s (peak resident %.1f bytes per asperity), press %.2f s, %d cycling steps "
      "%.3f s each (slowest %.3f s)\n"
      "  state held and charged: %.1f bytes per asperity (%.1f MB; default budget %.0f MB, of a "
      "token %.0f MB)\n"
      "  resident (process, after cycling): %.1f bytes per asperity\n"
      "  export %.2f s (%.1f MB), import %.2f s; the imported session continues %s\n"
      "  last state: F_N %.6g N, F_x %.6g N, W %.6g J\n",
      options.count, radii, options.workers, create_seconds, static_cast<double>(created_peak) / n,
      press_seconds, steps, cycle_seconds / steps, slowest, static_cast<double>(held) / n,
      static_cast<double>(held) / 1e6, static_cast<double>(defaults.max_state_bytes) / 1e6,
      static_cast<double>(defaults.max_state_bytes_per_token) / 1e6,
      static_cast<double>(resident) / n, export_seconds, static_cast<double>(export_bytes) / 1e6,
      import_seconds, same ? "bit for bit" : "DIFFERENTLY", last.state().normal_force(),
      last.state().tangential_force(), last.state().dissipated_energy());
  (*server)->Shutdown(std::chrono::system_clock::now());
  return same && held <= defaults.max_state_bytes_per_token ? 0 : 1;
}
