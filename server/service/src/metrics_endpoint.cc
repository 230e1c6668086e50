#include "mdr/service/metrics_endpoint.h"

#include <httplib.h>

#include <atomic>
#include <charconv>
#include <chrono>

#include "mdr/service/metrics.h"

namespace mdr::service {
namespace {

// Scrapes are rare and cheap: two threads are plenty.
constexpr std::size_t kHttpThreads = 2;

// host and port of "host:port" ("[v6]:port" too); false when malformed.
bool SplitAddress(const std::string& address, std::string* host, int* port) {
  const std::size_t colon = address.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == address.size()) return false;
  const char* first = address.data() + colon + 1;
  const char* last = address.data() + address.size();
  auto [end, error] = std::from_chars(first, last, *port);
  if (error != std::errc() || end != last || *port < 0 || *port > 65535) return false;
  *host = address.substr(0, colon);
  if (host->size() >= 2 && host->front() == '[' && host->back() == ']') {
    *host = host->substr(1, host->size() - 2);
  }
  return !host->empty();
}

}  // namespace

MetricsEndpoint::MetricsEndpoint() : http_(std::make_unique<httplib::Server>()) {}

Result<std::unique_ptr<MetricsEndpoint>> MetricsEndpoint::Start(const std::string& address,
                                                                std::function<void()> refresh) {
  std::string host;
  int port = 0;
  if (!SplitAddress(address, &host, &port)) {
    return InvalidArgument(
        "metrics-listen",
        "must be host:port with a port in [0, 65535] (0: any), got \"" + address + "\"");
  }
  std::unique_ptr<MetricsEndpoint> endpoint(new MetricsEndpoint());
  httplib::Server& http = *endpoint->http_;
  http.new_task_queue = [] { return new httplib::ThreadPool(kHttpThreads); };
  http.Get("/metrics", [refresh = std::move(refresh)](const httplib::Request&,
                                                      httplib::Response& response) {
    if (refresh) refresh();
    response.set_content(ProcessMetrics().Render(), "text/plain; version=0.0.4; charset=utf-8");
  });
  endpoint->port_ =
      port == 0 ? http.bind_to_any_port(host) : (http.bind_to_port(host, port) ? port : -1);
  if (endpoint->port_ <= 0) {
    return FailedPrecondition(
        "metrics-listen", "cannot listen on \"" + address + "\" (malformed host or port in use)");
  }
  auto ended = std::make_shared<std::atomic<bool>>(false);
  endpoint->listener_ = std::thread([&http, ended] {
    http.listen_after_bind();
    *ended = true;
  });
  // stop() is a no-op until the loop runs: wait for it, so the destructor always ends it.
  while (!http.is_running() && !*ended) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  if (*ended) return FailedPrecondition("metrics-listen", "cannot serve on \"" + address + "\"");
  return endpoint;
}

MetricsEndpoint::~MetricsEndpoint() {
  http_->stop();
  if (listener_.joinable()) listener_.join();
}

}  // namespace mdr::service
