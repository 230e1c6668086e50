// Interface sessions (scene.interface): many exact contacts through the real server. Each
// contact must behave bit for bit like a single session driven the same way, and the sessions
// must be atomic, exportable and journaled like single ones.
#include <signal.h>
#include <sys/resource.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <random>
#include <thread>

#include "mdr/service/executor.h"
#include "mdr/service/pool_parallel_for.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

// Summit heights and radii of the explicit populations (m): around the H1 contact's depth.
const std::vector<double> kHeights = {0, 0.4 * kDepth, -0.3 * kDepth};
const std::vector<double> kRadii = {kRadius, 0.5 * kRadius, 2 * kRadius};

v1::Scene ExplicitScene(v1::Interface::Kind kind) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_interface()->set_kind(kind);
  auto* list = scene.mutable_interface()->mutable_explicit_list();
  list->mutable_heights()->Add(kHeights.begin(), kHeights.end());
  list->mutable_radii()->Add(kRadii.begin(), kRadii.end());
  return scene;
}

v1::Scene GeneratedScene(v1::Interface::Kind kind, std::uint64_t count) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_interface()->set_kind(kind);
  auto* generated = scene.mutable_interface()->mutable_generated();
  generated->set_count(count);
  generated->set_height_scale(0.3 * kDepth);
  generated->set_radius_distribution(v1::GeneratedPopulation::RADIUS_DISTRIBUTION_LOGNORMAL);
  generated->set_log_sigma(0.2);
  generated->set_seed(17);
  return scene;
}

// A single session of contact i of the explicit population.
v1::Scene SingleScene(std::size_t i) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(kRadii[i]);
  return scene;
}

v1::Step ListStep(const std::vector<double>& normal, const std::vector<double>& tangential) {
  v1::Step step;
  step.set_depth_increment(0);  // the values are per contact
  step.mutable_contact_normal_values()->Add(normal.begin(), normal.end());
  step.set_displacement_increment(0);
  step.mutable_contact_tangential_values()->Add(tangential.begin(), tangential.end());
  return step;
}

v1::Step Increments(double depth, double displacement) {
  v1::Step step;
  step.set_depth_increment(depth);
  step.set_displacement_increment(displacement);
  return step;
}

// The journal and its side files (write-ahead log, commit counter), so that a test can run again.
void RemoveJournal(const std::filesystem::path& journal) {
  for (const char* suffix : {"", "-wal", "-shm", "-journal", ".commit"}) {
    std::filesystem::remove(journal.string() + suffix);
  }
}

class InterfaceSessionTest : public ServiceTest {
 protected:
  void ApplyOrDie(const std::string& session, const std::vector<v1::Step>& steps) {
    v1::ApplyResponse response;
    grpc::Status status = Apply(session, steps, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }

  grpc::Status QueryInterface(const std::string& session, const std::vector<std::string>& mask,
                              v1::QueryResponse* response,
                              std::optional<std::uint64_t> contact_index = std::nullopt,
                              int bins = 0, const std::vector<double>& radii = {}) {
    v1::QueryRequest request;
    request.set_session(session);
    *request.mutable_read_mask() = Mask(mask);
    if (contact_index) request.set_contact_index(*contact_index);
    request.set_slip_histogram_bins(bins);
    request.mutable_radii()->Add(radii.begin(), radii.end());
    return stub_->Query(Context().get(), request, response);
  }

  v1::InterfaceTotals TotalsOf(const std::string& session) {
    v1::QueryResponse response;
    grpc::Status status = QueryInterface(session, {"interface.totals"}, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response.interface().totals();
  }

  // The snapshot without its source name: what must match bit for bit.
  std::string StateBytesOf(const std::string& session) {
    v1::SessionSnapshot snapshot = ExportOrDie(session);
    snapshot.clear_source_name();
    return snapshot.SerializeAsString();
  }

  std::string Import(const v1::SessionSnapshot& snapshot) {
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = snapshot;
    v1::Session session;
    grpc::Status status = stub_->ImportSession(Context().get(), request, &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }
};

TEST_F(InterfaceSessionTest, CreatesGeneratedAndExplicitInterfaces) {
  const std::string generated = CreateScene(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 200));
  const std::string listed = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  v1::QueryResponse response;
  ASSERT_TRUE(QueryInterface(generated, {"interface"}, &response, std::nullopt, 10).ok());
  EXPECT_EQ(response.interface().contact_count(), 200u);
  EXPECT_GT(response.interface().memory_bytes(), 200u * PackedContacts::kRecordBytes);
  // A new shared-motion interface touches its highest summit: nothing is loaded yet.
  EXPECT_EQ(response.interface().totals().normal_force(), 0);
  EXPECT_EQ(response.interface().slip_histogram_size(), 10);
  ASSERT_TRUE(QueryInterface(listed, {"interface.memory_bytes"}, &response).ok());
  EXPECT_EQ(response.interface().contact_count(), 3u);
  EXPECT_FALSE(response.interface().has_totals());  // only what is asked
  EXPECT_EQ(StateOf(listed).applied_steps(), 0u);
}

TEST_F(InterfaceSessionTest, SharedMotionTotalsAreTheSumOfSingleSessionsBitForBit) {
  const std::string interface = CreateScene(ExplicitScene(v1::Interface::KIND_SHARED_MOTION));
  const double approach = 0.8 * kDepth;
  const std::vector<double> displacements = {0.2 * kDisplacementAt15N, -0.1 * kDisplacementAt15N,
                                             0.3 * kDisplacementAt15N};
  std::vector<v1::Step> steps = {DepthStep(approach)};
  for (double ux : displacements) steps.push_back(DisplacementStep(ux));
  ApplyOrDie(interface, steps);

  double normal_force = 0, tangential_force = 0, energy = 0;
  for (std::size_t i = 0; i < kHeights.size(); ++i) {
    const std::string single = CreateScene(SingleScene(i));
    // Contact i has the depth approach - h_i with h_i = -heights[i].
    std::vector<v1::Step> single_steps = {DepthStep(approach + kHeights[i])};
    for (double ux : displacements) single_steps.push_back(DisplacementStep(ux));
    ApplyOrDie(single, single_steps);
    const v1::ContactState state = StateOf(single);
    normal_force += state.normal_force();
    tangential_force += state.tangential_force();
    energy += state.dissipated_energy();
    // The contact by index answers exactly as the single session.
    v1::QueryResponse by_index, alone;
    ASSERT_TRUE(QueryInterface(interface, {"state", "jager_weights", "energy"}, &by_index, i).ok());
    ASSERT_TRUE(QueryInterface(single, {"state", "jager_weights", "energy"}, &alone).ok());
    by_index.clear_compute_seconds();
    alone.clear_compute_seconds();
    EXPECT_EQ(by_index.SerializeAsString(), alone.SerializeAsString()) << "contact " << i;
  }
  const v1::InterfaceTotals totals = TotalsOf(interface);
  EXPECT_EQ(totals.normal_force(), normal_force);
  EXPECT_EQ(totals.tangential_force(), tangential_force);
  EXPECT_EQ(totals.dissipated_energy(), energy);
  EXPECT_GT(totals.in_contact(), 0u);
  const v1::ContactState state = StateOf(interface);
  EXPECT_EQ(state.depth(), approach);
  EXPECT_EQ(state.tangential_displacement(), displacements.back());
  EXPECT_EQ(state.normal_force(), normal_force);
  EXPECT_EQ(state.applied_steps(), steps.size());
}

TEST_F(InterfaceSessionTest, NormalForceTargetOfTheWholeInterfaceIsReached) {
  const std::string interface = CreateScene(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 300));
  const double target = 250;  // N
  v1::ApplyResponse applied;
  ASSERT_TRUE(Apply(interface,
                    {NormalForceStep(target), TangentialForceStep(0.5 * kFriction * target)},
                    &applied, {"state.normal_force", "substeps"})
                  .ok());
  ASSERT_EQ(applied.step_results_size(), 2);
  EXPECT_NEAR(applied.step_results(0).state().normal_force(), target, 1e-12 * target);
  EXPECT_EQ(applied.step_results(1).substeps(), 1);
  EXPECT_EQ(applied.step_results(1).state().tangential_force(), 0);  // not asked for
  const v1::InterfaceTotals totals = TotalsOf(interface);
  EXPECT_EQ(applied.state().normal_force(), totals.normal_force());
  EXPECT_NEAR(totals.normal_force(), target, 1e-12 * target);
  EXPECT_NEAR(totals.tangential_force(), 0.5 * kFriction * target, 1e-12 * totals.friction_limit());
  EXPECT_EQ(totals.sticking() + totals.partial_slip() + totals.gross_slip(), totals.in_contact());
  v1::QueryResponse response;
  ASSERT_TRUE(
      QueryInterface(interface, {"interface.slip_histogram"}, &response, std::nullopt, 7).ok());
  std::uint64_t binned = 0;
  for (std::uint64_t count : response.interface().slip_histogram()) binned += count;
  EXPECT_EQ(binned, totals.in_contact());
}

TEST_F(InterfaceSessionTest, ContactListStepsEachContactLikeASingleSession) {
  const std::string list = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  const std::vector<std::vector<double>> depth_increments = {{kDepth, 0.5 * kDepth, 1.5 * kDepth},
                                                             {0, -0.1 * kDepth, 0.2 * kDepth}};
  const std::vector<std::vector<double>> displacement_increments = {
      {0.1 * kDisplacementAt15N, -0.2 * kDisplacementAt15N, 0},
      {-0.3 * kDisplacementAt15N, 0.1 * kDisplacementAt15N, 0.05 * kDisplacementAt15N}};
  ApplyOrDie(list, {ListStep(depth_increments[0], displacement_increments[0]),
                    ListStep(depth_increments[1], displacement_increments[1])});
  // A per-contact force target as a third step.
  v1::Step forces;
  forces.set_normal_force(0);
  for (double force : {80.0, 30.0, 200.0}) forces.add_contact_normal_values(force);
  ApplyOrDie(list, {forces});

  const std::vector<double> radii = {0, 1e-5, 5e-5};
  for (std::size_t i = 0; i < kRadii.size(); ++i) {
    const std::string single = CreateScene(SingleScene(i));
    ApplyOrDie(single, {Increments(depth_increments[0][i], displacement_increments[0][i]),
                        Increments(depth_increments[1][i], displacement_increments[1][i])});
    ApplyOrDie(single, {NormalForceStep(forces.contact_normal_values(static_cast<int>(i)))});
    v1::QueryResponse by_index, alone;
    const std::vector<std::string> mask = {"state", "jager_weights", "tractions",
                                           "tangential_stiffness", "memory_pieces"};
    ASSERT_TRUE(QueryInterface(list, mask, &by_index, i, 0, radii).ok());
    ASSERT_TRUE(QueryInterface(single, mask, &alone, std::nullopt, 0, radii).ok());
    by_index.clear_compute_seconds();
    alone.clear_compute_seconds();
    EXPECT_EQ(by_index.SerializeAsString(), alone.SerializeAsString()) << "contact " << i;
  }
}

// Random batches of either kind: list steps with per-contact increments, shared steps with
// increments of the rigid motion.
std::vector<v1::Step> RandomBatch(std::mt19937_64& random, v1::Interface::Kind kind,
                                  std::size_t contacts) {
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<v1::Step> steps(1 + random() % 3);
  for (v1::Step& step : steps) {
    if (kind == v1::Interface::KIND_SHARED_MOTION) {
      step = Increments(0.2 * kDepth * unit(random), 0.3 * kDisplacementAt15N * unit(random));
      continue;
    }
    std::vector<double> normal(contacts), tangential(contacts);
    for (double& value : normal) value = 0.2 * kDepth * (unit(random) + 0.3);
    for (double& value : tangential) value = 0.3 * kDisplacementAt15N * unit(random);
    step = ListStep(normal, tangential);
  }
  return steps;
}

TEST_F(InterfaceSessionTest, ExportImportAndJournalContinueBitIdentically) {
  const std::filesystem::path journal =
      std::filesystem::temp_directory_path() /
      ("mdr-interface-journal-" + std::to_string(::getpid()) + ".sqlite");
  RemoveJournal(journal);
  service::ServerOptions options = LocalServerOptions();
  options.journal.path = journal.string();
  options.journal.snapshot_every = 3;
  Restart(options);
  for (const v1::Interface::Kind kind :
       {v1::Interface::KIND_SHARED_MOTION, v1::Interface::KIND_CONTACT_LIST}) {
    SCOPED_TRACE(v1::Interface::Kind_Name(kind));
    const std::size_t count = 40;
    const std::string original = CreateScene(GeneratedScene(kind, count));
    std::mt19937_64 random(5);
    ApplyOrDie(original, {kind == v1::Interface::KIND_SHARED_MOTION
                              ? Increments(0.9 * kDepth, 0)
                              : ListStep(std::vector<double>(count, 0.9 * kDepth),
                                         std::vector<double>(count, 0))});
    for (int batch = 0; batch < 8; ++batch) ApplyOrDie(original, RandomBatch(random, kind, count));
    const std::string copy = Import(ExportOrDie(original));
    EXPECT_EQ(StateBytesOf(copy), StateBytesOf(original));
    // The server restarts on its journal: the session comes back exactly.
    const std::string before_restart = StateBytesOf(original);
    Restart(options);
    EXPECT_EQ(StateBytesOf(original), before_restart);
    for (int batch = 0; batch < 8; ++batch) {
      const std::vector<v1::Step> steps = RandomBatch(random, kind, count);
      ApplyOrDie(original, steps);
      ApplyOrDie(copy, steps);
    }
    EXPECT_EQ(StateBytesOf(copy), StateBytesOf(original));
    EXPECT_EQ(TotalsOf(copy).SerializeAsString(), TotalsOf(original).SerializeAsString());
  }
  server_.reset();
  RemoveJournal(journal);
}

TEST_F(InterfaceSessionTest, StreamApplyStepsAContactListAtomically) {
  const std::string list = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  const std::string reference = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  const std::vector<v1::Step> load = {ListStep({kDepth, kDepth, kDepth}, {0, 0, 0})};
  const std::vector<v1::Step> slide = {ListStep({0, 0, 0}, {1e-7, -1e-7, 2e-7})};
  auto context = Context();
  auto stream = stub_->StreamApply(context.get());
  v1::StreamApplyResponse answer;
  v1::StreamApplyRequest message;
  *message.mutable_apply() = ApplyRequestFor(list, load);
  ASSERT_TRUE(stream->Write(message));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), 0) << answer.status().message();
  // A batch whose second step has a bad count: refused in its answer, nothing of it applied.
  *message.mutable_apply() = ApplyRequestFor(list, {slide[0], ListStep({0}, {0, 0, 0})});
  ASSERT_TRUE(stream->Write(message));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(answer.status().message(), testing::StartsWith("steps[1].contact_normal_values: "));
  *message.mutable_apply() = ApplyRequestFor(list, slide);
  ASSERT_TRUE(stream->Write(message));
  ASSERT_TRUE(stream->Read(&answer));
  EXPECT_EQ(answer.status().code(), 0) << answer.status().message();
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
  ApplyOrDie(reference, load);
  ApplyOrDie(reference, slide);
  EXPECT_EQ(StateBytesOf(list), StateBytesOf(reference));
}

TEST_F(InterfaceSessionTest, BadScenesNameTheField) {
  v1::Session session;
  v1::Scene scene = GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 0);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.generated.count");
  scene = GeneratedScene(v1::Interface::KIND_UNSPECIFIED, 10);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.kind");
  scene = GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 10);
  scene.mutable_interface()->mutable_generated()->set_log_sigma(4);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.generated.log_sigma");
  scene = ExplicitScene(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->mutable_explicit_list()->add_radii(kRadius);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.explicit_list.radii");
  scene = ExplicitScene(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->mutable_explicit_list()->set_radii(1, -1);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.explicit_list.radii[1]");
  // A profile other than a sphere is shared by every contact: radii cannot be given.
  scene = ExplicitScene(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_cone()->set_slope_angle(0.1);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.explicit_list.radii");
  scene = GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 10);
  scene.mutable_cone()->set_slope_angle(0.1);
  ExpectInvalidArgument(Create(scene, &session),
                        "session.scene.interface.generated.radius_distribution");
  scene = ExplicitScene(v1::Interface::KIND_CONTACT_LIST);
  scene.mutable_interface()->clear_explicit_list();
  ExpectInvalidArgument(Create(scene, &session), "session.scene.interface.population");
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), {}, &list).ok());
  EXPECT_EQ(list.sessions_size(), 0);
}

// Without radii every contact has the scene's profile, whatever it is: a cone interface under a
// shared motion is, contact by contact, the single cone session at its own depth.
TEST_F(InterfaceSessionTest, ASharedProfileInterfaceIsTheSumOfSingleSessions) {
  v1::Scene scene = ExplicitScene(v1::Interface::KIND_SHARED_MOTION);
  scene.mutable_cone()->set_slope_angle(0.05);
  scene.mutable_interface()->mutable_explicit_list()->clear_radii();
  const std::string interface = CreateScene(scene);
  const double approach = 0.8 * kDepth;
  const std::vector<v1::Step> steps = {DepthStep(approach),
                                       DisplacementStep(0.1 * kDisplacementAt15N),
                                       DisplacementStep(-0.05 * kDisplacementAt15N)};
  ApplyOrDie(interface, steps);
  double normal_force = 0, tangential_force = 0, energy = 0;
  for (std::size_t i = 0; i < kHeights.size(); ++i) {
    v1::Scene single_scene = scene;
    single_scene.clear_interface();
    const std::string single = CreateScene(single_scene);
    std::vector<v1::Step> single_steps = steps;
    single_steps[0] = DepthStep(approach + kHeights[i]);
    ApplyOrDie(single, single_steps);
    const v1::ContactState state = StateOf(single);
    normal_force += state.normal_force();
    tangential_force += state.tangential_force();
    energy += state.dissipated_energy();
    v1::QueryResponse by_index, alone;
    ASSERT_TRUE(QueryInterface(interface, {"state", "jager_weights"}, &by_index, i).ok());
    ASSERT_TRUE(QueryInterface(single, {"state", "jager_weights"}, &alone).ok());
    by_index.clear_compute_seconds();
    alone.clear_compute_seconds();
    EXPECT_EQ(by_index.SerializeAsString(), alone.SerializeAsString()) << "contact " << i;
  }
  EXPECT_GT(normal_force, 0);
  const v1::InterfaceTotals totals = TotalsOf(interface);
  EXPECT_EQ(totals.normal_force(), normal_force);
  EXPECT_EQ(totals.tangential_force(), tangential_force);
  EXPECT_EQ(totals.dissipated_energy(), energy);
  // The state round-trips like any other interface.
  const std::string imported = Import(ExportOrDie(interface));
  EXPECT_EQ(StateBytesOf(imported), StateBytesOf(interface));
}

TEST_F(InterfaceSessionTest, BadStepsAndQueriesNameTheFieldAndChangeNothing) {
  const std::string list = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  const std::string shared = CreateScene(ExplicitScene(v1::Interface::KIND_SHARED_MOTION));
  const std::string single = CreateOrDie();
  ApplyOrDie(list, {ListStep({kDepth, kDepth, kDepth}, {0, 0, 0})});
  ApplyOrDie(shared, {DepthStep(kDepth)});
  const std::string list_before = StateBytesOf(list);
  const std::string shared_before = StateBytesOf(shared);
  v1::ApplyResponse response;
  // The first step is fine; the second has two values for three contacts.
  ExpectInvalidArgument(
      Apply(list, {ListStep({0, 0, 0}, {1e-7, 0, 0}), ListStep({0, 0}, {0, 0, 0})}, &response),
      "steps[1].contact_normal_values");
  ExpectInvalidArgument(Apply(list, {ListStep({0, std::nan(""), 0}, {0, 0, 0})}, &response),
                        "steps[0].contact_normal_values[1]");
  // A value the contact itself refuses is named by the request field that carried it.
  v1::Step negative_force = ListStep({10, -3, 10}, {0, 0, 0});
  negative_force.set_normal_force(0);
  ExpectInvalidArgument(Apply(list, {negative_force}, &response),
                        "steps[0].contact_normal_values[1]");
  v1::Step own_value = ListStep({0, 0, 0}, {0, 0, 0});
  own_value.set_depth_increment(1e-6);
  ExpectInvalidArgument(Apply(list, {own_value}, &response), "steps[0].depth_increment");
  v1::Step no_channel;
  no_channel.add_contact_tangential_values(0);
  ExpectInvalidArgument(Apply(list, {no_channel}, &response), "steps[0].contact_tangential_values");
  ExpectInvalidArgument(Apply(shared, {ListStep({0, 0, 0}, {0, 0, 0})}, &response),
                        "steps[0].contact_normal_values");
  ExpectInvalidArgument(Apply(single, {ListStep({0}, {0})}, &response),
                        "steps[0].contact_normal_values");
  EXPECT_EQ(StateBytesOf(list), list_before);
  EXPECT_EQ(StateBytesOf(shared), shared_before);

  v1::QueryResponse query;
  ExpectInvalidArgument(QueryInterface(list, {"state"}, &query, 3), "contact_index");
  EXPECT_THAT(QueryInterface(list, {"state"}, &query, 3).error_message(),
              testing::HasSubstr("[0, 2]"));
  ExpectInvalidArgument(QueryInterface(list, {"jager_weights"}, &query), "contact_index");
  ExpectInvalidArgument(QueryInterface(list, {"interface.slip_histogram"}, &query),
                        "slip_histogram_bins");
  ExpectInvalidArgument(QueryInterface(single, {"state"}, &query, 0), "contact_index");
  EXPECT_EQ(QueryInterface(single, {"interface.totals"}, &query).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(InterfaceSessionTest, BadSnapshotsNameTheField) {
  const std::string list = CreateScene(ExplicitScene(v1::Interface::KIND_CONTACT_LIST));
  ApplyOrDie(list, {ListStep({kDepth, kDepth, kDepth}, {1e-7, 0, 0})});
  const v1::SessionSnapshot good = ExportOrDie(list);
  ASSERT_EQ(good.interface().contacts_size(), 3);
  EXPECT_FALSE(good.has_contact());
  v1::ImportSessionRequest request;
  v1::Session session;
  *request.mutable_snapshot() = good;
  request.mutable_snapshot()->mutable_interface()->mutable_contacts(1)->set_dissipated_energy(-1);
  ExpectInvalidArgument(stub_->ImportSession(Context().get(), request, &session),
                        "snapshot.interface.contacts[1].dissipated_energy");
  *request.mutable_snapshot() = good;
  request.mutable_snapshot()->mutable_contact()->set_depth(1e-6);
  ExpectInvalidArgument(stub_->ImportSession(Context().get(), request, &session),
                        "snapshot.contact");
  *request.mutable_snapshot() = ExportOrDie(CreateOrDie());
  *request.mutable_snapshot()->mutable_interface() = good.interface();
  ExpectInvalidArgument(stub_->ImportSession(Context().get(), request, &session),
                        "snapshot.interface");
}

TEST_F(InterfaceSessionTest, StateBudgetAndExportLimitApply) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_state_bytes = 100000;
  Restart(options);
  v1::Session session;
  grpc::Status refused = Create(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 1000), &session);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-state-bytes"));
  // Refused before the interface is built, naming the count.
  EXPECT_THAT(refused.error_message(),
              testing::StartsWith("session.scene.interface.generated.count: "));
  EXPECT_TRUE(Create(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 10), &session).ok());

  options.limits.max_state_bytes = 0;
  options.limits.max_message_bytes = 64 << 10;
  Restart(options);
  // 2000 contacts export to at least 2000 * 48 bytes: above 64 KiB.
  refused = Create(GeneratedScene(v1::Interface::KIND_CONTACT_LIST, 2000), &session);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-message-bytes"));

  // A count far beyond every limit is refused up front: nothing of it is allocated (building 10^7
  // contacts would take gigabytes and seconds).
  options.limits = {};
  Restart(options);
  refused = Create(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, 10000000), &session);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(),
              testing::StartsWith("session.scene.interface.generated.count: "));
}

// A contact list of `count` generated contacts, each pressed by `depth` (one step).
v1::Step LoadEach(std::size_t count, double depth) {
  return ListStep(std::vector<double>(count, depth), std::vector<double>(count, 0));
}

// A one-step batch runs in place and a longer one on a copy (session.cc): every way either can
// fail must leave the session exactly as it was, with nothing applied.
class InterfaceFailureTest : public InterfaceSessionTest {
 protected:
  void Remember(const std::string& session) {
    session_ = session;
    before_ = StateBytesOf(session);
    applied_ = StateOf(session).applied_steps();
  }
  void ExpectUnchanged() {
    EXPECT_EQ(StateBytesOf(session_), before_);
    EXPECT_EQ(StateOf(session_).applied_steps(), applied_);
  }

  std::string session_, before_;
  std::uint64_t applied_ = 0;
};

TEST_F(InterfaceFailureTest, ABadValueAtOneContactChangesNothing) {
  constexpr std::size_t kCount = 40;
  const std::string list = CreateScene(GeneratedScene(v1::Interface::KIND_CONTACT_LIST, kCount));
  ApplyOrDie(list, {LoadEach(kCount, kDepth)});
  Remember(list);
  std::vector<double> tangential(kCount, 1e-8);
  tangential[17] = std::nan("");
  const v1::Step bad = ListStep(std::vector<double>(kCount, 0), tangential);
  const v1::Step good = ListStep(std::vector<double>(kCount, 0), std::vector<double>(kCount, 1e-8));
  v1::ApplyResponse response;
  ExpectInvalidArgument(Apply(list, {bad}, &response), "steps[0].contact_tangential_values[17]");
  ExpectUnchanged();
  ExpectInvalidArgument(Apply(list, {good, bad}, &response),
                        "steps[1].contact_tangential_values[17]");
  ExpectUnchanged();
  // Beyond contact 5's depth limit: found by the in-place check before anything moved.
  std::vector<double> normal(kCount, 0);
  normal[5] = 1e300;
  ExpectInvalidArgument(Apply(list, {ListStep(normal, std::vector<double>(kCount, 0))}, &response),
                        "steps[0].contact_normal_values[5]");
  ExpectUnchanged();

  const std::string shared = CreateScene(GeneratedScene(v1::Interface::KIND_SHARED_MOTION, kCount));
  ApplyOrDie(shared, {Increments(kDepth, 0)});
  Remember(shared);
  ExpectInvalidArgument(Apply(shared, {DepthStep(1e300)}, &response), "steps[0].approach");
  ExpectUnchanged();
  ExpectInvalidArgument(Apply(shared, {Increments(0, 1e-8), DepthStep(1e300)}, &response),
                        "steps[1].approach");
  ExpectUnchanged();
}

TEST_F(InterfaceFailureTest, TheStateBudgetRefusesAGrowingStepAndChangesNothing) {
  constexpr std::size_t kCount = 50;
  auto slide = [](double displacement) {
    return ListStep(std::vector<double>(kCount, 0), std::vector<double>(kCount, displacement));
  };
  // Loaded and reversed twice, every contact's memory still fits its record (PackedContacts); one
  // more reversal makes it longer than a record holds, so that each contact needs a heap block.
  const std::string source = CreateScene(GeneratedScene(v1::Interface::KIND_CONTACT_LIST, kCount));
  ApplyOrDie(source, {LoadEach(kCount, kDepth), slide(4e-8), slide(-6e-8), slide(4e-8)});
  const v1::SessionSnapshot loaded = ExportOrDie(source);
  v1::QueryResponse query;
  ASSERT_TRUE(QueryInterface(Import(loaded), {"interface.memory_bytes"}, &query).ok());
  const std::uint64_t bytes = query.interface().memory_bytes();
  // Room for the session as it is, not for the heap blocks of the next reversal.
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_state_bytes = bytes + 100;
  Restart(options);
  Remember(Import(loaded));
  v1::ApplyResponse response;
  for (const std::vector<v1::Step>& batch :
       {std::vector<v1::Step>{slide(-2e-8)}, std::vector<v1::Step>{slide(0), slide(-2e-8)}}) {
    grpc::Status refused = Apply(session_, batch, &response);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-state-bytes"));
    ExpectUnchanged();
  }
  // A step that adds nothing fits: the bound of what it could add does not, so the exact state
  // after it decides (on a copy).
  ASSERT_TRUE(Apply(session_, {slide(0)}, &response).ok());
  EXPECT_EQ(response.state().applied_steps(), applied_ + 1);
}

TEST_F(InterfaceFailureTest, TheExportLimitRefusesAGrowingStepAndChangesNothing) {
  // 900 unloaded contacts export in ~45 KB; loaded, each has at least two memory vertices (24
  // bytes each): ~88 KB.
  constexpr std::size_t kCount = 900;
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_message_bytes = 64 << 10;
  Restart(options);
  Remember(CreateScene(GeneratedScene(v1::Interface::KIND_CONTACT_LIST, kCount)));
  v1::ApplyResponse response;
  for (const std::vector<v1::Step>& batch :
       {std::vector<v1::Step>{LoadEach(kCount, kDepth)},
        std::vector<v1::Step>{LoadEach(kCount, 0), LoadEach(kCount, kDepth)}}) {
    grpc::Status refused = Apply(session_, batch, &response);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_THAT(refused.error_message(), testing::HasSubstr("--max-message-bytes"));
    ExpectUnchanged();
  }
  ASSERT_TRUE(Apply(session_, {LoadEach(kCount, 0)}, &response).ok());
}

TEST_F(InterfaceFailureTest, ADeadlineOrCancellationBeforeTheStepChangesNothing) {
  std::atomic<bool> slow{false};
  service::ServerOptions options = LocalServerOptions();
  options.test_hooks.before_step = [&slow](int) {
    if (slow.load()) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  };
  Restart(options);
  constexpr std::size_t kCount = 40;
  const std::string list = CreateScene(GeneratedScene(v1::Interface::KIND_CONTACT_LIST, kCount));
  ApplyOrDie(list, {LoadEach(kCount, kDepth)});
  Remember(list);
  slow = true;
  const v1::Step slide =
      ListStep(std::vector<double>(kCount, 0), std::vector<double>(kCount, 1e-8));
  for (const std::vector<v1::Step>& batch :
       {std::vector<v1::Step>{slide}, std::vector<v1::Step>{slide, slide}}) {
    v1::ApplyResponse response;
    grpc::Status status = stub_->Apply(Context(std::chrono::milliseconds(100)).get(),
                                       ApplyRequestFor(list, batch), &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
    auto context = Context();
    std::thread canceller([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      context->TryCancel();
    });
    status = stub_->Apply(context.get(), ApplyRequestFor(list, batch), &response);
    canceller.join();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED);
    ExpectUnchanged();  // Query waits for the abandoned batch
  }
  slow = false;
}

// Every write of this process to a regular file fails (EFBIG) while it lives.
class NoFileWrites {
 public:
  NoFileWrites() {
    previous_handler_ = signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &previous_);
    rlimit none = previous_;
    none.rlim_cur = 0;
    setrlimit(RLIMIT_FSIZE, &none);
  }
  ~NoFileWrites() {
    setrlimit(RLIMIT_FSIZE, &previous_);
    signal(SIGXFSZ, previous_handler_);
  }

 private:
  rlimit previous_{};
  sighandler_t previous_handler_;
};

TEST_F(InterfaceFailureTest, AJournalThatCannotWriteChangesNothing) {
  const std::filesystem::path journal =
      std::filesystem::temp_directory_path() /
      ("mdr-interface-failing-journal-" + std::to_string(::getpid()) + ".sqlite");
  RemoveJournal(journal);
  service::ServerOptions options = LocalServerOptions();
  options.journal.path = journal.string();
  Restart(options);
  constexpr std::size_t kCount = 40;
  for (const v1::Interface::Kind kind :
       {v1::Interface::KIND_CONTACT_LIST, v1::Interface::KIND_SHARED_MOTION}) {
    SCOPED_TRACE(v1::Interface::Kind_Name(kind));
    const bool list = kind == v1::Interface::KIND_CONTACT_LIST;
    const std::string session = CreateScene(GeneratedScene(kind, kCount));
    ApplyOrDie(session, {list ? LoadEach(kCount, kDepth) : Increments(kDepth, 0)});
    Remember(session);
    const v1::Step slide =
        list ? ListStep(std::vector<double>(kCount, 0), std::vector<double>(kCount, 1e-8))
             : Increments(0, 1e-8);
    for (const std::vector<v1::Step>& batch :
         {std::vector<v1::Step>{slide}, std::vector<v1::Step>{slide, slide}}) {
      v1::ApplyResponse response;
      grpc::Status refused;
      {
        const NoFileWrites no_writes;
        refused = Apply(session, batch, &response);
      }
      EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.error_message();
      ExpectUnchanged();
    }
    // The journal works again, and a restart replays what it accepted.
    ApplyOrDie(session, {slide});
    const std::string after = StateBytesOf(session);
    Restart(options);
    EXPECT_EQ(StateBytesOf(session), after);
  }
  server_.reset();
  RemoveJournal(journal);
}

// Interfaces large enough for their passes to be split (2048 contacts and more) give the same
// sessions on one worker and on two (the pool's shares go to whichever worker claims them).
TEST_F(InterfaceSessionTest, OneAndTwoPoolWorkersGiveIdenticalSessions) {
  constexpr std::size_t kCount = 3000;
  std::vector<std::string> exported;
  for (const std::size_t workers : {1u, 2u}) {
    service::ServerOptions options = LocalServerOptions();
    options.execution.workers = workers;
    Restart(options);
    std::string states;
    for (const v1::Interface::Kind kind :
         {v1::Interface::KIND_CONTACT_LIST, v1::Interface::KIND_SHARED_MOTION}) {
      const std::string session = CreateScene(GeneratedScene(kind, kCount));
      std::mt19937_64 random(11);
      ApplyOrDie(session,
                 {kind == v1::Interface::KIND_SHARED_MOTION ? Increments(0.9 * kDepth, 0)
                                                            : LoadEach(kCount, 0.9 * kDepth)});
      for (int batch = 0; batch < 4; ++batch)
        ApplyOrDie(session, RandomBatch(random, kind, kCount));
      if (kind == v1::Interface::KIND_SHARED_MOTION) {
        v1::Step target;
        target.set_tangential_force(0.2 * TotalsOf(session).friction_limit());
        ApplyOrDie(session, {target});
      }
      states += StateBytesOf(session) + TotalsOf(session).SerializeAsString();
    }
    exported.push_back(states);
  }
  EXPECT_TRUE(exported[0] == exported[1]);
}

TEST(PoolParallelForTest, ASaturatedPoolStillCompletesEveryIndexOnce) {
  service::Executor executor({.workers = 2, .max_queued = 1});
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<int> blocked{0};
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(executor.Submit("", "",
                              [&blocked, released] {
                                ++blocked;
                                released.wait();
                              }),
              service::Executor::Admission::kQueued);
    while (blocked.load() < i + 1) std::this_thread::yield();  // out of the queue, running
  }
  service::PoolParallelFor parallel(executor);
  EXPECT_EQ(parallel.workers(), 2);
  // Both workers are busy: the helper is queued but never starts; the caller runs every share.
  std::vector<int> visits(10000, 0);
  parallel.Run(visits.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) ++visits[i];
  });
  EXPECT_EQ(std::count(visits.begin(), visits.end(), 1), 10000);
  // The queue is full now (the helper waits in it): Submit is not even tried.
  parallel.Run(visits.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) ++visits[i];
  });
  EXPECT_EQ(std::count(visits.begin(), visits.end(), 2), 10000);
  release.set_value();  // the queued helper starts, finds nothing left and returns
  executor.Stop();
  // A stopped pool refuses every helper: still complete.
  parallel.Run(visits.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) ++visits[i];
  });
  EXPECT_EQ(std::count(visits.begin(), visits.end(), 3), 10000);
}

}  // namespace
}  // namespace mdr::service_testing
