// StreamApply throughput against a no-op echo stream of the same message shapes, measured in the
// same run (runs vary by tens of percent, the ratio much less):
//   build/release/tests/bench/mdr_service_bench [--messages N] [--rounds R]
// Each message carries one displacement-increment step on one session; the server applies it
// and answers with the state. "pipelined": the client writes ahead while it reads; "one in
// flight": it writes the next message only after the previous answer arrived.
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "echo_service.h"
#include "mdr/service/server.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace {

using Request = mdr::v1::StreamApplyRequest;
using Response = mdr::v1::StreamApplyResponse;

using StreamOpener = std::function<std::unique_ptr<grpc::ClientReaderWriter<Request, Response>>(
    grpc::ClientContext*)>;

// Messages per second through one stream.
double Measure(const StreamOpener& open, const Request& message, int messages, bool pipelined) {
  grpc::ClientContext context;
  auto stream = open(&context);
  Response answer;
  const auto start = std::chrono::steady_clock::now();
  if (pipelined) {
    std::thread writer([&] {
      for (int i = 0; i < messages; ++i) stream->Write(message);
      stream->WritesDone();
    });
    int answered = 0;
    while (stream->Read(&answer)) ++answered;
    writer.join();
    if (answered != messages) std::fprintf(stderr, "only %d answers\n", answered);
  } else {
    for (int i = 0; i < messages; ++i) {
      stream->Write(message);
      if (!stream->Read(&answer)) break;
    }
    stream->WritesDone();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const grpc::Status status = stream->Finish();
  if (!status.ok() || answer.status().code() != 0) {
    std::fprintf(stderr, "stream failed: %s %s\n", status.error_message().c_str(),
                 answer.status().message().c_str());
    std::exit(EXIT_FAILURE);
  }
  return messages / seconds;
}

int Flag(int argc, char** argv, const char* name, int fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], name) == 0) return std::atoi(argv[i + 1]);
  }
  return fallback;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int messages = Flag(argc, argv, "--messages", 20000);
  const int rounds = Flag(argc, argv, "--rounds", 5);

  mdr::service::ServerOptions options;
  options.listen_address = "127.0.0.1:0";
  auto contact_server = mdr::service::ContactServer::Start(options);
  if (!contact_server.ok()) return EXIT_FAILURE;
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string((*contact_server)->port()),
                                     grpc::InsecureChannelCredentials());
  auto contact = mdr::v1::ContactService::NewStub(channel);

  // H1 contact at F_N = 100 N; the steps move it back and forth by 1e-10 m, well inside stick.
  mdr::v1::CreateSessionRequest create;
  mdr::v1::Scene* scene = create.mutable_session()->mutable_scene();
  scene->mutable_sphere()->set_radius(0.01);
  scene->mutable_elastic_pair()->set_youngs_modulus_1(210e9);
  scene->mutable_elastic_pair()->set_poisson_ratio_1(0.3);
  scene->mutable_elastic_pair()->set_youngs_modulus_2(210e9);
  scene->mutable_elastic_pair()->set_poisson_ratio_2(0.3);
  scene->set_friction(0.3);
  mdr::v1::Session session;
  grpc::ClientContext create_context;
  if (!contact->CreateSession(&create_context, create, &session).ok()) return EXIT_FAILURE;
  mdr::v1::ApplyRequest load;
  load.set_session(session.name());
  load.add_steps()->set_normal_force(100);
  mdr::v1::ApplyResponse loaded;
  grpc::ClientContext load_context;
  if (!contact->Apply(&load_context, load, &loaded).ok()) return EXIT_FAILURE;

  Request forward, backward;
  forward.mutable_apply()->set_session(session.name());
  forward.mutable_apply()->add_steps()->set_displacement_increment(1e-10);
  backward = forward;
  backward.mutable_apply()->mutable_steps(0)->set_displacement_increment(-1e-10);

  // The echo answers with a real response of this session.
  mdr::bench::EchoService echo_service(loaded);
  Response canned;  // what the echo answers each message with, for the size printed below
  canned.mutable_status();
  *canned.mutable_result() = loaded;
  grpc::ServerBuilder builder;
  int echo_port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &echo_port);
  builder.RegisterService(&echo_service);
  std::unique_ptr<grpc::Server> echo_server = builder.BuildAndStart();
  auto echo = mdr::bench::Echo::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(echo_port), grpc::InsecureChannelCredentials()));

  const StreamOpener apply_stream = [&](grpc::ClientContext* c) { return contact->StreamApply(c); };
  const StreamOpener echo_stream = [&](grpc::ClientContext* c) { return echo->EchoStream(c); };
  std::printf(
      "StreamApply vs echo, %d messages per run, median of %d rounds; message %zu B, "
      "response %zu B\n",
      messages, rounds, forward.ByteSizeLong(), canned.ByteSizeLong());
  std::printf("%-14s %14s %14s %10s\n", "mode", "apply msg/s", "echo msg/s", "apply/echo");
  for (const bool pipelined : {true, false}) {
    const int count = pipelined ? messages : messages / 4;
    std::vector<double> apply_rates, echo_rates;
    for (int round = 0; round < rounds; ++round) {  // interleaved, so drifts hit both alike
      apply_rates.push_back(
          Measure(apply_stream, round % 2 ? backward : forward, count, pipelined));
      echo_rates.push_back(Measure(echo_stream, forward, count, pipelined));
    }
    const double apply_rate = Median(apply_rates), echo_rate = Median(echo_rates);
    std::printf("%-14s %14.0f %14.0f %10.2f\n", pipelined ? "pipelined" : "one in flight",
                apply_rate, echo_rate, apply_rate / echo_rate);
  }
  echo_server->Shutdown(std::chrono::system_clock::now());
  (*contact_server)->Shutdown(std::chrono::system_clock::now());
  return EXIT_SUCCESS;
}
