#include "mdr/service/journal.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "mdr/base/status.h"
#include "mdr/service/metrics.h"
#include "mdr/service/session_store.h"

namespace mdr::service {
namespace {

// PRAGMA user_version of a journal in this format (1: without checksums and commit counter).
constexpr int kFormatVersion = 2;

// Run once on a new journal; an existing one must have exactly these tables (CheckSchema).
constexpr char kSchema[] = R"sql(
CREATE TABLE sessions(
  name TEXT PRIMARY KEY,
  owner TEXT NOT NULL,
  create_time_seconds INTEGER NOT NULL,
  create_time_nanos INTEGER NOT NULL,
  snapshot_sequence INTEGER NOT NULL,
  snapshot BLOB NOT NULL,
  checksum INTEGER NOT NULL
) WITHOUT ROWID;
CREATE TABLE batches(
  session TEXT NOT NULL,
  sequence INTEGER NOT NULL,
  request_id TEXT NOT NULL,
  request BLOB NOT NULL,
  commit_number INTEGER NOT NULL,
  checksum INTEGER NOT NULL,
  PRIMARY KEY(session, sequence)
) WITHOUT ROWID;
CREATE TABLE requests(
  session TEXT NOT NULL,
  position INTEGER NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint INTEGER NOT NULL,
  response BLOB NOT NULL,
  checksum INTEGER NOT NULL,
  PRIMARY KEY(session, position)
) WITHOUT ROWID;
-- The commit counter: the last commit's number is the larger of commits.count (advanced by every
-- other write) and the largest batches.commit_number (a batch carries its own commit's number, so
-- the hot path writes one page, not two).
CREATE TABLE commits(
  id INTEGER PRIMARY KEY CHECK(id = 1),
  count INTEGER NOT NULL
);
INSERT INTO commits(id, count) VALUES(1, 0);
)sql";

const char* SynchronousPragma(JournalSync sync) {
  switch (sync) {
    case JournalSync::kOff:
      return "PRAGMA synchronous=OFF";
    case JournalSync::kNormal:
      return "PRAGMA synchronous=NORMAL";
    case JournalSync::kFull:
      return "PRAGMA synchronous=FULL";
  }
  return "PRAGMA synchronous=FULL";
}

// Binds text or a blob without copying; the caller keeps `bytes` alive until the step.
void BindText(sqlite3_stmt* statement, int index, const std::string& text) {
  sqlite3_bind_text(statement, index, text.data(), static_cast<int>(text.size()), SQLITE_STATIC);
}
void BindBlob(sqlite3_stmt* statement, int index, const std::string& bytes) {
  sqlite3_bind_blob(statement, index, bytes.data(), static_cast<int>(bytes.size()), SQLITE_STATIC);
}
void BindInteger(sqlite3_stmt* statement, int index, std::uint64_t value) {
  sqlite3_bind_int64(statement, index, static_cast<sqlite3_int64>(value));
}

std::string ColumnText(sqlite3_stmt* statement, int column) {
  const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(statement, column));
  return text == nullptr ? std::string()
                         : std::string(text, sqlite3_column_bytes(statement, column));
}
std::string_view ColumnBlob(sqlite3_stmt* statement, int column) {
  const auto* bytes = static_cast<const char*>(sqlite3_column_blob(statement, column));
  return bytes == nullptr ? std::string_view()
                          : std::string_view(bytes, sqlite3_column_bytes(statement, column));
}
std::uint64_t ColumnInteger(sqlite3_stmt* statement, int column) {
  return static_cast<std::uint64_t>(sqlite3_column_int64(statement, column));
}

// CRC-32 of a row's columns (each length-prefixed), stored in its `checksum` column: a flipped
// bit anywhere in a row is caught when it is read, whether or not the page still parses.
class RowChecksum {
 public:
  RowChecksum& Add(std::string_view bytes) {
    Add(static_cast<std::uint64_t>(bytes.size()));
    // zlib answers 0 for a null buffer (how SQLite returns an empty blob), whatever crc_ was.
    if (!bytes.empty())
      crc_ = crc32_z(crc_, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size());
    return *this;
  }
  RowChecksum& Add(std::uint64_t value) {
    std::array<Bytef, 8> little_endian;
    for (int i = 0; i < 8; ++i) little_endian[i] = static_cast<Bytef>(value >> (8 * i));
    crc_ = crc32_z(crc_, little_endian.data(), little_endian.size());
    return *this;
  }
  std::uint64_t value() const { return crc_; }

 private:
  uLong crc_ = crc32_z(0, nullptr, 0);
};

std::uint64_t SessionChecksum(std::string_view name, std::string_view owner,
                              const google::protobuf::Timestamp& create_time,
                              std::uint64_t snapshot_sequence, std::string_view snapshot) {
  return RowChecksum()
      .Add(name)
      .Add(owner)
      .Add(static_cast<std::uint64_t>(create_time.seconds()))
      .Add(static_cast<std::uint64_t>(create_time.nanos()))
      .Add(snapshot_sequence)
      .Add(snapshot)
      .value();
}
std::uint64_t BatchChecksum(std::string_view session, std::uint64_t sequence,
                            std::string_view request_id, std::string_view request,
                            std::uint64_t commit_number) {
  return RowChecksum()
      .Add(session)
      .Add(sequence)
      .Add(request_id)
      .Add(request)
      .Add(commit_number)
      .value();
}
std::uint64_t RequestChecksum(std::string_view session, std::uint64_t position,
                              std::string_view request_id, std::uint64_t fingerprint,
                              std::string_view response) {
  return RowChecksum()
      .Add(session)
      .Add(position)
      .Add(request_id)
      .Add(fingerprint)
      .Add(response)
      .value();
}

// The side file: two fixed-size slots, the counter written to slot (counter % 2), so a write
// torn by a machine crash leaves the other slot, one commit older, readable.
constexpr char kCommitMagic[8] = {'M', 'D', 'R', 'J', 'C', 'N', 'T', '1'};
constexpr std::size_t kCommitSlotBytes = 24;  // magic, counter, CRC-32 of both, zero padding

std::array<unsigned char, kCommitSlotBytes> EncodeCommitSlot(std::uint64_t commits) {
  std::array<unsigned char, kCommitSlotBytes> slot{};
  std::memcpy(slot.data(), kCommitMagic, 8);
  for (int i = 0; i < 8; ++i) slot[8 + i] = static_cast<unsigned char>(commits >> (8 * i));
  const uLong crc = crc32_z(crc32_z(0, nullptr, 0), slot.data(), 16);
  for (int i = 0; i < 4; ++i) slot[16 + i] = static_cast<unsigned char>(crc >> (8 * i));
  return slot;
}

// The counter in a slot; nullopt for a slot that is empty or damaged.
std::optional<std::uint64_t> DecodeCommitSlot(const unsigned char* slot) {
  std::uint64_t commits = 0;
  for (int i = 7; i >= 0; --i) commits = (commits << 8) | slot[8 + i];
  const auto expected = EncodeCommitSlot(commits);
  if (std::memcmp(expected.data(), slot, kCommitSlotBytes) != 0) return std::nullopt;
  return commits;
}

// Opens the database file, creating it with mode 0600 (SQLite gives its -wal file the
// database file's mode), and takes the lock that keeps every other process out: an flock,
// independent of SQLite's POSIX locks. The descriptor is kept, and closed only after SQLite's
// connections (closing any descriptor of the file drops the process's POSIX locks on it); -1 and
// *error otherwise.
int CreatePrivatelyAndLock(const std::string& path, std::string* error) {
  const int file = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (file < 0) {
    *error = std::strerror(errno);
    return -1;
  }
  if (::flock(file, LOCK_EX | LOCK_NB) != 0) {
    *error = errno == EWOULDBLOCK ? "database is locked (is another mdrd using it?)"
                                  : std::strerror(errno);
    ::close(file);
    return -1;
  }
  return file;
}

// SQLite's unix VFS with the process holding the database's lock: the write-ahead log's index
// lives in heap memory shared by this process's connections (the writer's and the
// checkpointer's), never in a memory-mapped "-shm" file, whose pages would turn an I/O error
// (a file made immutable, a full or vanished volume) into a SIGBUS instead of an error code.
// The flock of CreatePrivatelyAndLock keeps other processes out anyway.
constexpr const char* kVfs = "unix-excl";

bool IsCorruption(int code) { return (code & 0xFF) == SQLITE_CORRUPT; }

// Finalizes on scope exit (statements prepared for one use).
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) { sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr); }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  bool ok() const { return statement_ != nullptr; }
  sqlite3_stmt* get() const { return statement_; }

 private:
  sqlite3_stmt* statement_ = nullptr;
};

// name -> sql of every table and index (SQLite's own excepted).
std::map<std::string, std::string> SchemaOf(sqlite3* db, std::string* error) {
  std::map<std::string, std::string> schema;
  Statement read(db, "SELECT name, sql FROM sqlite_schema WHERE name NOT LIKE 'sqlite_%'");
  int result = SQLITE_ROW;
  while (read.ok() && (result = sqlite3_step(read.get())) == SQLITE_ROW) {
    schema[ColumnText(read.get(), 0)] = ColumnText(read.get(), 1);
  }
  if (!read.ok() || result != SQLITE_DONE) *error = sqlite3_errmsg(db);
  return schema;
}

// The schema a journal of this format has, from kSchema run on an empty in-memory database.
std::map<std::string, std::string> ExpectedSchema() {
  sqlite3* db = nullptr;
  sqlite3_open(":memory:", &db);
  sqlite3_exec(db, kSchema, nullptr, nullptr, nullptr);
  std::string error;
  std::map<std::string, std::string> schema = SchemaOf(db, &error);
  sqlite3_close(db);
  return schema;
}

std::string Join(const std::vector<std::string>& items) {
  std::string joined;
  for (const std::string& item : items) joined += (joined.empty() ? "" : "; ") + item;
  return joined;
}

Status Unusable(const std::string& path, const std::string& why) {
  return FailedPrecondition("journal", "cannot use \"" + path + "\": " + why);
}

Status Damaged(const std::string& path, const std::vector<std::string>& damage) {
  return DataLoss("journal",
                  "\"" + path + "\" is damaged: " + Join(damage) +
                      ". Nothing was changed; start mdrd with --journal-recover to restore what "
                      "is intact (the damaged files are kept as \"" +
                      path + ".damaged\")");
}

}  // namespace

bool ParseJournalSync(const std::string& text, JournalSync* sync) {
  for (JournalSync candidate : {JournalSync::kOff, JournalSync::kNormal, JournalSync::kFull}) {
    if (text == JournalSyncName(candidate)) {
      *sync = candidate;
      return true;
    }
  }
  return false;
}

const char* JournalSyncName(JournalSync sync) {
  switch (sync) {
    case JournalSync::kOff:
      return "off";
    case JournalSync::kNormal:
      return "normal";
    case JournalSync::kFull:
      return "full";
  }
  return "full";
}

Status Journal::Open(const JournalOptions& options, std::unique_ptr<Journal>* journal) {
  std::unique_ptr<Journal> opened(new Journal(options));
  std::vector<std::string> damage;
  if (Status status = opened->Connect(&damage); !status.ok()) return status;
  if (options.recover) {
    std::vector<JournaledSession> intact;
    opened->ReadSessions(&intact, &damage);
    if (!damage.empty()) {
      if (Status status = opened->Rebuild(intact); !status.ok()) return status;
      opened->recovery_drops_ = std::move(damage);
    }
  } else if (!damage.empty()) {
    return Damaged(options.path, damage);
  }
  std::string error;
  if (!opened->RecordCommits(&error)) return Unusable(options.path + ".commit", error);
  if (Status status = opened->StartCheckpointer(); !status.ok()) return status;
  opened->checkpoint_on_close_ = true;
  *journal = std::move(opened);
  return OkStatus();
}

Status Journal::Connect(std::vector<std::string>* damage) {
  const std::string& path = options_.path;
  std::string error;
  lock_file_ = CreatePrivatelyAndLock(path, &error);
  if (lock_file_ < 0) return Unusable(path, error);
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      kVfs) != SQLITE_OK) {
    return Unusable(path, db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory");
  }
  // Normal locking mode (the flock above keeps other processes out), so that the checkpointer's
  // own connection can checkpoint while this one writes. No automatic checkpoints: one would run
  // on the committing thread, under mutex_, and its fsyncs (5-20 ms measured here) would hold
  // every caller's commit.
  if (!Execute("PRAGMA journal_mode=WAL", &error) ||
      !Execute("PRAGMA wal_autocheckpoint=0", &error) ||
      !Execute(SynchronousPragma(options_.sync), &error) ||
      // A deletion must not need as much space as it frees (Debian's SQLite overwrites deleted
      // content by default), and the log shrinks back after a checkpoint.
      !Execute("PRAGMA secure_delete=OFF", &error) ||
      !Execute("PRAGMA journal_size_limit=4194304", &error) ||
      !Execute("BEGIN IMMEDIATE", &error)) {
    if (IsCorruption(sqlite3_extended_errcode(db_))) {
      damage->push_back("the database cannot be read (" + error + ")");
      return OkStatus();
    }
    return Unusable(path, error + " (is another mdrd using it?)");
  }
  int version = 0;
  {
    Statement read_version(db_, "PRAGMA user_version");
    if (sqlite3_step(read_version.get()) == SQLITE_ROW) {
      version = sqlite3_column_int(read_version.get(), 0);
    }
  }
  if (version == 0) {
    // A new file, or one that SQLite reads but mdrd never wrote.
    const bool empty = SchemaOf(db_, &error).empty();
    if (!error.empty()) {
      damage->push_back("its schema cannot be read (" + error + ")");
      return OkStatus();
    }
    if (!empty) {
      Execute("ROLLBACK", &error);
      return Unusable(path, "not an mdr journal (it has tables but no journal format version)");
    }
    if (!Execute(kSchema, &error) ||
        !Execute(("PRAGMA user_version=" + std::to_string(kFormatVersion)).c_str(), &error)) {
      return Unusable(path, error);
    }
  } else if (version != kFormatVersion) {
    Execute("ROLLBACK", &error);
    return Unusable(
        path, "journal format " + std::to_string(version) + " is not this mdrd's (" +
                  std::to_string(kFormatVersion) +
                  (version < kFormatVersion ? "); export its sessions with the mdrd that wrote it"
                                            : ", a newer mdrd wrote it)"));
  } else {
    CheckSchema(damage);
    CheckIntegrity(damage);
  }
  if (!Execute("COMMIT", &error)) return Unusable(path, error);
  CheckCommits(damage);
  return Prepare();
}

void Journal::CheckSchema(std::vector<std::string>* damage) {
  static const std::map<std::string, std::string> expected = ExpectedSchema();
  std::string error;
  const std::map<std::string, std::string> actual = SchemaOf(db_, &error);
  if (!error.empty()) {
    damage->push_back("its schema cannot be read (" + error + ")");
    return;
  }
  for (const auto& [name, sql] : expected) {
    auto found = actual.find(name);
    if (found == actual.end()) {
      damage->push_back("table " + name + " is missing");
    } else if (found->second != sql) {
      damage->push_back("table " + name + " is not defined as this format defines it");
    }
  }
  for (const auto& [name, sql] : actual) {
    if (!expected.contains(name)) damage->push_back("it has an unknown table or index " + name);
  }
}

void Journal::CheckIntegrity(std::vector<std::string>* damage) {
  constexpr int kReported = 5;
  Statement check(db_, ("PRAGMA quick_check(" + std::to_string(kReported) + ")").c_str());
  int result = SQLITE_ROW;
  while ((result = sqlite3_step(check.get())) == SQLITE_ROW) {
    const std::string finding = ColumnText(check.get(), 0);
    if (finding != "ok") damage->push_back("integrity check: " + finding);
  }
  if (result != SQLITE_DONE) {
    damage->push_back("the integrity check failed (" + std::string(sqlite3_errmsg(db_)) + ")");
  }
}

void Journal::CheckCommits(std::vector<std::string>* damage) {
  const std::string side_path = options_.path + ".commit";
  commit_file_ = ::open(side_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (commit_file_ < 0) {
    damage->push_back("\"" + side_path + "\" cannot be opened (" + std::strerror(errno) + ")");
    return;
  }
  std::array<unsigned char, 2 * kCommitSlotBytes> slots{};
  const ssize_t size = ::pread(commit_file_, slots.data(), slots.size(), 0);
  std::optional<std::uint64_t> recorded;
  for (int slot = 0; slot < 2; ++slot) {
    if (size < static_cast<ssize_t>((slot + 1) * kCommitSlotBytes)) break;
    if (auto commits = DecodeCommitSlot(slots.data() + slot * kCommitSlotBytes)) {
      recorded = std::max(recorded.value_or(0), *commits);
    }
  }
  side_commits_ = recorded.value_or(0);  // a recovery's counter goes past it
  {
    Statement read(db_,
                   "SELECT max(count, (SELECT ifnull(max(commit_number), 0) FROM batches)) FROM "
                   "commits WHERE id = 1");
    if (!read.ok() || sqlite3_step(read.get()) != SQLITE_ROW) {
      if (read.ok()) damage->push_back("its commit counter is missing");
      return;  // a missing table is reported by CheckSchema
    }
    commits_ = ColumnInteger(read.get(), 0);
  }
  if (size <= 0) {
    // Written right after the schema; only a crash in between leaves it empty, before any
    // commit.
    if (commits_ > 0) {
      damage->push_back("\"" + side_path +
                        "\" is missing or empty, so lost commits cannot be ruled out (copy a "
                        "journal together with its .commit file)");
    }
  } else if (!recorded) {
    damage->push_back("\"" + side_path + "\" is damaged (no valid record of the last commit)");
  } else if (*recorded > commits_ && commits_ == 0) {
    damage->push_back("the database is empty but \"" + side_path + "\" records " +
                      std::to_string(*recorded) +
                      " commits: the journal was lost (to start a new journal on purpose, move "
                      "the .commit file aside with it)");
  } else if (*recorded > commits_) {
    const std::string lost =
        *recorded == commits_ + 1
            ? "commit " + std::to_string(*recorded) + " is"
            : "commits " + std::to_string(commits_ + 1) + "-" + std::to_string(*recorded) + " are";
    damage->push_back(lost + " missing: the database ends at commit " + std::to_string(commits_) +
                      " but commit " + std::to_string(*recorded) +
                      " was made (a truncated or damaged write-ahead log, or a machine crash "
                      "under --journal-sync off/normal); the batches, sessions and deletions "
                      "they recorded are lost");
  }
}

Status Journal::Prepare() {
  const std::pair<sqlite3_stmt**, const char*> statements[] = {
      {&begin_, "BEGIN"},
      {&commit_, "COMMIT"},
      {&rollback_, "ROLLBACK"},
      {&count_commit_, "UPDATE commits SET count = ?1 WHERE id = 1"},
      {&insert_session_,
       "INSERT OR REPLACE INTO sessions(name, owner, create_time_seconds, create_time_nanos, "
       "snapshot_sequence, snapshot, checksum) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)"},
      {&insert_batch_,
       "INSERT INTO batches(session, sequence, request_id, request, commit_number, checksum) "
       "VALUES(?1, ?2, ?3, ?4, ?5, ?6)"},
      {&update_snapshot_,
       "UPDATE sessions SET snapshot_sequence = ?2, snapshot = ?3, checksum = ?4 WHERE name = ?1"},
      {&delete_batches_up_to_, "DELETE FROM batches WHERE session = ?1 AND sequence <= ?2"},
      {&delete_session_, "DELETE FROM sessions WHERE name = ?1"},
      {&delete_all_batches_, "DELETE FROM batches WHERE session = ?1"},
      {&insert_request_,
       "INSERT INTO requests(session, position, request_id, fingerprint, response, checksum) "
       "VALUES(?1, ?2, ?3, ?4, ?5, ?6)"},
      {&delete_requests_, "DELETE FROM requests WHERE session = ?1"},
  };
  for (const auto& [statement, sql] : statements) {
    if (sqlite3_prepare_v2(db_, sql, -1, statement, nullptr) != SQLITE_OK) {
      // A damaged schema: reported by CheckSchema; Rebuild or the refusal follows.
      *statement = nullptr;
    }
  }
  return OkStatus();
}

void Journal::FinalizeStatements() {
  for (sqlite3_stmt** statement :
       {&begin_, &commit_, &rollback_, &count_commit_, &insert_session_, &insert_batch_,
        &update_snapshot_, &delete_batches_up_to_, &delete_session_, &delete_all_batches_,
        &insert_request_, &delete_requests_}) {
    sqlite3_finalize(*statement);
    *statement = nullptr;
  }
}

void Journal::Disconnect(bool keep_log) {
  StopCheckpointer();
  FinalizeStatements();
  if (db_ != nullptr) {
    sqlite3_wal_hook(db_, nullptr, nullptr);
    if (keep_log) sqlite3_db_config(db_, SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
  }
  sqlite3_close(db_);
  db_ = nullptr;
  if (commit_file_ >= 0) ::close(commit_file_);
  commit_file_ = -1;
  if (lock_file_ >= 0) ::close(lock_file_);  // after SQLite's descriptors
  lock_file_ = -1;
  log_inode_ = 0;
}

// SQLite calls it after every commit (on the writer's connection, under mutex_) with the pages
// in the write-ahead log, those already checkpointed included: a checkpoint is asked for once per
// kCheckpointPages new pages, not after every commit while the log waits to start over.
int Journal::OnWalCommit(void* journal, sqlite3*, const char*, int pages) {
  auto* self = static_cast<Journal*>(journal);
  if (pages < self->pages_at_checkpoint_request_) self->pages_at_checkpoint_request_ = 0;
  if (pages - self->pages_at_checkpoint_request_ >= kCheckpointPages) {
    self->pages_at_checkpoint_request_ = pages;
    std::lock_guard lock(self->checkpoint_mutex_);
    self->checkpoint_wanted_ = true;
    self->checkpoint_wakeup_.notify_one();
  }
  return SQLITE_OK;
}

Status Journal::StartCheckpointer() {
  sqlite3* db = nullptr;
  std::string error;
  if (sqlite3_open_v2(options_.path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_NOMUTEX,
                      kVfs) != SQLITE_OK ||
      sqlite3_exec(db, SynchronousPragma(options_.sync), nullptr, nullptr, nullptr) != SQLITE_OK) {
    error = db != nullptr ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return Unusable(options_.path, "cannot open its checkpointer's connection: " + error);
  }
  // Never checkpoints on close: the writer's connection does, last.
  sqlite3_db_config(db, SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
  sqlite3_wal_hook(db_, &Journal::OnWalCommit, this);
  checkpoint_stop_ = false;
  pages_at_checkpoint_request_ = 0;
  checkpointer_ = std::thread([this, db] { RunCheckpointer(db); });
  return OkStatus();
}

void Journal::StopCheckpointer() {
  if (!checkpointer_.joinable()) return;
  {
    std::lock_guard lock(checkpoint_mutex_);
    checkpoint_stop_ = true;
    checkpoint_wakeup_.notify_one();
  }
  checkpointer_.join();
}

// PASSIVE: copies the committed frames into the database and syncs it (as synchronous says)
// without taking the writer's lock, so commits go on meanwhile; the writer starts the log over
// once a checkpoint has copied all of it.
void Journal::RunCheckpointer(sqlite3* db) {
  std::unique_lock lock(checkpoint_mutex_);
  while (true) {
    checkpoint_wakeup_.wait(lock, [this] { return checkpoint_wanted_ || checkpoint_stop_; });
    if (checkpoint_stop_) break;
    checkpoint_wanted_ = false;
    lock.unlock();
    const int result =
        sqlite3_wal_checkpoint_v2(db, "main", SQLITE_CHECKPOINT_PASSIVE, nullptr, nullptr);
    if (result == SQLITE_OK) {
      checkpoints_.fetch_add(1, std::memory_order_relaxed);
    } else if (result != SQLITE_BUSY) {
      spdlog::error("event=journal_error path={} error=\"checkpoint: {}\"", options_.path,
                    sqlite3_errmsg(db));
    }
    lock.lock();
  }
  lock.unlock();
  sqlite3_close(db);
}

// A journal refused at open is closed as it was found (its log is not checkpointed away).
// A journal whose files were deleted since its last write is rewritten first, so that the
// restart finds what was acknowledged.
Journal::~Journal() {
  if (checkpoint_on_close_) {
    std::lock_guard lock(mutex_);
    EnsureFilesAreOurs("close");
  }
  Disconnect(/*keep_log=*/!checkpoint_on_close_);
}

Status Journal::Load(std::vector<JournaledSession>* sessions) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> damage;
  ReadSessions(sessions, &damage);
  if (!damage.empty()) {
    sessions->clear();
    return Damaged(options_.path, damage);
  }
  return OkStatus();
}

void Journal::ReadSessions(std::vector<JournaledSession>* sessions,
                           std::vector<std::string>* damage) {
  sessions->clear();
  Statement read(db_,
                 "SELECT name, owner, create_time_seconds, create_time_nanos, snapshot_sequence, "
                 "snapshot, checksum FROM sessions ORDER BY name");
  if (!read.ok()) {
    damage->push_back("the sessions cannot be read (" + std::string(sqlite3_errmsg(db_)) + ")");
    return;
  }
  int result = SQLITE_ROW;
  while ((result = sqlite3_step(read.get())) == SQLITE_ROW) {
    JournaledSession session;
    session.name = ColumnText(read.get(), 0);
    session.owner = ColumnText(read.get(), 1);
    session.create_time.set_seconds(sqlite3_column_int64(read.get(), 2));
    session.create_time.set_nanos(sqlite3_column_int(read.get(), 3));
    session.snapshot_sequence = ColumnInteger(read.get(), 4);
    const std::string_view snapshot = ColumnBlob(read.get(), 5);
    if (!SessionStore::IsSessionName(session.name)) {
      damage->push_back("a session entry named \"" + session.name.substr(0, 80) +
                        "\" dropped (not a session name \"sessions/{session_id}\")");
    } else if (ColumnInteger(read.get(), 6) !=
               SessionChecksum(session.name, session.owner, session.create_time,
                               session.snapshot_sequence, snapshot)) {
      damage->push_back("session " + session.name +
                        " dropped (its entry's checksum does not match)");
    } else if (!session.snapshot.ParseFromArray(snapshot.data(),
                                                static_cast<int>(snapshot.size()))) {
      damage->push_back("session " + session.name + " dropped (its snapshot does not parse)");
    } else {
      sessions->push_back(std::move(session));
    }
  }
  if (result != SQLITE_DONE) {
    damage->push_back("the sessions after " +
                      (sessions->empty() ? std::string("the first") : sessions->back().name) +
                      " cannot be read (" + sqlite3_errmsg(db_) + ")");
  }
  for (JournaledSession& session : *sessions) {
    ReadRequests(&session, damage);
    ReadBatches(&session, damage);
  }
  ReadOrphans("batches", damage);
  ReadOrphans("requests", damage);
}

void Journal::ReadRequests(JournaledSession* session, std::vector<std::string>* damage) {
  Statement read(db_,
                 "SELECT position, request_id, fingerprint, response, checksum FROM requests "
                 "WHERE session = ?1 ORDER BY position");
  if (!read.ok()) return;  // a missing table: reported by CheckSchema
  BindText(read.get(), 1, session->name);
  int result = SQLITE_ROW;
  std::string problem;
  while (problem.empty() && (result = sqlite3_step(read.get())) == SQLITE_ROW) {
    CompletedRequest& request = session->completed.emplace_back();
    const std::uint64_t position = ColumnInteger(read.get(), 0);
    request.request_id = ColumnText(read.get(), 1);
    request.fingerprint = ColumnInteger(read.get(), 2);
    const std::string_view response = ColumnBlob(read.get(), 3);
    if (ColumnInteger(read.get(), 4) != RequestChecksum(session->name, position, request.request_id,
                                                        request.fingerprint, response)) {
      problem = "checksum of request " + request.request_id + " does not match";
    } else if (!request.response.ParseFromArray(response.data(),
                                                static_cast<int>(response.size()))) {
      problem = "the response of request " + request.request_id + " does not parse";
    }
  }
  if (problem.empty() && result != SQLITE_DONE) problem = sqlite3_errmsg(db_);
  if (!problem.empty()) {
    session->completed.clear();
    damage->push_back("session " + session->name +
                      ": the responses remembered for its request ids dropped (" + problem +
                      "); a retry of an earlier batch is applied again");
  }
}

void Journal::ReadBatches(JournaledSession* session, std::vector<std::string>* damage) {
  Statement read(db_,
                 "SELECT sequence, request_id, request, commit_number, checksum FROM batches "
                 "WHERE session = ?1 AND sequence > ?2 ORDER BY sequence");
  if (!read.ok()) return;  // a missing table: reported by CheckSchema
  BindText(read.get(), 1, session->name);
  BindInteger(read.get(), 2, session->snapshot_sequence);
  int result = SQLITE_ROW;
  std::string problem;
  std::uint64_t first_dropped = 0, last_dropped = 0;
  while ((result = sqlite3_step(read.get())) == SQLITE_ROW) {
    const std::uint64_t sequence = ColumnInteger(read.get(), 0);
    if (!problem.empty()) {  // counting what is dropped after the first damaged batch
      last_dropped = sequence;
      continue;
    }
    const std::uint64_t expected = session->snapshot_sequence + session->batches.size() + 1;
    const std::string request_id = ColumnText(read.get(), 1);
    const std::string_view bytes = ColumnBlob(read.get(), 2);
    JournaledBatch batch;
    batch.sequence = sequence;
    if (sequence != expected) {
      problem = "batch " + std::to_string(expected) + " is missing";
      first_dropped = expected;
    } else if (ColumnInteger(read.get(), 4) != BatchChecksum(session->name, sequence, request_id,
                                                             bytes, ColumnInteger(read.get(), 3))) {
      problem = "the checksum of batch " + std::to_string(sequence) + " does not match";
    } else if (!batch.request.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
      problem = "batch " + std::to_string(sequence) + " does not parse";
    } else {
      session->batches.push_back(std::move(batch));
      continue;
    }
    if (first_dropped == 0) first_dropped = sequence;
    last_dropped = sequence;
  }
  if (problem.empty() && result != SQLITE_DONE) {
    problem = sqlite3_errmsg(db_);
    first_dropped = session->snapshot_sequence + session->batches.size() + 1;
  }
  if (problem.empty()) return;
  damage->push_back("session " + session->name + ": " +
                    (last_dropped > first_dropped ? "batches " + std::to_string(first_dropped) +
                                                        "-" + std::to_string(last_dropped)
                                                  : "batch " + std::to_string(first_dropped)) +
                    " dropped (" + problem + "); restored as of batch " +
                    std::to_string(session->snapshot_sequence + session->batches.size()));
}

void Journal::ReadOrphans(const char* table, std::vector<std::string>* damage) {
  Statement read(db_, (std::string("SELECT session, COUNT(*) FROM ") + table +
                       " WHERE session NOT IN (SELECT name FROM sessions) GROUP BY session")
                          .c_str());
  if (!read.ok()) {
    damage->push_back(std::string("the ") + table + " cannot be read (" + sqlite3_errmsg(db_) +
                      ")");
    return;
  }
  while (sqlite3_step(read.get()) == SQLITE_ROW) {
    damage->push_back(std::to_string(sqlite3_column_int64(read.get(), 1)) + " " + table +
                      " rows of " + ColumnText(read.get(), 0) +
                      " dropped (the session has no entry)");
  }
}

Status Journal::Rebuild(const std::vector<JournaledSession>& intact) {
  const std::string& path = options_.path;
  for (const char* suffix : {"", "-wal", ".commit"}) {  // as found, for inspection
    std::error_code error;
    if (!std::filesystem::exists(path + suffix, error)) continue;
    std::filesystem::copy_file(path + suffix, path + ".damaged" + suffix,
                               std::filesystem::copy_options::overwrite_existing, error);
    if (error) return Unusable(path + suffix, "cannot copy it aside: " + error.message());
  }
  std::string error;
  if (db_ != nullptr && RewriteInPlace(intact, &error)) return OkStatus();
  // Not even rewritable: a new file (what was intact is in `intact` and the copy).
  spdlog::warn(
      "event=journal_recovery path={} note=\"rewriting in place failed ({}); starting a "
      "new file\"",
      path, error);
  Disconnect(/*keep_log=*/true);
  for (const char* suffix : {"", "-wal", "-shm", ".commit"}) {
    std::error_code ignored;
    std::filesystem::remove(path + suffix, ignored);
  }
  std::vector<std::string> damage;
  if (Status status = Connect(&damage); !status.ok()) return status;
  if (!RewriteInPlace(intact, &error)) return Unusable(path, error);
  return OkStatus();
}

// One transaction: a crash before its commit leaves the damaged journal as it was (recovered
// again at the next start), after it a consistent one. Its counter goes past the side file's, so
// the side file, written after the commit, is never ahead.
bool Journal::RewriteInPlace(const std::vector<JournaledSession>& intact, std::string* error) {
  FinalizeStatements();
  std::vector<std::pair<std::string, std::string>> objects;  // type, name
  {
    Statement read(db_,
                   "SELECT type, name FROM sqlite_schema WHERE name NOT LIKE 'sqlite_%' AND type "
                   "IN ('table', 'view', 'trigger')");
    while (read.ok() && sqlite3_step(read.get()) == SQLITE_ROW) {
      objects.emplace_back(ColumnText(read.get(), 0), ColumnText(read.get(), 1));
    }
  }
  const std::uint64_t commit = std::max(commits_, side_commits_) + 1;
  bool written = Execute("BEGIN", error);
  for (const auto& [type, name] : objects) {
    std::string quoted;
    for (char c : name) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    written = written && Execute(("DROP " + type + " IF EXISTS \"" + quoted + "\"").c_str(), error);
  }
  written = written && Execute(kSchema, error) && Prepare().ok();
  for (const JournaledSession& session : intact) {
    written = written && WriteSession(session, error).ok();
  }
  BindInteger(count_commit_, 1, commit);
  if (written && count_commit_ != nullptr && Execute(count_commit_, error) &&
      Execute("COMMIT", error)) {
    commits_ = commit;
    return true;
  }
  std::string ignored;
  Execute("ROLLBACK", &ignored);
  return false;
}

Status Journal::WriteSession(const JournaledSession& session, std::string* error) {
  const std::string snapshot = session.snapshot.SerializeAsString();
  BindText(insert_session_, 1, session.name);
  BindText(insert_session_, 2, session.owner);
  sqlite3_bind_int64(insert_session_, 3, session.create_time.seconds());
  sqlite3_bind_int(insert_session_, 4, session.create_time.nanos());
  BindInteger(insert_session_, 5, session.snapshot_sequence);
  BindBlob(insert_session_, 6, snapshot);
  BindInteger(insert_session_, 7,
              SessionChecksum(session.name, session.owner, session.create_time,
                              session.snapshot_sequence, snapshot));
  if (!Execute(insert_session_, error)) return Unusable(options_.path, *error);
  for (std::size_t position = 0; position < session.completed.size(); ++position) {
    const CompletedRequest& request = session.completed[position];
    const std::string response = request.response.SerializeAsString();
    BindText(insert_request_, 1, session.name);
    BindInteger(insert_request_, 2, position);
    BindText(insert_request_, 3, request.request_id);
    BindInteger(insert_request_, 4, request.fingerprint);
    BindBlob(insert_request_, 5, response);
    BindInteger(
        insert_request_, 6,
        RequestChecksum(session.name, position, request.request_id, request.fingerprint, response));
    if (!Execute(insert_request_, error)) return Unusable(options_.path, *error);
  }
  for (const JournaledBatch& batch : session.batches) {
    const std::string request = batch.request.SerializeAsString();
    BindText(insert_batch_, 1, session.name);
    BindInteger(insert_batch_, 2, batch.sequence);
    BindText(insert_batch_, 3, batch.request.request_id());
    BindBlob(insert_batch_, 4, request);
    BindInteger(insert_batch_, 5, 0);  // a rebuilt journal's counter starts at 0
    BindInteger(
        insert_batch_, 6,
        BatchChecksum(session.name, batch.sequence, batch.request.request_id(), request, 0));
    if (!Execute(insert_batch_, error)) return Unusable(options_.path, *error);
  }
  return OkStatus();
}

std::uint64_t JournalRoom(const std::string& path) {
  const std::filesystem::path file(path);
  const std::filesystem::path directory =
      file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
  struct statvfs volume {};
  if (::statvfs(directory.c_str(), &volume) != 0) return 0;
  std::uint64_t room = static_cast<std::uint64_t>(volume.f_bavail) * volume.f_frsize;
  struct rlimit limit {};
  if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
    std::uint64_t largest = 0;
    for (const char* suffix : {"", "-wal", ".commit"}) {
      struct stat info {};
      if (::stat((path + suffix).c_str(), &info) == 0) {
        largest = std::max(largest, static_cast<std::uint64_t>(info.st_size));
      }
    }
    const auto cap = static_cast<std::uint64_t>(limit.rlim_cur);
    room = std::min(room, cap > largest ? cap - largest : 0);
  }
  return room;
}

Status Journal::CheckRoom(const char* what) {
  const std::uint64_t room = JournalRoom(options_.path);
  ProcessMetrics().journal_free_bytes.Set(static_cast<double>(room));
  const bool below = room < options_.min_free_bytes;
  if (below != below_floor_) {
    below_floor_ = below;
    if (below) {
      spdlog::error(
          "event=journal_low_space path={} room_bytes={} min_free_bytes={} action=\"new sessions "
          "and batches are refused; DeleteSession and ExportSession go on\"",
          options_.path, room, options_.min_free_bytes);
    } else {
      spdlog::info("event=journal_space_restored path={} room_bytes={} min_free_bytes={}",
                   options_.path, room, options_.min_free_bytes);
    }
  }
  if (!below) return OkStatus();
  ProcessMetrics().journal_refusals.Increment();
  return Unavailable("", std::string("journal: cannot ") + what + ": the journal may grow by " +
                             std::to_string(room) + " bytes, below --journal-min-free-bytes = " +
                             std::to_string(options_.min_free_bytes) +
                             " kept for deletions; delete or export sessions, or free space");
}

Status Journal::AddSession(const std::string& name, const std::string& owner,
                           const google::protobuf::Timestamp& create_time,
                           const v1::SessionSnapshot& snapshot) {
  {
    std::lock_guard lock(mutex_);
    if (Status s = CheckRoom("record the new session"); !s.ok()) return s;
  }
  JournaledSession session;
  session.name = name;
  session.owner = owner;
  session.create_time = create_time;
  session.snapshot = snapshot;
  return InTransaction("record the new session", /*row_carries_commit=*/false,
                       [&](std::uint64_t, std::string* error) {
                         BindText(delete_all_batches_, 1, name);
                         BindText(delete_requests_, 1, name);
                         return Execute(delete_all_batches_, error) &&
                                Execute(delete_requests_, error) &&
                                WriteSession(session, error).ok();
                       });
}

Status Journal::AddBatch(const std::string& session, std::uint64_t sequence,
                         const v1::ApplyRequest& request) {
  {
    std::lock_guard lock(mutex_);
    if (Status s = CheckRoom("record the batch"); !s.ok()) return s;
  }
  const std::string bytes = request.SerializeAsString();
  return InTransaction("record the batch", /*row_carries_commit=*/true,
                       [&](std::uint64_t commit, std::string* error) {
                         BindText(insert_batch_, 1, session);
                         BindInteger(insert_batch_, 2, sequence);
                         BindText(insert_batch_, 3, request.request_id());
                         BindBlob(insert_batch_, 4, bytes);
                         BindInteger(insert_batch_, 5, commit);
                         BindInteger(
                             insert_batch_, 6,
                             BatchChecksum(session, sequence, request.request_id(), bytes, commit));
                         return Execute(insert_batch_, error);
                       });
}

Status Journal::Compact(const std::string& session, std::uint64_t sequence,
                        const v1::SessionSnapshot& snapshot,
                        const std::vector<CompletedRequest>& completed) {
  const std::string bytes = snapshot.SerializeAsString();
  return InTransaction(
      "compact the session", /*row_carries_commit=*/false, [&](std::uint64_t, std::string* error) {
        // The row's other columns, for its checksum.
        Statement read(db_,
                       "SELECT owner, create_time_seconds, create_time_nanos FROM sessions WHERE "
                       "name = ?1");
        BindText(read.get(), 1, session);
        if (sqlite3_step(read.get()) != SQLITE_ROW) {
          *error = "the session has no entry";
          return false;
        }
        google::protobuf::Timestamp create_time;
        create_time.set_seconds(sqlite3_column_int64(read.get(), 1));
        create_time.set_nanos(sqlite3_column_int(read.get(), 2));
        const std::string owner = ColumnText(read.get(), 0);
        BindText(update_snapshot_, 1, session);
        BindInteger(update_snapshot_, 2, sequence);
        BindBlob(update_snapshot_, 3, bytes);
        BindInteger(update_snapshot_, 4,
                    SessionChecksum(session, owner, create_time, sequence, bytes));
        BindText(delete_batches_up_to_, 1, session);
        BindInteger(delete_batches_up_to_, 2, sequence);
        BindText(delete_requests_, 1, session);
        if (!Execute(update_snapshot_, error) || !Execute(delete_batches_up_to_, error) ||
            !Execute(delete_requests_, error)) {
          return false;
        }
        for (std::size_t position = 0; position < completed.size(); ++position) {
          const std::string response = completed[position].response.SerializeAsString();
          BindText(insert_request_, 1, session);
          BindInteger(insert_request_, 2, position);
          BindText(insert_request_, 3, completed[position].request_id);
          BindInteger(insert_request_, 4, completed[position].fingerprint);
          BindBlob(insert_request_, 5, response);
          BindInteger(insert_request_, 6,
                      RequestChecksum(session, position, completed[position].request_id,
                                      completed[position].fingerprint, response));
          if (!Execute(insert_request_, error)) return false;
        }
        return true;
      });
}

Status Journal::RemoveSession(const std::string& session) {
  return InTransaction(
      "record the deletion", /*row_carries_commit=*/false, [&](std::uint64_t, std::string* error) {
        BindText(delete_session_, 1, session);
        BindText(delete_all_batches_, 1, session);
        BindText(delete_requests_, 1, session);
        return Execute(delete_session_, error) && Execute(delete_all_batches_, error) &&
               Execute(delete_requests_, error);
      });
}

bool Journal::RecordCommits(std::string* error) {
  const auto slot = EncodeCommitSlot(commits_);
  const off_t offset = static_cast<off_t>((commits_ % 2) * kCommitSlotBytes);
  if (::pwrite(commit_file_, slot.data(), slot.size(), offset) ==
      static_cast<ssize_t>(slot.size())) {
    return true;
  }
  *error = std::strerror(errno);
  return false;
}

bool Journal::Execute(const char* sql, std::string* error) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) == SQLITE_OK) return true;
  *error = message != nullptr ? message : sqlite3_errmsg(db_);
  sqlite3_free(message);
  return false;
}

bool Journal::Execute(sqlite3_stmt* statement, std::string* error) {
  const int result = sqlite3_step(statement);
  if (result != SQLITE_DONE) *error = sqlite3_errmsg(db_);
  sqlite3_reset(statement);
  sqlite3_clear_bindings(statement);
  return result == SQLITE_DONE;
}

// Every write: the body and the commit counter's increment in one transaction, then the counter
// in the side file (after the commit, so the side file is never ahead of a commit that a crash of
// the process could lose).
template <typename Body>
Status Journal::InTransaction(const char* what, bool row_carries_commit, Body body) {
  std::lock_guard lock(mutex_);
  const JournalWriteTimer timer;
  if (Status ours = EnsureFilesAreOurs(what); !ours.ok()) return ours;
  std::string error;
  if (!Execute(begin_, &error)) return WriteError(what, error);
  BindInteger(count_commit_, 1, commits_ + 1);
  if (body(commits_ + 1, &error) && (row_carries_commit || Execute(count_commit_, &error)) &&
      Execute(commit_, &error)) {
    ++commits_;
    if (!RecordCommits(&error)) {
      // The commit stands; a side file behind the database is never taken for damage.
      spdlog::error("event=journal_error path={}.commit error=\"cannot record commit {}: {}\"",
                    options_.path, commits_, error);
    }
    return OkStatus();
  }
  std::string ignored;
  Execute(rollback_, &ignored);
  return WriteError(what, error);
}

namespace {

bool SameFile(const struct stat& a, const struct stat& b) {
  return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

// Writes and syncs a file's whole content at `path` through a temporary file renamed over it.
bool WriteFileAtomically(const std::string& path, const void* data, std::size_t size,
                         std::string* error) {
  const std::string temporary = path + ".new";
  const int file = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  bool done =
      file >= 0 && ::write(file, data, size) == static_cast<ssize_t>(size) && ::fsync(file) == 0;
  if (!done) *error = "\"" + temporary + "\": " + std::strerror(errno);
  if (file >= 0) ::close(file);
  if (done && ::rename(temporary.c_str(), path.c_str()) != 0) {
    *error = "\"" + path + "\": " + std::strerror(errno);
    done = false;
  }
  if (!done) ::unlink(temporary.c_str());
  return done;
}

bool SyncFile(const std::string& path, int flags, std::string* error) {
  const int file = ::open(path.c_str(), flags | O_CLOEXEC);
  const bool done = file >= 0 && ::fsync(file) == 0;
  if (!done) *error = "\"" + path + "\": " + std::strerror(errno);
  if (file >= 0) ::close(file);
  return done;
}

}  // namespace

bool Journal::FilesAreOurs(std::string* which) {
  const std::string& path = options_.path;
  struct stat held {
  }, named{};
  if (::fstat(lock_file_, &held) != 0 || held.st_nlink == 0 || ::stat(path.c_str(), &named) != 0 ||
      !SameFile(held, named)) {
    *which = path;
    return false;
  }
  if (::fstat(commit_file_, &held) != 0 || ::stat((path + ".commit").c_str(), &named) != 0 ||
      !SameFile(held, named)) {
    *which = path + ".commit";
    return false;
  }
  // The log is SQLite's: its inode is learnt when first seen and must stay the same (SQLite
  // truncates it but never removes it while a connection is open).
  const bool log_seen = log_inode_ != 0;
  if (::stat((path + "-wal").c_str(), &named) != 0) {
    if (!log_seen) return true;
    *which = path + "-wal";
    return false;
  }
  if (!log_seen) {
    log_device_ = named.st_dev;
    log_inode_ = named.st_ino;
  } else if (named.st_dev != log_device_ || named.st_ino != log_inode_) {
    *which = path + "-wal";
    return false;
  }
  return true;
}

Status Journal::EnsureFilesAreOurs(const char* what) {
  if (db_ == nullptr) {
    return WriteError(what,
                      "it was closed when it could not be reopened after a rewrite; what "
                      "was acknowledged is in its files, restart mdrd");
  }
  std::string which;
  if (FilesAreOurs(&which)) return OkStatus();
  spdlog::error(
      "event=journal_error path={} error=\"{} was deleted or replaced while mdrd had it open; "
      "rewriting the journal from the open files\"",
      options_.path, which);
  if (Reestablish(which).ok()) return OkStatus();
  return WriteError(what, "its file " + which +
                              " was deleted or replaced while mdrd had it open, and the journal "
                              "cannot be rewritten there yet; what was acknowledged is kept in "
                              "the open files and rewritten at the next write that can");
}

Status Journal::Reestablish(const std::string& which) {
  const std::string& path = options_.path;
  const std::string copy = path + ".rewrite";
  std::string error;
  std::error_code ignored;
  std::filesystem::remove(copy, ignored);
  {
    // Through the open connection: it reads the unlinked files, the log's commits included.
    Statement vacuum(db_, "VACUUM INTO ?1");
    const bool copied =
        vacuum.ok() &&
        sqlite3_bind_text(vacuum.get(), 1, copy.c_str(), -1, SQLITE_TRANSIENT) == SQLITE_OK &&
        sqlite3_step(vacuum.get()) == SQLITE_DONE;
    if (!copied) error = sqlite3_errmsg(db_);
    if (!copied || !SyncFile(copy, O_RDONLY, &error)) {
      std::filesystem::remove(copy, ignored);
      spdlog::error("event=journal_error path={} error=\"cannot rewrite the journal: {}\"", path,
                    error);
      return Unavailable("", error);
    }
  }
  std::array<unsigned char, 2 * kCommitSlotBytes> slots{};
  const auto slot = EncodeCommitSlot(commits_);
  std::copy(slot.begin(), slot.end(), slots.begin());
  std::copy(slot.begin(), slot.end(), slots.begin() + kCommitSlotBytes);
  const std::uint64_t commits = commits_;
  // From here on the copy replaces the open files: the old log must not meet the new database.
  Disconnect(/*keep_log=*/true);
  for (const char* suffix : {"-wal", "-shm"}) {
    std::filesystem::remove(path + suffix, ignored);
  }
  const std::string directory = std::filesystem::path(path).parent_path().string();
  if (!WriteFileAtomically(path + ".commit", slots.data(), slots.size(), &error) ||
      ::rename(copy.c_str(), path.c_str()) != 0 ||
      !SyncFile(directory.empty() ? "." : directory, O_RDONLY | O_DIRECTORY, &error)) {
    if (error.empty()) error = std::strerror(errno);
  }
  std::vector<std::string> damage;
  Status connected = error.empty() ? Connect(&damage) : Unavailable("", error);
  if (connected.ok() && !damage.empty()) connected = Unavailable("", Join(damage));
  if (connected.ok() && commits_ != commits) connected = Unavailable("", "the copy lost commits");
  if (connected.ok()) connected = StartCheckpointer();
  if (!connected.ok()) {
    // Nothing open is left to write to: every later write is refused (db_ is null).
    Disconnect(/*keep_log=*/true);
    spdlog::error(
        "event=journal_error path={} error=\"cannot reconnect to the rewritten journal: "
        "{}\"",
        path, connected.ToString());
    return connected;
  }
  spdlog::warn(
      "event=journal_rewritten path={} commits={} note=\"{} had been deleted or "
      "replaced; every acknowledged commit is in the new files\"",
      path, commits, which);
  return OkStatus();
}

Status Journal::WriteError(const char* what, const std::string& error) const {
  ProcessMetrics().journal_write_failures.Increment();
  spdlog::error("event=journal_error path={} error=\"cannot {}: {}\"", options_.path, what, error);
  return Unavailable("", std::string("journal: cannot ") + what + " (" + error + ")");
}

}  // namespace mdr::service
