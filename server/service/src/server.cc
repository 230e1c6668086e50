#include "mdr/service/server.h"

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace mdr::service {
namespace {

Result<std::string> ReadPemFile(const std::string& flag, const std::string& path) {
  std::ifstream file(path);
  std::ostringstream text;
  if (file) text << file.rdbuf();
  if (!file || text.str().empty()) {
    return FailedPrecondition(flag, "cannot read \"" + path + "\" (a PEM file)");
  }
  return text.str();
}

// Plaintext without certificate files, else TLS, with client certificates required and verified
// when a client CA is given. Errors name the flag.
Result<std::shared_ptr<grpc::ServerCredentials>> ServerCredentials(const TlsOptions& tls) {
  if (tls.cert_file.empty() && tls.key_file.empty() && tls.client_ca_file.empty()) {
    return grpc::InsecureServerCredentials();
  }
  if (tls.cert_file.empty() || tls.key_file.empty()) {
    return InvalidArgument(tls.cert_file.empty() ? "tls-cert" : "tls-key",
                           "--tls-cert and --tls-key go together (--tls-client-ca needs both)");
  }
  Result<std::string> cert = ReadPemFile("tls-cert", tls.cert_file);
  if (!cert.ok()) return cert.status();
  Result<std::string> key = ReadPemFile("tls-key", tls.key_file);
  if (!key.ok()) return key.status();
  grpc::SslServerCredentialsOptions options(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  options.pem_key_cert_pairs.push_back({*key, *cert});
  if (!tls.client_ca_file.empty()) {
    Result<std::string> client_ca = ReadPemFile("tls-client-ca", tls.client_ca_file);
    if (!client_ca.ok()) return client_ca.status();
    options.pem_root_certs = *client_ca;
    options.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(options);
}

// A grpc::Status of the set-up (journal) as the core Status Start returns.
Status SetupError(const grpc::Status& status) {
  return FailedPrecondition("", status.error_message());
}

// Often enough that an idle session is gone soon after its timeout (lookups already treat it
// as gone), rarely enough to cost nothing.
std::chrono::milliseconds SweepPeriod(std::chrono::milliseconds idle_timeout) {
  return std::clamp(idle_timeout / 4, std::chrono::milliseconds(10),
                    std::chrono::milliseconds(1000));
}

}  // namespace

ContactServer::ContactServer(const ServerOptions& options,
                             std::optional<Authenticator> authenticator)
    : operations_(options.limits, options.test_hooks),
      authenticator_(std::move(authenticator)),
      executor_(options.execution),
      service_(operations_, authenticator_ ? &*authenticator_ : nullptr, executor_, stopping_) {}

Result<std::unique_ptr<ContactServer>> ContactServer::Start(const ServerOptions& options) {
  if (Status s = ValidateServiceLimits(options.limits); !s.ok()) return s;
  if (Status s = ValidateExecutorOptions(options.execution); !s.ok()) return s;
  Result<std::shared_ptr<grpc::ServerCredentials>> credentials = ServerCredentials(options.tls);
  if (!credentials.ok()) return credentials.status();
  std::optional<Authenticator> authenticator;
  if (!options.tokens_file.empty()) {
    Result<Authenticator> loaded = Authenticator::FromFile(options.tokens_file);
    if (!loaded.ok()) return loaded.status();
    authenticator = std::move(loaded).value();
  }
  std::unique_ptr<ContactServer> server(new ContactServer(options, std::move(authenticator)));
  if (!options.journal.path.empty()) {
    if (options.journal.snapshot_every < 1) {
      return InvalidArgument("journal-snapshot-every", "must be >= 1, got 0");
    }
    if (grpc::Status status = server->operations_.OpenJournal(options.journal); !status.ok()) {
      return SetupError(status);
    }
  }
  grpc::ServerBuilder builder;
  if (!options.listen_address.empty()) {
    builder.AddListeningPort(options.listen_address, *credentials, &server->port_);
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
  // gRPC cancels the calls still running at the deadline, but only the stopping flag reaches the
  // work they queued: set it then, so Shutdown returns soon after the deadline.
  std::jthread interrupter([this, deadline](std::stop_token stop) {
    std::mutex mutex;
    std::condition_variable_any wakeup;
    std::unique_lock lock(mutex);
    wakeup.wait_until(lock, stop, deadline, [] { return false; });
    if (!stop.stop_requested()) stopping_ = true;
  });
  server_->Shutdown(deadline);
  server_->Wait();
  interrupter.request_stop();
  interrupter.join();
  executor_.Stop();
  sweeper_.request_stop();
  if (sweeper_.joinable()) sweeper_.join();
  operations_.CompactJournal();
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
