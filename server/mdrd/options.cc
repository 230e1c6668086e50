#include "options.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>

namespace mdrd {

std::optional<int> ParseOptions(int argc, char** argv, Options* options) {
  CLI::App app{
      "mdrd: tangential contact sessions (Method of Dimensionality Reduction) over gRPC.\n"
      "Every flag can also be set by the environment variable shown with it; the flag wins."};
  mdr::service::ServerOptions& server = options->server;
  mdr::service::ServiceLimits& limits = server.limits;
  double idle_timeout_seconds = std::chrono::duration<double>(limits.session_idle_timeout).count();
  double max_call_seconds = std::chrono::duration<double>(limits.max_call_duration).count();
  mdr::service::JournalOptions& journal = server.journal;
  std::string journal_sync = mdr::service::JournalSyncName(journal.sync);
  bool no_journal = false;
  mdr::service::TlsOptions& tls = server.tls;

  app.add_option("--listen", server.listen_address, "Address to listen on (host:port; port 0: any)")
      ->envname("MDR_LISTEN")
      ->capture_default_str();
  app.add_option("--metrics-listen", server.metrics_listen_address,
                 "Address of the Prometheus metrics over HTTP, GET /metrics (host:port; port 0: "
                 "any; empty: none)")
      ->envname("MDR_METRICS_LISTEN")
      ->capture_default_str();
  app.add_option("--log-level", options->log_level,
                 "trace, debug (one line per call), info, warn, error, critical or off")
      ->envname("MDR_LOG_LEVEL")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--max-sessions", limits.max_sessions,
                 "Sessions held at most (RESOURCE_EXHAUSTED beyond)")
      ->envname("MDR_MAX_SESSIONS")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-steps-per-batch", limits.max_steps_per_batch,
                 "Steps per Apply request or StreamApply message at most")
      ->envname("MDR_MAX_STEPS_PER_BATCH")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-memory-vertices", limits.max_memory_vertices,
                 "Largest scene.options.max_memory_vertices a session may use (>= 8)")
      ->envname("MDR_MAX_MEMORY_VERTICES")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{8}, std::size_t{1} << 30));
  app.add_option("--session-idle-timeout", idle_timeout_seconds,
                 "Seconds after which an unused session is deleted (0: never)")
      ->envname("MDR_SESSION_IDLE_TIMEOUT")
      ->capture_default_str()
      ->check(CLI::Range(0.0, static_cast<double>(mdr::service::kMaxIdleTimeoutSeconds)));
  app.add_option("--max-call-seconds", max_call_seconds,
                 "Longest a computing call (and a FitLoops stream) runs when its client sets no "
                 "deadline or a later one: DEADLINE_EXCEEDED then, nothing changed (StreamApply "
                 "streams are exempt)")
      ->envname("MDR_MAX_CALL_SECONDS")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 31536000.0));
  app.add_option("--max-message-bytes", limits.max_message_bytes,
                 "Largest request or response message (RESOURCE_EXHAUSTED beyond)")
      ->envname("MDR_MAX_MESSAGE_BYTES")
      ->capture_default_str()
      ->check(CLI::Range(1024, 1 << 30));
  app.add_option("--max-state-bytes", limits.max_state_bytes,
                 "Bytes of session state (grid springs, memory vertices, profile tables) held at "
                 "most over all sessions; a create, import or batch beyond fails with "
                 "RESOURCE_EXHAUSTED (0: unlimited)")
      ->envname("MDR_MAX_STATE_BYTES")
      ->capture_default_str();
  app.add_option("--max-state-bytes-per-token", limits.max_state_bytes_per_token,
                 "Bytes of session state one token's sessions hold at most, inside "
                 "--max-state-bytes (0: only --max-state-bytes)")
      ->envname("MDR_MAX_STATE_BYTES_PER_TOKEN")
      ->capture_default_str();
  mdr::service::ExecutorOptions& execution = server.execution;
  app.add_option("--workers", execution.workers,
                 "Worker threads of the computing calls (Apply, StreamApply messages, Query, "
                 "Transform, Create/Import/ExportSession); 0: one per core")
      ->envname("MDR_WORKERS")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{0}, mdr::service::ExecutorOptions::kMaxWorkers));
  app.add_option("--reserve-workers", execution.reserve_workers,
                 "Threads kept for a caller with nothing running whose call finds every worker "
                 "busy, so that it never waits behind the others' calls; -1: as many as the "
                 "workers, 0: none")
      ->envname("MDR_RESERVE_WORKERS")
      ->capture_default_str()
      ->check(CLI::Range(-1, static_cast<int>(mdr::service::ExecutorOptions::kMaxWorkers)));
  app.add_option("--max-queued-calls", execution.max_queued,
                 "Computing calls waiting for a worker at most; beyond, a call is refused at once "
                 "with UNAVAILABLE (retry with backoff)")
      ->envname("MDR_MAX_QUEUED_CALLS")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-queued-calls-per-caller", execution.max_queued_per_caller,
                 "Computing calls one caller (token, or client host without authentication) may "
                 "have waiting; beyond, RESOURCE_EXHAUSTED at once. A caller under its share of "
                 "--max-queued-calls is admitted even when that queue is full")
      ->envname("MDR_MAX_QUEUED_CALLS_PER_CALLER")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-streams-per-caller", limits.max_streams_per_caller,
                 "Open StreamApply streams one caller (token, or client host without "
                 "authentication) may hold; a stream beyond ends at once with RESOURCE_EXHAUSTED")
      ->envname("MDR_MAX_STREAMS_PER_CALLER")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-inline-vertices", limits.max_inline_vertices,
                 "A one-step Apply or StreamApply message on a single exact contact of at most "
                 "this many memory vertices, of a straight step and without a journal, runs on the "
                 "transport's thread when its session has nothing queued (0: never)")
      ->envname("MDR_MAX_INLINE_VERTICES")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{0}, mdr::service::kMaxInlineVertices));
  app.add_option("--contended-stream-share", limits.stream_pacing.contended_share,
                 "While other callers are active, the fraction of one core one caller's "
                 "StreamApply streams may use (application and transport); beyond, its streams "
                 "are read more slowly. A caller alone is not paced")
      ->envname("MDR_CONTENDED_STREAM_SHARE")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--shutdown-grace", options->shutdown_grace_seconds,
                 "Seconds running calls get to finish after SIGTERM/SIGINT")
      ->envname("MDR_SHUTDOWN_GRACE")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--journal", journal.path,
                 "SQLite journal of the sessions, restored at start (empty: none)")
      ->envname("MDR_JOURNAL")
      ->capture_default_str();
  app.add_flag("--no-journal", no_journal,
               "Keep sessions in memory only (a restart loses them); wins over --journal")
      ->envname("MDR_NO_JOURNAL");
  app.add_option("--journal-sync", journal_sync,
                 "When a journal commit reaches the disk: off (never fsync), normal (fsync at "
                 "checkpoints: a power loss may lose the last batches), full (fsync every "
                 "commit: nothing acknowledged is lost). All survive a crash of mdrd itself")
      ->envname("MDR_JOURNAL_SYNC")
      ->capture_default_str()
      ->check(CLI::IsMember({"off", "normal", "full"}));
  app.add_option("--journal-snapshot-every", journal.snapshot_every,
                 "Batches per session between journal snapshots (compaction)")
      ->envname("MDR_JOURNAL_SNAPSHOT_EVERY")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--journal-min-free-bytes", journal.min_free_bytes,
                 "Room kept on the journal's volume for deletions: below it (or below what a "
                 "file-size limit leaves) new sessions and batches are refused UNAVAILABLE while "
                 "DeleteSession and ExportSession go on")
      ->envname("MDR_JOURNAL_MIN_FREE_BYTES")
      ->capture_default_str();
  app.add_flag("--journal-recover", journal.recover,
               "Start even if the journal is damaged: restore what is intact, log what was "
               "dropped, keep the damaged files as <journal>.damaged* and write a consistent "
               "journal (without it a damaged journal stops mdrd)")
      ->envname("MDR_JOURNAL_RECOVER");
  app.add_option("--tls-cert", tls.cert_file, "PEM certificate chain: serve TLS (with --tls-key)")
      ->envname("MDR_TLS_CERT");
  app.add_option("--tls-key", tls.key_file, "PEM private key of --tls-cert")
      ->envname("MDR_TLS_KEY");
  app.add_option("--tls-client-ca", tls.client_ca_file,
                 "PEM CA certificates: require client certificates signed by them (mutual TLS)")
      ->envname("MDR_TLS_CLIENT_CA");
  app.add_option("--tokens-file", server.tokens_file,
                 "Bearer tokens, one name:token per line: every call must carry "
                 "'authorization: Bearer <token>' and sees only its own sessions (unset: no "
                 "authentication)")
      ->envname("MDR_TOKENS_FILE");
  app.add_option("--max-sessions-per-token", limits.max_sessions_per_token,
                 "Sessions one token may hold at most (0: only --max-sessions)")
      ->envname("MDR_MAX_SESSIONS_PER_TOKEN")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  }
  limits.session_idle_timeout = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(idle_timeout_seconds));
  limits.max_call_duration = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(max_call_seconds));
  if (no_journal) journal.path.clear();
  mdr::service::ParseJournalSync(journal_sync, &journal.sync);  // checked above
  return std::nullopt;
}

void LogEffectiveOptions(const Options& options) {
  const mdr::service::ServerOptions& server = options.server;
  const mdr::service::ServiceLimits& limits = server.limits;
  spdlog::info(
      "event=config listen={} log_level={} max_sessions={} max_steps_per_batch={} "
      "max_memory_vertices={} session_idle_timeout_s={} max_call_s={} max_message_bytes={} "
      "shutdown_grace_s={} journal={} journal_sync={} journal_snapshot_every={} "
      "journal_recover={} journal_min_free_bytes={} tls={} mtls={} auth={} "
      "max_sessions_per_token={} max_state_bytes={} "
      "workers={} max_queued_calls={} max_queued_calls_per_caller={} "
      "max_streams_per_caller={} contended_stream_share={} metrics_listen={}",
      server.listen_address, options.log_level, limits.max_sessions, limits.max_steps_per_batch,
      limits.max_memory_vertices,
      std::chrono::duration<double>(limits.session_idle_timeout).count(),
      std::chrono::duration<double>(limits.max_call_duration).count(), limits.max_message_bytes,
      options.shutdown_grace_seconds, server.journal.path.empty() ? "-" : server.journal.path,
      mdr::service::JournalSyncName(server.journal.sync), server.journal.snapshot_every,
      server.journal.recover, server.journal.min_free_bytes, !server.tls.cert_file.empty(),
      !server.tls.client_ca_file.empty(), !server.tokens_file.empty(),
      limits.max_sessions_per_token, limits.max_state_bytes, server.execution.workers,
      server.execution.max_queued, server.execution.max_queued_per_caller,
      limits.max_streams_per_caller, limits.stream_pacing.contended_share,
      server.metrics_listen_address.empty() ? "-" : server.metrics_listen_address);
  if (!server.tokens_file.empty() && server.tls.cert_file.empty()) {
    spdlog::warn(
        "event=config_warning warning=\"bearer tokens without --tls-cert travel in clear text; "
        "use TLS or a TLS-terminating proxy on an untrusted network\"");
  }
  if (!server.tokens_file.empty() && limits.max_state_bytes > 0 &&
      limits.max_state_bytes_per_token >= limits.max_state_bytes) {
    spdlog::warn(
        "event=config_warning warning=\"--max-state-bytes-per-token ({}) is not below "
        "--max-state-bytes ({}): one token can take the whole state budget and leave nothing "
        "for the others\"",
        limits.max_state_bytes_per_token, limits.max_state_bytes);
  }
}

}  // namespace mdrd
