// The Prometheus metrics of a real server: a metrics endpoint on a free port, calls through the
// stub, and the exposition fetched over HTTP and parsed. Counters are process-wide, so every
// assertion compares a scrape after the calls with one before them.
#include "mdr/service/metrics.h"

#include <unistd.h>

#include <cstdio>
#include <map>
#include <sstream>
#include <thread>

#include "service_test_util.h"
// After Eigen (through the test utilities): a macro of its OpenSSL headers breaks Eigen's.
#include <httplib.h>

namespace mdr::service_testing {
namespace {

// "name{labels}" -> value of every sample line; the HELP and TYPE lines by metric name.
struct Exposition {
  std::map<std::string, double> samples;
  std::map<std::string, std::string> help;
  std::map<std::string, std::string> type;

  double Value(const std::string& series) const {
    auto it = samples.find(series);
    return it == samples.end() ? 0 : it->second;
  }
};

Exposition Parse(const std::string& text) {
  Exposition parsed;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty()) continue;
    std::istringstream fields(line);
    if (line.starts_with("# HELP ") || line.starts_with("# TYPE ")) {
      std::string hash, kind, name, rest;
      fields >> hash >> kind >> name;
      std::getline(fields, rest);
      (kind == "HELP" ? parsed.help : parsed.type)[name] = rest.substr(1);
      continue;
    }
    const std::size_t space = line.rfind(' ');
    parsed.samples[line.substr(0, space)] = std::stod(line.substr(space + 1));
  }
  return parsed;
}

class MetricsTest : public ServiceTest {
 protected:
  void SetUp() override {
    service::ServerOptions options = LocalServerOptions();
    options.metrics_listen_address = "127.0.0.1:0";
    Restart(options);
    ASSERT_GT(server_->metrics_port(), 0);
  }

  httplib::Result Get(const std::string& path) {
    httplib::Client client("127.0.0.1", server_->metrics_port());
    return client.Get(path.c_str());
  }

  Exposition Scrape() {
    httplib::Result result = Get("/metrics");
    EXPECT_TRUE(result) << httplib::to_string(result.error());
    if (!result) return {};
    EXPECT_EQ(result->status, 200);
    EXPECT_THAT(result->get_header_value("Content-Type"),
                ::testing::StartsWith("text/plain; version=0.0.4"));
    return Parse(result->body);
  }
};

TEST_F(MetricsTest, CountsCallsByMethodAndCode) {
  const Exposition before = Scrape();
  for (const std::string id : {"m-one", "m-two", "m-three"}) CreateOrDie(id);
  v1::Session session;
  v1::Scene bad = SteelSphereOnSteelFlat();
  bad.mutable_sphere()->set_radius(-1);
  EXPECT_EQ(Create(bad, &session).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply("sessions/m-one", {DepthStep(kDepth), DisplacementStep(1e-7)}, &applied).ok());
  EXPECT_EQ(Apply("sessions/m-missing", {DepthStep(kDepth)}, &applied).error_code(),
            grpc::StatusCode::NOT_FOUND);
  const Exposition after = Scrape();

  auto moved = [&](const std::string& series) {
    return after.Value(series) - before.Value(series);
  };
  EXPECT_EQ(moved(R"(mdr_rpc_calls_total{method="CreateSession",code="OK"})"), 3);
  EXPECT_EQ(moved(R"(mdr_rpc_calls_total{method="CreateSession",code="INVALID_ARGUMENT"})"), 1);
  EXPECT_EQ(moved(R"(mdr_rpc_calls_total{method="Apply",code="OK"})"), 1);
  EXPECT_EQ(moved(R"(mdr_rpc_calls_total{method="Apply",code="NOT_FOUND"})"), 1);
  EXPECT_EQ(moved(R"(mdr_rpc_duration_seconds_count{method="CreateSession"})"), 4);
  EXPECT_EQ(moved(R"(mdr_rpc_duration_seconds_count{method="Apply"})"), 2);
  EXPECT_EQ(moved("mdr_steps_applied_total"), 2);
  EXPECT_EQ(after.Value("mdr_sessions"), 3);
  EXPECT_EQ(after.Value("mdr_work_queue_depth"), 0);
  EXPECT_EQ(moved("mdr_work_rejected_total"), 0);
  EXPECT_GT(after.Value("mdr_start_time_seconds"), 1.6e9);
}

TEST_F(MetricsTest, TimesEveryJournalWrite) {
  const std::string journal =
      ::testing::TempDir() + "mdr-metrics-journal-" + std::to_string(::getpid()) + ".sqlite";
  service::ServerOptions options = LocalServerOptions();
  options.metrics_listen_address = "127.0.0.1:0";
  options.journal.path = journal;
  Restart(options);
  const Exposition before = Scrape();
  const std::string session = CreateOrDie("j-one");  // one transaction: the new session
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(session, {DepthStep(kDepth)}, &applied).ok());  // one: the batch
  const Exposition after = Scrape();
  EXPECT_EQ(after.Value("mdr_journal_write_seconds_count") -
                before.Value("mdr_journal_write_seconds_count"),
            2);
  EXPECT_EQ(after.Value("mdr_journal_write_failures_total") -
                before.Value("mdr_journal_write_failures_total"),
            0);
  stub_.reset();
  server_.reset();
  for (const char* suffix : {"", "-wal", "-shm", ".commit"})
    std::remove((journal + suffix).c_str());
}

TEST_F(MetricsTest, HistogramsAreConsistent) {
  CreateOrDie("h-one");
  const Exposition scraped = Scrape();
  for (const std::string series :
       {R"(mdr_rpc_duration_seconds{method="CreateSession")", "mdr_journal_write_seconds{"}) {
    const std::string name = series.substr(0, series.find('{'));
    std::string labels = series.substr(series.find('{') + 1);
    if (!labels.empty()) labels += ',';
    // Cumulative counts by upper bound ("+Inf" reads as infinity).
    std::map<double, double> buckets;
    const std::string bucket_prefix = name + "_bucket{" + labels + "le=\"";
    for (const auto& [key, value] : scraped.samples) {
      if (key.starts_with(bucket_prefix))
        buckets[std::stod(key.substr(bucket_prefix.size()))] = value;
    }
    EXPECT_EQ(buckets.size(), 17u) << name;  // 100 us ... 10 s, and +Inf
    double previous = 0;
    for (const auto& [bound, value] : buckets) {
      EXPECT_GE(value, previous) << name << " le=" << bound;
      previous = value;
    }
    const std::string suffix =
        labels.empty() ? "" : "{" + labels.substr(0, labels.size() - 1) + "}";
    const double count = scraped.Value(name + "_count" + suffix);
    EXPECT_EQ(scraped.Value(name + "_bucket{" + labels + "le=\"+Inf\"}"), count) << name;
    EXPECT_EQ(previous, count) << name;
  }
  EXPECT_GE(scraped.Value(R"(mdr_rpc_duration_seconds_count{method="CreateSession"})"), 1);
}

TEST_F(MetricsTest, EveryMetricHasHelpAndType) {
  const Exposition scraped = Scrape();
  const std::map<std::string, std::string> expected = {
      {"mdr_rpc_calls_total", "counter"},
      {"mdr_rpc_duration_seconds", "histogram"},
      {"mdr_sessions", "gauge"},
      {"mdr_steps_applied_total", "counter"},
      {"mdr_work_queue_depth", "gauge"},
      {"mdr_work_rejected_total", "counter"},
      {"mdr_stream_read_pauses_total", "counter"},
      {"mdr_inline_batches_total", "counter"},
      {"mdr_journal_write_seconds", "histogram"},
      {"mdr_journal_write_failures_total", "counter"},
      {"mdr_start_time_seconds", "gauge"}};
  for (const auto& [name, type] : expected) {
    EXPECT_EQ(scraped.type.count(name), 1u) << name;
    EXPECT_EQ(scraped.type.at(name), type) << name;
    EXPECT_FALSE(scraped.help.at(name).empty()) << name;
  }
}

TEST_F(MetricsTest, OtherPathsAreNotFound) {
  for (const std::string path : {"/", "/metric", "/metrics/x", "/healthz"}) {
    httplib::Result result = Get(path);
    ASSERT_TRUE(result) << path;
    EXPECT_EQ(result->status, 404) << path;
  }
  httplib::Client client("127.0.0.1", server_->metrics_port());
  httplib::Result posted = client.Post("/metrics", "x", "text/plain");
  ASSERT_TRUE(posted);
  EXPECT_EQ(posted->status, 404);
}

TEST(MetricsEndpointTest, RejectsMalformedAddress) {
  for (const std::string address :
       {"no-port", "127.0.0.1:", ":80", "127.0.0.1:65536", "127.0.0.1:x"}) {
    service::ServerOptions options = LocalServerOptions();
    options.metrics_listen_address = address;
    auto server = service::ContactServer::Start(options);
    ASSERT_FALSE(server.ok()) << address;
    EXPECT_EQ(server.status().field(), "metrics-listen") << address;
  }
}

TEST(MetricsRegistryTest, RendersLabelledCounterAndHistogram) {
  service::Family<service::Counter> counter("t_total", "A test counter.", {"method"});
  counter.With({"A"}).Increment(2);
  service::Family<service::Histogram> histogram("t_seconds", "A test histogram.", {}, {0.1, 1});
  histogram.With({}).Observe(0.05);
  histogram.With({}).Observe(0.5);
  histogram.With({}).Observe(5);
  std::string text;
  counter.Render(&text);
  histogram.Render(&text);
  EXPECT_EQ(text,
            "# HELP t_total A test counter.\n# TYPE t_total counter\nt_total{method=\"A\"} 2\n"
            "# HELP t_seconds A test histogram.\n# TYPE t_seconds histogram\n"
            "t_seconds_bucket{le=\"0.1\"} 1\nt_seconds_bucket{le=\"1\"} 2\n"
            "t_seconds_bucket{le=\"+Inf\"} 3\nt_seconds_sum 5.55\n"
            "t_seconds_count 3\n");
}

// Counters and histograms are striped per thread (metrics.h); reading sums every stripe, so
// recordings from more threads than stripes all count, and each bucket keeps its own count.
TEST(MetricsRegistryTest, StripedSeriesSumEveryThreadsRecordings) {
  constexpr int kThreads = 2 * static_cast<int>(service::kMetricStripes) + 3;
  constexpr int kPerThread = 1000;
  service::Counter counter;
  const std::vector<double> bounds = {0.1, 1};
  service::Histogram histogram(&bounds);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        counter.Increment(t + 1);
        histogram.Observe(i % 2 == 0 ? 0.5 : 4);  // exact in binary, so the sum is exact
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(counter.value(),
            static_cast<std::uint64_t>(kPerThread) * kThreads * (kThreads + 1) / 2);
  EXPECT_EQ(histogram.bucket(0), 0u);
  EXPECT_EQ(histogram.bucket(1), static_cast<std::uint64_t>(kThreads * kPerThread / 2));
  EXPECT_EQ(histogram.bucket(2), static_cast<std::uint64_t>(kThreads * kPerThread / 2));
  EXPECT_EQ(histogram.sum(), kThreads * kPerThread / 2 * 4.5);
}

// RecordCall keeps the series of the last few (method, code) pairs per thread; more pairs than
// it keeps, in turn, still count each call in its own series.
TEST(MetricsRegistryTest, RecordCallCountsEveryPairInItsOwnSeries) {
  static const char* const kMethods[] = {"TestA", "TestB", "TestC", "TestD", "TestE", "TestF"};
  static const char* const kCodes[] = {"OK", "NOT_FOUND"};
  service::Metrics& metrics = service::ProcessMetrics();
  auto calls = [&](const char* method, const char* code) {
    return metrics.rpc_calls.With({method, code}).value();
  };
  auto count = [&](const char* method) {
    const service::Histogram& histogram = metrics.rpc_duration_seconds.With({method});
    std::uint64_t total = 0;
    for (std::size_t i = 0; i <= histogram.bounds().size(); ++i) total += histogram.bucket(i);
    return total;
  };
  const std::uint64_t recorded = service::RecordedCalls();
  for (int round = 0; round < 3; ++round) {
    for (const char* method : kMethods) {
      for (const char* code : kCodes) service::RecordCall(method, code, 0.001);
      service::RecordCall(method, "OK", 0.001);
    }
  }
  for (const char* method : kMethods) {
    EXPECT_EQ(calls(method, "OK"), 6u) << method;
    EXPECT_EQ(calls(method, "NOT_FOUND"), 3u) << method;
    EXPECT_EQ(count(method), 9u) << method;
  }
  EXPECT_EQ(service::RecordedCalls() - recorded, 3u * 6 * 3);
}

}  // namespace
}  // namespace mdr::service_testing
