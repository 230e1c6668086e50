#include "mdr/service/metrics.h"

#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>
#include <type_traits>

namespace mdr::service {
namespace {

// Set when the library is loaded: the process's start for mdr_start_time_seconds.
const std::int64_t kProcessStartSeconds = static_cast<std::int64_t>(std::time(nullptr));

// From 100 us (a cheap inline call) to 10 s (a long batch), about 2.5x apart.
const std::vector<double> kSecondsBuckets = {0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005,
                                             0.01,   0.025,   0.05,   0.1,   0.25,   0.5,
                                             1,      2.5,     5,      10};

std::string FormatNumber(double value) {
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  if (std::isnan(value)) return "NaN";
  // The shortest form that reads back exactly ("0.1", not "0.10000000000000001").
  char text[32];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(text, sizeof text, "%.*g", precision, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  return text;
}

// Backslash, double quote and line feed escaped, as the format requires.
std::string EscapeLabelValue(const std::string& value) {
  std::string escaped;
  for (char c : value) {
    if (c == '\\' || c == '"') escaped += '\\';
    if (c == '\n') {
      escaped += "\\n";
      continue;
    }
    escaped += c;
  }
  return escaped;
}

// `name="value",...` without braces; empty without labels.
std::string LabelPairs(const std::vector<std::string>& names,
                       const std::vector<std::string>& values) {
  std::string pairs;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) pairs += ',';
    pairs += names[i] + "=\"" + EscapeLabelValue(values[i]) + '"';
  }
  return pairs;
}

std::string Braced(const std::string& pairs) { return pairs.empty() ? "" : "{" + pairs + "}"; }

std::int64_t SteadyNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

template <typename Series>
const char* TypeName() {
  if constexpr (std::is_same_v<Series, Counter>) return "counter";
  if constexpr (std::is_same_v<Series, Gauge>) return "gauge";
  return "histogram";
}

constexpr std::size_t kCountersPerLine = kCacheLineBytes / sizeof(std::uint64_t);

// Buckets and sum of one stripe, then a full line of padding: whatever the array's alignment,
// the last counter of a stripe and the first of the next are a line apart.
std::size_t StripeStride(std::size_t buckets) {
  const std::size_t used = buckets + 1;
  return (used + kCountersPerLine - 1) / kCountersPerLine * kCountersPerLine + kCountersPerLine;
}

std::atomic<std::size_t> next_stripe{0};

}  // namespace

std::size_t MetricStripe() {
  thread_local const std::size_t stripe =
      next_stripe.fetch_add(1, std::memory_order_relaxed) % kMetricStripes;
  return stripe;
}

std::uint64_t Counter::value() const {
  std::uint64_t total = 0;
  for (const Stripe& stripe : stripes_) total += stripe.value.load(std::memory_order_relaxed);
  return total;
}

Histogram::Histogram(const std::vector<double>* bounds)
    : bounds_(bounds),
      stride_(StripeStride(bounds->size() + 1)),
      counters_(new std::atomic<std::uint64_t>[kMetricStripes * stride_]) {
  // All zero bits: counts of 0, and sums of 0.0.
  for (std::size_t i = 0; i < kMetricStripes * stride_; ++i) counters_[i].store(0);
}

void Histogram::Observe(double value) {
  std::size_t i = 0;
  while (i < bounds_->size() && value > (*bounds_)[i]) ++i;
  std::atomic<std::uint64_t>* stripe = Stripe(MetricStripe());
  stripe[i].fetch_add(1, std::memory_order_relaxed);
  std::atomic<std::uint64_t>& sum = stripe[bounds_->size() + 1];
  std::uint64_t bits = sum.load(std::memory_order_relaxed);
  while (!sum.compare_exchange_weak(
      bits, std::bit_cast<std::uint64_t>(std::bit_cast<double>(bits) + value),
      std::memory_order_relaxed)) {
  }
}

std::uint64_t Histogram::bucket(std::size_t i) const {
  std::uint64_t total = 0;
  for (std::size_t s = 0; s < kMetricStripes; ++s) {
    total += Stripe(s)[i].load(std::memory_order_relaxed);
  }
  return total;
}

double Histogram::sum() const {
  double total = 0;
  for (std::size_t s = 0; s < kMetricStripes; ++s) {
    total += std::bit_cast<double>(Stripe(s)[bounds_->size() + 1].load(std::memory_order_relaxed));
  }
  return total;
}

template <typename Series>
Family<Series>::Family(std::string name, std::string help, std::vector<std::string> label_names,
                       std::vector<double> bounds)
    : name_(std::move(name)),
      help_(std::move(help)),
      label_names_(std::move(label_names)),
      bounds_(std::move(bounds)) {}

template <typename Series>
Series& Family<Series>::With(std::initializer_list<std::string_view> label_values) {
  const std::span<const std::string_view> values(label_values.begin(), label_values.size());
  {
    std::shared_lock lock(mutex_);
    if (auto it = series_.find(values); it != series_.end()) return *it->second;
  }
  std::unique_lock lock(mutex_);
  std::unique_ptr<Series>& series =
      series_[std::vector<std::string>(label_values.begin(), label_values.end())];
  if (series == nullptr) {
    if constexpr (std::is_same_v<Series, Histogram>) {
      series = std::make_unique<Histogram>(&bounds_);
    } else {
      series = std::make_unique<Series>();
    }
  }
  return *series;
}

template <typename Series>
void Family<Series>::Render(std::string* text) const {
  *text += "# HELP " + name_ + ' ' + help_ + '\n';
  *text += "# TYPE " + name_ + ' ' + TypeName<Series>() + '\n';
  std::shared_lock lock(mutex_);  // blocks only the creation of a new series
  for (const auto& [values, series] : series_) {
    RenderSeries(LabelPairs(label_names_, values), *series, text);
  }
}

template <typename Series>
void Family<Series>::RenderSeries(const std::string& labels, const Series& series,
                                  std::string* text) const {
  if constexpr (std::is_same_v<Series, Histogram>) {
    // Cumulative counts from one read of each bucket: +Inf always equals _count.
    const std::string prefix = labels.empty() ? "" : labels + ',';
    std::uint64_t cumulative = 0;
    for (std::size_t i = 0; i <= bounds_.size(); ++i) {
      cumulative += series.bucket(i);
      const double bound = i < bounds_.size() ? bounds_[i] : INFINITY;
      *text += name_ + "_bucket{" + prefix + "le=\"" + FormatNumber(bound) + "\"} " +
               std::to_string(cumulative) + '\n';
    }
    *text += name_ + "_sum" + Braced(labels) + ' ' + FormatNumber(series.sum()) + '\n';
    *text += name_ + "_count" + Braced(labels) + ' ' + std::to_string(cumulative) + '\n';
  } else {
    *text += name_ + Braced(labels) + ' ' + std::to_string(series.value()) + '\n';
  }
}

template class Family<Counter>;
template class Family<Gauge>;
template class Family<Histogram>;

Metrics::Metrics()
    : rpc_calls("mdr_rpc_calls_total",
                "Finished calls by method and status code (StreamApply: one per message).",
                {"method", "code"}),
      rpc_duration_seconds("mdr_rpc_duration_seconds",
                           "Seconds from a call's arrival to its answer (StreamApply: a "
                           "message's computation), by method.",
                           {"method"}, kSecondsBuckets),
      sessions_family("mdr_sessions",
                      "Sessions held (unavailable ones restored from a damaged journal included).",
                      {}),
      steps_applied_family("mdr_steps_applied_total",
                           "Steps committed to sessions (batches replayed from the journal at "
                           "start included).",
                           {}),
      work_queue_depth_family("mdr_work_queue_depth",
                              "Computing calls waiting for a worker (--max-queued-calls bounds "
                              "it).",
                              {}),
      work_rejected_family("mdr_work_rejected_total",
                           "Computing calls refused with UNAVAILABLE because the queue was full.",
                           {}),
      stream_read_pauses_family("mdr_stream_read_pauses_total",
                                "StreamApply streams paused because their caller used more than "
                                "--contended-stream-share while other callers were active.",
                                {}),
      inline_batches_family("mdr_inline_batches_total",
                            "Apply calls and StreamApply messages applied on the thread that "
                            "received them, their cost bounded a priori (--max-inline-vertices).",
                            {}),
      journal_write_seconds_family("mdr_journal_write_seconds",
                                   "Seconds of each journal write transaction (commit included).",
                                   {}, kSecondsBuckets),
      journal_write_failures_family("mdr_journal_write_failures_total",
                                    "Journal writes that failed (the call failed with "
                                    "UNAVAILABLE and changed nothing).",
                                    {}),
      journal_free_bytes_family("mdr_journal_free_bytes",
                                "Bytes the journal may still grow by (its volume's free space, "
                                "or the file-size limit's room), as of its last write.",
                                {}),
      journal_refusals_family("mdr_journal_refusals_total",
                              "New work refused with UNAVAILABLE because the journal's room was "
                              "below --journal-min-free-bytes.",
                              {}),
      start_time_family("mdr_start_time_seconds",
                        "Start time of the process in seconds since the Unix epoch.", {}),
      sessions(sessions_family.With({})),
      steps_applied(steps_applied_family.With({})),
      work_queue_depth(work_queue_depth_family.With({})),
      work_rejected(work_rejected_family.With({})),
      stream_read_pauses(stream_read_pauses_family.With({})),
      inline_batches(inline_batches_family.With({})),
      journal_write_seconds(journal_write_seconds_family.With({})),
      journal_write_failures(journal_write_failures_family.With({})),
      journal_free_bytes(journal_free_bytes_family.With({})),
      journal_refusals(journal_refusals_family.With({})) {
  start_time_family.With({}).Set(kProcessStartSeconds);
}

std::string Metrics::Render() const {
  std::string text;
  rpc_calls.Render(&text);
  rpc_duration_seconds.Render(&text);
  sessions_family.Render(&text);
  steps_applied_family.Render(&text);
  work_queue_depth_family.Render(&text);
  work_rejected_family.Render(&text);
  stream_read_pauses_family.Render(&text);
  inline_batches_family.Render(&text);
  journal_write_seconds_family.Render(&text);
  journal_write_failures_family.Render(&text);
  journal_free_bytes_family.Render(&text);
  journal_refusals_family.Render(&text);
  start_time_family.Render(&text);
  return text;
}

Metrics& ProcessMetrics() {
  static Metrics metrics;
  return metrics;
}

namespace {

Counter recorded_calls;

// The series of one (method, code) pair, found once per thread.
struct CallSeries {
  const char* method = nullptr;
  const char* code = nullptr;
  Counter* calls = nullptr;
  Histogram* duration = nullptr;
};

const CallSeries& CallSeriesOf(const char* method, const char* code) {
  // A few pairs per thread (a thread mostly answers one method with OK); replaced in turn.
  constexpr std::size_t kKept = 8;
  thread_local std::array<CallSeries, kKept> kept;
  thread_local std::size_t next = 0;
  for (const CallSeries& series : kept) {
    if (series.method == method && series.code == code) return series;
  }
  // Series are never removed, so the pointers stay valid for the process's life.
  Metrics& metrics = ProcessMetrics();
  CallSeries& series = kept[next++ % kKept];
  series = {method, code, &metrics.rpc_calls.With({method, code}),
            &metrics.rpc_duration_seconds.With({method})};
  return series;
}

}  // namespace

std::uint64_t RecordedCalls() { return recorded_calls.value(); }

void RecordCall(const char* method, const char* code, double seconds) {
  recorded_calls.Increment();
  const CallSeries& series = CallSeriesOf(method, code);
  series.calls->Increment();
  series.duration->Observe(seconds);
}

JournalWriteTimer::JournalWriteTimer() : start_nanoseconds_(SteadyNanoseconds()) {}

JournalWriteTimer::~JournalWriteTimer() {
  ProcessMetrics().journal_write_seconds.Observe((SteadyNanoseconds() - start_nanoseconds_) * 1e-9);
}

}  // namespace mdr::service
