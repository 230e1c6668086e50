// The HTTP endpoint of the metrics (mdrd --metrics-listen): GET /metrics answers
// ProcessMetrics() in the Prometheus text format 0.0.4; every other path is 404. Its own port and
// threads, so a scrape never waits behind gRPC work, and gRPC calls never wait on a scrape.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "mdr/base/status.h"

namespace httplib {
class Server;
}

namespace mdr::service {

class MetricsEndpoint {
 public:
  // Listens on address ("host:port"; port 0: any free one). refresh runs before every rendering
  // (the gauges sampled at scrape time). Errors name the field "metrics-listen".
  static Result<std::unique_ptr<MetricsEndpoint>> Start(const std::string& address,
                                                        std::function<void()> refresh);

  MetricsEndpoint(const MetricsEndpoint&) = delete;
  MetricsEndpoint& operator=(const MetricsEndpoint&) = delete;
  // Stops listening and waits for the scrapes in progress.
  ~MetricsEndpoint();

  int port() const { return port_; }

 private:
  MetricsEndpoint();

  std::unique_ptr<httplib::Server> http_;
  std::thread listener_;
  int port_ = 0;
};

}  // namespace mdr::service
