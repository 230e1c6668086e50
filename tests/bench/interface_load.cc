// mdr_interface_load: a contact list of 10^4 contacts per step through the service (issue #17),
// in contact-increments per second, beside the engine's rate (mdr::Interface::ApplyEach on the
// same contacts, in the same run):
//   build/release/tests/bench/mdr_interface_load [--contacts N] [--seconds S] [--no-energy]
//
// Workload: steel on steel, mu = 0.3, Hertz summits R = 0.1 mm with Gaussian heights (sigma
// 1 um, seed 2026), each contact of the list pressed to its depth at an approach of 3 sigma
// (asperities below it stay out of contact), then Mindlin-Deresiewicz cycling: every step sets
// each contact's tangential displacement (contact_tangential_values, `displacement` meaning) on
// a triangle wave of amplitude 0.4 mu kappa 3 sigma, 8 steps per half cycle. The service side is
// one unary Apply per step on loopback, with the client's request building and the server's
// batch copy (atomicity) included; the engine side is the bare ApplyEach loop.
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <cstring>
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
  double seconds = 3;
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
    } else if (arg == "--no-energy") {
      options.energy = false;
    } else {
      std::fprintf(stderr, "usage: %s [--contacts N] [--seconds S] [--no-energy]\n", argv[0]);
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

// Steps per second of the bare engine.
double EngineRate(const Options& options, const std::vector<double>& depths, double amplitude) {
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
  mdr::Interface interface = std::move(mdr::Interface::Create(std::move(config))).value();
  const std::vector<double> zeros(options.contacts, 0.0);
  std::vector<double> tangential(options.contacts, 0.0);
  if (!interface.ApplyEach({mdr::NormalControl::kDepth, depths,
                            mdr::TangentialControl::kDisplacementIncrement, zeros})
           .ok()) {
    std::exit(1);
  }
  long steps = 0;
  const Clock::time_point start = Clock::now();
  while (Since(start) < options.seconds) {
    tangential.assign(options.contacts, CycleDisplacement(steps++, amplitude));
    const mdr::Status status =
        interface.ApplyEach({mdr::NormalControl::kDepthIncrement, zeros,
                             mdr::TangentialControl::kDisplacement, tangential});
    if (!status.ok()) {
      std::fprintf(stderr, "engine: %s\n", status.ToString().c_str());
      std::exit(1);
    }
  }
  return static_cast<double>(steps) / Since(start);
}

bool Check(const grpc::Status& status, const char* what) {
  if (status.ok()) return true;
  std::fprintf(stderr, "%s: %s\n", what, status.error_message().c_str());
  return false;
}

struct ServiceRun {
  double steps_per_second;
  double compute_seconds_per_step;  // ApplyResponse.compute_seconds: the server's own time
};

// Steps per second through the service (one unary Apply per step).
ServiceRun ServiceRate(const Options& options, const std::vector<double>& depths,
                       double amplitude) {
  mdr::service::ServerOptions server_options;
  server_options.listen_address = "127.0.0.1:0";
  auto server = mdr::service::ContactServer::Start(server_options);
  if (!server.ok()) std::exit(1);
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string((*server)->port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = mdr::v1::ContactService::NewStub(channel);
  mdr::v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = ListScene(options);
  mdr::v1::Session session;
  grpc::ClientContext create_context;
  if (!Check(stub->CreateSession(&create_context, create, &session), "create")) std::exit(1);

  mdr::v1::ApplyRequest request;
  request.set_session(session.name());
  mdr::v1::Step* step = request.add_steps();
  step->set_depth(0);
  step->mutable_contact_normal_values()->Add(depths.begin(), depths.end());
  mdr::v1::ApplyResponse response;
  grpc::ClientContext load_context;
  if (!Check(stub->Apply(&load_context, request, &response), "load")) std::exit(1);
  step->Clear();
  step->set_displacement(0);
  step->mutable_contact_tangential_values()->Resize(static_cast<int>(options.contacts), 0.0);

  long steps = 0;
  double compute_seconds = 0;
  const Clock::time_point start = Clock::now();
  while (Since(start) < options.seconds) {
    const double ux = CycleDisplacement(steps++, amplitude);
    double* values = step->mutable_contact_tangential_values()->mutable_data();
    for (std::size_t i = 0; i < options.contacts; ++i) values[i] = ux;
    grpc::ClientContext context;
    if (!Check(stub->Apply(&context, request, &response), "apply")) std::exit(1);
    compute_seconds += response.compute_seconds();
  }
  const double elapsed = Since(start);
  return {static_cast<double>(steps) / elapsed, compute_seconds / static_cast<double>(steps)};
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = ParseOptions(argc, argv);
  spdlog::set_level(spdlog::level::warn);
  const std::vector<double> depths = LoadDepths(options);
  const double amplitude = Amplitude();
  const double engine = EngineRate(options, depths, amplitude);
  const ServiceRun run = ServiceRate(options, depths, amplitude);
  const double service = run.steps_per_second;
  const double n = static_cast<double>(options.contacts);
  std::printf(
      "contact list of %zu contacts per step, energy %s, %.1f s each\n"
      "engine  (Interface::ApplyEach): %8.1f steps/s  %6.3f M contact-increments/s\n"
      "service (unary Apply per step): %8.1f steps/s  %6.3f M contact-increments/s\n"
      "service / engine: %.2f; the server's own time per step (compute_seconds): %.2f ms, the "
      "engine's: %.2f ms\n",
      options.contacts, options.energy ? "on" : "off", options.seconds, engine, engine * n / 1e6,
      service, service * n / 1e6, service / engine, run.compute_seconds_per_step * 1e3,
      1e3 / engine);
  return 0;
}
