// mdr_interface_load: a contact list of 10^4 contacts per step through the service (issue #17),
// in contact-increments per second, beside the engine's rate (mdr::Interface::ApplyEach on the
// same contacts, in the same run):
//   build/release/tests/bench/mdr_interface_load [--contacts N] [--seconds S] [--rounds R]
//                                                [--workers W] [--no-energy]
//
// Workload: steel on steel, mu = 0.3, Hertz summits R = 0.1 mm with Gaussian heights (sigma
// 1 um, seed 2026), each contact of the list pressed to its depth at an approach of 3 sigma
// (asperities below it stay out of contact), then Mindlin-Deresiewicz cycling: every step sets
// each contact's tangential displacement (contact_tangential_values, `displacement` meaning) on
// a triangle wave of amplitude 0.4 mu kappa 3 sigma, 8 steps per half cycle. The service side is
// one unary Apply per step on loopback, with the client's request building included; the engine
// side is the bare ApplyEach loop. W workers on both sides: the engine's MakeThreadParallelFor(W),
// the server's executor of W workers (its pool runs the interface's passes). The two sides take
// turns, S / R seconds each, R times, so that load from other processes hits both alike; the
// ratio reported is the median of the rounds' ratios.
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <spdlog/spdlog.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mdr/core/interface.h"
#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace {

constexpr double kHeightSigma = 1e-6;  // m
constexpr double kRadius = 1e-4;       // m
constexpr double kFriction = 0.3;
constexpr double kModulus = 210e9, kPoisson = 0.3;
constexpr int kStepsPerHalfCycle = 8;
constexpr std::uint64_t kSeed = 2026;

struct Options {
  std::size_t contacts = 10000;
  double seconds = 6;
  int rounds = 6;
  int workers = 1;
  bool energy = true;
};

Options ParseOptions(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--contacts" && i + 1 < argc) {
      options.contacts = std::stoul(argv[++i]);
    } else if (arg == "--seconds" && i + 1 < argc) {
      options.seconds = std::stod(argv[++i]);
    } else if (arg == "--rounds" && i + 1 < argc) {
      options.rounds = std::max(1, std::stoi(argv[++i]));
    } else if (arg == "--workers" && i + 1 < argc) {
      options.workers = std::stoi(argv[++i]);
    } else if (arg == "--no-energy") {
      options.energy = false;
    } else {
      std::fprintf(stderr,
                   "usage: %s [--contacts N] [--seconds S] [--rounds R] [--workers W] "
                   "[--no-energy]\n",
                   argv[0]);
      std::exit(2);
    }
  }
  return options;
}

double CycleDisplacement(long k, double amplitude) {
  const long phase = k % (2 * kStepsPerHalfCycle);
  const double s =
      static_cast<double>(phase < kStepsPerHalfCycle ? phase : 2 * kStepsPerHalfCycle - phase);
  return amplitude * (2.0 * s / kStepsPerHalfCycle - 1.0);
}

mdr::v1::Scene ListScene(const Options& options) {
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(kRadius);
  auto* pair = scene.mutable_elastic_pair();
  pair->set_youngs_modulus_1(kModulus);
  pair->set_poisson_ratio_1(kPoisson);
  pair->set_youngs_modulus_2(kModulus);
  pair->set_poisson_ratio_2(kPoisson);
  scene.set_friction(kFriction);
  scene.mutable_options()->set_track_energy(options.energy);
  auto* interface = scene.mutable_interface();
  interface->set_kind(mdr::v1::Interface::KIND_CONTACT_LIST);
  interface->mutable_generated()->set_count(options.contacts);
  interface->mutable_generated()->set_height_scale(kHeightSigma);
  interface->mutable_generated()->set_seed(kSeed);
  return scene;
}

// The depth of every contact at an approach of 3 sigma (the same population as the scene's).
std::vector<double> LoadDepths(const Options& options) {
  mdr::PopulationSpec spec;
  spec.count = options.contacts;
  spec.height_scale = kHeightSigma;
  spec.radius = kRadius;
  spec.seed = kSeed;
  const mdr::Population population = mdr::GeneratePopulation(spec).value();
  std::vector<double> depths;
  for (double height : population.heights) depths.push_back(3 * kHeightSigma + height);
  return depths;
}

double Amplitude() {
  mdr::ContactConfig config;
  config.profile = mdr::MakeSphere(kRadius).value();
  config.material = mdr::ElasticPair(kModulus, kPoisson, kModulus, kPoisson).value();
  config.friction = kFriction;
  const mdr::Contact contact = std::move(mdr::Contact::Create(config)).value();
  return 0.4 * contact.mu_kappa() * 3 * kHeightSigma;
}

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// CPU seconds of the whole process (engine threads; or client, gRPC and server threads), which
// other processes' load does not inflate as it does wall time.
double ProcessCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

struct Rates {
  double steps_per_second;
  double cpu_seconds_per_step;
};

// The bare engine, loaded; Steps runs its cycle on.
class Engine {
 public:
  Engine(const Options& options, const std::vector<double>& depths, double amplitude)
      : options_(options), amplitude_(amplitude), zeros_(options.contacts, 0.0) {
    mdr::PopulationSpec spec;
    spec.count = options.contacts;
    spec.height_scale = kHeightSigma;
    spec.radius = kRadius;
    spec.seed = kSeed;
    mdr::InterfaceConfig config =
        mdr::HertzInterfaceConfig(mdr::GeneratePopulation(spec).value(),
                                  mdr::ElasticPair(kModulus, kPoisson, kModulus, kPoisson).value(),
                                  kFriction, options.energy)
            .value();
    config.kind = mdr::InterfaceKind::kContactList;
    config.heights.clear();
    interface_.emplace(std::move(mdr::Interface::Create(std::move(config))).value());
    interface_->set_parallel(mdr::MakeThreadParallelFor(options.workers).value());
    Require(interface_->ApplyEach({mdr::NormalControl::kDepth, depths,
                                   mdr::TangentialControl::kDisplacementIncrement, zeros_}));
  }

  // Steps per second over `seconds`.
  Rates Run(double seconds) {
    std::vector<double> tangential(options_.contacts, 0.0);
    long steps = 0;
    const double cpu = ProcessCpuSeconds();
    const Clock::time_point start = Clock::now();
    while (Since(start) < seconds) {
      tangential.assign(options_.contacts, CycleDisplacement(step_++, amplitude_));
      Require(interface_->ApplyEach({mdr::NormalControl::kDepthIncrement, zeros_,
                                     mdr::TangentialControl::kDisplacement, tangential}));
      ++steps;
    }
    const double elapsed = Since(start);
    return {static_cast<double>(steps) / elapsed,
            (ProcessCpuSeconds() - cpu) / static_cast<double>(steps)};
  }

 private:
  static void Require(const mdr::Status& status) {
    if (status.ok()) return;
    std::fprintf(stderr, "engine: %s\n", status.ToString().c_str());
    std::exit(1);
  }

  const Options& options_;
  const double amplitude_;
  const std::vector<double> zeros_;
  std::optional<mdr::Interface> interface_;
  long step_ = 0;
};

bool Check(const grpc::Status& status, const char* what) {
  if (status.ok()) return true;
  std::fprintf(stderr, "%s: %s\n", what, status.error_message().c_str());
  return false;
}

struct ServiceRun {
  Rates rates;
  double compute_seconds_per_step;  // ApplyResponse.compute_seconds: the server's own time
};

// A server with one loaded contact-list session; Run drives its cycle on.
class Service {
 public:
  Service(const Options& options, const std::vector<double>& depths, double amplitude)
      : options_(options), amplitude_(amplitude) {
    mdr::service::ServerOptions server_options;
    server_options.listen_address = "127.0.0.1:0";
    server_options.execution.workers = static_cast<std::size_t>(options.workers);
    auto server = mdr::service::ContactServer::Start(server_options);
    if (!server.ok()) std::exit(1);
    server_ = std::move(server).value();
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server_->port()),
                                       grpc::InsecureChannelCredentials());
    stub_ = mdr::v1::ContactService::NewStub(channel);
    mdr::v1::CreateSessionRequest create;
    *create.mutable_session()->mutable_scene() = ListScene(options);
    mdr::v1::Session session;
    grpc::ClientContext create_context;
    if (!Check(stub_->CreateSession(&create_context, create, &session), "create")) std::exit(1);

    request_.set_session(session.name());
    mdr::v1::Step* step = request_.add_steps();
    step->set_depth(0);
    step->mutable_contact_normal_values()->Add(depths.begin(), depths.end());
    mdr::v1::ApplyResponse response;
    grpc::ClientContext load_context;
    if (!Check(stub_->Apply(&load_context, request_, &response), "load")) std::exit(1);
    step->Clear();
    step->set_displacement(0);
    step->mutable_contact_tangential_values()->Resize(static_cast<int>(options.contacts), 0.0);
  }

  ServiceRun Run(double seconds) {
    mdr::v1::ApplyResponse response;
    long steps = 0;
    double compute_seconds = 0;
    const double cpu = ProcessCpuSeconds();
    const Clock::time_point start = Clock::now();
    while (Since(start) < seconds) {
      const double ux = CycleDisplacement(step_++, amplitude_);
      double* values =
          request_.mutable_steps(0)->mutable_contact_tangential_values()->mutable_data();
      for (std::size_t i = 0; i < options_.contacts; ++i) values[i] = ux;
      grpc::ClientContext context;
      if (!Check(stub_->Apply(&context, request_, &response), "apply")) std::exit(1);
      compute_seconds += response.compute_seconds();
      ++steps;
    }
    const double elapsed = Since(start);
    const double n = static_cast<double>(steps);
    return {{n / elapsed, (ProcessCpuSeconds() - cpu) / n}, compute_seconds / n};
  }

 private:
  const Options& options_;
  const double amplitude_;
  std::unique_ptr<mdr::service::ContactServer> server_;
  std::unique_ptr<mdr::v1::ContactService::Stub> stub_;
  mdr::v1::ApplyRequest request_;
  long step_ = 0;
};

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = ParseOptions(argc, argv);
  spdlog::set_level(spdlog::level::warn);
  const std::vector<double> depths = LoadDepths(options);
  const double amplitude = Amplitude();
  Engine engine(options, depths, amplitude);
  Service service(options, depths, amplitude);
  const double n = static_cast<double>(options.contacts);
  const double turn = options.seconds / options.rounds;
  std::printf(
      "contact list of %zu contacts per step, energy %s, %d worker(s), %d rounds of %.1f s "
      "per side\n",
      options.contacts, options.energy ? "on" : "off", options.workers, options.rounds, turn);
  std::vector<double> ratios, cpu_ratios, engine_rates, service_rates, compute_ms;
  std::vector<double> engine_cpu_ms, service_cpu_ms;
  for (int round = 0; round < options.rounds; ++round) {
    const Rates engine_run = engine.Run(turn);
    const ServiceRun run = service.Run(turn);
    ratios.push_back(run.rates.steps_per_second / engine_run.steps_per_second);
    cpu_ratios.push_back(engine_run.cpu_seconds_per_step / run.rates.cpu_seconds_per_step);
    engine_rates.push_back(engine_run.steps_per_second);
    service_rates.push_back(run.rates.steps_per_second);
    compute_ms.push_back(run.compute_seconds_per_step * 1e3);
    engine_cpu_ms.push_back(engine_run.cpu_seconds_per_step * 1e3);
    service_cpu_ms.push_back(run.rates.cpu_seconds_per_step * 1e3);
    std::printf(
        "  round %d: engine %7.1f steps/s (%.2f ms CPU per step), service %7.1f steps/s "
        "(%.2f ms CPU, server %.2f ms per step), ratio %.2f\n",
        round + 1, engine_run.steps_per_second, engine_cpu_ms.back(), run.rates.steps_per_second,
        service_cpu_ms.back(), compute_ms.back(), ratios.back());
  }
  const double engine_median = Median(engine_rates), service_median = Median(service_rates);
  std::printf(
      "engine  (Interface::ApplyEach): %8.1f steps/s  %6.3f M contact-increments/s (median)\n"
      "service (unary Apply per step): %8.1f steps/s  %6.3f M contact-increments/s (median)\n"
      "service / engine: %.2f (median of the rounds; range %.2f-%.2f); the server's own time per "
      "step (compute_seconds): %.2f ms, the engine's: %.2f ms\n"
      "CPU per step (whole process: client, gRPC and server against the engine's threads): "
      "service %.2f ms, engine %.2f ms; engine / service: %.2f (median)\n",
      engine_median, engine_median * n / 1e6, service_median, service_median * n / 1e6,
      Median(ratios), *std::min_element(ratios.begin(), ratios.end()),
      *std::max_element(ratios.begin(), ratios.end()), Median(compute_ms), 1e3 / engine_median,
      Median(service_cpu_ms), Median(engine_cpu_ms), Median(cpu_ratios));
  return 0;
}
