#include "mdr/service/server.h"

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <spdlog/spdlog.h>

#include <algorithm>

namespace mdr::service {
namespace {

// Often enough that an idle session is gone soon after its timeout (lookups already treat it
// as gone), rarely enough to cost nothing.
std::chrono::milliseconds SweepPeriod(std::chrono::milliseconds idle_timeout) {
  return std::clamp(idle_timeout / 4, std::chrono::milliseconds(10),
                    std::chrono::milliseconds(1000));
}

}  // namespace

ContactServer::ContactServer(const ServerOptions& options)
    : operations_(options.limits, options.test_hooks), service_(operations_) {}

Result<std::unique_ptr<ContactServer>> ContactServer::Start(const ServerOptions& options) {
  if (Status s = ValidateServiceLimits(options.limits); !s.ok()) return s;
  std::unique_ptr<ContactServer> server(new ContactServer(options));
  grpc::ServerBuilder builder;
  if (!options.listen_address.empty()) {
    builder.AddListeningPort(options.listen_address, grpc::InsecureServerCredentials(),
                             &server->port_);
  }
  builder.SetMaxReceiveMessageSize(options.limits.max_message_bytes);
  builder.SetMaxSendMessageSize(options.limits.max_message_bytes);
  builder.RegisterService(&server->service_);
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || (!options.listen_address.empty() && server->port_ == 0)) {
    return FailedPrecondition("listen", "cannot listen on \"" + options.listen_address +
                                            "\" (malformed address or port in use)");
  }
  if (options.limits.session_idle_timeout.count() > 0) {
    const auto period = SweepPeriod(options.limits.session_idle_timeout);
    ContactServer* self = server.get();
    server->sweeper_ = std::jthread(
        [self, period](std::stop_token stop) { self->SweepExpiredSessions(stop, period); });
  }
  return server;
}

ContactServer::~ContactServer() {
  if (server_ != nullptr && !shut_down_) Shutdown(std::chrono::system_clock::now());
}

std::shared_ptr<grpc::Channel> ContactServer::InProcessChannel() {
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  return server_->InProcessChannel(arguments);
}

void ContactServer::Shutdown(std::chrono::system_clock::time_point deadline) {
  service_.DrainStreams();
  server_->Shutdown(deadline);
  server_->Wait();
  sweeper_.request_stop();
  if (sweeper_.joinable()) sweeper_.join();
  shut_down_ = true;
}

void ContactServer::SweepExpiredSessions(std::stop_token stop, std::chrono::milliseconds period) {
  std::unique_lock lock(sweeper_mutex_);
  while (!sweeper_wakeup_.wait_for(lock, stop, period, [] { return false; })) {
    if (stop.stop_requested()) return;
    for (const std::string& name : operations_.EraseExpiredSessions()) {
      spdlog::info("event=session_expired session={}", name);
    }
  }
}

}  // namespace mdr::service
