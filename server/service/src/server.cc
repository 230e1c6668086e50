#include "mdr/service/server.h"

#include <absl/synchronization/mutex.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <malloc.h>
#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <vector>

#include "mdr/base/log_value.h"
#include "mdr/service/journal.h"
#include "mdr/service/metrics.h"
#include "mdr/service/pool_parallel_for.h"
#include "mdr/service/request_parse_errors.h"

namespace mdr::service {

void ReturnLargeFreesToTheSystem() {
  // Setting the threshold fixes it (and the trim threshold, 128 KiB by default): glibc then
  // maps every allocation of this size or more and unmaps it when it is freed.
  constexpr int kMmapThreshold = 128 * 1024;
  (void)mallopt(M_MMAP_THRESHOLD, kMmapThreshold);
}

namespace {

// As a release build of abseil (see ContactServer::Start).
void SkipMutexDeadlockDetection() {
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
}

Result<std::string> ReadPemFile(const std::string& flag, const std::string& path) {
  std::ifstream file(path);
  std::ostringstream text;
  if (file) text << file.rdbuf();
  if (!file || text.str().empty()) {
    return FailedPrecondition(flag, "cannot read \"" + path + "\" (a PEM file)");
  }
  return text.str();
}

// OpenSSL objects freed when they go out of scope.
using Bio = std::unique_ptr<BIO, decltype(&BIO_free)>;
using Certificate = std::unique_ptr<X509, decltype(&X509_free)>;
using PrivateKey = std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)>;

Bio MemoryBio(const std::string& pem) {
  return Bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())), &BIO_free);
}

// The PEM certificates in `pem`, in order; empty when the first block is missing or malformed.
std::vector<Certificate> ParseCertificates(const std::string& pem) {
  std::vector<Certificate> certificates;
  Bio bio = MemoryBio(pem);
  while (X509* certificate = PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr)) {
    certificates.emplace_back(certificate, &X509_free);
  }
  ERR_clear_error();  // the read that ended the loop
  return certificates;
}

// The files are checked here, so that a bad one is named at start-up instead of surfacing as a
// listen failure from gRPC: the chain and the CA bundle hold PEM certificates, the key is a PEM
// private key, and it is the key of the chain's first certificate.
Status CheckTlsFiles(const TlsOptions& tls, const std::string& cert_pem, const std::string& key_pem,
                     const std::string& client_ca_pem) {
  const std::vector<Certificate> chain = ParseCertificates(cert_pem);
  if (chain.empty()) {
    return FailedPrecondition("tls-cert", "\"" + tls.cert_file + "\" is not a PEM certificate");
  }
  // No passphrase: an encrypted key fails here instead of OpenSSL prompting on the terminal.
  pem_password_cb* no_passphrase = [](char*, int, int, void*) { return 0; };
  PrivateKey key(PEM_read_bio_PrivateKey(MemoryBio(key_pem).get(), nullptr, no_passphrase, nullptr),
                 &EVP_PKEY_free);
  ERR_clear_error();
  if (key == nullptr) {
    return FailedPrecondition(
        "tls-key", "\"" + tls.key_file + "\" is not a PEM private key (or is encrypted)");
  }
  if (X509_check_private_key(chain.front().get(), key.get()) != 1) {
    ERR_clear_error();
    return FailedPrecondition("tls-cert", "the certificate in \"" + tls.cert_file +
                                              "\" does not match --tls-key \"" + tls.key_file +
                                              "\"");
  }
  if (!tls.client_ca_file.empty() && ParseCertificates(client_ca_pem).empty()) {
    return FailedPrecondition("tls-client-ca",
                              "\"" + tls.client_ca_file + "\" is not a PEM certificate bundle");
  }
  return OkStatus();
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
  Result<std::string> client_ca = std::string();
  if (!tls.client_ca_file.empty()) client_ca = ReadPemFile("tls-client-ca", tls.client_ca_file);
  if (!client_ca.ok()) return client_ca.status();
  if (Status s = CheckTlsFiles(tls, *cert, *key, *client_ca); !s.ok()) return s;
  grpc::SslServerCredentialsOptions options(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  options.pem_key_cert_pairs.push_back({*key, *cert});
  if (!tls.client_ca_file.empty()) {
    options.pem_root_certs = *client_ca;
    options.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(options);
}

// An error of the set-up (journal) as the FAILED_PRECONDITION Start returns.
Status SetupError(const Status& status) { return FailedPrecondition("", status.ToString()); }

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
      service_(operations_, authenticator_ ? &*authenticator_ : nullptr, executor_, stopping_) {
  operations_.set_parallel(std::make_shared<PoolParallelFor>(executor_));
}

Result<std::unique_ptr<ContactServer>> ContactServer::Start(const ServerOptions& options) {
  SkipMutexDeadlockDetection();
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
    if (Status status = server->operations_.OpenJournal(options.journal); !status.ok()) {
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
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(UnparseableRequestInterceptorFactory());
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || (!options.listen_address.empty() && server->port_ == 0)) {
    // The TLS files were checked above; what gRPC may still refuse is named as a possibility.
    const bool tls = !options.tls.cert_file.empty();
    return FailedPrecondition("listen", "cannot listen on \"" + options.listen_address +
                                            (tls ? "\" (malformed address, port in use, or a TLS "
                                                   "setting gRPC refused: see its log above)"
                                                 : "\" (malformed address or port in use)"));
  }
  if (!options.metrics_listen_address.empty()) {
    const ContactServer* self = server.get();
    auto metrics =
        MetricsEndpoint::Start(options.metrics_listen_address, [self] { self->RefreshMetrics(); });
    if (!metrics.ok()) return metrics.status();
    server->metrics_ = std::move(metrics).value();
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
  // work they queued. It is set a little before the deadline (a quarter of the grace, at most
  // 250 ms): work that completes (a session created, a batch committed) does so early enough for
  // its answer to go out before gRPC cancels the call, and work still running then is
  // interrupted and changes nothing. So Shutdown returns soon after the deadline.
  const auto margin = std::min<std::chrono::system_clock::duration>(
      std::chrono::milliseconds(250),
      std::max<std::chrono::system_clock::duration>(deadline - std::chrono::system_clock::now(),
                                                    std::chrono::system_clock::duration::zero()) /
          4);
  std::jthread interrupter([this, stop_at = deadline - margin](std::stop_token stop) {
    std::mutex mutex;
    std::condition_variable_any wakeup;
    std::unique_lock lock(mutex);
    wakeup.wait_until(lock, stop, stop_at, [] { return false; });
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

void ContactServer::RefreshMetrics() const {
  Metrics& metrics = ProcessMetrics();
  metrics.sessions.Set(static_cast<std::int64_t>(session_count()));
  metrics.work_queue_depth.Set(static_cast<std::int64_t>(queued_calls()));
}

void ContactServer::SweepExpiredSessions(std::stop_token stop, std::chrono::milliseconds period) {
  std::unique_lock lock(sweeper_mutex_);
  while (!sweeper_wakeup_.wait_for(lock, stop, period, [] { return false; })) {
    if (stop.stop_requested()) return;
    for (const std::string& name : operations_.EraseExpiredSessions()) {
      spdlog::info("event=session_expired session={}", LogValue(name));
    }
  }
}

}  // namespace mdr::service
