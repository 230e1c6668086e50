// mdr_load: load test of mdrd's ContactService beside a no-op echo service with the same message
// shapes (echo.proto), both served in this process on loopback ports and measured in the same
// run, so the ratio apply/echo says what the service adds to the framework's own cost (absolute
// figures on a shared machine vary by tens of percent, the ratio much less):
//   build/release/tests/bench/mdr_load [--seconds S] [--rounds R] [--window W] [--json FILE]
//                                      [--energy false] [--only "sessions:1/"]
//   build/release/tests/bench/mdr_load --execution [--execution-seconds S]
//                                      [--inline-clients-compete]   (see below)
//
// Workload: H1, a steel sphere R = 10 mm on steel (E = 210 GPa, nu = 0.3 for both), mu = 0.3,
// loaded to F_N = 100 N; then Mindlin-Deresiewicz cycling at constant F_N: the tangential
// displacement follows a triangle wave between -0.6 and +0.6 mu kappa delta, 8 steps per half
// cycle, every session at its own phase (partial slip, so the contact memory stays bounded).
// Energy is tracked (the scene's default); --energy false leaves it off, so that the service's
// own cost per step shows beside a cheaper engine step.
//
// Scenarios, each with 1, 10 and 100 sessions:
// - "apply batch N": unary Apply through mdr_client with N steps per call (N = 1, 10, 100, 1000;
//   N = 1 is the one-step-per-call case), beside a unary echo of the same request and response.
// - "stream window W": StreamApply with one step per message and at most W messages in flight
//   per stream, beside the echo stream (through the generated stub: a window bounded in time
//   needs the stream's reader and writer). A third side, "engine inline", is the echo stream
//   that first applies each step to an engine contact of its session on the transport's thread:
//   the ceiling of any server computing the same steps (no hand-off to a worker, no service
//   around the engine). mdrd computes on the transport's threads only a message whose cost is
//   bounded a priori (docs/operations.md, "Inline steps"); this side says how close to the echo
//   the physics alone would allow.
// Client threads: min(sessions, 8). Thread t drives sessions t, t + T, t + 2T, ... in turn
// (round-robin), one call at a time (unary) or over one stream (a writer and a reader thread), on
// its own channel and TCP connection, like independent test rigs. So at most 8 unary calls are in
// flight: 100 sessions mean 100 session states on the server, not 100 concurrent calls.
// Bounded: each side (apply, echo, engine inline) of a scenario runs for --seconds of wall time
// (default 1.5, at most 2), split into --rounds (default 3) that alternate the sides so that a
// drift of the machine hits them alike; 15 scenarios, about 55 s in all. Throughputs are the
// median over the rounds; latencies percentiles over every call: per call (unary), per message
// from write to answer (stream, including the wait behind the messages ahead of it in the
// window). The server's own compute time per step (ApplyResponse.compute_seconds) is reported
// beside them, and the context switches and CPU time of the whole process per call or message on
// each side (getrusage: the client threads' count with the servers', alike on every side; the
// JSON also has the switches of the stream clients' own threads). Client and servers share this
// machine's cores, so a server that is the slower end makes the client wait (and switch) per
// answer, and a few microseconds of server time per message show up several times over.
#include <grpc/grpc.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <sched.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <latch>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <semaphore>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "child_process.h"
#include "echo_service.h"
#include "fixtures/reference_scenes.h"
#include "mdr/client/contact_client.h"
#include "mdr/core/contact.h"
#include "mdr/core/material.h"
#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
using mdr::v1::ApplyRequest;
using mdr::v1::ApplyResponse;
using mdr::v1::StreamApplyRequest;
using mdr::v1::StreamApplyResponse;
using Steps = google::protobuf::RepeatedPtrField<mdr::v1::Step>;

constexpr int kMaxClientThreads = 8;
constexpr std::array kSessionCounts{1, 10, 100};
constexpr std::array kBatchSizes{1, 10, 100, 1000};
constexpr int kStepsPerHalfCycle = 8;
constexpr int kCyclePeriod = 2 * kStepsPerHalfCycle;
constexpr double kCycleAmplitude = 0.6;  // of mu kappa delta, the full-slip displacement
constexpr auto kCallTimeout = std::chrono::seconds(30);

// H1 (tests/fixtures/reference_scenes.h, docs/reference-values.md).
using H1 = mdr::reference::H1;
constexpr double kSphereRadius = H1::kRadius;
constexpr double kYoungsModulus = H1::kYoungsModulus;
constexpr double kPoissonRatio = H1::kPoissonRatio;
constexpr double kFriction = H1::kFriction;
constexpr double kNormalForce = H1::kNormalForce;

[[noreturn]] void Fail(const std::string& what) {
  std::fprintf(stderr, "mdr_load: %s\n", what.c_str());
  std::exit(EXIT_FAILURE);
}

std::unique_ptr<grpc::Server> StartEchoServer(mdr::bench::EchoService& service, int* port) {
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || *port == 0) Fail("cannot start the echo server on 127.0.0.1");
  return server;
}

// ---------------------------------------------------------------------------------------------
// The workload: H1 sessions and their cycling steps.

mdr::v1::Scene HertzScene() { return mdr::reference::H1Scene<mdr::v1::Scene>(); }

double HertzKappa() {
  const auto material =
      mdr::ElasticPair(kYoungsModulus, kPoissonRatio, kYoungsModulus, kPoissonRatio);
  if (!material.ok()) Fail("H1 material: " + material.status().ToString());
  return material->kappa();
}

// Displacement at a phase of the triangle wave: -amplitude at phase 0, +amplitude at half cycle.
double CyclingDisplacement(double amplitude, int phase) {
  return mdr::reference::TriangleWave(amplitude, phase, kStepsPerHalfCycle);
}

// The batches of every size for every starting phase, built once so that the measured loops
// only send them.
class CyclingSteps {
 public:
  explicit CyclingSteps(double amplitude) {
    for (const int size : kBatchSizes) {
      for (int phase = 0; phase < kCyclePeriod; ++phase) {
        Steps& batch = batches_[size][phase];
        for (int i = 0; i < size; ++i) {
          batch.Add()->set_displacement(CyclingDisplacement(amplitude, (phase + i) % kCyclePeriod));
        }
      }
    }
  }

  const Steps& Batch(int size, int phase) const { return batches_.at(size)[phase]; }

 private:
  std::map<int, std::array<Steps, kCyclePeriod>> batches_;
};

// A session and where it is in its cycle; each measurement gives it to exactly one thread.
struct SessionCursor {
  std::string name;
  int phase = 0;
  void Advance(int steps) { phase = (phase + steps) % kCyclePeriod; }
};

struct Workload {
  std::vector<SessionCursor> sessions;
  double depth = 0;      // delta at F_N, m
  double kappa = 0;      // E*/G*
  double amplitude = 0;  // m
};

SessionCursor CreateLoadedSession(mdr::client::ContactClient& client, const mdr::v1::Scene& scene,
                                  double* depth) {
  auto session = client.CreateSession(scene);
  if (!session.ok()) Fail("CreateSession: " + session.status().error_message());
  Steps load;
  load.Add()->set_normal_force(kNormalForce);
  auto loaded = client.Apply(session->name(), load);
  if (!loaded.ok()) Fail("Apply F_N: " + loaded.status().error_message());
  *depth = loaded->state().depth();
  return {session->name()};
}

Workload CreateWorkload(mdr::client::ContactClient& client, int session_count, bool track_energy) {
  mdr::v1::Scene scene = HertzScene();
  scene.mutable_options()->set_track_energy(track_energy);
  Workload workload;
  for (int i = 0; i < session_count; ++i) {
    workload.sessions.push_back(CreateLoadedSession(client, scene, &workload.depth));
  }
  workload.kappa = HertzKappa();
  workload.amplitude = kCycleAmplitude * kFriction * workload.kappa * workload.depth;
  return workload;
}

// The engine side of "engine inline": one H1 contact per session, loaded to F_N, stepped to each
// message's displacements on the echo server's transport thread.
class EngineContacts {
 public:
  EngineContacts(const std::vector<SessionCursor>& sessions, bool track_energy) {
    const mdr::Contact loaded = mdr::reference::LoadedH1Contact(track_energy);
    for (const SessionCursor& session : sessions) contacts_.emplace(session.name, loaded);
  }

  // Every session's contact exists from the start, so concurrent streams (never two on one
  // session) only read the map.
  void Apply(const ApplyRequest& request) {
    const auto found = contacts_.find(request.session());
    if (found == contacts_.end()) Fail("engine inline: unknown session " + request.session());
    mdr::Contact& contact = found->second;
    for (const mdr::v1::Step& step : request.steps()) {
      if (auto status = contact.MoveTo(contact.depth(), step.displacement()); !status.ok()) {
        Fail("engine inline step: " + status.ToString());
      }
    }
  }

 private:
  std::map<std::string, mdr::Contact> contacts_;
};

// A real response of one cycling step, for the echo to answer with.
ApplyResponse OneCyclingStep(mdr::client::ContactClient& client, SessionCursor& session,
                             const CyclingSteps& steps) {
  auto response = client.Apply(session.name, steps.Batch(1, session.phase));
  if (!response.ok()) Fail("Apply: " + response.status().error_message());
  session.Advance(1);
  return std::move(response).value();
}

// ---------------------------------------------------------------------------------------------
// Running threads against a deadline and summarising what they measured.

struct ThreadTally {
  std::vector<double> latencies_us;
  std::int64_t calls = 0;
  std::int64_t steps = 0;
  double compute_seconds = 0;        // ApplyResponse.compute_seconds summed (0 for the echo)
  std::int64_t client_switches = 0;  // streams: of the reader and the writer thread
};

// What the threads of one round did in `seconds` of wall time.
struct Round {
  std::vector<ThreadTally> tallies;
  double seconds = 0;
  std::int64_t context_switches = 0;  // of the whole process: clients and servers alike
  double cpu_seconds = 0;             // of the whole process (user and system)
  std::int64_t steps() const {
    std::int64_t steps = 0;
    for (const ThreadTally& tally : tallies) steps += tally.steps;
    return steps;
  }
};

// One side (apply or echo) of a scenario over its rounds: rates are the median over the rounds,
// latencies percentiles of every call of every round.
struct RunFigures {
  int threads = 0;
  int rounds = 0;
  double seconds = 0;
  std::int64_t calls = 0;
  std::int64_t steps = 0;
  double steps_per_second = 0;
  double calls_per_second = 0;
  double p50_us = 0;
  double p99_us = 0;
  double p999_us = 0;
  double compute_seconds = 0;
  std::int64_t context_switches = 0;  // of the whole process
  std::int64_t client_switches = 0;   // of the client's stream threads
  double cpu_seconds = 0;             // of the whole process (user and system)
  double compute_ns_per_step() const { return compute_seconds / steps * 1e9; }
  double context_switches_per_call() const { return static_cast<double>(context_switches) / calls; }
  // Streams only (0 for unary calls): the switches of the client's reader and writer threads.
  double client_context_switches_per_call() const {
    return static_cast<double>(client_switches) / calls;
  }
  double cpu_us_per_call() const { return cpu_seconds / calls * 1e6; }
};

// Nearest-rank percentile of sorted values.
double Percentile(const std::vector<double>& sorted, double fraction) {
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * sorted.size()));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t middle = values.size() / 2;
  return values.size() % 2 ? values[middle] : (values[middle - 1] + values[middle]) / 2;
}

RunFigures Summarise(const std::vector<Round>& rounds) {
  RunFigures figures{.threads = static_cast<int>(rounds.front().tallies.size()),
                     .rounds = static_cast<int>(rounds.size())};
  std::vector<double> latencies, steps_per_second, calls_per_second;
  for (const Round& round : rounds) {
    std::int64_t round_calls = 0;
    for (const ThreadTally& tally : round.tallies) {
      round_calls += tally.calls;
      figures.compute_seconds += tally.compute_seconds;
      latencies.insert(latencies.end(), tally.latencies_us.begin(), tally.latencies_us.end());
    }
    figures.seconds += round.seconds;
    figures.context_switches += round.context_switches;
    figures.cpu_seconds += round.cpu_seconds;
    for (const ThreadTally& tally : round.tallies) figures.client_switches += tally.client_switches;
    figures.calls += round_calls;
    figures.steps += round.steps();
    steps_per_second.push_back(round.steps() / round.seconds);
    calls_per_second.push_back(round_calls / round.seconds);
  }
  if (latencies.empty()) Fail("a measurement completed no call");
  std::sort(latencies.begin(), latencies.end());
  figures.p50_us = Percentile(latencies, 0.50);
  figures.p99_us = Percentile(latencies, 0.99);
  figures.p999_us = Percentile(latencies, 0.999);
  figures.steps_per_second = Median(steps_per_second);
  figures.calls_per_second = Median(calls_per_second);
  return figures;
}

// Sessions of thread `thread` out of `threads`: every threads-th, starting at its index.
std::vector<SessionCursor*> SessionsOfThread(std::span<SessionCursor> sessions, int thread,
                                             int threads) {
  std::vector<SessionCursor*> own;
  for (std::size_t i = thread; i < sessions.size(); i += threads) own.push_back(&sessions[i]);
  return own;
}

// What getrusage tells of this process (RUSAGE_SELF: every thread) or of the calling thread
// (RUSAGE_THREAD) so far: voluntary and involuntary context switches, user and system CPU time.
struct Usage {
  std::int64_t context_switches = 0;
  double cpu_seconds = 0;
};
Usage UsageOf(int who) {
  rusage usage{};
  getrusage(who, &usage);
  return {usage.ru_nvcsw + usage.ru_nivcsw,
          usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
              1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec)};
}

using ThreadBody = std::function<ThreadTally(int thread, std::span<SessionCursor* const> sessions,
                                             Clock::time_point deadline)>;

// Runs min(sessions, 8) threads from a common start until `seconds` have passed.
Round RunConcurrently(std::span<SessionCursor> sessions, double seconds, const ThreadBody& body) {
  const int threads = std::min<int>(sessions.size(), kMaxClientThreads);
  std::vector<ThreadTally> tallies(threads);
  std::latch ready(threads + 1);
  Clock::time_point start, deadline;
  Usage at_start;
  {
    std::vector<std::jthread> workers;
    for (int t = 0; t < threads; ++t) {
      workers.emplace_back([&, t] {
        const std::vector<SessionCursor*> own = SessionsOfThread(sessions, t, threads);
        ready.arrive_and_wait();
        tallies[t] = body(t, own, deadline);
      });
    }
    at_start = UsageOf(RUSAGE_SELF);
    start = Clock::now();
    deadline =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    ready.arrive_and_wait();
  }  // joins
  const Usage at_end = UsageOf(RUSAGE_SELF);
  return {std::move(tallies), std::chrono::duration<double>(Clock::now() - start).count(),
          at_end.context_switches - at_start.context_switches,
          at_end.cpu_seconds - at_start.cpu_seconds};
}

void RecordCall(ThreadTally& tally, Clock::time_point start, int steps, double compute_seconds) {
  tally.latencies_us.push_back(
      std::chrono::duration<double, std::micro>(Clock::now() - start).count());
  ++tally.calls;
  tally.steps += steps;
  tally.compute_seconds += compute_seconds;
}

// ---------------------------------------------------------------------------------------------
// Unary calls: Apply through mdr_client, the echo through its stub with the same request.

struct CallOutcome {
  grpc::Status status;
  double compute_seconds = 0;  // server-side, as the response states
};

using UnaryCall =
    std::function<CallOutcome(int thread, const std::string& session, const Steps& steps)>;

// applies_steps: the call applies the steps (Apply), so the sessions' cycles advance; the echo
// applies nothing and leaves them where the server has them.
constexpr bool kAppliesSteps = true;
constexpr bool kAppliesNothing = false;

ThreadBody UnaryBody(const UnaryCall& call, const CyclingSteps& steps, int batch,
                     bool applies_steps) {
  return [&call, &steps, batch, applies_steps](int thread, std::span<SessionCursor* const> sessions,
                                               Clock::time_point deadline) {
    ThreadTally tally;
    for (std::size_t next = 0; Clock::now() < deadline; ++next) {
      SessionCursor& session = *sessions[next % sessions.size()];
      const Clock::time_point start = Clock::now();
      const CallOutcome outcome = call(thread, session.name, steps.Batch(batch, session.phase));
      RecordCall(tally, start, batch, outcome.compute_seconds);
      if (!outcome.status.ok()) {
        Fail("unary call on " + session.name + ": " + outcome.status.error_message());
      }
      if (applies_steps) session.Advance(batch);
    }
    return tally;
  };
}

// What mdr::client::ContactClient::Apply sends, sent to the echo.
CallOutcome EchoApply(mdr::bench::Echo::Stub& echo, const std::string& session,
                      const Steps& steps) {
  ApplyRequest request;
  request.set_session(session);
  *request.mutable_steps() = steps;
  request.mutable_step_mask();
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kCallTimeout);
  ApplyResponse response;
  return {echo.EchoApply(&context, request, &response)};
}

CallOutcome ClientApply(mdr::client::ContactClient& client, const std::string& session,
                        const Steps& steps) {
  auto response = client.Apply(session, steps);
  if (!response.ok()) return {response.status()};
  return {grpc::Status::OK, response->compute_seconds()};
}

// ---------------------------------------------------------------------------------------------
// Streams: one step per message, at most `window` messages written and not yet answered.

using StreamReaderWriter = grpc::ClientReaderWriter<StreamApplyRequest, StreamApplyResponse>;
using StreamOpener =
    std::function<std::unique_ptr<StreamReaderWriter>(int thread, grpc::ClientContext* context)>;

std::int64_t NanosSinceEpoch() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

// The send times of the messages in flight, by sequence number modulo the window.
class SendTimes {
 public:
  explicit SendTimes(int window) : slots_(window) {}
  void Stamp(std::int64_t sequence) {
    slots_[sequence % slots_.size()].store(NanosSinceEpoch(), std::memory_order_release);
  }
  double MicrosSince(std::int64_t sequence) const {
    const std::int64_t sent = slots_[sequence % slots_.size()].load(std::memory_order_acquire);
    return (NanosSinceEpoch() - sent) / 1e3;
  }

 private:
  std::vector<std::atomic<std::int64_t>> slots_;
};

// The writer's credits: messages it may still write before an answer comes back. Not a
// std::counting_semaphore: libstdc++ 12's timed acquire polls with sleeps of half the time waited
// so far (its __timed_backoff_spin_policy), which delays the writer by up to milliseconds after a
// credit is released and makes the stream's throughput depend on that backoff, not on the server.
class WindowCredits {
 public:
  explicit WindowCredits(int window) : available_(window) {}
  // Takes one credit, waiting until `deadline` at most; false if none came by then.
  bool AcquireUntil(Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    if (!released_.wait_until(lock, deadline, [this] { return available_ > 0; })) return false;
    --available_;
    return true;
  }
  void Release() {
    {
      std::lock_guard lock(mutex_);
      ++available_;
    }
    released_.notify_one();
  }

 private:
  std::mutex mutex_;
  std::condition_variable released_;
  int available_;  // guarded by mutex_
};

// One stream of a client thread: a writer keeps at most `window` messages unanswered until the
// deadline, while the thread that owns it reads the answers.
class WindowedStream {
 public:
  WindowedStream(std::unique_ptr<StreamReaderWriter> stream, int window)
      : stream_(std::move(stream)), credits_(window), send_times_(window) {}

  // Writes one step per message, to the sessions in turn, then half-closes.
  void WriteUntil(Clock::time_point deadline, std::span<SessionCursor* const> sessions,
                  const CyclingSteps& steps, bool applies_steps) {
    StreamApplyRequest request;
    for (; credits_.AcquireUntil(deadline); ++written_) {
      SessionCursor& session = *sessions[written_ % sessions.size()];
      request.mutable_apply()->set_session(session.name);
      *request.mutable_apply()->mutable_steps() = steps.Batch(1, session.phase);
      send_times_.Stamp(written_);
      if (!stream_->Write(request)) break;
      if (applies_steps) session.Advance(1);
    }
    stream_->WritesDone();
  }

  // Reads every answer until the server ends the stream.
  ThreadTally ReadAnswers() {
    ThreadTally tally;
    StreamApplyResponse response;
    while (stream_->Read(&response)) {
      if (response.status().code() != 0) Fail("stream message: " + response.status().message());
      RecordAnswer(tally, response);
      credits_.Release();
    }
    return tally;
  }

  // After the writer has finished: the stream ended OK and every message was answered.
  void CheckComplete(const ThreadTally& tally) {
    const grpc::Status status = stream_->Finish();
    if (!status.ok()) Fail("stream: " + status.error_message());
    if (tally.calls != written_) {
      Fail("stream: " + std::to_string(written_ - tally.calls) + " messages unanswered");
    }
  }

 private:
  void RecordAnswer(ThreadTally& tally, const StreamApplyResponse& response) const {
    tally.latencies_us.push_back(send_times_.MicrosSince(tally.calls));
    tally.compute_seconds += response.result().compute_seconds();
    ++tally.calls;
    ++tally.steps;
  }

  std::unique_ptr<StreamReaderWriter> stream_;
  WindowCredits credits_;
  SendTimes send_times_;
  std::int64_t written_ = 0;  // by the writer; read by the owner after joining it
};

ThreadBody StreamBody(const StreamOpener& open, const CyclingSteps& steps, int window,
                      bool applies_steps) {
  return [&open, &steps, window, applies_steps](
             int thread, std::span<SessionCursor* const> sessions, Clock::time_point deadline) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + kCallTimeout);
    WindowedStream stream(open(thread, &context), window);
    const std::int64_t reader_switches = UsageOf(RUSAGE_THREAD).context_switches;
    std::int64_t writer_switches = 0;
    std::jthread writer([&] {
      const std::int64_t at_start = UsageOf(RUSAGE_THREAD).context_switches;
      stream.WriteUntil(deadline, sessions, steps, applies_steps);
      writer_switches = UsageOf(RUSAGE_THREAD).context_switches - at_start;
    });
    ThreadTally tally = stream.ReadAnswers();
    writer.join();
    tally.client_switches =
        UsageOf(RUSAGE_THREAD).context_switches - reader_switches + writer_switches;
    stream.CheckComplete(tally);
    return tally;
  };
}

// ---------------------------------------------------------------------------------------------
// The scenarios.

// One channel (TCP connection) per client thread; a local subchannel pool keeps channels to the
// same address from sharing one connection.
std::shared_ptr<grpc::Channel> ConnectLoopback(int port) {
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port),
                                           grpc::InsecureChannelCredentials(), arguments);
  if (!channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(5))) {
    Fail("cannot connect to 127.0.0.1:" + std::to_string(port));
  }
  return channel;
}

struct LoadTargets {
  std::vector<mdr::client::ContactClient> contact_clients;                    // one per thread
  std::vector<std::unique_ptr<mdr::v1::ContactService::Stub>> contact_stubs;  // streams
  std::vector<std::unique_ptr<mdr::bench::Echo::Stub>> echo_stubs;
};

LoadTargets ConnectClients(int contact_port, int echo_port) {
  LoadTargets targets;
  for (int t = 0; t < kMaxClientThreads; ++t) {
    auto contact_channel = ConnectLoopback(contact_port);
    targets.contact_clients.emplace_back(contact_channel, kCallTimeout);
    targets.contact_stubs.push_back(mdr::v1::ContactService::NewStub(contact_channel));
    targets.echo_stubs.push_back(mdr::bench::Echo::NewStub(ConnectLoopback(echo_port)));
  }
  return targets;
}

std::string UnaryScenario(int batch) { return "apply batch " + std::to_string(batch); }

// "<scenario>/sessions:<n>", the prefix of the scenario's figures in the JSON.
std::string FigureName(const std::string& scenario, int sessions) {
  return scenario + "/sessions:" + std::to_string(sessions);
}

struct ScenarioResult {
  std::string scenario;
  int sessions = 0;
  RunFigures apply;
  RunFigures echo;
  std::optional<RunFigures> engine_inline;  // streams only
  double ratio() const { return apply.steps_per_second / echo.steps_per_second; }
  double engine_inline_ratio() const {
    return engine_inline ? engine_inline->steps_per_second / echo.steps_per_second : 0;
  }
};

struct LoadSettings {
  double seconds = 1.5;  // per side of a scenario, split into `rounds`
  int rounds = 3;
  int window = 32;
  std::string json_path;
  bool track_energy = true;  // scene.options.track_energy of the sessions
  std::string only;          // run only the scenarios whose name contains it
  bool execution = false;    // run the execution scenarios instead
  double execution_seconds = 5;
  // mdrd's --max-inline-vertices (docs/operations.md, "Inline steps"); 0: no inline steps.
  std::size_t max_inline_vertices = mdr::service::ServiceLimits{}.max_inline_vertices;
  std::vector<int> inline_streams_child;  // PORT COUNT: the child mode of --execution
  bool inline_clients_compete = false;    // the inline streams' client at normal priority
};

class LoadRun {
 public:
  LoadRun(LoadTargets& targets, Workload& workload, const CyclingSteps& steps,
          const LoadSettings& settings)
      : targets_(targets),
        workload_(workload),
        settings_(settings),
        steps_(steps),
        apply_([this](int t, const std::string& session, const Steps& steps) {
          return ClientApply(targets_.contact_clients[t], session, steps);
        }),
        echo_apply_([this](int t, const std::string& session, const Steps& steps) {
          return EchoApply(*targets_.echo_stubs[t], session, steps);
        }),
        open_apply_stream_([this](int t, grpc::ClientContext* context) {
          return targets_.contact_stubs[t]->StreamApply(context);
        }),
        open_echo_stream_([this](int t, grpc::ClientContext* context) {
          return targets_.echo_stubs[t]->EchoStream(context);
        }),
        open_engine_stream_([this](int t, grpc::ClientContext* context) {
          return targets_.echo_stubs[t]->EngineStream(context);
        }) {}

  ScenarioResult UnaryBatch(int sessions, int batch) {
    return Compare(UnaryScenario(batch), sessions, UnaryBody(apply_, steps_, batch, kAppliesSteps),
                   UnaryBody(echo_apply_, steps_, batch, kAppliesNothing));
  }

  std::string StreamScenario() const { return "stream window " + std::to_string(settings_.window); }

  ScenarioResult Stream(int sessions) {
    const ThreadBody engine_inline =
        StreamBody(open_engine_stream_, steps_, settings_.window, kAppliesNothing);
    return Compare(StreamScenario(), sessions,
                   StreamBody(open_apply_stream_, steps_, settings_.window, kAppliesSteps),
                   StreamBody(open_echo_stream_, steps_, settings_.window, kAppliesNothing),
                   &engine_inline);
  }

  // Untimed: the first calls on every connection and session.
  void WarmUp() {
    const double seconds = std::min(settings_.seconds, 0.2);
    RunConcurrently(workload_.sessions, seconds, UnaryBody(apply_, steps_, 1, kAppliesSteps));
    RunConcurrently(workload_.sessions, seconds,
                    UnaryBody(echo_apply_, steps_, 1, kAppliesNothing));
  }

 private:
  // Apply, echo (and engine inline) in alternating rounds, so that a drift of the machine hits
  // every side alike. The engine side is not given sessions' phases: like the echo, it does not
  // advance them.
  ScenarioResult Compare(const std::string& scenario, int sessions, const ThreadBody& apply,
                         const ThreadBody& echo, const ThreadBody* engine_inline = nullptr) {
    const std::span<SessionCursor> used = std::span(workload_.sessions).first(sessions);
    const double seconds = settings_.seconds / settings_.rounds;
    std::vector<Round> apply_rounds, echo_rounds, engine_rounds;
    for (int round = 0; round < settings_.rounds; ++round) {
      apply_rounds.push_back(RunConcurrently(used, seconds, apply));
      echo_rounds.push_back(RunConcurrently(used, seconds, echo));
      if (engine_inline) engine_rounds.push_back(RunConcurrently(used, seconds, *engine_inline));
    }
    ScenarioResult result{scenario, sessions, Summarise(apply_rounds), Summarise(echo_rounds),
                          std::nullopt};
    if (engine_inline) result.engine_inline = Summarise(engine_rounds);
    return result;
  }

  LoadTargets& targets_;
  Workload& workload_;
  const LoadSettings& settings_;
  const CyclingSteps& steps_;
  const UnaryCall apply_, echo_apply_;
  const StreamOpener open_apply_stream_, open_echo_stream_, open_engine_stream_;
};

// ---------------------------------------------------------------------------------------------
// Output: a table on stdout and the figures as JSON.

void PrintTableHeader() {
  std::printf("%-17s %8s %7s %9s %9s %9s %12s %9s %9s %9s %12s %7s %9s %8s %16s %18s\n", "scenario",
              "sessions", "threads", "p50 [us]", "p99 [us]", "p99.9", "steps/s", "echo p50",
              "echo p99", "echo p99.9", "echo steps/s", "ratio", "ns/step*", "inline**",
              "switches***", "cpu [us]***");
}

void PrintRow(const ScenarioResult& r) {
  // "apply/echo[/engine inline]" of one per-call figure.
  const auto per_side = [&r](const std::function<double(const RunFigures&)>& figure,
                             const char* format) {
    const auto formatted = [format](double value) {
      char text[32];
      std::snprintf(text, sizeof text, format, value);
      return std::string(text);
    };
    std::string cell = formatted(figure(r.apply)) + "/" + formatted(figure(r.echo));
    if (r.engine_inline) cell += "/" + formatted(figure(*r.engine_inline));
    return cell;
  };
  const std::string switches =
      per_side([](const RunFigures& run) { return run.context_switches_per_call(); }, "%.2f");
  const std::string cpu =
      per_side([](const RunFigures& run) { return run.cpu_us_per_call(); }, "%.1f");
  char engine_inline[32] = "-";
  if (r.engine_inline)
    std::snprintf(engine_inline, sizeof engine_inline, "%.2f", r.engine_inline_ratio());
  std::printf(
      "%-17s %8d %7d %9.1f %9.1f %9.1f %12.0f %9.1f %9.1f %9.1f %12.0f %7.2f %9.0f %8s %16s "
      "%18s\n",
      r.scenario.c_str(), r.sessions, r.apply.threads, r.apply.p50_us, r.apply.p99_us,
      r.apply.p999_us, r.apply.steps_per_second, r.echo.p50_us, r.echo.p99_us, r.echo.p999_us,
      r.echo.steps_per_second, r.ratio(), r.apply.compute_ns_per_step(), engine_inline,
      switches.c_str(), cpu.c_str());
  std::fflush(stdout);
}

void AddFigure(nlohmann::json& figures, const ScenarioResult& r, const std::string& metric,
               double value, const std::string& unit) {
  figures.push_back({{"name", FigureName(r.scenario, r.sessions) + "/" + metric},
                     {"scenario", r.scenario},
                     {"sessions", r.sessions},
                     {"metric", metric},
                     {"value", value},
                     {"unit", unit}});
}

void AddRunFigures(nlohmann::json& figures, const ScenarioResult& r, const std::string& prefix,
                   const RunFigures& run) {
  AddFigure(figures, r, prefix + "p50_latency", run.p50_us, "us");
  AddFigure(figures, r, prefix + "p99_latency", run.p99_us, "us");
  AddFigure(figures, r, prefix + "p999_latency", run.p999_us, "us");
  AddFigure(figures, r, prefix + "throughput", run.steps_per_second, "steps/s");
  AddFigure(figures, r, prefix + "call_rate", run.calls_per_second, "calls/s");
  AddFigure(figures, r, prefix + "calls", static_cast<double>(run.calls), "calls");
  AddFigure(figures, r, prefix + "seconds", run.seconds, "s");
  AddFigure(figures, r, prefix + "rounds", run.rounds, "rounds");
  AddFigure(figures, r, prefix + "context_switches_per_call", run.context_switches_per_call(),
            "switches/call");
  AddFigure(figures, r, prefix + "client_context_switches_per_call",
            run.client_context_switches_per_call(), "switches/call");
  AddFigure(figures, r, prefix + "cpu_per_call", run.cpu_us_per_call(), "us/call");
}

void AddServiceFigures(nlohmann::json& figures, const ScenarioResult& r) {
  AddFigure(figures, r, "client_threads", r.apply.threads, "threads");
  AddFigure(figures, r, "server_compute_per_step", r.apply.compute_ns_per_step(), "ns/step");
  AddFigure(figures, r, "ratio", r.ratio(), "1");
  if (r.engine_inline) AddFigure(figures, r, "engine_inline_ratio", r.engine_inline_ratio(), "1");
}

nlohmann::json FiguresJson(const std::vector<ScenarioResult>& results) {
  nlohmann::json figures = nlohmann::json::array();
  for (const ScenarioResult& r : results) {
    AddServiceFigures(figures, r);
    AddRunFigures(figures, r, "", r.apply);
    AddRunFigures(figures, r, "echo_", r.echo);
    if (r.engine_inline) AddRunFigures(figures, r, "engine_inline_", *r.engine_inline);
  }
  return figures;
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return text;
}

nlohmann::json ContextJson(const Workload& workload, const LoadSettings& settings,
                           const ApplyResponse& canned) {
  const std::string scene =
      std::string("H1: sphere R = 0.01 m, steel on steel (E = 210e9 Pa, nu = 0.3), mu = 0.3, ") +
      (settings.track_energy ? "energy tracked (the default)" : "energy not tracked");
  return {{"date", UtcNow()},
          {"host_cpus", std::thread::hardware_concurrency()},
          {"grpc_version", grpc::Version()},
          {"seconds_per_side", settings.seconds},
          {"rounds", settings.rounds},
          {"stream_window", settings.window},
          {"client_threads", "min(sessions, 8), sessions round-robin, one channel each"},
          {"scene", scene},
          {"track_energy", settings.track_energy},
          {"normal_force_n", kNormalForce},
          {"depth_m", workload.depth},
          {"kappa", workload.kappa},
          {"cycle", "triangle wave +-0.6 mu kappa delta, 8 steps per half cycle"},
          {"cycle_amplitude_m", workload.amplitude},
          {"apply_response_bytes", canned.ByteSizeLong()}};
}

void WriteJson(const std::string& path, const nlohmann::json& report) {
  std::ofstream out(path);
  out << report.dump(2) << "\n";
  if (!out) Fail("cannot write " + path);
}

// The state of a session after the run: the cycling stayed in partial slip.
void PrintSessionCheck(mdr::client::ContactClient& client, const SessionCursor& session) {
  auto query = client.Query(session.name);
  if (!query.ok()) Fail("Query: " + query.status().error_message());
  const mdr::v1::ContactState& state = query->state();
  std::printf(
      "check %s: %llu steps applied, F_N = %.6g N, |F_x| = %.3g mu F_N, %llu memory "
      "vertices\n",
      session.name.c_str(), static_cast<unsigned long long>(state.applied_steps()),
      state.normal_force(), std::abs(state.tangential_force()) / state.friction_limit(),
      static_cast<unsigned long long>(state.memory_vertices()));
}

void PrintPreamble(const Workload& workload, const LoadSettings& settings, int contact_port,
                   int echo_port) {
  std::printf(
      "mdr_load: H1 at F_N = %g N (delta = %.6g m), cycling +-%.6g m (0.6 mu kappa delta), "
      "energy %s; %g s per side in %d rounds, stream window %d; servers on 127.0.0.1:%d (mdr), "
      ":%d (echo)\n",
      kNormalForce, workload.depth, workload.amplitude, settings.track_energy ? "on" : "off",
      settings.seconds, settings.rounds, settings.window, contact_port, echo_port);
}

// ---------------------------------------------------------------------------------------------
// --execution: the execution model (docs/operations.md) under heavy calls. While N = 4 and 16
// clients each run heavy calls back to back (a CreateSession with a tabulated profile of
// kHeavySamples samples, a batch of steps on a grid of kHeavyGridSprings springs, a curved force
// path bisected to a tight tolerance), one prober measures a health check and a GetSession every
// kProbePeriod: p50/p99. Then the same with 8 and 32 streams of inline messages in the mix (their
// client in a child process at SCHED_IDLE unless --inline-clients-compete). Then compute-bound
// throughput: Apply of 1000-step cycling batches with energy tracking on one session by one client
// against two sessions by two clients.

constexpr int kHeavySamples = 20000;
constexpr std::uint32_t kHeavyGridSprings = 1 << 20;
constexpr int kHeavyGridSteps = 20;
constexpr auto kProbePeriod = std::chrono::milliseconds(10);
constexpr auto kHeavyTimeout = std::chrono::seconds(120);

mdr::v1::Scene HeavyTabulatedScene() {
  mdr::v1::Scene scene = HertzScene();
  mdr::v1::TabulatedProfile* profile = scene.mutable_tabulated();
  constexpr double kSampledTo = 5e-4;
  for (int i = 0; i < kHeavySamples; ++i) {
    const double r = kSampledTo * i / (kHeavySamples - 1);
    profile->add_radii(r);
    profile->add_heights(r * r / (2 * kSphereRadius) * (1 + 1e-3 * std::sin(20 * r / kSampledTo)));
  }
  return scene;
}

mdr::v1::Scene HeavyGridScene() {
  mdr::v1::Scene scene = HertzScene();
  scene.set_method(mdr::v1::METHOD_GRID);
  scene.mutable_grid()->set_size(kHeavyGridSprings);
  scene.mutable_grid()->set_max_radius(1e-3);
  return scene;
}

mdr::v1::Scene CurvedPathScene() {
  mdr::v1::Scene scene = HertzScene();
  scene.mutable_options()->set_force_path_tolerance(1e-9);
  return scene;
}

std::unique_ptr<grpc::ClientContext> DeadlineContext(std::chrono::seconds timeout) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + timeout);
  return context;
}

std::string CreateOrFail(mdr::v1::ContactService::Stub& stub, const mdr::v1::Scene& scene) {
  mdr::v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = scene;
  mdr::v1::Session session;
  const grpc::Status status =
      stub.CreateSession(DeadlineContext(kHeavyTimeout).get(), request, &session);
  if (!status.ok()) Fail("CreateSession: " + status.error_message());
  return session.name();
}

// One client's heavy calls, by kind (client % 3), until `stop`; returns the calls completed.
int RunHeavyCalls(mdr::v1::ContactService::Stub& stub, int client, const std::atomic<bool>& stop) {
  const mdr::v1::Scene tabulated = HeavyTabulatedScene();
  std::string session;
  ApplyRequest batch;
  if (client % 3 == 1) {
    session = CreateOrFail(stub, HeavyGridScene());
    for (int i = 0; i < kHeavyGridSteps; ++i) {
      batch.add_steps()->set_depth(3e-6 * (1 + 0.1 * (i % 2)));
    }
  } else if (client % 3 == 2) {
    session = CreateOrFail(stub, CurvedPathScene());
    // Normal force and displacement change together: a curved path in (delta, ux).
    mdr::v1::Step* load = batch.add_steps();
    load->set_normal_force(kNormalForce);
    load->set_displacement(0);
    mdr::v1::Step* curved = batch.add_steps();
    curved->set_normal_force(2 * kNormalForce);
    curved->set_displacement(1e-7);
  }
  batch.set_session(session);
  int completed = 0;
  while (!stop) {
    grpc::Status status;
    if (client % 3 == 0) {
      mdr::v1::CreateSessionRequest request;
      *request.mutable_session()->mutable_scene() = tabulated;
      mdr::v1::Session created;
      status = stub.CreateSession(DeadlineContext(kHeavyTimeout).get(), request, &created);
      if (status.ok()) {
        mdr::v1::DeleteSessionRequest erase;
        erase.set_name(created.name());
        google::protobuf::Empty empty;
        stub.DeleteSession(DeadlineContext(kHeavyTimeout).get(), erase, &empty);
      }
    } else {
      ApplyResponse response;
      status = stub.Apply(DeadlineContext(kHeavyTimeout).get(), batch, &response);
    }
    if (!status.ok()) Fail("heavy call: " + status.error_message());
    ++completed;
  }
  return completed;
}

// One client's StreamApply of one-step cycling messages on its own loaded H1 session, at most
// kInlineWindow in flight, until `stop`: every message is one the server may apply inline
// (docs/operations.md, "Inline steps"). Returns the messages answered.
constexpr int kInlineWindow = 32;
struct InlineStreamSession {
  std::string name;
  double depth = 0;
};
// Created before the heavy calls start (they would hold the workers a creation needs).
InlineStreamSession CreateInlineStreamSession(int port) {
  mdr::client::ContactClient client(ConnectLoopback(port), kCallTimeout);
  InlineStreamSession session;
  session.name = CreateLoadedSession(client, HertzScene(), &session.depth).name;
  return session;
}
long RunInlineStream(int port, const InlineStreamSession& session, const std::atomic<bool>& stop) {
  const CyclingSteps steps(kCycleAmplitude * kFriction * HertzKappa() * session.depth);
  auto stub = mdr::v1::ContactService::NewStub(ConnectLoopback(port));
  grpc::ClientContext context;
  auto stream = stub->StreamApply(&context);
  std::counting_semaphore<kInlineWindow> window(kInlineWindow);
  std::atomic<long> answered{0};
  std::thread reader([&] {
    mdr::v1::StreamApplyResponse response;
    while (stream->Read(&response)) {
      if (response.status().code() != 0) Fail("inline stream: " + response.status().message());
      ++answered;
      window.release();
    }
  });
  mdr::v1::StreamApplyRequest message;
  message.mutable_apply()->set_session(session.name);
  for (int phase = 0; !stop; phase = (phase + 1) % kCyclePeriod) {
    window.acquire();
    *message.mutable_apply()->mutable_steps() = steps.Batch(1, phase);
    if (!stream->Write(message)) break;
  }
  stream->WritesDone();
  reader.join();
  if (const grpc::Status status = stream->Finish(); !status.ok()) {
    Fail("inline stream: " + status.error_message());
  }
  return answered;
}

// --inline-streams-child PORT COUNT: COUNT streams of inline messages at SCHED_IDLE (a client on
// its own machine: on this one its threads would otherwise compete with the server for the
// cores, which is no server's doing). Prints "ready" once the sessions exist and the streams
// run, streams until its stdin ends, then prints the messages answered.
int RunInlineStreamsChild(int port, int count, bool compete) {
  sched_param parameter{};
  if (!compete && sched_setscheduler(0, SCHED_IDLE, &parameter) != 0) {
    Fail("sched_setscheduler(SCHED_IDLE)");
  }
  std::vector<InlineStreamSession> sessions;
  for (int i = 0; i < count; ++i) sessions.push_back(CreateInlineStreamSession(port));
  std::atomic<bool> stop{false};
  std::atomic<long> answered{0};
  std::vector<std::thread> streams;
  for (int i = 0; i < count; ++i) {
    streams.emplace_back([&, i] { answered += RunInlineStream(port, sessions[i], stop); });
  }
  std::printf("ready\n");
  std::fflush(stdout);
  char byte = 0;
  while (read(STDIN_FILENO, &byte, 1) > 0) {
  }
  stop = true;
  for (std::thread& stream : streams) stream.join();
  std::printf("%ld\n", answered.load());
  return EXIT_SUCCESS;
}

// The parent's side of RunInlineStreamsChild.
class InlineStreamsChild {
 public:
  InlineStreamsChild(int port, int count, bool compete) {
    const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
    std::vector<std::string> command = {self, "--inline-streams-child", std::to_string(port),
                                        std::to_string(count)};
    if (compete) command.push_back("--inline-clients-compete");
    try {
      pid_ = mdr::bench::Spawn(command, &output_, &input_);
    } catch (const std::runtime_error& error) {
      Fail(error.what());
    }
    if (ReadLine() != "ready") Fail("the inline streams did not start");
  }
  // Ends the streams; the messages they had answered.
  long Stop() {
    close(input_);
    const std::string answered = ReadLine();
    int status = 0;
    waitpid(pid_, &status, 0);
    close(output_);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) Fail("the inline streams failed");
    return std::stol(answered);
  }

 private:
  std::string ReadLine() {
    std::string line;
    char c = 0;
    while (read(output_, &c, 1) == 1 && c != '\n') line += c;
    return line;
  }

  pid_t pid_ = 0;
  int output_ = -1, input_ = -1;
};

struct ProbeFigures {
  std::vector<double> health_ms, get_session_ms;
  long inline_messages = 0;  // answered by the inline streams
};

double ProbeMillis(const std::function<grpc::Status(grpc::ClientContext*)>& call) {
  const Clock::time_point start = Clock::now();
  const grpc::Status status = call(DeadlineContext(std::chrono::seconds(30)).get());
  if (!status.ok()) Fail("probe: " + status.error_message());
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// grpc.health.v1.Health/Check through a generic stub (an empty request: the server's status).
grpc::Status HealthCheck(grpc::GenericStub& stub, grpc::ClientContext* context) {
  grpc::Slice empty_message("");  // HealthCheckRequest{} encodes to no bytes
  grpc::ByteBuffer request(&empty_message, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  return done.get_future().get();
}

// heavy_clients clients of heavy calls and inline_streams streams of inline messages at once.
ProbeFigures ProbeUnderHeavyLoad(int port, int heavy_clients, int inline_streams, bool compete,
                                 double seconds) {
  std::vector<std::unique_ptr<mdr::v1::ContactService::Stub>> stubs;
  for (int i = 0; i < heavy_clients; ++i) {
    stubs.push_back(mdr::v1::ContactService::NewStub(ConnectLoopback(port)));
  }
  auto probe_channel = ConnectLoopback(port);
  auto probe_stub = mdr::v1::ContactService::NewStub(probe_channel);
  grpc::GenericStub health(probe_channel);
  mdr::v1::GetSessionRequest get;
  get.set_name(CreateOrFail(*probe_stub, HertzScene()));

  std::optional<InlineStreamsChild> streams;
  if (inline_streams > 0) streams.emplace(port, inline_streams, compete);  // sessions created
  std::atomic<bool> stop{false};
  std::vector<std::thread> clients;
  for (int i = 0; i < heavy_clients; ++i) {
    clients.emplace_back([&, i] { RunHeavyCalls(*stubs[i], i, stop); });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the heavy calls are running
  ProbeFigures figures;
  const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(seconds));
  while (Clock::now() < end) {
    figures.health_ms.push_back(
        ProbeMillis([&](grpc::ClientContext* c) { return HealthCheck(health, c); }));
    figures.get_session_ms.push_back(ProbeMillis([&](grpc::ClientContext* c) {
      mdr::v1::Session session;
      return probe_stub->GetSession(c, get, &session);
    }));
    std::this_thread::sleep_for(kProbePeriod);
  }
  stop = true;
  for (std::thread& client : clients) client.join();
  if (streams) figures.inline_messages = streams->Stop();
  return figures;
}

void PrintProbe(int heavy_clients, int inline_streams, const char* what,
                std::vector<double> millis) {
  std::sort(millis.begin(), millis.end());
  std::printf(
      "%2d heavy calls, %2d inline streams  %-10s  n=%4zu  p50 %8.3f ms  p99 %8.3f ms  max "
      "%8.3f ms\n",
      heavy_clients, inline_streams, what, millis.size(), Percentile(millis, 0.5),
      Percentile(millis, 0.99), millis.back());
}

// Steps per second of 1000-step cycling batches (energy on), one client per session.
double BatchThroughput(int port, int sessions, double seconds, const CyclingSteps& steps) {
  std::vector<mdr::client::ContactClient> clients;
  std::vector<std::string> names;
  for (int i = 0; i < sessions; ++i) {
    clients.emplace_back(ConnectLoopback(port), kCallTimeout);
    mdr::v1::Scene scene = HertzScene();
    scene.mutable_options()->set_track_energy(true);
    auto session = clients.back().CreateSession(scene);
    if (!session.ok()) Fail("CreateSession: " + session.status().error_message());
    Steps load;
    load.Add()->set_normal_force(kNormalForce);
    if (!clients.back().Apply(session->name(), load).ok()) Fail("Apply F_N");
    names.push_back(session->name());
  }
  std::atomic<long> total_steps{0};
  const Clock::time_point start = Clock::now();
  const Clock::time_point end =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::vector<std::thread> threads;
  for (int i = 0; i < sessions; ++i) {
    threads.emplace_back([&, i] {
      while (Clock::now() < end) {
        const CallOutcome outcome = ClientApply(clients[i], names[i], steps.Batch(1000, 0));
        if (!outcome.status.ok()) Fail("Apply: " + outcome.status.error_message());
        total_steps += 1000;
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  return total_steps / std::chrono::duration<double>(Clock::now() - start).count();
}

void RunExecutionScenarios(double seconds, std::size_t max_inline_vertices, bool clients_compete) {
  mdr::service::ServerOptions options;
  options.listen_address = "127.0.0.1:0";
  options.limits.max_inline_vertices = max_inline_vertices;
  options.limits.max_message_bytes = 64 << 20;  // grids of 2^20 springs must stay exportable
  grpc::EnableDefaultHealthCheckService(true);
  auto server = mdr::service::ContactServer::Start(options);
  if (!server.ok()) Fail(server.status().ToString());
  const int port = (*server)->port();
  std::printf(
      "mdr_load --execution: %u hardware threads, workers = one per core; heavy calls: "
      "tabulated create (%d samples), grid batch (%d steps, %u springs), curved force "
      "path; probes every %lld ms for %g s\n",
      std::thread::hardware_concurrency(), kHeavySamples, kHeavyGridSteps, kHeavyGridSprings,
      static_cast<long long>(kProbePeriod.count()), seconds);
  // Heavy calls alone, then with streams of inline messages in the mix (issue #25: a message
  // the server applies on the transport's thread must not starve the health checks either).
  for (const auto& [heavy_clients, inline_streams] :
       std::array<std::pair<int, int>, 4>{{{4, 0}, {16, 0}, {4, 8}, {16, 32}}}) {
    ProbeFigures figures =
        ProbeUnderHeavyLoad(port, heavy_clients, inline_streams, clients_compete, seconds);
    PrintProbe(heavy_clients, inline_streams, "health", std::move(figures.health_ms));
    PrintProbe(heavy_clients, inline_streams, "GetSession", std::move(figures.get_session_ms));
    if (inline_streams > 0) {
      std::printf("%2d heavy calls, %2d inline streams  inline messages answered: %.0f/s\n",
                  heavy_clients, inline_streams,
                  static_cast<double>(figures.inline_messages) / seconds);
    }
  }
  // The cycling amplitude of H1 (as CreateWorkload computes it).
  mdr::client::ContactClient setup(ConnectLoopback(port), kCallTimeout);
  double depth = 0;
  CreateLoadedSession(setup, HertzScene(), &depth);
  const CyclingSteps steps(kCycleAmplitude * kFriction * HertzKappa() * depth);
  const double one = BatchThroughput(port, 1, seconds, steps);
  const double two = BatchThroughput(port, 2, seconds, steps);
  std::printf(
      "1000-step batches, energy on: 1 session %.0f steps/s, 2 sessions %.0f steps/s, "
      "ratio %.2f\n",
      one, two, two / one);
  (*server)->Shutdown(std::chrono::system_clock::now());
}

LoadSettings ParseSettings(int argc, char** argv) {
  LoadSettings settings;
  CLI::App app{"mdr_load: ContactService load test against an echo baseline on loopback"};
  app.add_option("--seconds", settings.seconds,
                 "wall time of each side (apply, echo) of a scenario, over all its rounds")
      ->check(CLI::Range(0.05, 2.0));
  app.add_option("--rounds", settings.rounds, "alternating apply/echo rounds per scenario")
      ->check(CLI::Range(1, 10));
  app.add_option("--window", settings.window, "stream messages in flight per stream")
      ->check(CLI::Range(1, 1024));
  app.add_option("--json", settings.json_path, "write every figure to this JSON file");
  app.add_option("--energy", settings.track_energy,
                 "scene.options.track_energy of the sessions (true: the default scene; false "
                 "shows the service's own cost per step beside a cheaper engine step)");
  app.add_option("--only", settings.only,
                 "run only the scenarios whose \"<scenario>/sessions:<n>/\" contains this text, "
                 "e.g. \"apply batch 1000/sessions:1/\" or \"sessions:1/\"");
  app.add_flag("--execution", settings.execution,
               "instead: health/GetSession latency under 4 and 16 heavy calls, and 1000-step "
               "batch throughput on 1 against 2 sessions");
  app.add_option("--execution-seconds", settings.execution_seconds,
                 "wall time of each --execution measurement")
      ->check(CLI::Range(0.5, 60.0));
  app.add_option("--inline-streams-child", settings.inline_streams_child,
                 "(internal) PORT COUNT: streams of inline messages for --execution")
      ->expected(2)
      ->group("");
  app.add_flag("--inline-clients-compete", settings.inline_clients_compete,
               "--execution: the client of the inline streams at normal priority, competing for "
               "this machine's cores with the server (default: SCHED_IDLE, as if on its own)");
  app.add_option("--max-inline-vertices", settings.max_inline_vertices,
                 "the server's --max-inline-vertices (0: every batch on the workers)")
      ->check(CLI::Range(std::size_t{0}, mdr::service::kMaxInlineVertices));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    std::exit(app.exit(error));
  }
  return settings;
}

std::vector<ScenarioResult> RunScenarios(LoadRun& run, const std::string& only) {
  std::vector<ScenarioResult> results;
  const auto run_selected = [&](const std::string& scenario, int sessions,
                                const std::function<ScenarioResult()>& measure) {
    if ((FigureName(scenario, sessions) + '/').find(only) == std::string::npos) return;
    results.push_back(measure());
    PrintRow(results.back());
  };
  PrintTableHeader();
  for (const int sessions : kSessionCounts) {
    for (const int batch : kBatchSizes) {
      run_selected(UnaryScenario(batch), sessions, [&] { return run.UnaryBatch(sessions, batch); });
    }
    run_selected(run.StreamScenario(), sessions, [&] { return run.Stream(sessions); });
  }
  std::printf(
      "ratio: apply steps/s / echo steps/s; * server compute per step "
      "(ApplyResponse.compute_seconds); ** engine inline steps/s / echo steps/s (the ceiling); "
      "*** context switches and CPU time (user and system) of the whole process (clients and "
      "servers) per call or message: apply/echo[/engine inline]\n");
  return results;
}

}  // namespace

int main(int argc, char** argv) {
  const LoadSettings settings = ParseSettings(argc, argv);
  spdlog::set_level(spdlog::level::warn);  // the in-process server logs every session at info
  if (settings.inline_streams_child.size() == 2) {
    return RunInlineStreamsChild(settings.inline_streams_child[0], settings.inline_streams_child[1],
                                 settings.inline_clients_compete);
  }
  if (settings.execution) {
    RunExecutionScenarios(settings.execution_seconds, settings.max_inline_vertices,
                          settings.inline_clients_compete);
    return EXIT_SUCCESS;
  }
  const Clock::time_point begin = Clock::now();

  mdr::service::ServerOptions options;
  options.listen_address = "127.0.0.1:0";
  options.limits.max_inline_vertices = settings.max_inline_vertices;
  auto contact_server = mdr::service::ContactServer::Start(options);
  if (!contact_server.ok()) Fail(contact_server.status().ToString());
  const int contact_port = (*contact_server)->port();

  mdr::client::ContactClient setup_client(ConnectLoopback(contact_port), kCallTimeout);
  Workload workload = CreateWorkload(setup_client, kSessionCounts.back(), settings.track_energy);
  const CyclingSteps steps(workload.amplitude);
  const ApplyResponse canned = OneCyclingStep(setup_client, workload.sessions[0], steps);

  EngineContacts engine(workload.sessions, settings.track_energy);
  mdr::bench::EchoService echo_service(
      canned, [&engine](const ApplyRequest& request) { engine.Apply(request); });
  int echo_port = 0;
  std::unique_ptr<grpc::Server> echo_server = StartEchoServer(echo_service, &echo_port);
  LoadTargets targets = ConnectClients(contact_port, echo_port);

  PrintPreamble(workload, settings, contact_port, echo_port);
  LoadRun run(targets, workload, steps, settings);
  run.WarmUp();
  const std::vector<ScenarioResult> results = RunScenarios(run, settings.only);
  PrintSessionCheck(setup_client, workload.sessions[0]);
  std::printf("total %.1f s\n", std::chrono::duration<double>(Clock::now() - begin).count());

  if (!settings.json_path.empty()) {
    WriteJson(settings.json_path, {{"tool", "mdr_load"},
                                   {"context", ContextJson(workload, settings, canned)},
                                   {"figures", FiguresJson(results)}});
  }
  echo_server->Shutdown(std::chrono::system_clock::now());
  (*contact_server)->Shutdown(std::chrono::system_clock::now());
  return EXIT_SUCCESS;
}
