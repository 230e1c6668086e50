// The session journal: restoring replays every journaled batch bit-identically (state, applied
// steps, and the responses remembered for request ids), compaction replaces batches by a snapshot
// without changing what is restored, deleted sessions stay deleted, owners are kept, and one
// journal serves one process at a time. The crash test against the real mdrd binary is
// journal_crash_test.py.
#include "mdr/service/journal.h"

#include <google/protobuf/util/message_differencer.h>
#include <stdlib.h>

#include <filesystem>
#include <optional>
#include <random>

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

  std::unique_ptr<ContactOperations> Open(const JournalOptions& options) {
    auto operations =
        std::make_unique<ContactOperations>(service::ServiceLimits(), service::TestHooks());
    grpc::Status status = operations->OpenJournal(options);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return operations;
  }

  // What the journal holds (opened while no ContactOperations has it).
  std::vector<JournaledSession> Load(const JournalOptions& options) {
    std::unique_ptr<Journal> journal;
    EXPECT_TRUE(Journal::Open(options, &journal).ok());
    std::vector<JournaledSession> sessions;
    EXPECT_TRUE(journal->Load(&sessions).ok());
    return sessions;
  }

  static std::string Create(ContactOperations& operations, const std::string& id,
                            const Principal& caller = std::nullopt) {
    v1::CreateSessionRequest request;
    *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
    request.set_session_id(id);
    v1::Session session;
    grpc::Status status = operations.CreateSession(caller, request, &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }

  static grpc::Status Apply(ContactOperations& operations, const v1::ApplyRequest& request,
                            v1::ApplyResponse* response) {
    return operations.Apply(std::nullopt, request, nullptr, response);
  }

  static v1::SessionSnapshot Export(ContactOperations& operations, const std::string& name,
                                    const Principal& caller = std::nullopt) {
    v1::ExportSessionRequest request;
    request.set_name(name);
    v1::SessionSnapshot snapshot;
    grpc::Status status = operations.ExportSession(caller, request, &snapshot);
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
  EXPECT_EQ(restored->GetSession(std::nullopt, get_request, &session).error_code(),
            grpc::StatusCode::NOT_FOUND);

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
  EXPECT_EQ(restored->GetSession(Principal("bob"), request, &session).error_code(),
            grpc::StatusCode::NOT_FOUND);
}

TEST_F(JournalTest, OneProcessAtATime) {
  auto operations = Open(Options());
  ContactOperations second{service::ServiceLimits(), service::TestHooks()};
  grpc::Status status = second.OpenJournal(Options());
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
  grpc::Status status = operations.OpenJournal(options);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr(options.path));
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
