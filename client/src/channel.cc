#include "mdr/client/channel.h"

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include <fstream>
#include <map>
#include <sstream>

namespace mdr::client {
namespace {

grpc::Status InvalidOption(const std::string& option, const std::string& message) {
  return {grpc::StatusCode::INVALID_ARGUMENT, option + ": " + message};
}

// The file's contents; empty path: empty.
RpcResult<std::string> ReadPem(const std::string& option, const std::string& path) {
  if (path.empty()) return std::string();
  std::ifstream in(path);
  if (!in) return InvalidOption(option, "cannot open " + path);
  std::stringstream pem;
  pem << in.rdbuf();
  return pem.str();
}

class BearerTokenPlugin : public grpc::MetadataCredentialsPlugin {
 public:
  explicit BearerTokenPlugin(std::string token) : header_("Bearer " + std::move(token)) {}
  grpc::Status GetMetadata(grpc::string_ref /*service_url*/, grpc::string_ref /*method_name*/,
                           const grpc::AuthContext& /*channel_auth_context*/,
                           std::multimap<grpc::string, grpc::string>* metadata) override {
    metadata->emplace("authorization", header_);
    return grpc::Status::OK;
  }

 private:
  std::string header_;
};

}  // namespace

std::shared_ptr<grpc::CallCredentials> BearerTokenCredentials(const std::string& token) {
  return grpc::MetadataCredentialsFromPlugin(std::make_unique<BearerTokenPlugin>(token));
}

RpcResult<std::shared_ptr<grpc::ChannelCredentials>> MakeCredentials(
    const ChannelOptions& options) {
  const bool tls = options.tls || !options.root_certificates_file.empty() ||
                   !options.client_certificate_file.empty() || !options.client_key_file.empty();
  if (!tls) {
    if (!options.bearer_token.empty()) {
      return InvalidOption("bearer_token",
                           "needs TLS (gRPC sends no call credentials in plaintext)");
    }
    return grpc::InsecureChannelCredentials();
  }
  if (options.client_certificate_file.empty() != options.client_key_file.empty()) {
    return InvalidOption("client_certificate_file",
                         "a client certificate needs its key (client_key_file) and vice versa");
  }
  grpc::SslCredentialsOptions ssl;
  auto roots = ReadPem("root_certificates_file", options.root_certificates_file);
  auto certificate = ReadPem("client_certificate_file", options.client_certificate_file);
  auto key = ReadPem("client_key_file", options.client_key_file);
  for (const auto* pem : {&roots, &certificate, &key}) {
    if (!pem->ok()) return pem->status();
  }
  ssl.pem_root_certs = *roots;
  ssl.pem_cert_chain = *certificate;
  ssl.pem_private_key = *key;
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::SslCredentials(ssl);
  if (!options.bearer_token.empty()) {
    credentials = grpc::CompositeChannelCredentials(credentials,
                                                    BearerTokenCredentials(options.bearer_token));
  }
  return credentials;
}

RpcResult<std::shared_ptr<grpc::Channel>> MakeChannel(const ChannelOptions& options) {
  if (options.address.empty()) return InvalidOption("address", "must not be empty");
  auto credentials = MakeCredentials(options);
  if (!credentials.ok()) return credentials.status();
  // The server's --max-message-bytes bounds what it sends; gRPC's client default (4 MiB) would
  // refuse an export or a traction profile the server was configured to send.
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  return grpc::CreateCustomChannel(options.address, *credentials, arguments);
}

}  // namespace mdr::client
