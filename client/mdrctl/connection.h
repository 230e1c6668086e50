// What every mdrctl subcommand shares: the connection to the service (--server, or a server
// started in this process), error reporting as "mdrctl: field: message", and reading files.
#pragma once

#include <grpcpp/support/status.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "mdr/base/status.h"
#include "mdr/client/contact_client.h"
#include "mdr/service/server.h"

namespace mdrctl {

// Prints "mdrctl: message" on stderr; returns EXIT_FAILURE.
int Fail(const std::string& message);
int Fail(const grpc::Status& status);
int Fail(const mdr::Status& status);

// The message limit of the server mdrctl starts in its own process: it guards no other caller,
// so it holds the largest request the service takes, an analysis of 10^7 samples of four
// columns (320 MB), where mdrd's default (4 MiB) stops at about 130 000 samples.
inline constexpr int kEmbeddedMaxMessageBytes = 512 << 20;

// A request the server refused at its transport for its size (gRPC's "Received message larger
// than max"), said in the command line's terms: `what` (the file), the request's size, and the
// mdrd flag that bounds it. nullopt for any other status.
std::optional<mdr::Status> RequestTooLarge(const grpc::Status& status, const std::string& what,
                                           std::size_t request_bytes);

// A client of --server, or of a server started in this process.
class Connection {
 public:
  static mdr::Result<std::unique_ptr<Connection>> Open(const Common& common);
  mdr::client::ContactClient& client() { return *client_; }

 private:
  Connection() = default;
  std::unique_ptr<mdr::service::ContactServer> embedded_;
  std::unique_ptr<mdr::client::ContactClient> client_;
};

// The whole file; INVALID_ARGUMENT "path: cannot open" if it cannot be read.
mdr::Result<std::string> ReadFile(const std::string& path);

}  // namespace mdrctl
