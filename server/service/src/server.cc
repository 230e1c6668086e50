#include "mdr/service/server.h"

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

namespace mdr::service {

Result<std::unique_ptr<ContactServer>> ContactServer::Start(const ServerOptions& options) {
  if (options.max_sessions == 0) {
    return InvalidArgument("max_sessions", "must be >= 1, got 0");
  }
  std::unique_ptr<ContactServer> server(new ContactServer(options.max_sessions));
  grpc::ServerBuilder builder;
  if (!options.listen_address.empty()) {
    builder.AddListeningPort(options.listen_address, grpc::InsecureServerCredentials(),
                             &server->port_);
  }
  builder.RegisterService(&server->service_);
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || (!options.listen_address.empty() && server->port_ == 0)) {
    return FailedPrecondition("listen", "cannot listen on \"" + options.listen_address +
                                            "\" (malformed address or port in use)");
  }
  return server;
}

ContactServer::~ContactServer() {
  if (server_ != nullptr && !shut_down_) Shutdown(std::chrono::system_clock::now());
}

std::shared_ptr<grpc::Channel> ContactServer::InProcessChannel() {
  return server_->InProcessChannel(grpc::ChannelArguments());
}

void ContactServer::Shutdown(std::chrono::system_clock::time_point deadline) {
  server_->Shutdown(deadline);
  server_->Wait();
  shut_down_ = true;
}

}  // namespace mdr::service
