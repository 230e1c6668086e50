// Builds and starts a gRPC server for ContactService; shared by mdrd, mdrctl's embedded mode and
// the tests. Owns the operations (sessions and their journal), the authenticator, the service,
// the idle-session sweeper and the drain.
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/server.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "mdr/base/status.h"
#include "mdr/service/auth.h"
#include "mdr/service/contact_service.h"
#include "mdr/service/executor.h"
#include "mdr/service/journal.h"
#include "mdr/service/limits.h"
#include "mdr/service/metrics_endpoint.h"
#include "mdr/service/operations.h"

namespace mdr::service {

// PEM files; all empty: plaintext.
struct TlsOptions {
  // The server's certificate chain and private key (both or neither).
  std::string cert_file;
  std::string key_file;
  // CA certificates that client certificates must chain to; set: mutual TLS (a client without a
  // valid certificate is refused). Needs cert_file.
  std::string client_ca_file;
};

struct ServerOptions {
  // "host:port" to listen on (port 0: pick a free one); empty: in-process channels only.
  std::string listen_address;
  ServiceLimits limits;
  // path empty: sessions are not journaled.
  JournalOptions journal;
  TlsOptions tls;
  // "name:token" lines (Authenticator); empty: no authentication.
  std::string tokens_file;
  // The worker pool of the computing calls and its queue bound (contact_service.h).
  ExecutorOptions execution;
  // "host:port" of the Prometheus metrics over HTTP (port 0: pick a free one); empty: none.
  std::string metrics_listen_address;
  TestHooks test_hooks;
};

// Process-wide, once at the start of a serving process (mdrd; the tools that measure its memory):
// every freed allocation of 128 KiB or more goes back to the system at once. By default glibc
// raises its mmap and trim thresholds after the first large frees (up to 32 and 64 MB), and the
// buffers of several MB that an interface's creation and steps free then stay resident in the
// workers' arenas: about 70 bytes per asperity beyond what a session of 10^6 asperities holds
// (docs/interfaces.md, "Memory layout").
void ReturnLargeFreesToTheSystem();

class ContactServer {
 public:
  // Health checking and reflection are process-wide switches
  // (grpc::EnableDefaultHealthCheckService, InitProtoReflectionServerBuilderPlugin) that the caller
  // sets before Start when wanted. Start itself turns off abseil's debug deadlock detector for
  // the whole process (Debian's abseil is built without NDEBUG): it ran on every absl::Mutex that
  // gRPC locks, behind a process-wide lock, and aborted the process on a lock-order cycle.
  static Result<std::unique_ptr<ContactServer>> Start(const ServerOptions& options);

  ContactServer(const ContactServer&) = delete;
  ContactServer& operator=(const ContactServer&) = delete;
  ~ContactServer();

  // The bound port (the one picked for port 0); 0 without a listen address.
  int port() const { return port_; }
  // The bound port of the metrics endpoint; 0 without one.
  int metrics_port() const { return metrics_ ? metrics_->port() : 0; }
  std::shared_ptr<grpc::Channel> InProcessChannel();
  grpc::Server& server() { return *server_; }
  std::size_t session_count() const { return operations_.session_count(); }
  std::size_t open_streams() const { return service_.open_streams(); }
  // Computing calls waiting for a worker now.
  std::size_t queued_calls() const { return executor_.queued(); }
  // Computing calls waiting or running now. A worker's call answers its client before the
  // worker lets go of the session: a client's next call may find it busy for a moment.
  std::size_t busy_calls() const { return executor_.busy(); }

  // Graceful stop: open StreamApply streams finish (UNAVAILABLE, after answering the message they
  // are working on), new calls are refused, running and queued calls get until the deadline; then
  // every call still running is interrupted (its work abandoned, nothing changed: CANCELLED) and
  // the workers stop; then every journaled session is compacted to a snapshot.
  void Shutdown(std::chrono::system_clock::time_point deadline);

 private:
  ContactServer(const ServerOptions& options, std::optional<Authenticator> authenticator);
  // Sets the gauges sampled at scrape time (sessions held, queued calls).
  void RefreshMetrics() const;
  // Deletes idle sessions every `period` until stopped.
  void SweepExpiredSessions(std::stop_token stop, std::chrono::milliseconds period);

  ContactOperations operations_;
  const std::optional<Authenticator> authenticator_;
  // Set when the drain's grace period ends: interrupts every running computation.
  std::atomic<bool> stopping_{false};
  Executor executor_;  // before service_, which queues on it
  ContactServiceImpl service_;
  std::unique_ptr<grpc::Server> server_;
  std::mutex sweeper_mutex_;
  std::condition_variable_any sweeper_wakeup_;
  std::jthread sweeper_;
  int port_ = 0;
  bool shut_down_ = false;
  // Last: destroyed first, as its scrapes read the members above.
  std::unique_ptr<MetricsEndpoint> metrics_;
};

}  // namespace mdr::service
