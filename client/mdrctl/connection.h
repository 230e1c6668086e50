// What every mdrctl subcommand shares: the connection to the service (--server, or a server
// started in this process), error reporting as "mdrctl: field: message", and reading files.
#pragma once

#include <grpcpp/support/status.h>

#include <memory>
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
