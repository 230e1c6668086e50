// The session journal: restoring replays every journaled batch bit-identically (state, applied
// steps, and the responses remembered for request ids), compaction replaces batches by a snapshot
// without changing what is restored, deleted sessions stay deleted, owners are kept, and one
// journal serves one process at a time. A session that cannot be restored is kept aside as
// unavailable while the others come back; a damaged journal (truncated or flipped write-ahead
// log, a dropped table, a damaged row, a missing batch) is refused, and with `recover` what is
// intact is restored and the journal is consistent again. The crash tests against the real mdrd
// binary are in journal_crash_test.py.
#include "mdr/service/journal.h"

#include <fcntl.h>
#include <google/protobuf/util/message_differencer.h>
#include <linux/fs.h>
#include <sqlite3.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <thread>

#include "mdr/service/grpc_status.h"
#include "mdr/service/operations.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using google::protobuf::util::MessageDifferencer;
using service::ContactOperations;
using service::Journal;
using service::JournaledSession;
using service::JournalOptions;
using service::Principal;
using service::ToGrpcStatus;

class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    std::string pattern = (std::filesystem::temp_directory_path() / "mdr-journal-XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TemporaryDirectory() { std::filesystem::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A ContactOperations on a journal, as mdrd holds it; destroying it without CompactJournal is a
// crash as far as the journal can tell (every batch was committed when it was answered).
class JournalTest : public ::testing::Test {
 protected:
  JournalOptions Options(std::uint32_t snapshot_every = 1000) const {
    JournalOptions options;
    options.path = directory_.File("journal.sqlite");
    options.sync = service::JournalSync::kOff;
    options.snapshot_every = snapshot_every;
    return options;
  }

  static grpc::Status OpenStatus(const JournalOptions& options,
                                 service::ServiceLimits limits = service::ServiceLimits()) {
    ContactOperations operations{limits, service::TestHooks()};
    return ToGrpcStatus(operations.OpenJournal(options));
  }

  std::unique_ptr<ContactOperations> Open(const JournalOptions& options) {
    auto operations =
        std::make_unique<ContactOperations>(service::ServiceLimits(), service::TestHooks());
    grpc::Status status = ToGrpcStatus(operations->OpenJournal(options));
    EXPECT_TRUE(status.ok()) << status.error_message();
    return operations;
  }

  // What the journal holds (opened while no ContactOperations has it).
  std::vector<JournaledSession> Load(const JournalOptions& options) {
    std::unique_ptr<Journal> journal;
    EXPECT_TRUE(Journal::Open(options, &journal).ok());
    std::vector<JournaledSession> sessions;
    const Status status = journal->Load(&sessions);
    EXPECT_TRUE(status.ok()) << status.ToString();
    return sessions;
  }

  static std::string Create(ContactOperations& operations, const std::string& id,
                            const Principal& caller = std::nullopt) {
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
    request.set_session_id(id);
    v1::Session session;
    grpc::Status status = ToGrpcStatus(operations.CreateSession(caller, request, &session));
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }

  static grpc::Status Apply(ContactOperations& operations, const v1::ApplyRequest& request,
                            v1::ApplyResponse* response) {
    return ToGrpcStatus(operations.Apply(std::nullopt, request, nullptr, response));
  }

  static v1::SessionSnapshot Export(ContactOperations& operations, const std::string& name,
                                    const Principal& caller = std::nullopt) {
    v1::ExportSessionRequest request;
    request.set_name(name);
    v1::SessionSnapshot snapshot;
    grpc::Status status = ToGrpcStatus(operations.ExportSession(caller, request, &snapshot));
    EXPECT_TRUE(status.ok()) << status.error_message();
    return snapshot;
  }

  // A reproducible batch of 1-3 steps of the H1 contact around the 100 N state: depth and
  // displacement control, and now and then a tangential force at constant depth; every step is
  // reachable.
  static std::vector<v1::Step> RandomBatch(std::mt19937_64& random) {
    std::uniform_real_distribution<double> unit(0, 1);
    const int count = 1 + static_cast<int>(random() % 3);
    std::vector<v1::Step> steps;
    for (int i = 0; i < count; ++i) {
      if (random() % 4 == 0) {
        steps.push_back(TangentialForceStep((2 * unit(random) - 1) * 0.5 * kFriction *
                                            HertzNormalForce(0.6 * kDepth)));
        continue;
      }
      const double depth = kDepth * (0.6 + 0.8 * unit(random));
      v1::Step step = DepthStep(depth);
      step.set_displacement((2 * unit(random) - 1) * 0.8 * kFriction * Kappa() * depth);
      steps.push_back(step);
    }
    return steps;
  }

  // Applies `batches` random batches to `name`, every third with a request id ("<tag>-<i>") and
  // a step mask.
  static void ApplyRandomBatches(ContactOperations& operations, const std::string& name,
                                 int batches, std::mt19937_64& random,
                                 const std::string& tag = "first") {
    for (int i = 0; i < batches; ++i) {
      const bool with_id = i % 3 == 0;
      const v1::ApplyRequest request =
          ApplyRequestFor(name, RandomBatch(random),
                          with_id ? std::vector<std::string>{"state.tangential_force", "path_error"}
                                  : std::vector<std::string>{},
                          with_id ? tag + "-" + std::to_string(i) : "");
      v1::ApplyResponse response;
      grpc::Status status = Apply(operations, request, &response);
      ASSERT_TRUE(status.ok()) << status.error_message();
    }
  }

  static void ExpectSameSnapshot(const v1::SessionSnapshot& actual,
                                 const v1::SessionSnapshot& expected) {
    // Bit for bit: the serialized contacts are equal byte for byte (doubles included).
    EXPECT_EQ(actual.contact().SerializeAsString(), expected.contact().SerializeAsString());
    EXPECT_TRUE(MessageDifferencer::Equals(actual, expected)) << actual.DebugString() << "\nvs\n"
                                                              << expected.DebugString();
  }

  // A session at 100 N and 15 N (so its memory has vertices) with `batches` more random batches.
  static void CreateLoaded(ContactOperations& operations, const std::string& id, int batches,
                           std::mt19937_64& random) {
    const std::string name = Create(operations, id);
    v1::ApplyResponse response;
    ASSERT_TRUE(
        Apply(operations,
              ApplyRequestFor(name, {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}),
              &response)
            .ok());
    ApplyRandomBatches(operations, name, batches, random);
  }

  // Runs SQL on the journal behind mdr's back (as a person with the sqlite3 shell would).
  static void Sql(const std::string& path, const std::string& sql) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    char* error = nullptr;
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << (error != nullptr ? error : "");
    sqlite3_free(error);
    sqlite3_close(db);
  }

  // The journal's files as a crash of the process leaves them: copied while it is open (the
  // commits since the last checkpoint are only in the write-ahead log).
  static void CopyCrashImage(const std::string& from, const std::string& to) {
    for (const char* suffix : {"", "-wal", ".commit"}) {
      ASSERT_TRUE(std::filesystem::exists(from + suffix)) << from + suffix;
      std::filesystem::copy_file(from + suffix, to + suffix,
                                 std::filesystem::copy_options::overwrite_existing);
    }
  }

  // The crash image of a journal with sessions "x" (12 batches) and "y" (3), taken after the
  // last batch of "x"; the images' options are returned, *expected holds the states then.
  JournalOptions CrashImage(std::vector<v1::SessionSnapshot>* expected) {
    const JournalOptions live = Options();
    JournalOptions image = live;
    image.path = directory_.File("image.sqlite");
    std::mt19937_64 random(5);
    auto operations = Open(live);
    CreateLoaded(*operations, "y", 3, random);
    CreateLoaded(*operations, "x", 12, random);
    expected->push_back(Export(*operations, "sessions/x"));
    expected->push_back(Export(*operations, "sessions/y"));
    CopyCrashImage(live.path, image.path);
    return image;
  }

  // Batch `sequence`'s request with the lowest bit of its last byte flipped (the last character of
  // its request id: still a valid ApplyRequest).
  static void FlipLastBitOfBatch(const std::string& path, int sequence) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* read = nullptr;
    sqlite3_prepare_v2(db, "SELECT request FROM batches WHERE sequence = ?1", -1, &read, nullptr);
    sqlite3_bind_int(read, 1, sequence);
    ASSERT_EQ(sqlite3_step(read), SQLITE_ROW);
    std::string request(static_cast<const char*>(sqlite3_column_blob(read, 0)),
                        sqlite3_column_bytes(read, 0));
    sqlite3_finalize(read);
    request.back() ^= 1;
    sqlite3_stmt* write = nullptr;
    sqlite3_prepare_v2(db, "UPDATE batches SET request = ?1 WHERE sequence = ?2", -1, &write,
                       nullptr);
    sqlite3_bind_blob(write, 1, request.data(), static_cast<int>(request.size()), SQLITE_STATIC);
    sqlite3_bind_int(write, 2, sequence);
    EXPECT_EQ(sqlite3_step(write), SQLITE_DONE);
    sqlite3_finalize(write);
    sqlite3_close(db);
  }

  static void FlipByte(const std::string& path, std::uintmax_t offset) {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekg(static_cast<std::streamoff>(offset));
    const char byte = static_cast<char>(file.get() ^ 0x5A);
    file.seekp(static_cast<std::streamoff>(offset));
    file.put(byte);
  }

  // Refused without recovery (naming the file and `what`), nothing changed; then restored with
  // recovery, the drop logged, and the rebuilt journal opens without it.
  std::unique_ptr<ContactOperations> ExpectRefusedThenRecovered(JournalOptions options,
                                                                const std::string& what) {
    auto sizes = [&] {
      std::vector<std::uintmax_t> sizes;
      for (const char* suffix : {"", "-wal", ".commit"}) {
        std::error_code missing;  // SQLite creates an empty log: as good as none
        const std::uintmax_t size = std::filesystem::file_size(options.path + suffix, missing);
        sizes.push_back(missing ? 0 : size);
      }
      return sizes;
    };
    const std::vector<std::uintmax_t> files_before = sizes();
    grpc::Status refused = OpenStatus(options);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::DATA_LOSS);
    EXPECT_THAT(refused.error_message(),
                ::testing::HasSubstr("\"" + options.path + "\" is damaged"));
    EXPECT_THAT(refused.error_message(), ::testing::HasSubstr(what));
    EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("--journal-recover"));
    EXPECT_EQ(sizes(), files_before);
    EXPECT_EQ(OpenStatus(options).error_code(), grpc::StatusCode::DATA_LOSS);  // still refused

    options.recover = true;
    {
      std::unique_ptr<Journal> journal;
      Status status = Journal::Open(options, &journal);
      EXPECT_TRUE(status.ok()) << status.ToString();
      if (journal) {
        EXPECT_THAT(Join(journal->recovery_drops()), ::testing::HasSubstr(what));
      }
    }
    EXPECT_TRUE(std::filesystem::exists(options.path + ".damaged"));
    options.recover = false;
    return Open(options);  // consistent again: opens without recovery
  }

  static std::string Join(const std::vector<std::string>& items) {
    std::string joined;
    for (const std::string& item : items) joined += item + "\n";
    return joined;
  }

  TemporaryDirectory directory_;
};

TEST_F(JournalTest, RestartReplaysEveryBatchBitIdentically) {
  const JournalOptions options = Options();
  std::mt19937_64 random(7);
  v1::SessionSnapshot a_before, imported_before;
  {
    auto operations = Open(options);
    const std::string a = Create(*operations, "a");
    const std::string gone = Create(*operations, "gone");
    ApplyRandomBatches(*operations, a, 40, random);
    ApplyRandomBatches(*operations, gone, 5, random);
    v1::ImportSessionRequest import_request;
    *import_request.mutable_snapshot() = Export(*operations, a);
    import_request.set_session_id("imported");
    v1::Session imported;
    ASSERT_TRUE(operations->ImportSession(std::nullopt, import_request, &imported).ok());
    ApplyRandomBatches(*operations, imported.name(), 10, random);
    v1::DeleteSessionRequest delete_request;
    delete_request.set_name(gone);
    ASSERT_TRUE(operations->DeleteSession(std::nullopt, delete_request).ok());
    a_before = Export(*operations, a);
    imported_before = Export(*operations, imported.name());
  }  // no compaction: the journal holds the batches themselves

  const std::vector<JournaledSession> journaled = Load(options);
  ASSERT_EQ(journaled.size(), 2u);
  EXPECT_EQ(journaled[0].name, "sessions/a");
  EXPECT_EQ(journaled[0].snapshot_sequence, 0u);
  EXPECT_EQ(journaled[0].batches.size(), 40u);
  EXPECT_EQ(journaled[0].snapshot.applied_steps(), 0u);
  EXPECT_EQ(journaled[1].name, "sessions/imported");
  EXPECT_EQ(journaled[1].batches.size(), 10u);

  auto restored = Open(options);
  EXPECT_EQ(restored->session_count(), 2u);
  ExpectSameSnapshot(Export(*restored, "sessions/a"), a_before);
  ExpectSameSnapshot(Export(*restored, "sessions/imported"), imported_before);
  v1::GetSessionRequest get_request;
  get_request.set_name("sessions/gone");
  v1::Session session;
  EXPECT_EQ(restored->GetSession(std::nullopt, get_request, &session).code(),
            StatusCode::kNotFound);

  // The restored session continues like the state it restored, imported elsewhere.
  ContactOperations reference{service::ServiceLimits(), service::TestHooks()};
  v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = a_before;
  import_request.set_session_id("a");
  v1::Session imported;
  ASSERT_TRUE(reference.ImportSession(std::nullopt, import_request, &imported).ok());
  std::mt19937_64 same(99), again(99);
  ApplyRandomBatches(*restored, "sessions/a", 5, same, "after");
  ApplyRandomBatches(reference, "sessions/a", 5, again, "after");
  ExpectSameSnapshot(Export(*restored, "sessions/a"), Export(reference, "sessions/a"));
}

// A torsional session is journaled like any other: a restart replays its batches (refused steps
// included, which change nothing) to the state it acknowledged, bit for bit, and it continues
// like an import of that state.
TEST_F(JournalTest, ATorsionalSessionRestartsBitForBit) {
  const JournalOptions options = Options(7);  // a snapshot every 7 batches, and batches after it
  v1::SessionSnapshot before;
  std::mt19937_64 random(5);
  {
    auto operations = Open(options);
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = bridge_testing::TwistedSteelSphere();
    request.set_session_id("twisted");
    v1::Session session;
    ASSERT_TRUE(operations->CreateSession(std::nullopt, request, &session).ok());
    for (int i = 0; i < 40; ++i) {
      v1::ApplyResponse response;
      (void)Apply(*operations,
                  ApplyRequestFor(session.name(), {bridge_testing::RandomTorsionStep(random)}),
                  &response);
    }
    before = Export(*operations, "sessions/twisted");
  }  // a crash as far as the journal can tell
  ASSERT_GT(before.torsion().pieces_size(), 2);
  auto restored = Open(options);
  ExpectSameSnapshot(Export(*restored, "sessions/twisted"), before);
  EXPECT_EQ(Export(*restored, "sessions/twisted").torsion().SerializeAsString(),
            before.torsion().SerializeAsString());
  ContactOperations reference{service::ServiceLimits(), service::TestHooks()};
  v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = before;
  import_request.set_session_id("twisted");
  v1::Session imported;
  ASSERT_TRUE(reference.ImportSession(std::nullopt, import_request, &imported).ok());
  std::mt19937_64 same(6), again(6);
  for (int i = 0; i < 10; ++i) {
    v1::ApplyResponse first, second;
    (void)Apply(*restored,
                ApplyRequestFor("sessions/twisted", {bridge_testing::RandomTorsionStep(same)}),
                &first);
    (void)Apply(reference,
                ApplyRequestFor("sessions/twisted", {bridge_testing::RandomTorsionStep(again)}),
                &second);
  }
  ExpectSameSnapshot(Export(*restored, "sessions/twisted"), Export(reference, "sessions/twisted"));
}

// Below the room kept for deletions (--journal-min-free-bytes) new work is refused UNAVAILABLE
// naming the journal's room, while Export and Delete go on; nothing acknowledged is lost, and the
// deletion is journaled (issue #27: a full volume made every DeleteSession fail). The floor above
// any volume's size stands for a full one.
TEST_F(JournalTest, BelowTheFloorNewWorkIsRefusedAndDeletionsGoOn) {
  JournalOptions options = Options();
  std::mt19937_64 random(3);
  v1::SessionSnapshot kept_before;
  {
    auto operations = Open(options);
    Create(*operations, "kept");
    Create(*operations, "freed");
    ApplyRandomBatches(*operations, "sessions/kept", 3, random);
    kept_before = Export(*operations, "sessions/kept");
  }
  options.min_free_bytes = std::uint64_t{1} << 62;
  {
    auto operations = Open(options);
    v1::ApplyResponse applied;
    const grpc::Status refused =
        Apply(*operations, ApplyRequestFor("sessions/kept", {DepthStep(1e-6)}), &applied);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE);
    EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("--journal-min-free-bytes"));
    v1::CreateSessionRequest create;
    *create.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
    create.set_session_id("new");
    v1::Session created;
    EXPECT_EQ(operations->CreateSession(std::nullopt, create, &created).code(),
              StatusCode::kUnavailable);
    ExpectSameSnapshot(Export(*operations, "sessions/kept"), kept_before);  // unchanged
    v1::DeleteSessionRequest remove;
    remove.set_name("sessions/freed");
    ASSERT_TRUE(operations->DeleteSession(std::nullopt, remove).ok());
    EXPECT_EQ(operations->session_count(), 1u);
  }
  options.min_free_bytes = 0;
  auto restored = Open(options);
  EXPECT_EQ(restored->session_count(), 1u);
  ExpectSameSnapshot(Export(*restored, "sessions/kept"), kept_before);
  EXPECT_GT(service::JournalRoom(options.path), 0u);
}

// Sets or clears the immutable attribute (chattr +i) of each file; false where the file system
// or the process's privileges do not allow it.
bool SetImmutable(const std::vector<std::string>& files, bool immutable) {
  for (const std::string& file : files) {
    const int descriptor = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (descriptor < 0) return false;
    int flags = 0;
    bool done = ::ioctl(descriptor, FS_IOC_GETFLAGS, &flags) == 0;
    flags = immutable ? (flags | FS_IMMUTABLE_FL) : (flags & ~FS_IMMUTABLE_FL);
    done = done && ::ioctl(descriptor, FS_IOC_SETFLAGS, &flags) == 0;
    ::close(descriptor);
    if (!done) return false;
  }
  return true;
}

// The write-ahead log's index is in the process's heap: no "-shm" file is ever mapped, so an I/O
// error of the journal's files is an error code, never a SIGBUS.
TEST_F(JournalTest, TheLogsIndexIsNeverAMappedFile) {
  const JournalOptions options = Options();
  std::mt19937_64 random(11);
  auto operations = Open(options);
  Create(*operations, "a");
  ApplyRandomBatches(*operations, "sessions/a", 20, random);
  EXPECT_TRUE(std::filesystem::exists(options.path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(options.path + "-shm"));
}

// Journal files made immutable under load: each Apply is refused UNAVAILABLE and changes nothing
// (the process lives: before the log's index left its mapped file, this was a SIGBUS); once they
// are writable again the work goes on, and a restart restores every acknowledged batch.
TEST_F(JournalTest, ImmutableFilesRefuseWorkAndChangeNothing) {
  const JournalOptions options = Options();
  std::vector<std::string> files = {options.path, options.path + "-wal"};
  std::mt19937_64 random(12);
  v1::SessionSnapshot acknowledged;
  {
    auto operations = Open(options);
    Create(*operations, "a");
    ApplyRandomBatches(*operations, "sessions/a", 5, random);
    acknowledged = Export(*operations, "sessions/a");
    // Every file of the journal there is (an -shm file too, where SQLite made one).
    if (std::filesystem::exists(options.path + "-shm")) files.push_back(options.path + "-shm");
    if (!SetImmutable(files, true)) GTEST_SKIP() << "cannot set the immutable attribute here";
    for (int i = 0; i < 20; ++i) {
      v1::ApplyResponse applied;
      const grpc::Status refused =
          Apply(*operations, ApplyRequestFor("sessions/a", {DisplacementStep(1e-8 * i)}), &applied);
      EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.error_message();
      ExpectSameSnapshot(Export(*operations, "sessions/a"), acknowledged);
    }
    ASSERT_TRUE(SetImmutable(files, false));
    ApplyRandomBatches(*operations, "sessions/a", 3, random, "again");
    acknowledged = Export(*operations, "sessions/a");
  }
  auto restored = Open(options);
  ExpectSameSnapshot(Export(*restored, "sessions/a"), acknowledged);
}

// Journal files deleted under load (each alone, and all of them): the next write finds them gone
// and rewrites the journal from the files it still has open, so that a restart restores every
// acknowledged batch, those before the deletion included.
TEST_F(JournalTest, DeletedFilesAreRewrittenWithEveryAcknowledgedBatch) {
  const std::vector<std::vector<std::string>> cases = {
      {""}, {"-wal"}, {".commit"}, {"", "-wal", ".commit"}};
  for (const std::vector<std::string>& deleted : cases) {
    const JournalOptions options = Options();
    std::mt19937_64 random(13);
    v1::SessionSnapshot acknowledged;
    {
      auto operations = Open(options);
      Create(*operations, "a");
      ApplyRandomBatches(*operations, "sessions/a", 5, random);
      for (const std::string& suffix : deleted) {
        ASSERT_TRUE(std::filesystem::remove(options.path + suffix)) << suffix;
      }
      ApplyRandomBatches(*operations, "sessions/a", 5, random, "after");
      for (const char* suffix : {"", "-wal", ".commit"}) {
        EXPECT_TRUE(std::filesystem::exists(options.path + suffix)) << suffix;
      }
      for (const std::string& suffix : deleted) {  // again, now without a write after it
        ASSERT_TRUE(std::filesystem::remove(options.path + suffix)) << suffix;
      }
      acknowledged = Export(*operations, "sessions/a");
    }
    auto restored = Open(options);
    ExpectSameSnapshot(Export(*restored, "sessions/a"), acknowledged);
    restored.reset();
    std::filesystem::remove(options.path + ".commit");
    std::filesystem::remove(options.path + "-wal");
    std::filesystem::remove(options.path);
  }
}

// The journal's directory removed: writes are refused UNAVAILABLE and change nothing; once the
// directory is back, the next write rewrites the journal there, everything acknowledged in it.
TEST_F(JournalTest, AVanishedDirectoryRefusesWorkUntilItIsBack) {
  JournalOptions options = Options();
  const std::filesystem::path directory =
      std::filesystem::path(options.path).parent_path() / "vanishing";
  std::filesystem::create_directory(directory);
  options.path = (directory / "journal.sqlite").string();
  options.min_free_bytes = 0;  // the room of a missing directory reads 0
  std::mt19937_64 random(14);
  v1::SessionSnapshot acknowledged;
  {
    auto operations = Open(options);
    Create(*operations, "a");
    ApplyRandomBatches(*operations, "sessions/a", 5, random);
    acknowledged = Export(*operations, "sessions/a");
    std::filesystem::remove_all(directory);
    v1::ApplyResponse applied;
    const grpc::Status refused =
        Apply(*operations, ApplyRequestFor("sessions/a", {DisplacementStep(1e-8)}), &applied);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE);
    EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("was deleted or replaced"));
    ExpectSameSnapshot(Export(*operations, "sessions/a"), acknowledged);
    std::filesystem::create_directory(directory);
    ApplyRandomBatches(*operations, "sessions/a", 3, random, "again");
    acknowledged = Export(*operations, "sessions/a");
  }
  auto restored = Open(options);
  ExpectSameSnapshot(Export(*restored, "sessions/a"), acknowledged);
}

// Whether the batch was replayed from the journal or is part of a snapshot (snapshot_every 1),
// its request id is remembered.
TEST_F(JournalTest, RequestIdsAnsweredBeforeARestartAreNotAppliedAgain) {
  for (const std::uint32_t snapshot_every : {1000u, 1u}) {
    SCOPED_TRACE("snapshot_every " + std::to_string(snapshot_every));
    const JournalOptions options = Options(snapshot_every);
    std::filesystem::remove(options.path);
    std::filesystem::remove(options.path + ".commit");
    const v1::ApplyRequest request = ApplyRequestFor(
        "sessions/s", {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}, {"state"}, "r-1");
    v1::ApplyResponse first;
    {
      auto operations = Open(options);
      Create(*operations, "s");
      ASSERT_TRUE(Apply(*operations, request, &first).ok());
    }
    EXPECT_EQ(Load(options)[0].batches.size(), snapshot_every == 1 ? 0u : 1u);
    auto restored = Open(options);
    v1::ApplyResponse retried;
    ASSERT_TRUE(Apply(*restored, request, &retried).ok());
    EXPECT_TRUE(retried.replayed());
    EXPECT_EQ(retried.state().applied_steps(), 2u);
    ASSERT_EQ(retried.step_results_size(), 2);
    EXPECT_TRUE(MessageDifferencer::Equals(retried.step_results(1), first.step_results(1)));
    EXPECT_EQ(Export(*restored, "sessions/s").applied_steps(), 2u);
    // The same id for other steps is still caught.
    v1::ApplyRequest reused = request;
    reused.mutable_steps(1)->set_displacement(0);
    EXPECT_EQ(Apply(*restored, reused, &retried).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  }
}

TEST_F(JournalTest, CompactionReplacesBatchesBySnapshotsAndRestoresTheSameState) {
  const JournalOptions options = Options(/*snapshot_every=*/3);
  std::mt19937_64 random(11);
  v1::SessionSnapshot before;
  {
    auto operations = Open(options);
    Create(*operations, "c");
    ApplyRandomBatches(*operations, "sessions/c", 7, random);
    before = Export(*operations, "sessions/c");
  }
  std::vector<JournaledSession> journaled = Load(options);
  ASSERT_EQ(journaled.size(), 1u);
  EXPECT_EQ(journaled[0].snapshot_sequence, 6u);  // compacted after batches 3 and 6
  ASSERT_EQ(journaled[0].batches.size(), 1u);
  EXPECT_EQ(journaled[0].batches[0].sequence, 7u);
  EXPECT_LT(journaled[0].snapshot.applied_steps(), before.applied_steps());

  {
    auto restored = Open(options);
    ExpectSameSnapshot(Export(*restored, "sessions/c"), before);
    restored->CompactJournal();  // as at a clean shutdown
  }
  journaled = Load(options);
  ASSERT_EQ(journaled.size(), 1u);
  EXPECT_EQ(journaled[0].snapshot_sequence, 7u);
  EXPECT_TRUE(journaled[0].batches.empty());
  EXPECT_EQ(journaled[0].snapshot.applied_steps(), before.applied_steps());

  auto restored = Open(options);
  ExpectSameSnapshot(Export(*restored, "sessions/c"), before);
  // Numbering goes on after the snapshot.
  ApplyRandomBatches(*restored, "sessions/c", 1, random, "after");
  restored.reset();
  journaled = Load(options);
  ASSERT_EQ(journaled[0].batches.size(), 1u);
  EXPECT_EQ(journaled[0].batches[0].sequence, 8u);
}

TEST_F(JournalTest, FailedBatchesAreNotJournaled) {
  const JournalOptions options = Options();
  {
    auto operations = Open(options);
    Create(*operations, "f");
    v1::ApplyResponse response;
    ASSERT_TRUE(
        Apply(*operations, ApplyRequestFor("sessions/f", {DepthStep(kDepth)}), &response).ok());
    // |F_x| above the friction limit: FAILED_PRECONDITION, nothing applied.
    EXPECT_EQ(Apply(*operations,
                    ApplyRequestFor("sessions/f", {DisplacementStep(0), TangentialForceStep(1e6)}),
                    &response)
                  .error_code(),
              grpc::StatusCode::FAILED_PRECONDITION);
  }
  const std::vector<JournaledSession> journaled = Load(options);
  ASSERT_EQ(journaled.size(), 1u);
  EXPECT_EQ(journaled[0].batches.size(), 1u);
  auto restored = Open(options);
  EXPECT_EQ(Export(*restored, "sessions/f").applied_steps(), 1u);
}

TEST_F(JournalTest, OwnersAreKept) {
  const JournalOptions options = Options();
  Create(*Open(options), "owned", Principal("alice"));
  auto restored = Open(options);
  v1::GetSessionRequest request;
  request.set_name("sessions/owned");
  v1::Session session;
  EXPECT_TRUE(restored->GetSession(Principal("alice"), request, &session).ok());
  EXPECT_EQ(restored->GetSession(Principal("bob"), request, &session).code(),
            StatusCode::kNotFound);
}

TEST_F(JournalTest, OneProcessAtATime) {
  auto operations = Open(Options());
  ContactOperations second{service::ServiceLimits(), service::TestHooks()};
  grpc::Status status = ToGrpcStatus(second.OpenJournal(Options()));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("locked"));
}

TEST_F(JournalTest, NotAJournalIsRefused) {
  const JournalOptions options = Options();
  {
    std::FILE* file = std::fopen(options.path.c_str(), "w");
    std::fputs("not a database, just text that is long enough to fill a header page.....", file);
    std::fclose(file);
  }
  ContactOperations operations{service::ServiceLimits(), service::TestHooks()};
  grpc::Status status = ToGrpcStatus(operations.OpenJournal(options));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr(options.path));
}

// A snapshot row that parses but that Contact::Restore refuses (a memory vertex far above the
// Coulomb bound) beside good sessions: the good ones come back bit for bit, the bad one is
// listed as unavailable with the reason, refuses the calls that need its state, keeps its
// journal entry across restarts, counts against the limits, and can be deleted.
TEST_F(JournalTest, ASessionThatCannotBeRestoredIsKeptAsideAndTheOthersComeBack) {
  const JournalOptions options = Options();
  std::mt19937_64 random(3);
  v1::SessionSnapshot a_before, c_before, refused;
  {
    auto operations = Open(options);
    CreateLoaded(*operations, "a", 6, random);
    CreateLoaded(*operations, "bad", 2, random);
    CreateLoaded(*operations, "c", 4, random);
    a_before = Export(*operations, "sessions/a");
    c_before = Export(*operations, "sessions/c");
    refused = Export(*operations, "sessions/bad");
  }
  ASSERT_GT(refused.contact().memory_size(), 1);
  refused.mutable_contact()->mutable_memory(0)->set_u(1.0);  // |u| <= mu kappa depth ~ 1e-6 m
  {
    std::unique_ptr<Journal> journal;
    ASSERT_TRUE(Journal::Open(options, &journal).ok());
    ASSERT_TRUE(
        journal->AddSession("sessions/bad", "", google::protobuf::Timestamp(), refused).ok());
  }
  for (int restart = 0; restart < 2; ++restart) {
    auto restored = Open(options);
    EXPECT_EQ(restored->session_count(), 3u);
    ExpectSameSnapshot(Export(*restored, "sessions/a"), a_before);
    ExpectSameSnapshot(Export(*restored, "sessions/c"), c_before);

    v1::GetSessionRequest get;
    get.set_name("sessions/bad");
    v1::Session bad;
    ASSERT_TRUE(restored->GetSession(std::nullopt, get, &bad).ok());
    EXPECT_EQ(bad.availability(), v1::Session::AVAILABILITY_UNAVAILABLE);
    EXPECT_THAT(bad.unavailable_reason(), ::testing::HasSubstr("snapshot.contact.memory[0]"));
    EXPECT_FALSE(bad.has_state());
    v1::ListSessionsResponse list;
    ASSERT_TRUE(restored->ListSessions(std::nullopt, v1::ListSessionsRequest(), &list).ok());
    ASSERT_EQ(list.sessions_size(), 3);
    EXPECT_EQ(list.sessions(0).availability(), v1::Session::AVAILABILITY_ACTIVE);
    EXPECT_EQ(list.sessions(1).availability(), v1::Session::AVAILABILITY_UNAVAILABLE);
    EXPECT_EQ(list.sessions(1).unavailable_reason(), bad.unavailable_reason());

    v1::ApplyResponse applied;
    grpc::Status apply =
        Apply(*restored, ApplyRequestFor("sessions/bad", {DepthStep(kDepth)}), &applied);
    v1::QueryRequest query;
    query.set_session("sessions/bad");
    v1::QueryResponse queried;
    v1::ExportSessionRequest export_request;
    export_request.set_name("sessions/bad");
    v1::SessionSnapshot exported;
    for (const grpc::Status& status :
         {apply, ToGrpcStatus(restored->Query(std::nullopt, query, &queried)),
          ToGrpcStatus(restored->ExportSession(std::nullopt, export_request, &exported))}) {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
      EXPECT_THAT(status.error_message(), ::testing::HasSubstr("sessions/bad is unavailable"));
      EXPECT_THAT(status.error_message(), ::testing::HasSubstr(bad.unavailable_reason()));
    }
  }
  // Its entry was kept as written.
  std::vector<JournaledSession> journaled = Load(options);
  ASSERT_EQ(journaled.size(), 3u);
  EXPECT_EQ(journaled[1].snapshot.SerializeAsString(), refused.SerializeAsString());

  // It counts against the limits.
  service::ServiceLimits three;
  three.max_sessions = 3;
  ContactOperations full{three, service::TestHooks()};
  ASSERT_TRUE(full.OpenJournal(options).ok());
  v1::CreateSessionRequest create;
  *create.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  v1::Session created;
  EXPECT_EQ(full.CreateSession(std::nullopt, create, &created).code(),
            StatusCode::kResourceExhausted);
  v1::DeleteSessionRequest remove;
  remove.set_name("sessions/bad");
  ASSERT_TRUE(full.DeleteSession(std::nullopt, remove).ok());
  EXPECT_TRUE(full.CreateSession(std::nullopt, create, &created).ok());
}

TEST_F(JournalTest, DeletingAnUnavailableSessionRemovesItsEntry) {
  const JournalOptions options = Options();
  v1::SessionSnapshot refused;
  {
    auto operations = Open(options);
    std::mt19937_64 random(1);
    CreateLoaded(*operations, "bad", 1, random);
    refused = Export(*operations, "sessions/bad");
  }
  refused.mutable_contact()->mutable_memory(0)->set_u(1.0);
  {
    std::unique_ptr<Journal> journal;
    ASSERT_TRUE(Journal::Open(options, &journal).ok());
    ASSERT_TRUE(
        journal->AddSession("sessions/bad", "", google::protobuf::Timestamp(), refused).ok());
  }
  {
    auto restored = Open(options);
    v1::DeleteSessionRequest remove;
    remove.set_name("sessions/bad");
    ASSERT_TRUE(restored->DeleteSession(std::nullopt, remove).ok());
    EXPECT_EQ(restored->session_count(), 0u);
  }
  EXPECT_TRUE(Load(options).empty());
}

// A deletion that races batches on its session leaves nothing of it in the journal: a batch
// either commits before the deletion (which then removes its row too) or finds the session gone
// (NOT_FOUND), never writes its row after the deletion (rows of a deleted session made the next
// start refuse the journal as damaged). Every round deletes while a batch of 400 steps runs.
TEST_F(JournalTest, ADeletionRacingBatchesLeavesNothingOfTheSession) {
  const JournalOptions options = Options();
  std::vector<v1::Step> cycle;
  for (int i = 0; i < 400; ++i) {
    cycle.push_back(DisplacementStep((i % 2 == 0 ? 1 : -1) * kDisplacementAt15N));
  }
  {
    auto operations = Open(options);
    for (int round = 0; round < 40; ++round) {
      const std::string name = Create(*operations, "race-" + std::to_string(round));
      v1::ApplyResponse response;
      ASSERT_TRUE(Apply(*operations, ApplyRequestFor(name, {DepthStep(kDepth)}), &response).ok());
      std::atomic<int> started{0};
      std::atomic<bool> stop{false};
      grpc::Status last;
      std::thread applier([&] {
        const v1::ApplyRequest batch = ApplyRequestFor(name, cycle);
        while (!stop.load()) {
          started.fetch_add(1);
          v1::ApplyResponse ignored;
          last = Apply(*operations, batch, &ignored);
          if (!last.ok()) return;
        }
      });
      while (started.load() < 1 + round % 3) std::this_thread::yield();
      v1::DeleteSessionRequest remove;
      remove.set_name(name);
      const grpc::Status deleted = ToGrpcStatus(operations->DeleteSession(std::nullopt, remove));
      stop.store(true);
      applier.join();
      ASSERT_TRUE(deleted.ok()) << deleted.error_message();
      EXPECT_TRUE(last.ok() || last.error_code() == grpc::StatusCode::NOT_FOUND)
          << last.error_message();
    }
    EXPECT_EQ(operations->session_count(), 0u);
  }
  std::unique_ptr<Journal> journal;
  ASSERT_TRUE(Journal::Open(options, &journal).ok());
  std::vector<JournaledSession> sessions;
  const grpc::Status loaded = ToGrpcStatus(journal->Load(&sessions));
  EXPECT_TRUE(loaded.ok()) << loaded.error_message();
  EXPECT_TRUE(sessions.empty());
}

// Sessions are journaled outside the store's lock, their names held meanwhile: concurrent
// creations of one name make one session, and concurrent creations never exceed the limits.
TEST_F(JournalTest, ConcurrentCreationsKeepNamesUniqueAndLimitsHeld) {
  const JournalOptions options = Options();
  service::ServiceLimits limits;
  limits.max_sessions = 12;
  limits.max_sessions_per_token = 3;
  auto operations = std::make_unique<ContactOperations>(limits, service::TestHooks());
  ASSERT_TRUE(operations->OpenJournal(options).ok());
  std::atomic<int> created{0}, taken{0}, full{0};
  auto create = [&](const std::string& id, const Principal& caller) {
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
    request.set_session_id(id);
    v1::Session session;
    const grpc::Status status = ToGrpcStatus(operations->CreateSession(caller, request, &session));
    if (status.ok()) ++created;
    if (status.error_code() == grpc::StatusCode::ALREADY_EXISTS) ++taken;
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) ++full;
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      const Principal caller = "token-" + std::to_string(t % 4);
      create("same", caller);
      for (int i = 0; i < 4; ++i) create("s" + std::to_string(t) + "-" + std::to_string(i), caller);
    });
  }
  for (std::thread& thread : threads) thread.join();
  // 4 tokens x 3 sessions = 12 = max_sessions: every token ends at its limit, "same" included.
  EXPECT_EQ(created.load(), 12);
  EXPECT_EQ(operations->session_count(), 12u);
  EXPECT_EQ(created + taken + full, 8 * 5) << "only these refusals";
  operations.reset();
  std::vector<std::string> names;
  for (const JournaledSession& session : Load(options)) names.push_back(session.name);
  EXPECT_EQ(names.size(), 12u);
  EXPECT_EQ(std::count(names.begin(), names.end(), "sessions/same"), 1);
}

// SQLite hands an empty blob back as a null pointer: an empty field's checksum must not depend
// on that (zlib's CRC of a null buffer is 0, whatever came before), or the row reads as damaged.
TEST_F(JournalTest, AnEmptySnapshotReadsBackIntact) {
  const JournalOptions options = Options();
  {
    std::unique_ptr<Journal> journal;
    ASSERT_TRUE(Journal::Open(options, &journal).ok());
    ASSERT_TRUE(
        journal
            ->AddSession("sessions/empty", "", google::protobuf::Timestamp(), v1::SessionSnapshot())
            .ok());
  }
  const std::vector<JournaledSession> loaded = Load(options);
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_EQ(loaded[0].name, "sessions/empty");
}

// Checkpoints run on the journal's own thread (no commit waits for their fsyncs): once the log
// holds Journal::kCheckpointPages pages, its content reaches the database file while commits go
// on, and every batch comes back.
TEST_F(JournalTest, TheCheckpointerCopiesTheLogIntoTheDatabase) {
  const JournalOptions options = Options();
  std::vector<v1::Step> steps;
  for (int i = 0; i < 200; ++i) steps.push_back(DisplacementStep(1e-9 * i));
  const v1::ApplyRequest batch = ApplyRequestFor("sessions/big", steps);
  const int batches = 3 * Journal::kCheckpointPages / 2;  // a batch takes a page or more
  {
    std::unique_ptr<Journal> journal;
    ASSERT_TRUE(Journal::Open(options, &journal).ok());
    ASSERT_TRUE(
        journal
            ->AddSession("sessions/big", "", google::protobuf::Timestamp(), v1::SessionSnapshot())
            .ok());
    const auto before = std::filesystem::file_size(options.path);
    for (int i = 1; i <= batches; ++i)
      ASSERT_TRUE(journal->AddBatch("sessions/big", i, batch).ok());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (journal->checkpoints() == 0 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_GE(journal->checkpoints(), 1u);
    EXPECT_GT(std::filesystem::file_size(options.path),
              before + std::uintmax_t{Journal::kCheckpointPages} * 1024)
        << "the log's pages are in the database";
    ASSERT_TRUE(journal->AddBatch("sessions/big", batches + 1, batch).ok());
  }
  const std::vector<JournaledSession> loaded = Load(options);
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_EQ(loaded[0].batches.size(), static_cast<std::size_t>(batches + 1));
}

TEST_F(JournalTest, FilesAreCreatedPrivate) {
  const JournalOptions options = Options();
  const mode_t previous = umask(0);  // nothing masked: the mode is mdr's own choice
  auto operations = Open(options);
  umask(previous);
  Create(*operations, "p");
  for (const char* suffix : {"", "-wal", ".commit"}) {
    struct stat info {};
    ASSERT_EQ(stat((options.path + suffix).c_str(), &info), 0) << suffix;
    EXPECT_EQ(info.st_mode & 0777, 0600u) << options.path + suffix;
  }
}

TEST_F(JournalTest, ACrashImageIsRestoredAsItIs) {
  std::vector<v1::SessionSnapshot> expected;
  const JournalOptions image = CrashImage(&expected);
  auto restored = Open(image);
  ExpectSameSnapshot(Export(*restored, "sessions/x"), expected[0]);
  ExpectSameSnapshot(Export(*restored, "sessions/y"), expected[1]);
}

// An interface of three Hertz summits around the H1 depth (heights s_i, radii R_i).
v1::Scene InterfaceScene(v1::Interface::Kind kind) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_interface()->set_kind(kind);
  v1::ExplicitPopulation* summits = scene.mutable_interface()->mutable_explicit_list();
  for (const auto& [height, radius] :
       {std::pair{0.0, kRadius}, std::pair{0.4 * kDepth, 0.5 * kRadius},
        std::pair{-0.3 * kDepth, 2 * kRadius}}) {
    summits->add_heights(height);
    summits->add_radii(radius);
  }
  return scene;
}

// A reproducible interface batch of 1-3 steps, every step reachable from any state the batches
// reach. Shared motion: approaches of 0.6-1.4 of the H1 depth with displacements, total normal
// force targets with the displacement held, total tangential force targets within the friction
// limit the smallest approach leaves. Contact list: per-contact depths with displacements, per-
// contact normal force targets, per-contact tangential force targets within each contact's limit.
std::vector<v1::Step> RandomInterfaceBatch(std::mt19937_64& random, v1::Interface::Kind kind) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double slip = kFriction * Kappa() * kDepth;
  // The smallest friction limit of the smallest summit (0.5 R) at 0.6 of the H1 depth.
  const double least_limit = kFriction * HertzNormalForce(0.6 * kDepth) * std::sqrt(0.5);
  const int count = 1 + static_cast<int>(random() % 3);
  std::vector<v1::Step> steps;
  for (int i = 0; i < count; ++i) {
    const int choice = static_cast<int>(random() % 3);
    v1::Step step;
    if (kind == v1::Interface::KIND_SHARED_MOTION) {
      if (choice == 0) {
        step.set_depth(kDepth * (0.6 + 0.8 * unit(random)));
        step.set_displacement((2 * unit(random) - 1) * 0.8 * slip);
      } else if (choice == 1) {
        step.set_normal_force(HertzNormalForce(kDepth) * (1 + 2 * unit(random)));
      } else {
        step.set_tangential_force((2 * unit(random) - 1) * 0.5 * least_limit);
      }
      steps.push_back(step);
      continue;
    }
    for (int contact = 0; contact < 3; ++contact) {
      if (choice == 0) {
        step.set_depth(0);
        step.add_contact_normal_values(kDepth * (0.6 + 0.8 * unit(random)));
        step.set_displacement_increment(0);
        step.add_contact_tangential_values((2 * unit(random) - 1) * 0.5 * slip);
      } else if (choice == 1) {
        step.set_normal_force(0);
        step.add_contact_normal_values(HertzNormalForce(kDepth) * (0.6 + 0.8 * unit(random)));
      } else {
        step.set_tangential_force(0);
        step.add_contact_tangential_values((2 * unit(random) - 1) * 0.5 * least_limit);
      }
    }
    steps.push_back(step);
  }
  return steps;
}

// Every state of an interface session (both kinds) comes back from a crash image of the journal
// bit for bit, whether its batches are replayed (snapshot every 1000) or partly compacted
// (every 3), and continues like the state imported elsewhere; a refused batch is not journaled.
TEST_F(JournalTest, EveryInterfaceStateIsRestoredFromACrashImageBitForBit) {
  for (const std::uint32_t snapshot_every : {1000u, 3u}) {
    for (const v1::Interface::Kind kind :
         {v1::Interface::KIND_SHARED_MOTION, v1::Interface::KIND_CONTACT_LIST}) {
      SCOPED_TRACE(v1::Interface::Kind_Name(kind) + ", snapshot every " +
                   std::to_string(snapshot_every));
      JournalOptions live = Options(snapshot_every);
      live.path = directory_.File(v1::Interface::Kind_Name(kind) + std::to_string(snapshot_every) +
                                  ".sqlite");
      JournalOptions image = live;
      image.path = live.path + ".image";
      auto operations = Open(live);
      v1::CreateSessionRequest create;
      *create.mutable_session()->mutable_scene() = InterfaceScene(kind);
      create.set_session_id("i");
      v1::Session session;
      ASSERT_TRUE(operations->CreateSession(std::nullopt, create, &session).ok());
      std::mt19937_64 random(23);
      v1::ApplyResponse response;
      // The first batch presses every contact (a contact list starts unloaded).
      v1::Step press = DepthStep(kDepth);
      // Refused (|F_x| beyond the friction limit): changes nothing and is not journaled.
      v1::Step beyond = TangentialForceStep(1e6);
      if (kind == v1::Interface::KIND_CONTACT_LIST) {
        press = v1::Step();
        press.set_depth(0);
        beyond.set_tangential_force(0);
        for (int contact = 0; contact < 3; ++contact) {
          press.add_contact_normal_values(kDepth);
          beyond.add_contact_tangential_values(1e6);
        }
      }
      for (int b = 0; b < 12; ++b) {
        const std::vector<v1::Step> batch =
            b == 0 ? std::vector<v1::Step>{press} : RandomInterfaceBatch(random, kind);
        const grpc::Status status =
            Apply(*operations, ApplyRequestFor(session.name(), batch, {}, "b-" + std::to_string(b)),
                  &response);
        ASSERT_TRUE(status.ok()) << "batch " << b << ": " << status.error_message();
        if (b % 4 == 3) {
          EXPECT_EQ(
              Apply(*operations, ApplyRequestFor(session.name(), {beyond}), &response).error_code(),
              grpc::StatusCode::FAILED_PRECONDITION);
        }
        const v1::SessionSnapshot expected = Export(*operations, session.name());
        CopyCrashImage(live.path, image.path);
        auto restored = Open(image);
        const v1::SessionSnapshot actual = Export(*restored, session.name());
        EXPECT_EQ(actual.SerializeAsString(), expected.SerializeAsString()) << "batch " << b;
        // The restored session and an imported copy of the state take the next batch alike.
        ContactOperations reference{service::ServiceLimits(), service::TestHooks()};
        v1::ImportSessionRequest import;
        *import.mutable_snapshot() = expected;
        import.set_session_id("i");
        v1::Session imported_session;
        ASSERT_TRUE(reference.ImportSession(std::nullopt, import, &imported_session).ok());
        std::mt19937_64 same(b), again(b);
        ASSERT_TRUE(Apply(*restored,
                          ApplyRequestFor(session.name(), RandomInterfaceBatch(same, kind)),
                          &response)
                        .ok());
        ASSERT_TRUE(Apply(reference,
                          ApplyRequestFor(session.name(), RandomInterfaceBatch(again, kind)),
                          &response)
                        .ok());
        v1::SessionSnapshot continued = Export(*restored, session.name());
        v1::SessionSnapshot imported = Export(reference, session.name());
        EXPECT_EQ(continued.SerializeAsString(), imported.SerializeAsString()) << "batch " << b;
      }
    }
  }
}

// SQLite ends the log at a cut frame and silently drops the commits from there; the side file's
// commit counter tells.
TEST_F(JournalTest, ATruncatedWriteAheadLogIsDetected) {
  std::vector<v1::SessionSnapshot> expected;
  const JournalOptions image = CrashImage(&expected);
  const std::string log = image.path + "-wal";
  std::filesystem::resize_file(log, std::filesystem::file_size(log) - 100);  // the last batch
  auto recovered = ExpectRefusedThenRecovered(image, " missing: the database ends at commit");
  // Restored as of the commit before: "x" without its last batch, "y" whole.
  ExpectSameSnapshot(Export(*recovered, "sessions/y"), expected[1]);
  EXPECT_LT(Export(*recovered, "sessions/x").applied_steps(), expected[0].applied_steps());
  EXPECT_TRUE(std::filesystem::exists(image.path + ".damaged-wal"));
  EXPECT_TRUE(std::filesystem::exists(image.path + ".damaged.commit"));
}

TEST_F(JournalTest, FlippedBytesInTheWriteAheadLogAreDetected) {
  std::vector<v1::SessionSnapshot> expected;
  const JournalOptions image = CrashImage(&expected);
  const std::string log = image.path + "-wal";
  FlipByte(log, std::filesystem::file_size(log) * 3 / 4);
  auto recovered = ExpectRefusedThenRecovered(image, " missing: the database ends at commit");
  EXPECT_LT(Export(*recovered, "sessions/x").applied_steps(), expected[0].applied_steps());
}

TEST_F(JournalTest, ADroppedTableIsDetected) {
  std::vector<v1::SessionSnapshot> expected;
  const JournalOptions options = Options();
  {
    std::mt19937_64 random(5);
    auto operations = Open(options);
    CreateLoaded(*operations, "x", 4, random);
  }
  Sql(options.path, "DROP TABLE batches");
  auto recovered = ExpectRefusedThenRecovered(options, "table batches is missing");
  // The snapshot (the state before the batches) is what is intact.
  EXPECT_EQ(Export(*recovered, "sessions/x").applied_steps(), 0u);
}

// A changed byte inside a row that still parses is caught by the row's checksum; recovery keeps
// the batches before it.
TEST_F(JournalTest, ADamagedRowIsDetectedByItsChecksum) {
  const JournalOptions options = Options();
  v1::SessionSnapshot after_two;
  {
    std::mt19937_64 random(5);
    auto operations = Open(options);
    const std::string name = "sessions/x";
    CreateLoaded(*operations, "x", 1, random);
    after_two = Export(*operations, name);
    ApplyRandomBatches(*operations, name, 3, random, "later");
  }
  // The third batch's request: one bit of its first step's depth flipped (still a valid proto).
  FlipLastBitOfBatch(options.path, 3);
  grpc::Status refused = OpenStatus(options);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("checksum of batch 3 does not match"));
  auto recovered = ExpectRefusedThenRecovered(options, "batches 3-5 dropped");
  ExpectSameSnapshot(Export(*recovered, "sessions/x"), after_two);
}

TEST_F(JournalTest, AMissingBatchIsDetected) {
  const JournalOptions options = Options();
  {
    std::mt19937_64 random(5);
    auto operations = Open(options);
    CreateLoaded(*operations, "x", 3, random);
  }
  Sql(options.path, "DELETE FROM batches WHERE sequence = 2");
  auto recovered = ExpectRefusedThenRecovered(options, "batches 2-4 dropped (batch 2 is missing)");
  EXPECT_EQ(Export(*recovered, "sessions/x").applied_steps(), 2u);  // batch 1: two steps
}

// A name no session can have (written with a valid checksum) is damage, not a session.
TEST_F(JournalTest, AnEntryWithoutASessionNameIsDetected) {
  const JournalOptions options = Options();
  v1::SessionSnapshot snapshot;
  {
    auto operations = Open(options);
    snapshot = Export(*operations, Create(*operations, "good"));
  }
  {
    std::unique_ptr<Journal> journal;
    ASSERT_TRUE(Journal::Open(options, &journal).ok());
    ASSERT_TRUE(
        journal->AddSession("sessions/../../etc", "", google::protobuf::Timestamp(), snapshot)
            .ok());
  }
  auto recovered = ExpectRefusedThenRecovered(options, "named \"sessions/../../etc\" dropped");
  EXPECT_EQ(recovered->session_count(), 1u);
}

TEST_F(JournalTest, ImportChecksTheCountersOfASnapshot) {
  ContactOperations operations{service::ServiceLimits(), service::TestHooks()};
  const std::string name = Create(operations, "source");
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(operations, ApplyRequestFor(name, {DepthStep(kDepth)}), &response).ok());
  const v1::SessionSnapshot valid = Export(operations, name);
  auto import = [&](const v1::SessionSnapshot& snapshot) {
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = snapshot;
    v1::Session session;
    return ToGrpcStatus(operations.ImportSession(std::nullopt, request, &session));
  };
  v1::SessionSnapshot snapshot = valid;
  snapshot.set_applied_steps((std::uint64_t{1} << 53) + 1);
  grpc::Status status = import(snapshot);
  ExpectInvalidArgument(status, "snapshot.applied_steps");
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("[0, 9007199254740992]"));
  for (double energy :
       {-1e-9, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    snapshot = valid;
    snapshot.mutable_contact()->set_last_step_dissipated_energy(energy);
    ExpectInvalidArgument(import(snapshot), "snapshot.contact.last_step_dissipated_energy");
    snapshot = valid;
    snapshot.mutable_contact()->set_dissipated_energy(energy);
    EXPECT_THAT(import(snapshot).error_message(),
                ::testing::HasSubstr("snapshot.contact.dissipated_energy"));
  }
  for (const char* source : {"../../etc/passwd", "sessions/", "sessions/Upper", "x"}) {
    snapshot = valid;
    snapshot.set_source_name(source);
    ExpectInvalidArgument(import(snapshot), "snapshot.source_name");
  }
  EXPECT_EQ(operations.session_count(), 1u);  // nothing was imported
  snapshot = valid;
  snapshot.set_source_name("");
  EXPECT_TRUE(import(snapshot).ok());
}

// The step counter stops at 2^53 instead of wrapping; the failed batch changes nothing.
TEST_F(JournalTest, TheStepCounterCannotWrap) {
  ContactOperations operations{service::ServiceLimits(), service::TestHooks()};
  v1::SessionSnapshot snapshot;
  {
    const std::string name = Create(operations, "source");
    snapshot = Export(operations, name);
  }
  snapshot.set_applied_steps(std::uint64_t{1} << 53);
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  request.set_session_id("full");
  v1::Session session;
  ASSERT_TRUE(operations.ImportSession(std::nullopt, request, &session).ok());
  v1::ApplyResponse response;
  grpc::Status status =
      Apply(operations, ApplyRequestFor("sessions/full", {DepthStep(kDepth)}), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(),
              ::testing::HasSubstr("steps[0]: the session has applied its maximum of 2^53 steps"));
  ExpectSameSnapshot(Export(operations, "sessions/full"), [&] {
    v1::SessionSnapshot expected = snapshot;
    expected.set_source_name("sessions/full");
    return expected;
  }());
}

TEST(JournalSync, ParsesItsNames) {
  service::JournalSync sync = service::JournalSync::kOff;
  EXPECT_TRUE(service::ParseJournalSync("full", &sync));
  EXPECT_EQ(sync, service::JournalSync::kFull);
  EXPECT_TRUE(service::ParseJournalSync("normal", &sync));
  EXPECT_EQ(sync, service::JournalSync::kNormal);
  EXPECT_FALSE(service::ParseJournalSync("always", &sync));
}

}  // namespace
}  // namespace mdr::service_testing
