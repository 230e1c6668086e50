// Channels to mdrd: plaintext, or TLS from PEM files, optionally with a bearer token sent as
// "authorization: Bearer <token>" metadata by call credentials on every call.
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/security/credentials.h>

#include <memory>
#include <string>

#include "mdr/client/rpc_result.h"

namespace mdr::client {

struct ChannelOptions {
  // "host:port".
  std::string address{};
  // Use TLS. Implied by any of the PEM files below.
  bool tls = false;
  // PEM file of the root certificates that sign the server's certificate; empty: the system's.
  std::string root_certificates_file{};
  // PEM files of a client certificate and its private key for mutual TLS; both or neither.
  std::string client_certificate_file{};
  std::string client_key_file{};
  // Bearer token sent on every call; needs TLS (gRPC never sends call credentials in plaintext).
  std::string bearer_token{};
};

// Call credentials that add "authorization: Bearer <token>" to every call.
std::shared_ptr<grpc::CallCredentials> BearerTokenCredentials(const std::string& token);

// The channel credentials the options describe; INVALID_ARGUMENT naming the option for an
// unreadable file, a certificate without its key, or a token without TLS.
RpcResult<std::shared_ptr<grpc::ChannelCredentials>> MakeCredentials(const ChannelOptions& options);

// A channel to options.address with MakeCredentials(options), taking responses of any size (the
// server's --max-message-bytes bounds them).
RpcResult<std::shared_ptr<grpc::Channel>> MakeChannel(const ChannelOptions& options);

}  // namespace mdr::client
