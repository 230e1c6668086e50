// mdrd's configuration: command-line flags, each with an MDR_* environment variable (a flag wins
// over its variable), documented defaults, and the startup log of the effective values.
#pragma once

#include <optional>
#include <string>

#include "mdr/service/server.h"

namespace mdrd {

inline mdr::service::ServerOptions DefaultServerOptions() {
  mdr::service::ServerOptions options;
  options.listen_address = "0.0.0.0:50051";
  options.journal.path = "mdr-journal.sqlite";  // in the working directory
  return options;
}

struct Options {
  mdr::service::ServerOptions server = DefaultServerOptions();
  std::string log_level = "info";
  // Seconds running calls get after SIGTERM/SIGINT before they are cancelled.
  double shutdown_grace_seconds = 5;
};

// Parses argv and the environment into *options. Returns an exit code when the program should
// end at once (--help, or an invalid value, which is reported on stderr).
std::optional<int> ParseOptions(int argc, char** argv, Options* options);

// One structured log line with every effective setting.
void LogEffectiveOptions(const Options& options);

}  // namespace mdrd
