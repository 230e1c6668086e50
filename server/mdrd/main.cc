// mdrd: serves mdr.v1.ContactService with health checking and reflection until SIGTERM/SIGINT,
// then drains: readiness NOT_SERVING, open streams told to finish, Shutdown(grace deadline).
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>

#include "options.h"

namespace {

constexpr char kServiceName[] = "mdr.v1.ContactService";
// Health name that turns NOT_SERVING as soon as a drain starts (readiness probes).
constexpr char kReadiness[] = "readiness";

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
  // Beyond a file-size limit (RLIMIT_FSIZE) a write then fails with EFBIG, which the journal
  // answers UNAVAILABLE, instead of SIGXFSZ killing the process.
  if (std::signal(SIGXFSZ, SIG_IGN) == SIG_ERR) return false;
  return sigaction(SIGTERM, &action, nullptr) == 0 && sigaction(SIGINT, &action, nullptr) == 0;
}

int WaitForTerminationSignal() {
  char byte = 0;
  while (read(signal_pipe[0], &byte, 1) < 0 && errno == EINTR) {
  }
  return byte;
}

void SetServing(grpc::HealthCheckServiceInterface* health, bool serving) {
  health->SetServingStatus(kServiceName, serving);
  health->SetServingStatus(kReadiness, serving);
}

}  // namespace

int main(int argc, char** argv) {
  mdrd::Options options;
  if (auto exit_code = mdrd::ParseOptions(argc, argv, &options)) return *exit_code;
  mdr::service::ReturnLargeFreesToTheSystem();
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  spdlog::set_pattern("ts=%Y-%m-%dT%H:%M:%S.%e%z level=%l %v");
  mdrd::LogEffectiveOptions(options);

  if (!InstallSignalHandlers()) {
    spdlog::critical("event=error error=\"cannot install signal handlers\"");
    return EXIT_FAILURE;
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  auto server = mdr::service::ContactServer::Start(options.server);
  if (!server.ok()) {
    spdlog::critical("event=error error=\"{}\"", server.status().ToString());
    return EXIT_FAILURE;
  }
  grpc::HealthCheckServiceInterface* health = (*server)->server().GetHealthCheckService();
  SetServing(health, true);
  spdlog::info("event=serving service={} port={}", kServiceName, (*server)->port());
  if ((*server)->metrics_port() != 0) {
    spdlog::info("event=metrics_serving path=/metrics port={}", (*server)->metrics_port());
  }

  const int signal_number = WaitForTerminationSignal();
  spdlog::info("event=draining signal={} grace_s={} sessions={} streams={}", signal_number,
               options.shutdown_grace_seconds, (*server)->session_count(),
               (*server)->open_streams());
  // NOT_SERVING first, so health-checking load balancers stop sending new work here.
  SetServing(health, false);
  const auto grace = std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::duration<double>(options.shutdown_grace_seconds));
  (*server)->Shutdown(std::chrono::system_clock::now() + grace);
  spdlog::info("event=stopped");
  return EXIT_SUCCESS;
}
