#include "mdr/service/journal.h"

#include <sqlite3.h>

#include <string>
#include <utility>

#include "mdr/service/status.h"

namespace mdr::service {
namespace {

// PRAGMA user_version of a journal in this format.
constexpr int kFormatVersion = 1;

constexpr char kSchema[] = R"sql(
CREATE TABLE IF NOT EXISTS sessions(
  name TEXT PRIMARY KEY,
  owner TEXT NOT NULL,
  create_time_seconds INTEGER NOT NULL,
  create_time_nanos INTEGER NOT NULL,
  snapshot_sequence INTEGER NOT NULL,
  snapshot BLOB NOT NULL
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS batches(
  session TEXT NOT NULL,
  sequence INTEGER NOT NULL,
  request_id TEXT NOT NULL,
  request BLOB NOT NULL,
  PRIMARY KEY(session, sequence)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS requests(
  session TEXT NOT NULL,
  position INTEGER NOT NULL,
  request_id TEXT NOT NULL,
  fingerprint INTEGER NOT NULL,
  response BLOB NOT NULL,
  PRIMARY KEY(session, position)
) WITHOUT ROWID;
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
void BindSequence(sqlite3_stmt* statement, int index, std::uint64_t sequence) {
  sqlite3_bind_int64(statement, index, static_cast<sqlite3_int64>(sequence));
}

std::string ColumnText(sqlite3_stmt* statement, int column) {
  const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(statement, column));
  return text == nullptr ? std::string()
                         : std::string(text, sqlite3_column_bytes(statement, column));
}

template <typename Message>
bool ParseColumn(sqlite3_stmt* statement, int column, Message* message) {
  return message->ParseFromArray(sqlite3_column_blob(statement, column),
                                 sqlite3_column_bytes(statement, column));
}

// Finalizes on scope exit (statements prepared for one use).
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) { sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr); }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() const { return statement_; }

 private:
  sqlite3_stmt* statement_ = nullptr;
};

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

grpc::Status Journal::Open(const JournalOptions& options, std::unique_ptr<Journal>* journal) {
  std::unique_ptr<Journal> opened(new Journal(options));
  auto failure = [&](const std::string& why) {
    return GrpcError(grpc::StatusCode::FAILED_PRECONDITION, "journal",
                     "cannot use \"" + options.path + "\": " + why);
  };
  if (sqlite3_open_v2(options.path.c_str(), &opened->db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    return failure(opened->db_ != nullptr ? sqlite3_errmsg(opened->db_) : "out of memory");
  }
  std::string error;
  // Exclusive locking before WAL: no shared-memory index, and a second process cannot open the
  // journal while this one holds it (its first statement fails with "database is locked").
  if (!opened->Execute("PRAGMA locking_mode=EXCLUSIVE", &error) ||
      !opened->Execute("PRAGMA journal_mode=WAL", &error) ||
      !opened->Execute(SynchronousPragma(options.sync), &error) ||
      !opened->Execute("BEGIN IMMEDIATE", &error)) {
    return failure(error + " (is another mdrd using it?)");
  }
  int version = 0;
  {
    Statement read_version(opened->db_, "PRAGMA user_version");
    if (sqlite3_step(read_version.get()) == SQLITE_ROW) {
      version = sqlite3_column_int(read_version.get(), 0);
    }
  }
  if (version > kFormatVersion) {
    opened->Execute("ROLLBACK", &error);
    return failure("journal format " + std::to_string(version) + " is newer than this mdrd's (" +
                   std::to_string(kFormatVersion) + ")");
  }
  if (!opened->Execute(kSchema, &error) ||
      !opened->Execute(("PRAGMA user_version=" + std::to_string(kFormatVersion)).c_str(), &error) ||
      !opened->Execute("COMMIT", &error)) {
    return failure(error);
  }
  const std::pair<sqlite3_stmt**, const char*> statements[] = {
      {&opened->insert_session_,
       "INSERT OR REPLACE INTO sessions(name, owner, create_time_seconds, create_time_nanos, "
       "snapshot_sequence, snapshot) VALUES(?1, ?2, ?3, ?4, 0, ?5)"},
      {&opened->insert_batch_,
       "INSERT INTO batches(session, sequence, request_id, request) VALUES(?1, ?2, ?3, ?4)"},
      {&opened->update_snapshot_,
       "UPDATE sessions SET snapshot_sequence = ?2, snapshot = ?3 WHERE name = ?1"},
      {&opened->delete_batches_up_to_, "DELETE FROM batches WHERE session = ?1 AND sequence <= ?2"},
      {&opened->delete_session_, "DELETE FROM sessions WHERE name = ?1"},
      {&opened->delete_all_batches_, "DELETE FROM batches WHERE session = ?1"},
      {&opened->insert_request_,
       "INSERT INTO requests(session, position, request_id, fingerprint, response) "
       "VALUES(?1, ?2, ?3, ?4, ?5)"},
      {&opened->delete_requests_, "DELETE FROM requests WHERE session = ?1"},
  };
  for (const auto& [statement, sql] : statements) {
    if (sqlite3_prepare_v2(opened->db_, sql, -1, statement, nullptr) != SQLITE_OK) {
      return failure(sqlite3_errmsg(opened->db_));
    }
  }
  *journal = std::move(opened);
  return grpc::Status::OK;
}

Journal::~Journal() {
  for (sqlite3_stmt* statement :
       {insert_session_, insert_batch_, update_snapshot_, delete_batches_up_to_, delete_session_,
        delete_all_batches_, insert_request_, delete_requests_}) {
    sqlite3_finalize(statement);
  }
  sqlite3_close(db_);
}

grpc::Status Journal::Load(std::vector<JournaledSession>* sessions) {
  std::lock_guard lock(mutex_);
  sessions->clear();
  auto data_loss = [&](const std::string& what) {
    return GrpcError(grpc::StatusCode::DATA_LOSS, "journal",
                     "\"" + options_.path + "\": " + what +
                         " does not parse; move the journal aside to start without it");
  };
  Statement read_sessions(db_,
                          "SELECT name, owner, create_time_seconds, create_time_nanos, "
                          "snapshot_sequence, snapshot FROM sessions ORDER BY name");
  int result = SQLITE_ROW;
  while ((result = sqlite3_step(read_sessions.get())) == SQLITE_ROW) {
    JournaledSession& session = sessions->emplace_back();
    session.name = ColumnText(read_sessions.get(), 0);
    session.owner = ColumnText(read_sessions.get(), 1);
    session.create_time.set_seconds(sqlite3_column_int64(read_sessions.get(), 2));
    session.create_time.set_nanos(sqlite3_column_int(read_sessions.get(), 3));
    session.snapshot_sequence =
        static_cast<std::uint64_t>(sqlite3_column_int64(read_sessions.get(), 4));
    if (!ParseColumn(read_sessions.get(), 5, &session.snapshot)) {
      return data_loss("the snapshot of " + session.name);
    }
  }
  if (result != SQLITE_DONE) return WriteError("read the sessions", sqlite3_errmsg(db_));
  Statement read_requests(db_,
                          "SELECT request_id, fingerprint, response FROM requests WHERE "
                          "session = ?1 ORDER BY position");
  for (JournaledSession& session : *sessions) {
    sqlite3_reset(read_requests.get());
    BindText(read_requests.get(), 1, session.name);
    while ((result = sqlite3_step(read_requests.get())) == SQLITE_ROW) {
      JournaledRequest& request = session.completed.emplace_back();
      request.request_id = ColumnText(read_requests.get(), 0);
      request.fingerprint =
          static_cast<std::uint64_t>(sqlite3_column_int64(read_requests.get(), 1));
      if (!ParseColumn(read_requests.get(), 2, &request.response)) {
        return data_loss("the response of request " + request.request_id + " of " + session.name);
      }
    }
    if (result != SQLITE_DONE) return WriteError("read the requests", sqlite3_errmsg(db_));
  }
  Statement read_batches(db_,
                         "SELECT sequence, request FROM batches WHERE session = ?1 AND "
                         "sequence > ?2 ORDER BY sequence");
  for (JournaledSession& session : *sessions) {
    sqlite3_reset(read_batches.get());
    BindText(read_batches.get(), 1, session.name);
    BindSequence(read_batches.get(), 2, session.snapshot_sequence);
    while ((result = sqlite3_step(read_batches.get())) == SQLITE_ROW) {
      JournaledBatch& batch = session.batches.emplace_back();
      batch.sequence = static_cast<std::uint64_t>(sqlite3_column_int64(read_batches.get(), 0));
      if (!ParseColumn(read_batches.get(), 1, &batch.request)) {
        return data_loss("batch " + std::to_string(batch.sequence) + " of " + session.name);
      }
    }
    if (result != SQLITE_DONE) return WriteError("read the batches", sqlite3_errmsg(db_));
  }
  return grpc::Status::OK;
}

grpc::Status Journal::AddSession(const std::string& name, const std::string& owner,
                                 const google::protobuf::Timestamp& create_time,
                                 const v1::SessionSnapshot& snapshot) {
  const std::string bytes = snapshot.SerializeAsString();
  return InTransaction("record the new session", [&](std::string* error) {
    BindText(delete_all_batches_, 1, name);
    BindText(delete_requests_, 1, name);
    BindText(insert_session_, 1, name);
    BindText(insert_session_, 2, owner);
    sqlite3_bind_int64(insert_session_, 3, create_time.seconds());
    sqlite3_bind_int(insert_session_, 4, create_time.nanos());
    BindBlob(insert_session_, 5, bytes);
    return Step(delete_all_batches_, error) && Step(delete_requests_, error) &&
           Step(insert_session_, error);
  });
}

grpc::Status Journal::AddBatch(const std::string& session, std::uint64_t sequence,
                               const v1::ApplyRequest& request) {
  const std::string bytes = request.SerializeAsString();
  std::lock_guard lock(mutex_);
  BindText(insert_batch_, 1, session);
  BindSequence(insert_batch_, 2, sequence);
  BindText(insert_batch_, 3, request.request_id());
  BindBlob(insert_batch_, 4, bytes);
  std::string error;
  if (!Step(insert_batch_, &error)) return WriteError("record the batch", error);
  return grpc::Status::OK;
}

grpc::Status Journal::Compact(const std::string& session, std::uint64_t sequence,
                              const v1::SessionSnapshot& snapshot,
                              const std::vector<JournaledRequest>& completed) {
  const std::string bytes = snapshot.SerializeAsString();
  return InTransaction("compact the session", [&](std::string* error) {
    BindText(update_snapshot_, 1, session);
    BindSequence(update_snapshot_, 2, sequence);
    BindBlob(update_snapshot_, 3, bytes);
    BindText(delete_batches_up_to_, 1, session);
    BindSequence(delete_batches_up_to_, 2, sequence);
    BindText(delete_requests_, 1, session);
    if (!Step(update_snapshot_, error) || !Step(delete_batches_up_to_, error) ||
        !Step(delete_requests_, error)) {
      return false;
    }
    for (std::size_t position = 0; position < completed.size(); ++position) {
      const std::string response = completed[position].response.SerializeAsString();
      BindText(insert_request_, 1, session);
      sqlite3_bind_int64(insert_request_, 2, static_cast<sqlite3_int64>(position));
      BindText(insert_request_, 3, completed[position].request_id);
      sqlite3_bind_int64(insert_request_, 4,
                         static_cast<sqlite3_int64>(completed[position].fingerprint));
      BindBlob(insert_request_, 5, response);
      if (!Step(insert_request_, error)) return false;
    }
    return true;
  });
}

grpc::Status Journal::RemoveSession(const std::string& session) {
  return InTransaction("record the deletion", [&](std::string* error) {
    BindText(delete_session_, 1, session);
    BindText(delete_all_batches_, 1, session);
    BindText(delete_requests_, 1, session);
    return Step(delete_session_, error) && Step(delete_all_batches_, error) &&
           Step(delete_requests_, error);
  });
}

bool Journal::Execute(const char* sql, std::string* error) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) == SQLITE_OK) return true;
  *error = message != nullptr ? message : sqlite3_errmsg(db_);
  sqlite3_free(message);
  return false;
}

bool Journal::Step(sqlite3_stmt* statement, std::string* error) {
  const int result = sqlite3_step(statement);
  if (result != SQLITE_DONE) *error = sqlite3_errmsg(db_);
  sqlite3_reset(statement);
  sqlite3_clear_bindings(statement);
  return result == SQLITE_DONE;
}

template <typename Body>
grpc::Status Journal::InTransaction(const char* what, Body body) {
  std::lock_guard lock(mutex_);
  std::string error;
  if (!Execute("BEGIN", &error)) return WriteError(what, error);
  if (body(&error) && Execute("COMMIT", &error)) return grpc::Status::OK;
  std::string ignored;
  Execute("ROLLBACK", &ignored);
  return WriteError(what, error);
}

grpc::Status Journal::WriteError(const char* what, const std::string& error) const {
  return GrpcError(grpc::StatusCode::UNAVAILABLE, "",
                   std::string("journal: cannot ") + what + " (" + error + ")");
}

}  // namespace mdr::service
