#include "connection.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "mdr/client/channel.h"

namespace mdrctl {

int Fail(const std::string& message) {
  std::fprintf(stderr, "mdrctl: %s\n", message.c_str());
  return EXIT_FAILURE;
}
int Fail(const grpc::Status& status) { return Fail(status.error_message()); }
int Fail(const mdr::Status& status) { return Fail(status.ToString()); }

std::optional<mdr::Status> RequestTooLarge(const grpc::Status& status, const std::string& what,
                                           std::size_t request_bytes) {
  if (status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED ||
      !status.error_message().starts_with("Received message larger than max")) {
    return std::nullopt;
  }
  return mdr::InvalidArgument(
      what, "the request of " + std::to_string(request_bytes) +
                " bytes is larger than the server takes (" + status.error_message() +
                "): start mdrd with --max-message-bytes above it, or run mdrctl without --server");
}

mdr::Result<std::unique_ptr<Connection>> Connection::Open(const Common& common) {
  auto connection = std::unique_ptr<Connection>(new Connection());
  std::shared_ptr<grpc::Channel> channel;
  if (common.server.empty()) {
    mdr::service::ServerOptions options;
    options.limits.max_message_bytes = kEmbeddedMaxMessageBytes;
    auto started = mdr::service::ContactServer::Start(options);
    if (!started.ok()) return started.status();
    connection->embedded_ = std::move(started).value();
    channel = connection->embedded_->InProcessChannel();
  } else {
    auto made = mdr::client::MakeChannel({.address = common.server,
                                          .tls = common.tls,
                                          .root_certificates_file = common.root_certificates_file,
                                          .client_certificate_file = common.client_certificate_file,
                                          .client_key_file = common.client_key_file,
                                          .bearer_token = common.token});
    if (!made.ok()) return mdr::InvalidArgument("", made.status().error_message());
    channel = *made;
  }
  const auto timeout = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(common.timeout_seconds));
  connection->client_ = std::make_unique<mdr::client::ContactClient>(
      channel, mdr::client::ClientOptions{.timeout = timeout});
  return connection;
}

mdr::Result<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return mdr::InvalidArgument(path, "cannot open");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace mdrctl
