// mdrd: serves mdr.v1.ContactService with health checking and reflection until SIGTERM/SIGINT.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <string>

#include "mdr/service/server.h"

namespace {

constexpr char kServiceName[] = "mdr.v1.ContactService";

// Self-pipe: the handler only writes one byte (async-signal-safe); main blocks reading it.
int signal_pipe[2] = {-1, -1};

extern "C" void OnTerminationSignal(int signal_number) {
  const char byte = static_cast<char>(signal_number);
  [[maybe_unused]] ssize_t written = write(signal_pipe[1], &byte, 1);
}

bool InstallSignalHandlers() {
  if (pipe(signal_pipe) != 0) return false;
  struct sigaction action = {};
  action.sa_handler = OnTerminationSignal;
  sigemptyset(&action.sa_mask);
  return sigaction(SIGTERM, &action, nullptr) == 0 && sigaction(SIGINT, &action, nullptr) == 0;
}

int WaitForTerminationSignal() {
  char byte = 0;
  while (read(signal_pipe[0], &byte, 1) < 0 && errno == EINTR) {
  }
  return byte;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mdrd: tangential contact sessions (Method of Dimensionality Reduction) over gRPC"};
  mdr::service::ServerOptions options{.listen_address = "0.0.0.0:50051"};
  std::string log_level = "info";
  double shutdown_grace_seconds = 5;
  app.add_option("--listen", options.listen_address, "Address to listen on (host:port)")
      ->capture_default_str();
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical or off")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--max-sessions", options.max_sessions, "Sessions held at most")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--shutdown-grace", shutdown_grace_seconds,
                 "Seconds running calls get to finish after SIGTERM/SIGINT")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::from_str(log_level));

  if (!InstallSignalHandlers()) {
    spdlog::critical("cannot install signal handlers");
    return EXIT_FAILURE;
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  auto server = mdr::service::ContactServer::Start(options);
  if (!server.ok()) {
    spdlog::critical("{}", server.status().ToString());
    return EXIT_FAILURE;
  }
  grpc::HealthCheckServiceInterface* health = (*server)->server().GetHealthCheckService();
  health->SetServingStatus(kServiceName, true);
  spdlog::info("mdrd serving {} on port {}", kServiceName, (*server)->port());

  const int signal_number = WaitForTerminationSignal();
  spdlog::info("signal {}: draining for up to {} s", signal_number, shutdown_grace_seconds);
  // NOT_SERVING first, so health-checking load balancers stop sending new sessions here.
  health->SetServingStatus(kServiceName, false);
  const auto grace = std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::duration<double>(shutdown_grace_seconds));
  (*server)->Shutdown(std::chrono::system_clock::now() + grace);
  spdlog::info("mdrd stopped");
  return EXIT_SUCCESS;
}
