// The durable record of the sessions: an embedded SQLite database (WAL mode) holding, per live
// session, a base snapshot (SessionSnapshot, the portable exact state of Export/Import) and the
// Apply batches accepted since, in order. A session is restored by importing its snapshot and
// replaying its batches through Session::Apply; compaction replaces the snapshot and deletes the
// batches it covers. Every write is one transaction and returns once SQLite has committed it
// (durability against power loss depends on JournalSync). One process at a time: the database is
// locked against other processes while open (an flock on the database file). Checkpoints run
// on a thread of their own, so that no commit waits for their fsyncs.
//
// Damage is detected, never accepted silently: at open the schema is compared with this format's
// and PRAGMA quick_check runs; every row carries a CRC-32 of its content and a session's batches
// are numbered without gaps (checked by Load); and every write transaction increments a commit
// counter in the database whose last committed value is also written, after the commit, to a
// small side file "<path>.commit" outside the write-ahead log. SQLite silently ends the log at a
// truncated or damaged frame, dropping every later commit; the database then looks consistent
// but older, and only the side file (counter ahead of the database's) tells. A process crash
// never leaves the side file ahead (it is written after the commit); a machine crash under
// JournalSync kOff/kNormal may, when the operating system wrote the side file but not the log:
// commits acknowledged before the crash were then lost, and that is reported. The files are
// created with mode 0600.
#pragma once

#include <google/protobuf/timestamp.pb.h>
#include <sys/types.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/service/completed_requests.h"
#include "mdr/v1/contact_service.pb.h"

struct sqlite3;
struct sqlite3_stmt;

namespace mdr::service {

// When a commit reaches the disk (PRAGMA synchronous in WAL mode). Every mode survives a crash
// of the process (SIGKILL included): a commit is in the operating system's cache before the
// response is sent.
enum class JournalSync {
  // No fsync: a crash of the machine (power loss, kernel panic) may lose recent commits or
  // corrupt the journal.
  kOff,
  // fsync at checkpoints only: a crash of the machine may lose the last commits, the journal stays
  // consistent.
  kNormal,
  // fsync of the write-ahead log at every commit: nothing acknowledged is lost.
  kFull,
};

// "off", "normal", "full"; false for anything else.
bool ParseJournalSync(const std::string& text, JournalSync* sync);
const char* JournalSyncName(JournalSync sync);

struct JournalOptions {
  // SQLite database file; empty: no journal (sessions live in memory only).
  std::string path;
  JournalSync sync = JournalSync::kNormal;
  // A session's snapshot is rewritten (and the batches it covers deleted) after this many batches;
  // also at a clean shutdown. >= 1.
  std::uint32_t snapshot_every = 1000;
  // What Open does with a damaged journal: false refuses it (DATA_LOSS naming the damage); true
  // keeps what is intact, copies the damaged files aside ("<path>.damaged", "-wal" and ".commit"
  // appended) and rewrites the journal with the intact sessions in one transaction (a crash
  // during it leaves the damaged journal as it was); recovery_drops() lists what was dropped.
  bool recover = false;
  // The room kept for deletions: when the journal could grow by less than this (its volume's free
  // space, or what a file-size limit leaves), new sessions and batches are refused UNAVAILABLE
  // while DeleteSession and ExportSession go on, so that a full volume can always be freed.
  std::uint64_t min_free_bytes = std::uint64_t{64} << 20;
};

// How many bytes the journal at `path` may still grow by: the free space of its volume (for an
// unprivileged process) and, under a file-size limit (RLIMIT_FSIZE), what the limit leaves its
// largest file; 0 if that cannot be read.
std::uint64_t JournalRoom(const std::string& path);

// One accepted batch: the ApplyRequest as received (steps, step_mask, request_id), numbered
// 1, 2, ... per session.
struct JournaledBatch {
  std::uint64_t sequence = 0;
  v1::ApplyRequest request;
};

// A response remembered for a request id (CompletedRequests), kept with a snapshot so that a
// retry after a restart is still recognised.
// A live session as journaled: its base snapshot, which includes the batches up to
// snapshot_sequence, the request ids remembered at that point (oldest first), and the later
// batches in order.
struct JournaledSession {
  std::string name;
  std::string owner;
  google::protobuf::Timestamp create_time;
  std::uint64_t snapshot_sequence = 0;
  v1::SessionSnapshot snapshot;
  std::vector<CompletedRequest> completed;
  std::vector<JournaledBatch> batches;
};

class Journal {
 public:
  // Opens (creating if needed, mode 0600) the database at options.path and takes its lock, then
  // checks it for damage (see above and JournalOptions::recover). Errors name the file and say
  // why: FAILED_PRECONDITION (unreadable, not a journal, another format, in use by another
  // process), DATA_LOSS (damaged; what is wrong, each item).
  static Status Open(const JournalOptions& options, std::unique_ptr<Journal>* journal);

  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  ~Journal();

  // Every journaled session with the batches after its snapshot, sessions by name, batches by
  // sequence. DATA_LOSS naming every damaged entry: a row whose checksum does not match or that
  // does not parse, a session name that is not "sessions/{session_id}"
  // (SessionStore::IsSessionName), a gap in a session's batch numbers, rows of a session that has
  // no entry.
  Status Load(std::vector<JournaledSession>* sessions);

  // What a recovering Open found damaged and dropped (sessions, batch ranges, commits), one
  // sentence each; empty when nothing was.
  const std::vector<std::string>& recovery_drops() const { return recovery_drops_; }

  // The write operations, each one transaction that also advances the commit counter.
  // UNAVAILABLE (and logged at error level) when SQLite fails (disk full, I/O error): then
  // nothing was written. AddSession and AddBatch are new work: UNAVAILABLE naming the journal's
  // room first when it is below options.min_free_bytes (logged when it falls below, and when it
  // is back); RemoveSession and Compact always try.
  // A new session (created or imported) with its initial snapshot as sequence 0; replaces any
  // entry of the same name.
  Status AddSession(const std::string& name, const std::string& owner,
                    const google::protobuf::Timestamp& create_time,
                    const v1::SessionSnapshot& snapshot);
  Status AddBatch(const std::string& session, std::uint64_t sequence,
                  const v1::ApplyRequest& request);
  // Replaces the session's snapshot (and remembered request ids) by one that includes the batches
  // up to `sequence` and deletes those batches.
  Status Compact(const std::string& session, std::uint64_t sequence,
                 const v1::SessionSnapshot& snapshot,
                 const std::vector<CompletedRequest>& completed);
  Status RemoveSession(const std::string& session);

  const JournalOptions& options() const { return options_; }
  // Write-ahead log pages after which the checkpointer copies the log into the database.
  static constexpr int kCheckpointPages = 1000;
  // Checkpoints the checkpointer has completed (tests).
  std::uint64_t checkpoints() const { return checkpoints_.load(std::memory_order_relaxed); }

 private:
  explicit Journal(const JournalOptions& options) : options_(options) {}
  // Opens the database and the side file, creates a new journal's schema, checks an existing
  // one (damage found is appended to *damage) and prepares the statements.
  Status Connect(std::vector<std::string>* damage);
  void CheckSchema(std::vector<std::string>* damage);
  void CheckIntegrity(std::vector<std::string>* damage);
  // Reads the database's commit counter and compares the side file's with it.
  void CheckCommits(std::vector<std::string>* damage);
  Status Prepare();
  // Stops the checkpointer, finalizes the statements and closes the database (without a
  // checkpoint when `keep_log`), then lets go of the lock.
  void Disconnect(bool keep_log);
  // A thread with its own connection that checkpoints when a commit finds kCheckpointPages in
  // the log (OnWalCommit, SQLite's WAL hook), so that no caller's commit waits for it.
  Status StartCheckpointer();
  void StopCheckpointer();
  void RunCheckpointer(sqlite3* db);  // the thread's loop, on its connection `db`
  static int OnWalCommit(void* journal, sqlite3* db, const char* name, int pages);
  // Every intact session; what is damaged is described in *damage and left out.
  void ReadSessions(std::vector<JournaledSession>* sessions, std::vector<std::string>* damage);
  void ReadRequests(JournaledSession* session, std::vector<std::string>* damage);
  void ReadBatches(JournaledSession* session, std::vector<std::string>* damage);
  // Rows of `table` whose session has no entry.
  void ReadOrphans(const char* table, std::vector<std::string>* damage);
  // Copies the damaged files aside and replaces the journal's content by `intact` (in place, or
  // in a new file when the old one cannot even be rewritten).
  Status Rebuild(const std::vector<JournaledSession>& intact);
  bool RewriteInPlace(const std::vector<JournaledSession>& intact, std::string* error);
  void FinalizeStatements();
  Status WriteSession(const JournaledSession& session, std::string* error);
  // Writes the commit counter to the side file (after a commit).
  bool RecordCommits(std::string* error);
  // Runs SQL without results; the SQLite error message otherwise.
  bool Execute(const char* sql, std::string* error);
  // Runs a prepared statement to completion and resets it.
  bool Execute(sqlite3_stmt* statement, std::string* error);
  template <typename Body>
  // Runs body(commit number, error) in a transaction (committed if it returns true, rolled back
  // otherwise). The commit counter is advanced in the commits table, or by the body in the batch
  // row it writes (row_carries_commit).
  Status InTransaction(const char* what, bool row_carries_commit, Body body);
  Status WriteError(const char* what, const std::string& error) const;
  // Whether the database, its log and the side file at options_.path are still the files this
  // journal has open (an operator may delete or replace them: SQLite would go on writing to the
  // unlinked files, and a restart would find none of it); *which names the first that is not.
  bool FilesAreOurs(std::string* which);
  // Writes what the open files hold (every commit, the log's included) to new files at
  // options_.path and reconnects to them; the open files are kept on failure, so that the next
  // write tries again.
  Status Reestablish(const std::string& which);
  // OK if the files are ours or were rewritten; UNAVAILABLE naming the file otherwise.
  Status EnsureFilesAreOurs(const char* what);
  // OK while the journal's room is at least options_.min_free_bytes; else UNAVAILABLE saying so.
  // Records the room in the metrics and logs when it crosses the floor.
  Status CheckRoom(const char* what);

  const JournalOptions options_;
  std::mutex mutex_;  // one statement or transaction at a time
  std::vector<std::string> recovery_drops_;
  sqlite3* db_ = nullptr;
  int commit_file_ = -1;  // the side file "<path>.commit"
  int lock_file_ = -1;    // the database file, flock'ed: one process at a time
  // The log's device and inode once it exists (st_ino 0: not yet seen).
  dev_t log_device_ = 0;
  ino_t log_inode_ = 0;
  std::thread checkpointer_;
  std::mutex checkpoint_mutex_;
  std::condition_variable checkpoint_wakeup_;
  bool checkpoint_wanted_ = false;  // guarded by checkpoint_mutex_
  bool checkpoint_stop_ = false;    // guarded by checkpoint_mutex_
  std::atomic<std::uint64_t> checkpoints_{0};
  int pages_at_checkpoint_request_ = 0;  // the log's pages when a checkpoint was last asked for
  std::uint64_t commits_ = 0;            // the commit counter of the last commit
  std::uint64_t side_commits_ = 0;       // the side file's counter when opened
  bool checkpoint_on_close_ = false;     // opened and checked
  bool below_floor_ = false;             // the room was below min_free_bytes at the last check
  sqlite3_stmt* begin_ = nullptr;
  sqlite3_stmt* commit_ = nullptr;
  sqlite3_stmt* rollback_ = nullptr;
  sqlite3_stmt* count_commit_ = nullptr;
  sqlite3_stmt* insert_session_ = nullptr;
  sqlite3_stmt* insert_batch_ = nullptr;
  sqlite3_stmt* update_snapshot_ = nullptr;
  sqlite3_stmt* delete_batches_up_to_ = nullptr;
  sqlite3_stmt* delete_session_ = nullptr;
  sqlite3_stmt* delete_all_batches_ = nullptr;
  sqlite3_stmt* insert_request_ = nullptr;
  sqlite3_stmt* delete_requests_ = nullptr;
};

}  // namespace mdr::service
