// mdrd's Prometheus metrics: a small process-wide registry of counters, gauges and histograms
// with fixed label names, rendered in the text exposition format 0.0.4. Recording is lock-free
// (atomics); a labelled series is found under a shared lock and created once under an exclusive
// one. Label values come from fixed sets (method names, status code names), never from clients.
// Counters and histograms are recorded on every call (StreamApply: every message) by whichever
// thread answers it, so each is striped: a thread records into its own stripe (a cache line of
// its own), and reading sums the stripes; threads recording the same series then do not pass one
// cache line between cores on every call.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <shared_mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mdr::service {

// Stripes per series; threads take them in turn, so up to this many threads record without
// sharing a cache line.
inline constexpr std::size_t kMetricStripes = 8;
inline constexpr std::size_t kCacheLineBytes = 64;
// The calling thread's stripe, in [0, kMetricStripes).
std::size_t MetricStripe();

// A value that only goes up (events, seconds).
class Counter {
 public:
  void Increment(std::uint64_t by = 1) {
    stripes_[MetricStripe()].value.fetch_add(by, std::memory_order_relaxed);
  }
  std::uint64_t value() const;

 private:
  struct alignas(kCacheLineBytes) Stripe {
    std::atomic<std::uint64_t> value{0};
  };
  std::array<Stripe, kMetricStripes> stripes_;
};

// A value that goes up and down (queue depth) or is set when scraped (sessions held).
class Gauge {
 public:
  void Add(std::int64_t delta) { value_.fetch_add(delta, std::memory_order_relaxed); }
  void Set(std::int64_t value) { value_.store(value, std::memory_order_relaxed); }
  std::int64_t value() const { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<std::int64_t> value_{0};
};

// Observations counted in fixed buckets (upper bounds, increasing); rendered cumulatively.
class Histogram {
 public:
  explicit Histogram(const std::vector<double>* bounds);
  void Observe(double value);
  const std::vector<double>& bounds() const { return *bounds_; }
  // Observations <= bounds()[i] alone (not cumulative); index bounds().size(): above every bound.
  std::uint64_t bucket(std::size_t i) const;
  double sum() const;

 private:
  // A stripe's counters: the buckets, then the sum (as a double's bits, added by compare and
  // exchange), then padding, so that no two stripes share a cache line.
  std::atomic<std::uint64_t>* Stripe(std::size_t stripe) const {
    return &counters_[stripe * stride_];
  }

  const std::vector<double>* const bounds_;
  const std::size_t stride_;
  std::unique_ptr<std::atomic<std::uint64_t>[]> counters_;
};

// Orders label value lists; transparent, so that a series is found from string views without
// building its key (recording a call allocates nothing).
struct LabelValuesLess {
  using is_transparent = void;
  template <typename A, typename B>
  bool operator()(const A& a, const B& b) const {
    return std::lexicographical_compare(
        a.begin(), a.end(), b.begin(), b.end(),
        [](std::string_view x, std::string_view y) { return x < y; });
  }
};

// Every series of one metric: one per combination of label values.
template <typename Series>
class Family {
 public:
  Family(std::string name, std::string help, std::vector<std::string> label_names,
         std::vector<double> bounds = {});
  // The series of these label values (as many as label names), created on first use.
  Series& With(std::initializer_list<std::string_view> label_values);
  // Appends the HELP and TYPE lines and every series, in label order.
  void Render(std::string* text) const;

 private:
  void RenderSeries(const std::string& labels, const Series& series, std::string* text) const;

  const std::string name_;
  const std::string help_;
  const std::vector<std::string> label_names_;
  const std::vector<double> bounds_;  // histograms only
  mutable std::shared_mutex mutex_;
  // guarded by mutex_
  std::map<std::vector<std::string>, std::unique_ptr<Series>, LabelValuesLess> series_;
};

// The metrics of this process (names and meaning: docs/operations.md, Metrics).
struct Metrics {
  Metrics();
  // The exposition text (Content-Type: text/plain; version=0.0.4).
  std::string Render() const;

  Family<Counter> rpc_calls;               // labels method, code
  Family<Histogram> rpc_duration_seconds;  // label method
  Family<Gauge> sessions_family;           // no labels (as the ones below)
  Family<Counter> steps_applied_family;
  Family<Gauge> work_queue_depth_family;
  Family<Counter> work_rejected_family;
  Family<Counter> stream_read_pauses_family;
  Family<Counter> inline_batches_family;
  Family<Histogram> journal_write_seconds_family;
  Family<Counter> journal_write_failures_family;
  Family<Gauge> journal_free_bytes_family;
  Family<Counter> journal_refusals_family;
  Family<Gauge> start_time_family;
  // The unlabelled series of the families above (constructed after them).
  Gauge& sessions;
  Counter& steps_applied;
  Gauge& work_queue_depth;
  Counter& work_rejected;
  Counter& stream_read_pauses;
  Counter& inline_batches;
  Histogram& journal_write_seconds;
  Counter& journal_write_failures;
  Gauge& journal_free_bytes;
  Counter& journal_refusals;
};

// The process-wide instance that the hooks record to.
Metrics& ProcessMetrics();

// Records one finished call (or StreamApply message): method is a fixed handler name and code a
// status code name, both with static storage (each thread keeps the series of the last few
// (method, code) pairs by address, so a repeated call takes no lock).
void RecordCall(const char* method, const char* code, double seconds);
// The calls and stream messages recorded so far (what gRPC's threads carried; stream_pacer.h).
std::uint64_t RecordedCalls();

// Observes the seconds from its construction to its destruction (a journal write).
class JournalWriteTimer {
 public:
  JournalWriteTimer();
  ~JournalWriteTimer();
  JournalWriteTimer(const JournalWriteTimer&) = delete;
  JournalWriteTimer& operator=(const JournalWriteTimer&) = delete;

 private:
  const std::int64_t start_nanoseconds_;
};

}  // namespace mdr::service
