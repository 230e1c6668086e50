#include "mdr/service/limits.h"

#include <google/protobuf/util/time_util.h>

#include <cstdint>
#include <string>

#include "mdr/base/validate.h"

namespace mdr::service {

using google::protobuf::util::TimeUtil;

namespace {

// A duration as the API takes it: non-negative and normalized (nanos in [0, 999999999]), its
// seconds at most max_seconds, which is below google.protobuf.Duration's own bound and checked
// before any conversion to nanoseconds could overflow; anything else is refused rather than
// normalized or clamped, so an invalid Duration is never echoed back.
Status ValidateDuration(const std::string& field, const google::protobuf::Duration& duration,
                        std::int64_t max_seconds) {
  if (duration.seconds() < 0 || duration.seconds() > max_seconds) {
    return InvalidArgument(field + ".seconds", "must be in [0, " + std::to_string(max_seconds) +
                                                   "], got " + std::to_string(duration.seconds()));
  }
  constexpr std::int32_t kMaxNanos = 999'999'999;
  if (duration.nanos() < 0 || duration.nanos() > kMaxNanos) {
    return InvalidArgument(field + ".nanos", "must be in [0, " + std::to_string(kMaxNanos) +
                                                 "] (whole seconds go in seconds), got " +
                                                 std::to_string(duration.nanos()));
  }
  return OkStatus();
}

}  // namespace

Status ValidateServiceLimits(const ServiceLimits& limits) {
  if (limits.max_sessions < 1) return InvalidArgument("max-sessions", "must be >= 1, got 0");
  if (limits.max_steps_per_batch < 1) {
    return InvalidArgument("max-steps-per-batch", "must be >= 1, got 0");
  }
  if (limits.max_memory_vertices < 8) {
    return InvalidArgument("max-memory-vertices",
                           "must be >= 8, got " + std::to_string(limits.max_memory_vertices));
  }
  if (limits.session_idle_timeout.count() < 0 ||
      limits.session_idle_timeout > std::chrono::seconds(kMaxIdleTimeoutSeconds)) {
    return InvalidArgument(
        "session-idle-timeout",
        "must be in [0, " + std::to_string(kMaxIdleTimeoutSeconds) + "] seconds (0: never)");
  }
  if (limits.max_call_duration <= std::chrono::milliseconds(0) ||
      limits.max_call_duration > std::chrono::hours(24 * 365)) {
    return InvalidArgument("max-call-seconds", "must be in (0, 31536000] seconds");
  }
  if (limits.max_inline_vertices > kMaxInlineVertices) {
    return InvalidArgument("max-inline-vertices",
                           "must be in [0, " + std::to_string(kMaxInlineVertices) +
                               "] (a bound on the work a transport thread does), got " +
                               std::to_string(limits.max_inline_vertices));
  }
  if (limits.max_streams_per_caller < 1) {
    return InvalidArgument("max-streams-per-caller", "must be >= 1, got 0");
  }
  if (const double share = limits.stream_pacing.contended_share; !(share > 0 && share <= 1024)) {
    return InvalidArgument(
        "contended-stream-share",
        "must be in (0, 1024] (a fraction of one core), got " + std::to_string(share));
  }
  if (limits.max_message_bytes < 1024) {
    return InvalidArgument("max-message-bytes",
                           "must be >= 1024, got " + std::to_string(limits.max_message_bytes));
  }
  return OkStatus();
}

Result<v1::SessionLimits> ResolveSessionLimits(const v1::SessionLimits& requested,
                                               const ServiceLimits& server) {
  v1::SessionLimits effective;
  effective.set_max_steps_per_batch(server.max_steps_per_batch);
  if (requested.max_steps_per_batch() != 0) {
    if (Status s = RequireInRange("max_steps_per_batch", requested.max_steps_per_batch(), 1,
                                  server.max_steps_per_batch);
        !s.ok()) {
      return s;
    }
    effective.set_max_steps_per_batch(requested.max_steps_per_batch());
  }
  const double server_seconds = std::chrono::duration<double>(server.session_idle_timeout).count();
  if (server_seconds > 0) {
    *effective.mutable_idle_timeout() =
        TimeUtil::MillisecondsToDuration(server.session_idle_timeout.count());
  }
  if (requested.has_idle_timeout()) {
    if (Status s =
            ValidateDuration("idle_timeout", requested.idle_timeout(), kMaxIdleTimeoutSeconds);
        !s.ok())
      return s;
    const double seconds =
        static_cast<double>(TimeUtil::DurationToNanoseconds(requested.idle_timeout())) * 1e-9;
    Status s = server_seconds > 0 ? RequireInRange("idle_timeout", seconds, 0, server_seconds,
                                                   /*lo_open=*/true)
                                  : RequirePositive("idle_timeout", seconds);
    if (!s.ok()) return s;
    *effective.mutable_idle_timeout() = requested.idle_timeout();
  }
  return effective;
}

std::chrono::nanoseconds IdleTimeout(const v1::SessionLimits& limits) {
  if (!limits.has_idle_timeout()) return std::chrono::nanoseconds(0);
  return std::chrono::nanoseconds(TimeUtil::DurationToNanoseconds(limits.idle_timeout()));
}

}  // namespace mdr::service
