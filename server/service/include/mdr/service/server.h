// Builds and starts a gRPC server for ContactService; shared by mdrd and mdrctl's embedded mode.
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/server.h>

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>

#include "mdr/core/status.h"
#include "mdr/service/contact_service.h"

namespace mdr::service {

struct ServerOptions {
  // "host:port" to listen on (port 0: pick a free one); empty: in-process channels only.
  std::string listen_address;
  // Sessions held at most; CreateSession beyond it fails with RESOURCE_EXHAUSTED.
  std::size_t max_sessions = 10000;
};

class ContactServer {
 public:
  // Health checking and reflection are process-wide switches
  // (grpc::EnableDefaultHealthCheckService, InitProtoReflectionServerBuilderPlugin) that the caller
  // sets before Start when wanted.
  static Result<std::unique_ptr<ContactServer>> Start(const ServerOptions& options);

  ContactServer(const ContactServer&) = delete;
  ContactServer& operator=(const ContactServer&) = delete;
  ~ContactServer();

  // The bound port (the one picked for port 0); 0 without a listen address.
  int port() const { return port_; }
  std::shared_ptr<grpc::Channel> InProcessChannel();
  grpc::Server& server() { return *server_; }
  // Refuses new calls, lets running ones finish until the deadline, then cancels the rest.
  void Shutdown(std::chrono::system_clock::time_point deadline);

 private:
  explicit ContactServer(std::size_t max_sessions) : service_(max_sessions) {}

  ContactServiceImpl service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace mdr::service
