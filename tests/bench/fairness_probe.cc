// mdr_fairness: one caller's service while another abuses the server (issue #27, docs/
// operations.md "Fairness between callers"), on loopback with three processes, as an outside
// tester would run it: mdrd with two bearer tokens and its default limits, alice's abusive client
// (this program again, --abuse), and bob's probe (this process).
//   build/release/tests/bench/mdr_fairness --mdrd build/release/server/mdrd/mdrd
//                                          [--seconds S] [--streams N] [--heavy-clients N]
//                                          [--alice-competes] [--journal FILE]
//                                          [--mdrd-arg=--flag ...]
//
// Bob's probe: a one-step Apply on his loaded H1 session every 2 ms (partial-slip cycling), its
// round-trip time and whether it succeeded. Measured alone (quiet), then while alice
// - "abandoned streams": holds N StreamApply streams (default 256, the per-caller limit) spread
//   over 30 sessions, each sending 100-step messages as fast as flow control lets it and never
//   reading an answer;
// - "heavy calls": runs N clients (default 4) of heavy calls back to back, each a
//   CreateSession of a tabulated profile of 20000 samples or a 20-step batch on a grid of 2^20
//   springs, both hundreds of milliseconds of a core.
// Then bob as a newcomer (issue #48): idle for 2.5 s (longer than the executor's recent window,
// so no worker is kept for him), then one one-step Apply and one AnalyzeLoops of a 3-cycle
// record, --newcomer-rounds times; alone, while alice runs fits back to back (FitLoops of 120 000
// noisy samples that run into their 10 s and 30 s deadlines, on two clients) and while she runs
// the heavy calls above. With --journal the Apply is journaled, as by default in mdrd.
// Alice's client runs at SCHED_IDLE, standing in for a client on its own machine (her 256 client
// threads would otherwise take most of this machine's cores whatever mdrd does);
// --alice-competes runs it at normal priority. Prints bob's p50/p99/max and refusals per phase,
// the p99 against quiet with the target (<= 2x), and the cores mdrd and alice's client used. Exit
// status 1 if any of bob's calls failed: he must never be refused. Timing is judged here and in the
// report, never in the test suite (the ctest run only checks the exit status). Clients in their own
// processes matter: a synchronous gRPC call's thread also polls the process's other connections, so
// an abuser in bob's process would slow bob's client, not mdrd.
#include <grpcpp/grpcpp.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "child_process.h"
#include "fixtures/reference_scenes.h"
#include "fixtures/rig_simulator.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
using Stub = mdr::v1::ContactService::Stub;

constexpr char kAliceToken[] = "alice-fairness-probe-0123456789";
constexpr char kBobToken[] = "bob-fairness-probe-0123456789ab";
constexpr auto kProbePeriod = std::chrono::milliseconds(2);
constexpr double kDepth = 3.4829e-6;    // H1 at about 100 N
constexpr double kBobAmplitude = 2e-8;  // partial slip at that depth
constexpr int kAbuseSessions = 30;
constexpr int kAbuseStepsPerMessage = 100;
constexpr int kHeavySamples = 20000;
constexpr std::uint32_t kHeavyGridSprings = 1 << 20;

[[noreturn]] void Fail(const std::string& what) {
  std::fprintf(stderr, "mdr_fairness: %s\n", what.c_str());
  std::exit(EXIT_FAILURE);
}

std::unique_ptr<grpc::ClientContext> As(const char* token, std::chrono::seconds timeout) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->AddMetadata("authorization", std::string("Bearer ") + token);
  context->set_deadline(std::chrono::system_clock::now() + timeout);
  return context;
}

std::unique_ptr<Stub> Connect(const std::string& address) {
  // Each client on its own channel and TCP connection.
  grpc::ChannelArguments arguments;
  arguments.SetInt("grpc.channel_id", static_cast<int>(Clock::now().time_since_epoch().count()));
  return mdr::v1::ContactService::NewStub(
      grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments));
}

std::string Create(Stub& stub, const char* token, const mdr::v1::Scene& scene) {
  mdr::v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = scene;
  mdr::v1::Session session;
  const grpc::Status status =
      stub.CreateSession(As(token, std::chrono::seconds(120)).get(), request, &session);
  if (!status.ok()) Fail("CreateSession: " + status.error_message());
  return session.name();
}

mdr::v1::ApplyRequest DepthRequest(const std::string& session, double depth) {
  mdr::v1::ApplyRequest request;
  request.set_session(session);
  request.add_steps()->set_depth(depth);
  return request;
}

// ---------------------------------------------------------------------------------------------
// Bob's probe.

struct ProbeFigures {
  std::vector<double> millis;
  int refused = 0;
  std::string first_error;
};

ProbeFigures Probe(Stub& stub, const std::string& session, double seconds) {
  ProbeFigures figures;
  mdr::v1::ApplyRequest request;
  request.set_session(session);
  mdr::v1::Step* step = request.add_steps();
  const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(seconds));
  for (int k = 0; Clock::now() < end; ++k) {
    step->set_displacement(k % 2 == 0 ? kBobAmplitude : -kBobAmplitude);
    mdr::v1::ApplyResponse response;
    const Clock::time_point start = Clock::now();
    const grpc::Status status =
        stub.Apply(As(kBobToken, std::chrono::seconds(30)).get(), request, &response);
    figures.millis.push_back(
        std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    if (!status.ok()) {
      if (figures.refused++ == 0) figures.first_error = status.error_message();
    }
    std::this_thread::sleep_for(kProbePeriod);
  }
  return figures;
}

// A record of the H1 contact behind a rig (the simulator's, written apart from the analysis), as
// loop samples; noisy as a rig's sensors.
void Record(const mdr::rig_simulator::Run& run, mdr::v1::LoopSamples* samples) {
  mdr::ContactConfig truth;
  truth.profile = *mdr::MakeSphere(mdr::reference::H1::kRadius);
  truth.material =
      *mdr::ElasticPair(mdr::reference::H1::kYoungsModulus, mdr::reference::H1::kPoissonRatio,
                        mdr::reference::H1::kYoungsModulus, mdr::reference::H1::kPoissonRatio);
  truth.friction = mdr::reference::H1::kFriction;
  truth.track_energy = false;
  const mdr::rig_simulator::Record record = mdr::rig_simulator::Simulate(truth, run);
  *samples->mutable_displacement() = {record.displacement.begin(), record.displacement.end()};
  *samples->mutable_tangential_force() = {record.tangential_force.begin(),
                                          record.tangential_force.end()};
}

mdr::v1::AnalyzeLoopsRequest BobsLoops() {
  mdr::rig_simulator::Run run;
  run.amplitude = 3e-6;
  run.force_noise = 0.05;
  mdr::v1::AnalyzeLoopsRequest request;
  Record(run, request.mutable_samples());
  return request;
}

// Six sets of 20 000 samples at three loads, with 5 nm and 0.1 N of noise: mu and the rig's
// compliance free, a force offset and a drift per set. Far more than 10 s of a core here.
mdr::v1::FitLoopsRequest AlicesFit() {
  mdr::v1::FitLoopsRequest request;
  *request.mutable_scene() = mdr::reference::H1Scene<mdr::v1::Scene>();
  request.mutable_scene()->set_friction(0.4);
  std::uint64_t seed = 0;
  for (const double load : {50.0, 100.0, 150.0}) {
    for (const double amplitude : {2e-6, 6e-6}) {
      mdr::rig_simulator::Run run;
      run.normal_force = load;
      run.amplitude = amplitude;
      run.cycles = 10;
      run.samples_per_cycle = 2000;
      run.displacement_noise = 5e-9;
      run.force_noise = 0.1;
      run.seed = ++seed;
      auto* set = request.add_sets();
      Record(run, set->mutable_samples());
      set->set_normal_force(load);
    }
  }
  auto* friction = request.add_free();
  friction->set_parameter(mdr::v1::FIT_PARAMETER_FRICTION);
  friction->set_lower(0.05);
  friction->set_upper(2);
  auto* rig = request.add_free();
  rig->set_parameter(mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE);
  rig->set_lower(0);
  rig->set_upper(1e-6);
  request.mutable_nuisances()->set_force_offset(true);
  request.mutable_nuisances()->set_displacement_drift(true);
  return request;
}

double Percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(std::ceil(p * values.size())) - 1;
  return values[std::min(index, values.size() - 1)];
}

// ---------------------------------------------------------------------------------------------
// Alice's abuse.

// Streams that send and never read, until the phase ends (cancelled).
class AbandonedStreams {
 public:
  AbandonedStreams(const std::string& address, int streams) {
    auto setup = Connect(address);
    std::vector<std::string> sessions;
    for (int i = 0; i < kAbuseSessions; ++i) {
      sessions.push_back(Create(*setup, kAliceToken, mdr::reference::H1Scene<mdr::v1::Scene>()));
      mdr::v1::ApplyResponse response;
      if (!setup
               ->Apply(As(kAliceToken, std::chrono::seconds(30)).get(),
                       DepthRequest(sessions.back(), kDepth), &response)
               .ok()) {
        Fail("alice's depth step");
      }
    }
    stub_ = Connect(address);
    for (int i = 0; i < streams; ++i) {
      contexts_.push_back(As(kAliceToken, std::chrono::seconds(3600)));
      threads_.emplace_back([this, context = contexts_.back().get(),
                             session = sessions[i % kAbuseSessions]] { Send(context, session); });
    }
  }
  ~AbandonedStreams() {
    for (auto& context : contexts_) context->TryCancel();
    for (std::thread& thread : threads_) thread.join();
  }

 private:
  void Send(grpc::ClientContext* context, const std::string& session) {
    auto stream = stub_->StreamApply(context);
    mdr::v1::StreamApplyRequest message;
    message.mutable_apply()->set_session(session);
    for (int k = 0; k < kAbuseStepsPerMessage; ++k) {
      message.mutable_apply()->add_steps()->set_displacement_increment(k % 2 == 0 ? 1e-9 : -1e-9);
    }
    while (stream->Write(message)) {  // blocks once flow control stops it
    }
    stream->Finish();
  }

  std::unique_ptr<Stub> stub_;
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts_;
  std::vector<std::thread> threads_;
};

mdr::v1::Scene HeavyTabulatedScene() {
  mdr::v1::Scene scene = mdr::reference::H1Scene<mdr::v1::Scene>();
  mdr::v1::TabulatedProfile* profile = scene.mutable_tabulated();
  constexpr double kSampledTo = 5e-4;
  for (int i = 0; i < kHeavySamples; ++i) {
    const double r = kSampledTo * i / (kHeavySamples - 1);
    profile->add_radii(r);
    profile->add_heights(r * r / (2 * mdr::reference::H1::kRadius) *
                         (1 + 1e-3 * std::sin(20 * r / kSampledTo)));
  }
  return scene;
}

// Clients of heavy calls back to back, until the phase ends.
class HeavyCalls {
 public:
  HeavyCalls(const std::string& address, int clients) {
    for (int i = 0; i < clients; ++i) {
      threads_.emplace_back([this, address, i] { Run(address, i); });
    }
  }
  ~HeavyCalls() {
    stop_ = true;
    for (std::thread& thread : threads_) thread.join();
  }

 private:
  void Run(const std::string& address, int client) {
    auto stub = Connect(address);
    std::string grid;
    mdr::v1::ApplyRequest batch;
    if (client % 2 == 1) {
      mdr::v1::Scene scene = mdr::reference::H1Scene<mdr::v1::Scene>();
      scene.set_method(mdr::v1::METHOD_GRID);
      scene.mutable_grid()->set_size(kHeavyGridSprings);
      scene.mutable_grid()->set_max_radius(1e-3);
      batch.set_session(Create(*stub, kAliceToken, scene));
      for (int k = 0; k < 20; ++k) batch.add_steps()->set_depth(kDepth * (1 + 0.1 * (k % 2)));
    }
    const mdr::v1::Scene tabulated = HeavyTabulatedScene();
    while (!stop_) {
      grpc::Status status;
      if (client % 2 == 1) {
        mdr::v1::ApplyResponse response;
        status = stub->Apply(As(kAliceToken, std::chrono::seconds(120)).get(), batch, &response);
      } else {
        mdr::v1::CreateSessionRequest request;
        *request.mutable_session()->mutable_scene() = tabulated;
        mdr::v1::Session created;
        status = stub->CreateSession(As(kAliceToken, std::chrono::seconds(120)).get(), request,
                                     &created);
        if (status.ok()) {
          mdr::v1::DeleteSessionRequest erase;
          erase.set_name(created.name());
          google::protobuf::Empty empty;
          stub->DeleteSession(As(kAliceToken, std::chrono::seconds(30)).get(), erase, &empty);
        }
      }
    }
  }

  std::vector<std::thread> threads_;
  std::atomic<bool> stop_{false};
};

// Clients of fits back to back until the phase ends, client k with a deadline of 10 s (even k)
// or 30 s (odd k): each fit runs until its deadline cancels it.
class Fits {
 public:
  Fits(const std::string& address, int clients) {
    for (int i = 0; i < clients; ++i) {
      threads_.emplace_back([this, address, i] { Run(address, i); });
    }
  }
  ~Fits() {
    stop_ = true;
    for (std::thread& thread : threads_) thread.join();
  }

 private:
  void Run(const std::string& address, int client) {
    auto stub = Connect(address);
    const mdr::v1::FitLoopsRequest request = AlicesFit();
    while (!stop_) {
      auto context = As(kAliceToken, std::chrono::seconds(client % 2 == 0 ? 10 : 30));
      auto reader = stub->FitLoops(context.get(), request);
      mdr::v1::FitLoopsResponse response;
      while (reader->Read(&response)) {
      }
      reader->Finish();
    }
  }

  std::vector<std::thread> threads_;
  std::atomic<bool> stop_{false};
};

// Bob as a newcomer: idle for longer than the executor's recent window, then one one-step Apply
// and one AnalyzeLoops; each call's round trip is a sample.
ProbeFigures NewcomerProbe(Stub& stub, const std::string& session, int rounds) {
  constexpr auto kIdle = std::chrono::milliseconds(2500);
  const mdr::v1::AnalyzeLoopsRequest loops = BobsLoops();
  ProbeFigures figures;
  mdr::v1::ApplyRequest apply;
  apply.set_session(session);
  mdr::v1::Step* step = apply.add_steps();
  auto record = [&](const grpc::Status& status, Clock::time_point start) {
    figures.millis.push_back(
        std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    if (!status.ok() && figures.refused++ == 0) figures.first_error = status.error_message();
  };
  for (int k = 0; k < rounds; ++k) {
    std::this_thread::sleep_for(kIdle);
    step->set_displacement(k % 2 == 0 ? kBobAmplitude : -kBobAmplitude);
    mdr::v1::ApplyResponse applied;
    Clock::time_point start = Clock::now();
    record(stub.Apply(As(kBobToken, std::chrono::seconds(60)).get(), apply, &applied), start);
    mdr::v1::AnalyzeLoopsResponse analysed;
    start = Clock::now();
    record(stub.AnalyzeLoops(As(kBobToken, std::chrono::seconds(60)).get(), loops, &analysed),
           start);
  }
  return figures;
}

// ---------------------------------------------------------------------------------------------

struct Settings {
  std::string mdrd;
  double seconds = 4;
  int streams = 256;
  int heavy_clients = 4;
  std::vector<std::string> mdrd_args;  // passed on to mdrd
  bool alice_competes = false;         // her client at normal priority instead of SCHED_IDLE
  std::string journal;                 // mdrd's journal file; empty: --no-journal
  int newcomer_rounds = 8;             // bob's idle-then-call rounds per phase; 0: none
  std::string abuse;                   // child mode: "streams" or "heavy"
  std::string connect;                 // child mode: mdrd's address
};

Settings Parse(int argc, char** argv) {
  Settings settings;
  CLI::App app{"mdr_fairness: one caller's one-step Apply while another abuses mdrd"};
  app.add_option("--mdrd", settings.mdrd, "the mdrd binary to start")->check(CLI::ExistingFile);
  app.add_option("--seconds", settings.seconds, "bob's probe per phase")
      ->check(CLI::Range(0.5, 120.0));
  app.add_option("--streams", settings.streams, "alice's abandoned streams")
      ->check(CLI::Range(1, 256));
  app.add_option("--heavy-clients", settings.heavy_clients, "alice's clients of heavy calls")
      ->check(CLI::Range(1, 64));
  app.add_option("--mdrd-arg", settings.mdrd_args,
                 "an argument passed on to mdrd (repeat: --mdrd-arg=--workers --mdrd-arg=4)");
  app.add_option("--journal", settings.journal,
                 "mdrd journals to this file (created; removed at the end) instead of running "
                 "without a journal");
  app.add_option("--newcomer-rounds", settings.newcomer_rounds,
                 "bob's rounds of 2.5 s idle, then an Apply and an AnalyzeLoops, per phase; 0: "
                 "none")
      ->check(CLI::Range(0, 100));
  app.add_flag("--alice-competes", settings.alice_competes,
               "run alice's client at normal priority (default: SCHED_IDLE, as if on its own "
               "machine)");
  app.add_option("--abuse", settings.abuse, "(internal) run as alice until killed")
      ->check(CLI::IsMember({"streams", "heavy", "fits"}));
  app.add_option("--connect", settings.connect, "(internal) alice's server address");
  try {
    app.parse(argc, argv);
    if (settings.abuse.empty() && settings.mdrd.empty()) {
      throw CLI::RequiredError("--mdrd");
    }
  } catch (const CLI::ParseError& error) {
    std::exit(app.exit(error));
  }
  return settings;
}

// One phase's line; false if bob was refused.
bool Report(const char* phase, const ProbeFigures& figures, double quiet_p99) {
  const double p99 = Percentile(figures.millis, 0.99);
  std::printf("%-18s n=%5zu  p50 %7.3f ms  p99 %7.3f ms  max %8.3f ms  refused %d", phase,
              figures.millis.size(), Percentile(figures.millis, 0.5), p99,
              *std::max_element(figures.millis.begin(), figures.millis.end()), figures.refused);
  if (quiet_p99 > 0) std::printf("  p99/quiet %.2f (target <= 2)", p99 / quiet_p99);
  std::printf("\n");
  if (figures.refused > 0) std::printf("  bob's first error: %s\n", figures.first_error.c_str());
  std::fflush(stdout);
  return figures.refused == 0;
}

// A child process with its stdout and stderr on a pipe (read end in *output, -1 if none wanted).
pid_t Spawn(const std::vector<std::string>& command, int* output) {
  try {
    return mdr::bench::Spawn(command, output);
  } catch (const std::runtime_error& error) {
    Fail(error.what());
  }
}

// A process's CPU time (user and system, all threads) since construction, in cores.
class CpuClock {
 public:
  explicit CpuClock(pid_t pid)
      : pid_(pid), cpu_(Seconds()), start_(std::chrono::steady_clock::now()) {}
  double Cores() const {
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    return (Seconds() - cpu_) / wall;
  }

 private:
  // Fields 14 and 15 of /proc/PID/stat (after the parenthesised command name).
  double Seconds() const {
    std::ifstream stat("/proc/" + std::to_string(pid_) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    std::istringstream fields(text.substr(text.rfind(')') + 2));
    std::string field;
    double ticks = 0;
    for (int i = 3; i <= 15 && fields >> field; ++i) {
      if (i >= 14) ticks += std::stod(field);
    }
    return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
  }

  pid_t pid_;
  double cpu_;
  std::chrono::steady_clock::time_point start_;
};

void Stop(pid_t pid) {
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
}

// Starts mdrd with the two tokens, and a journal if one is asked for; returns its address once
// it serves.
std::string StartMdrd(const Settings& settings, const std::string& tokens, pid_t* pid) {
  int output = -1;
  std::vector<std::string> command = {settings.mdrd,
                                      "--listen",
                                      "127.0.0.1:0",
                                      "--tokens-file",
                                      tokens,
                                      "--max-message-bytes",
                                      std::to_string(64 << 20),
                                      "--log-level",
                                      "info"};
  if (settings.journal.empty()) {
    command.push_back("--no-journal");
  } else {
    command.insert(command.end(), {"--journal", settings.journal});
  }
  command.insert(command.end(), settings.mdrd_args.begin(), settings.mdrd_args.end());
  *pid = Spawn(command, &output);
  FILE* log = fdopen(output, "r");
  const std::regex serving(R"(event=serving.*\bport="?(\d+))");
  char line[4096];
  while (std::fgets(line, sizeof line, log) != nullptr) {
    std::cmatch match;
    if (std::regex_search(line, match, serving)) {
      // Drain the rest of its log so that mdrd never blocks on a full pipe.
      std::thread([log] {
        char rest[4096];
        while (std::fgets(rest, sizeof rest, log) != nullptr) {
        }
        std::fclose(log);
      }).detach();
      return "127.0.0.1:" + match[1].str();
    }
  }
  Fail("mdrd exited before serving");
}

int RunAlice(const Settings& settings) {
  if (!settings.alice_competes) {
    // SCHED_IDLE (inherited by her threads): her client stands in for one on its own machine.
    // Without it, her gRPC client's 256 threads alone take 1.3-1.4 of this machine's 2 cores,
    // however slowly mdrd reads her streams, and that is no server's doing.
    sched_param parameter{};
    if (sched_setscheduler(0, SCHED_IDLE, &parameter) != 0) Fail("sched_setscheduler(SCHED_IDLE)");
  }
  if (settings.abuse == "streams") {
    AbandonedStreams abuse(settings.connect, settings.streams);
    pause();  // until SIGTERM ends the process
  } else if (settings.abuse == "heavy") {
    HeavyCalls abuse(settings.connect, settings.heavy_clients);
    pause();
  } else {
    Fits abuse(settings.connect, 2);
    pause();
  }
  return EXIT_SUCCESS;
}

}  // namespace

int main(int argc, char** argv) {
  const Settings settings = Parse(argc, argv);
  if (!settings.abuse.empty()) return RunAlice(settings);
  const std::filesystem::path tokens =
      std::filesystem::temp_directory_path() / ("mdr_fairness_tokens." + std::to_string(getpid()));
  std::ofstream(tokens) << "alice:" << kAliceToken << "\nbob:" << kBobToken << "\n";
  pid_t mdrd = 0;
  const std::string address = StartMdrd(settings, tokens.string(), &mdrd);
  std::filesystem::remove(tokens);

  auto bob = Connect(address);
  const std::string session = Create(*bob, kBobToken, mdr::reference::H1Scene<mdr::v1::Scene>());
  mdr::v1::ApplyResponse loaded;
  if (!bob->Apply(As(kBobToken, std::chrono::seconds(30)).get(), DepthRequest(session, kDepth),
                  &loaded)
           .ok()) {
    Fail("bob's depth step");
  }
  std::printf(
      "mdr_fairness: %u hardware threads, mdrd with default workers and limits; bob's one-step "
      "Apply every %lld ms for %g s per phase; alice: %d streams / %d heavy clients, her client "
      "%s\n",
      std::thread::hardware_concurrency(), static_cast<long long>(kProbePeriod.count()),
      settings.seconds, settings.streams, settings.heavy_clients,
      settings.alice_competes ? "at normal priority (--alice-competes)" : "at SCHED_IDLE");
  Probe(*bob, session, 0.5);  // warm-up
  const CpuClock quiet_cpu(mdrd);
  const ProbeFigures quiet = Probe(*bob, session, settings.seconds);
  const double quiet_cores = quiet_cpu.Cores();
  bool never_refused = Report("quiet", quiet, 0);
  std::printf("  during it: mdrd used %.2f cores\n", quiet_cores);
  const double quiet_p99 = Percentile(quiet.millis, 0.99);
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  auto spawn_alice = [&](const char* kind) {
    std::vector<std::string> command = {self,
                                        "--abuse",
                                        kind,
                                        "--connect",
                                        address,
                                        "--streams",
                                        std::to_string(settings.streams),
                                        "--heavy-clients",
                                        std::to_string(settings.heavy_clients)};
    if (settings.alice_competes) command.push_back("--alice-competes");
    const pid_t alice = Spawn(command, nullptr);
    std::this_thread::sleep_for(std::chrono::seconds(2));  // her sessions and calls are going
    return alice;
  };
  for (const char* kind : {"streams", "heavy"}) {
    const pid_t alice = spawn_alice(kind);
    const CpuClock mdrd_cpu(mdrd), alice_cpu(alice);
    const ProbeFigures figures = Probe(*bob, session, settings.seconds);
    const double mdrd_cores = mdrd_cpu.Cores(), alice_cores = alice_cpu.Cores();
    Stop(alice);
    never_refused &= Report(std::strcmp(kind, "streams") == 0 ? "abandoned streams" : "heavy calls",
                            figures, quiet_p99);
    std::printf("  during it: mdrd used %.2f cores, alice's client %.2f\n", mdrd_cores,
                alice_cores);
  }
  if (settings.newcomer_rounds > 0) {
    std::printf("bob as a newcomer: %d rounds of 2.5 s idle, then an Apply and an AnalyzeLoops\n",
                settings.newcomer_rounds);
    const ProbeFigures alone = NewcomerProbe(*bob, session, settings.newcomer_rounds);
    never_refused &= Report("newcomer quiet", alone, 0);
    const double alone_p99 = Percentile(alone.millis, 0.99);
    for (const char* kind : {"fits", "heavy"}) {
      const pid_t alice = spawn_alice(kind);
      const ProbeFigures figures = NewcomerProbe(*bob, session, settings.newcomer_rounds);
      Stop(alice);
      never_refused &= Report(std::strcmp(kind, "fits") == 0 ? "newcomer, fits" : "newcomer, heavy",
                              figures, alone_p99);
    }
  }
  Stop(mdrd);
  if (!settings.journal.empty()) {
    for (const char* suffix : {"", "-wal", "-shm", ".commit"}) {
      std::filesystem::remove(settings.journal + suffix);
    }
  }
  return never_refused ? EXIT_SUCCESS : EXIT_FAILURE;
}
