#include "options.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>

namespace mdrd {

std::optional<int> ParseOptions(int argc, char** argv, Options* options) {
  CLI::App app{
      "mdrd: tangential contact sessions (Method of Dimensionality Reduction) over gRPC.\n"
      "Every flag can also be set by the environment variable shown with it; the flag wins."};
  mdr::service::ServerOptions& server = options->server;
  mdr::service::ServiceLimits& limits = server.limits;
  double idle_timeout_seconds = std::chrono::duration<double>(limits.session_idle_timeout).count();

  app.add_option("--listen", server.listen_address, "Address to listen on (host:port; port 0: any)")
      ->envname("MDR_LISTEN")
      ->capture_default_str();
  app.add_option("--log-level", options->log_level,
                 "trace, debug (one line per call), info, warn, error, critical or off")
      ->envname("MDR_LOG_LEVEL")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--max-sessions", limits.max_sessions,
                 "Sessions held at most (RESOURCE_EXHAUSTED beyond)")
      ->envname("MDR_MAX_SESSIONS")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-steps-per-batch", limits.max_steps_per_batch,
                 "Steps per Apply request or StreamApply message at most")
      ->envname("MDR_MAX_STEPS_PER_BATCH")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-memory-vertices", limits.max_memory_vertices,
                 "Largest scene.options.max_memory_vertices a session may use (>= 8)")
      ->envname("MDR_MAX_MEMORY_VERTICES")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{8}, std::size_t{1} << 30));
  app.add_option("--session-idle-timeout", idle_timeout_seconds,
                 "Seconds after which an unused session is deleted (0: never)")
      ->envname("MDR_SESSION_IDLE_TIMEOUT")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-message-bytes", limits.max_message_bytes,
                 "Largest request or response message (RESOURCE_EXHAUSTED beyond)")
      ->envname("MDR_MAX_MESSAGE_BYTES")
      ->capture_default_str()
      ->check(CLI::Range(1024, 1 << 30));
  app.add_option("--shutdown-grace", options->shutdown_grace_seconds,
                 "Seconds running calls get to finish after SIGTERM/SIGINT")
      ->envname("MDR_SHUTDOWN_GRACE")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  }
  limits.session_idle_timeout = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(idle_timeout_seconds));
  return std::nullopt;
}

void LogEffectiveOptions(const Options& options) {
  const mdr::service::ServiceLimits& limits = options.server.limits;
  spdlog::info(
      "event=config listen={} log_level={} max_sessions={} max_steps_per_batch={} "
      "max_memory_vertices={} session_idle_timeout_s={} max_message_bytes={} "
      "shutdown_grace_s={}",
      options.server.listen_address, options.log_level, limits.max_sessions,
      limits.max_steps_per_batch, limits.max_memory_vertices,
      std::chrono::duration<double>(limits.session_idle_timeout).count(), limits.max_message_bytes,
      options.shutdown_grace_seconds);
}

}  // namespace mdrd
