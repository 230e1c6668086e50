// Server-wide limits and the per-session limits derived from them.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>

#include "mdr/base/status.h"
#include "mdr/bridge/conversion.h"
#include "mdr/service/stream_pacer.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// The longest idle timeout, of the server or of a session: 100 years. Bounded so that a deadline
// of now + timeout stays far inside the clocks' int64 nanoseconds (292 years from their epoch).
inline constexpr std::int64_t kMaxIdleTimeoutSeconds = 3'155'760'000;

// The largest ServiceLimits::max_inline_vertices: the bound on what a transport thread computes.
inline constexpr std::size_t kMaxInlineVertices = 256;

struct ServiceLimits {
  // Sessions held at most; CreateSession/ImportSession beyond it fail with RESOURCE_EXHAUSTED.
  std::size_t max_sessions = 10000;
  // Sessions one token (principal) may hold at most, with authentication; 0: only max_sessions.
  std::size_t max_sessions_per_token = 0;
  // Steps in one Apply request or StreamApply message at most (and the sessions' default).
  std::uint32_t max_steps_per_batch = 10000;
  // Largest scene.options.max_memory_vertices a session may ask for (and its default when
  // lower than the core's default of 65536).
  std::size_t max_memory_vertices = bridge::kDefaultMaxMemoryVertices;
  // Sessions idle this long are deleted (and the sessions' longest idle timeout); 0: never.
  std::chrono::milliseconds session_idle_timeout = std::chrono::hours(1);
  // Largest request or response message in bytes (RESOURCE_EXHAUSTED beyond). A batch whose
  // response would be larger fails before it is committed.
  int max_message_bytes = 4 << 20;
  // Sum of the state bytes of every session (grid springs, memory vertices; state_budget.h) at
  // most: a create, import or batch beyond fails with RESOURCE_EXHAUSTED. 0: unlimited.
  std::size_t max_state_bytes = std::size_t{4} << 30;
  // The same for the sessions of one token (principal), inside max_state_bytes, so that one
  // caller cannot take another's room (a quarter of the default budget); 0: only max_state_bytes.
  // Callers without a token (authentication off) share max_state_bytes.
  std::size_t max_state_bytes_per_token = std::size_t{1} << 30;
  // The longest a computing unary call (and a FitLoops stream) may run: one whose client set no
  // deadline, or a later one, is stopped here with DEADLINE_EXCEEDED and changes nothing, so that
  // no call holds a worker without bound. StreamApply streams are exempt (a rig streams for
  // hours; each message is bounded by max_steps_per_batch). (0, 1 year].
  std::chrono::milliseconds max_call_duration = std::chrono::minutes(5);
  // Open StreamApply streams one caller (a token's principal, or a client host without
  // authentication) may hold, >= 1: each holds up to StreamApplyReactor::kMaxPendingResponses
  // messages, so this bounds what one caller's streams hold in memory.
  std::size_t max_streams_per_caller = 256;
  // A one-step Apply (or StreamApply message) on a single exact contact of at most this many
  // memory vertices, of a step whose path is straight, and without a journal, runs on the
  // transport's thread when its session has nothing queued: its cost is bounded a priori and
  // small (docs/operations.md, "Inline steps"). [0, 256]; 0: every batch goes to the workers.
  std::size_t max_inline_vertices = 32;
  // How one caller's StreamApply streams are paced while other callers are active
  // (stream_pacer.h); contended_share (mdrd --contended-stream-share) in (0, 1024].
  StreamPacing stream_pacing;
};

// Checks the server limits themselves (field names are the mdrd flags).
Status ValidateServiceLimits(const ServiceLimits& limits);

// The effective limits of a new session: unset (0) fields take the server's, set ones must not
// exceed them. Errors name the field bare ("max_steps_per_batch", "idle_timeout",
// "idle_timeout.nanos" for a Duration that is not normalized).
Result<v1::SessionLimits> ResolveSessionLimits(const v1::SessionLimits& requested,
                                               const ServiceLimits& server);

// A session's idle timeout; zero when it never expires.
std::chrono::nanoseconds IdleTimeout(const v1::SessionLimits& limits);

}  // namespace mdr::service
