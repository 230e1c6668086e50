// Sessions as resources: pagination, export/import with bit-identical continuation, idle expiry.
#include <algorithm>
#include <functional>
#include <random>
#include <thread>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

using SessionResourcesTest = ServiceTest;

std::vector<std::string> NamesOf(const v1::ListSessionsResponse& page) {
  std::vector<std::string> names;
  for (const v1::Session& session : page.sessions()) names.push_back(session.name());
  return names;
}

TEST_F(SessionResourcesTest, ListSessionsPaginatesInNameOrder) {
  for (const char* id : {"g", "c", "a", "f", "b", "e", "d"}) CreateOrDie(id);
  v1::ListSessionsRequest request;
  request.set_page_size(3);
  v1::ListSessionsResponse page;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), request, &page).ok());
  EXPECT_THAT(NamesOf(page), ElementsAre("sessions/a", "sessions/b", "sessions/c"));
  EXPECT_EQ(page.sessions(0).scene().friction(), kFriction);
  ASSERT_FALSE(page.next_page_token().empty());

  // Deleting a session already listed does not shift the next page.
  v1::DeleteSessionRequest delete_request;
  delete_request.set_name("sessions/b");
  google::protobuf::Empty empty;
  ASSERT_TRUE(stub_->DeleteSession(Context().get(), delete_request, &empty).ok());

  request.set_page_token(page.next_page_token());
  ASSERT_TRUE(stub_->ListSessions(Context().get(), request, &page).ok());
  EXPECT_THAT(NamesOf(page), ElementsAre("sessions/d", "sessions/e", "sessions/f"));
  request.set_page_token(page.next_page_token());
  ASSERT_TRUE(stub_->ListSessions(Context().get(), request, &page).ok());
  EXPECT_THAT(NamesOf(page), ElementsAre("sessions/g"));
  EXPECT_TRUE(page.next_page_token().empty());

  // Default page size holds them all.
  ASSERT_TRUE(stub_->ListSessions(Context().get(), v1::ListSessionsRequest(), &page).ok());
  EXPECT_EQ(page.sessions_size(), 6);
  EXPECT_TRUE(page.next_page_token().empty());

  request.set_page_size(-1);
  ExpectInvalidArgument(stub_->ListSessions(Context().get(), request, &page), "page_size");
  request.set_page_size(3);
  request.set_page_token("not a token");
  ExpectInvalidArgument(stub_->ListSessions(Context().get(), request, &page), "page_token");
}

// Sessions with tabulated profiles of 20001 points (about 320 kB each) under a message limit of
// 1 MiB: the default page would be 1.6 MB, so pages end early, each within the limit, and
// together list every session once, in order.
TEST_F(SessionResourcesTest, ListSessionsPagesStayWithinTheMessageLimit) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_message_bytes = 1 << 20;
  Restart(options);
  v1::CreateSessionRequest create;
  v1::Scene& scene = *create.mutable_session()->mutable_scene();
  scene = SteelSphereOnSteelFlat();
  for (int i = 0; i <= 20000; ++i) {
    const double r = 1e-3 * i / 20000;
    scene.mutable_tabulated()->add_radii(r);
    scene.mutable_tabulated()->add_heights(r * r / (2 * 0.01));
  }
  std::vector<std::string> created;
  for (const char* id : {"a", "b", "c", "d", "e"}) {
    create.set_session_id(id);
    v1::Session session;
    ASSERT_TRUE(stub_->CreateSession(Context().get(), create, &session).ok());
    created.push_back(session.name());
  }
  std::vector<std::string> listed;
  v1::ListSessionsRequest request;
  int pages = 0;
  do {
    v1::ListSessionsResponse page;
    const grpc::Status status = stub_->ListSessions(Context().get(), request, &page);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_LE(page.ByteSizeLong(), std::size_t{1} << 20);
    EXPECT_GE(page.sessions_size(), 1);
    for (const std::string& name : NamesOf(page)) listed.push_back(name);
    request.set_page_token(page.next_page_token());
    ASSERT_LT(++pages, 10);
  } while (!request.page_token().empty());
  EXPECT_EQ(listed, created);
  EXPECT_GE(pages, 2);
}

// A reproducible random loading history of the H1 contact: depth, displacement and force
// control, increments, curved force paths, lift-off and re-contact, load reversals.
class RandomHistory {
 public:
  explicit RandomHistory(unsigned seed) : random_(seed) {}

  v1::Step Next() {
    v1::Step step;
    switch (Uniform(0, 5) < 1 ? 0 : static_cast<int>(Uniform(1, 5))) {
      case 0:  // depth, possibly lifting off, with a tangential increment
        step.set_depth(kDepth * Uniform(-0.2, 1.2));
        step.set_displacement_increment(kDisplacementAt15N * Uniform(-0.3, 0.3));
        break;
      case 1:  // both forces at once: a curved path
        step.set_normal_force(Uniform(20, 150));
        step.set_tangential_force(0.9 * kFriction * step.normal_force() * Uniform(-1, 1));
        break;
      case 2:
        step.set_displacement(kDisplacementAt15N * Uniform(-1, 1));
        break;
      case 3:
        step.set_depth_increment(kDepth * Uniform(-0.05, 0.05));
        step.set_displacement_increment(kDisplacementAt15N * Uniform(-0.2, 0.2));
        break;
      default:
        step.set_normal_force(Uniform(20, 150));
        step.set_displacement_increment(kDisplacementAt15N * Uniform(-0.2, 0.2));
        break;
    }
    return step;
  }

  std::vector<v1::Step> Batch(int size) {
    std::vector<v1::Step> steps;
    for (int i = 0; i < size; ++i) steps.push_back(Next());
    return steps;
  }

 private:
  double Uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(random_);
  }
  std::mt19937_64 random_;
};

// Applies the same batches of `history` to a session here (through `apply_here`) and to its
// imported copy on another server: every response, all doubles included, must match bit for
// bit. `check` sees each response.
using ApplyHere = std::function<grpc::Status(const std::vector<v1::Step>&,
                                             const std::vector<std::string>&, v1::ApplyResponse*)>;
void ExpectSameContinuation(const ApplyHere& apply_here, v1::ContactService::Stub& there,
                            const std::string& imported, RandomHistory& history, int batches,
                            const std::function<void(const v1::ApplyResponse&)>& check = {}) {
  const std::vector<std::string> every_field = {"state", "substeps", "path_error",
                                                "dissipated_energy"};
  for (int batch = 0; batch < batches; ++batch) {
    const std::vector<v1::Step> steps = history.Batch(10);
    v1::ApplyResponse here, there_response;
    ASSERT_TRUE(apply_here(steps, every_field, &here).ok());
    ASSERT_TRUE(
        there.Apply(Context().get(), ApplyRequestFor(imported, steps, every_field), &there_response)
            .ok());
    here.clear_compute_seconds();
    there_response.clear_compute_seconds();
    // Serialised doubles compare bit for bit.
    ASSERT_EQ(here.SerializeAsString(), there_response.SerializeAsString()) << "batch " << batch;
    if (check) check(here);
  }
}

TEST_F(SessionResourcesTest, ImportedSessionContinuesBitIdentically) {
  // A loose path tolerance keeps the curved force paths to a few sub-steps each.
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_force_path_tolerance(1e-6);
  v1::Session created;
  ASSERT_TRUE(Create(scene, &created).ok());
  const std::string original = created.name();
  RandomHistory history(20261121);
  v1::ApplyResponse response;
  for (int batch = 0; batch < 20; ++batch) {
    grpc::Status status = Apply(original, history.Batch(10), &response, {"substeps"});
    for (const v1::StepResult& result : response.step_results()) {
      EXPECT_LT(result.substeps(), 1000) << "batch " << batch;
    }
    ASSERT_TRUE(status.ok()) << "batch " << batch << ": " << status.error_message();
  }
  // End on nested load reversals, so the exported memory has many pieces.
  std::vector<v1::Step> reversals = {DepthStep(kDepth)};
  for (double fraction : {1.0, -0.8, 0.6, -0.45, 0.3, -0.2, 0.12, -0.06}) {
    reversals.push_back(DisplacementStep(fraction * kDisplacementAt15N));
  }
  ASSERT_TRUE(Apply(original, reversals, &response).ok());
  const v1::SessionSnapshot snapshot = ExportOrDie(original);
  EXPECT_EQ(snapshot.version(), 1u);
  EXPECT_EQ(snapshot.source_name(), original);
  EXPECT_EQ(snapshot.applied_steps(), 209u);
  EXPECT_GE(snapshot.contact().memory_size(), 8) << "the history should leave a rich memory";
  EXPECT_TRUE(snapshot.scene().options().has_max_memory_vertices());  // effective options

  // Into a fresh server, as a rig moving to another replica would.
  auto other = service::ContactServer::Start(LocalServerOptions());
  ASSERT_TRUE(other.ok());
  auto other_stub = v1::ContactService::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string((*other)->port()), grpc::InsecureChannelCredentials()));
  v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = snapshot;
  import_request.set_session_id("moved");
  v1::Session imported;
  grpc::Status status = other_stub->ImportSession(Context().get(), import_request, &imported);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(imported.name(), "sessions/moved");
  EXPECT_EQ(imported.state().SerializeAsString(), StateOf(original).SerializeAsString());

  ASSERT_NO_FATAL_FAILURE(ExpectSameContinuation(
      [&](const std::vector<v1::Step>& steps, const std::vector<std::string>& mask,
          v1::ApplyResponse* response) { return Apply(original, steps, response, mask); },
      *other_stub, imported.name(), history, 10));
  v1::ExportSessionRequest export_request;
  export_request.set_name(imported.name());
  v1::SessionSnapshot continued;
  ASSERT_TRUE(other_stub->ExportSession(Context().get(), export_request, &continued).ok());
  v1::SessionSnapshot reference = ExportOrDie(original);
  EXPECT_EQ(reference.contact().SerializeAsString(), continued.contact().SerializeAsString());
  EXPECT_EQ(continued.applied_steps(), 309u);
}

TEST_F(SessionResourcesTest, ImportedGridSessionContinuesBitIdentically) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_force_path_tolerance(1e-6);
  scene.set_method(v1::METHOD_GRID);
  scene.mutable_grid()->set_size(512);
  scene.mutable_grid()->set_max_radius(3 * std::sqrt(kRadius * kDepth));
  scene.mutable_grid()->set_step_rule(v1::GRID_STEP_RULE_NAIVE);
  v1::Session created;
  grpc::Status status = Create(scene, &created);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const std::string original = created.name();
  RandomHistory history(7);
  v1::ApplyResponse response;
  for (int batch = 0; batch < 5; ++batch) {
    status = Apply(original, history.Batch(10), &response);
    ASSERT_TRUE(status.ok()) << "batch " << batch << ": " << status.error_message();
  }
  ASSERT_TRUE(Apply(original,
                    {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N),
                     DisplacementStep(-0.5 * kDisplacementAt15N),
                     DisplacementStep(0.2 * kDisplacementAt15N)},
                    &response)
                  .ok());
  const v1::SessionSnapshot snapshot = ExportOrDie(original);
  EXPECT_EQ(snapshot.scene().method(), v1::METHOD_GRID);
  EXPECT_EQ(snapshot.scene().grid().step_rule(), v1::GRID_STEP_RULE_NAIVE);
  EXPECT_EQ(snapshot.contact().memory_size(), 0);
  ASSERT_EQ(snapshot.contact().grid_u_size(), 512);
  EXPECT_GT(
      *std::max_element(snapshot.contact().grid_u().begin(), snapshot.contact().grid_u().end()), 0);
  EXPECT_LT(
      *std::min_element(snapshot.contact().grid_u().begin(), snapshot.contact().grid_u().end()), 0);

  auto other = service::ContactServer::Start(LocalServerOptions());
  ASSERT_TRUE(other.ok());
  auto other_stub = v1::ContactService::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string((*other)->port()), grpc::InsecureChannelCredentials()));
  v1::ImportSessionRequest import_request;
  *import_request.mutable_snapshot() = snapshot;
  v1::Session imported;
  status = other_stub->ImportSession(Context().get(), import_request, &imported);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(imported.state().SerializeAsString(), StateOf(original).SerializeAsString());
  ASSERT_NO_FATAL_FAILURE(ExpectSameContinuation(
      [&](const std::vector<v1::Step>& steps, const std::vector<std::string>& mask,
          v1::ApplyResponse* response) { return Apply(original, steps, response, mask); },
      *other_stub, imported.name(), history, 5,
      [](const v1::ApplyResponse& here) { EXPECT_GT(here.error_estimate().grid_spacing(), 0); }));
  v1::ExportSessionRequest export_request;
  export_request.set_name(imported.name());
  v1::SessionSnapshot continued;
  ASSERT_TRUE(other_stub->ExportSession(Context().get(), export_request, &continued).ok());
  EXPECT_EQ(ExportOrDie(original).contact().SerializeAsString(),
            continued.contact().SerializeAsString());

  // The snapshot's state must fit its method.
  const auto import = [&](const v1::SessionSnapshot& bad) {
    *import_request.mutable_snapshot() = bad;
    return stub_->ImportSession(Context().get(), import_request, &imported);
  };
  v1::SessionSnapshot bad = snapshot;
  bad.mutable_contact()->mutable_grid_u()->RemoveLast();
  ExpectInvalidArgument(import(bad), "snapshot.contact.grid_u");
  bad = snapshot;
  bad.mutable_contact()->set_grid_u(3, 1);  // far beyond the Coulomb bound
  ExpectInvalidArgument(import(bad), "snapshot.contact.grid_u[3]");
  bad = snapshot;
  bad.mutable_contact()->add_memory()->set_z(0);
  ExpectInvalidArgument(import(bad), "snapshot.contact.memory");
  bad = snapshot;
  bad.mutable_scene()->set_method(v1::METHOD_EXACT);
  ExpectInvalidArgument(import(bad), "snapshot.contact.grid_u");
}

TEST_F(SessionResourcesTest, ImportRejectsInconsistentSnapshots) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session,
                    {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N),
                     DisplacementStep(kDisplacementAt15N / 2)},
                    &response)
                  .ok());
  const v1::SessionSnapshot good = ExportOrDie(session);
  ASSERT_GE(good.contact().memory_size(), 3);
  const auto import = [&](const v1::SessionSnapshot& snapshot) {
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = snapshot;
    v1::Session imported;
    return stub_->ImportSession(Context().get(), request, &imported);
  };
  ASSERT_TRUE(import(good).ok());

  v1::SessionSnapshot bad = good;
  bad.set_version(2);
  ExpectInvalidArgument(import(bad), "snapshot.version");

  bad = good;
  bad.mutable_scene()->mutable_sphere()->set_radius(0);
  ExpectInvalidArgument(import(bad), "snapshot.scene.sphere.radius");

  bad = good;
  bad.mutable_contact()->mutable_memory(2)->set_z(bad.contact().memory(1).z());
  ExpectInvalidArgument(import(bad), "snapshot.contact.memory[2]");

  bad = good;
  bad.mutable_contact()->mutable_memory(0)->set_u(1);  // far beyond the Coulomb bound
  ExpectInvalidArgument(import(bad), "snapshot.contact.memory[0]");

  bad = good;
  bad.mutable_contact()->mutable_memory(1)->set_bound(static_cast<v1::MemoryBound>(9));
  ExpectInvalidArgument(import(bad), "snapshot.contact.memory[1]");

  bad = good;
  bad.mutable_contact()->set_dissipated_energy(-1);
  ExpectInvalidArgument(import(bad), "snapshot.contact.dissipated_energy");

  bad = good;
  bad.mutable_contact()->set_depth(-1e-6);  // out of contact, yet with a memory
  ExpectInvalidArgument(import(bad), "snapshot.contact.memory");

  bad = good;
  bad.mutable_limits()->set_max_steps_per_batch(1 << 20);
  ExpectInvalidArgument(import(bad), "snapshot.limits.max_steps_per_batch");

  bad = good;
  bad.mutable_scene()->mutable_options()->set_max_memory_vertices(8);
  for (int i = 0; i < 8; ++i) *bad.mutable_contact()->add_memory() = good.contact().memory(0);
  grpc::Status status = import(bad);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("snapshot.contact.memory: "));
}

TEST_F(SessionResourcesTest, IdleSessionsExpire) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.session_idle_timeout = std::chrono::milliseconds(500);
  Restart(options);
  const std::string kept = CreateOrDie("kept");
  const std::string idle = CreateOrDie("idle");
  v1::Session resource;
  v1::GetSessionRequest get;
  get.set_name(kept);
  for (int i = 0; i < 8; ++i) {  // 800 ms of use, never 500 ms idle
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ASSERT_TRUE(stub_->GetSession(Context().get(), get, &resource).ok()) << i;
  }
  EXPECT_EQ(resource.limits().idle_timeout().nanos(), 500'000'000);
  v1::QueryResponse response;
  EXPECT_TRUE(Query(kept, &response).ok());
  EXPECT_EQ(Query(idle, &response).error_code(), grpc::StatusCode::NOT_FOUND);
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));
  // The sweeper deleted the other one without any call on it.
  EXPECT_EQ(server_->session_count(), 0u);
  EXPECT_EQ(Query(kept, &response).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(SessionResourcesTest, SessionIdleTimeoutShorterThanTheServersApplies) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  request.mutable_session()->mutable_limits()->mutable_idle_timeout()->set_nanos(100'000'000);
  v1::Session session;
  ASSERT_TRUE(stub_->CreateSession(Context().get(), request, &session).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  v1::QueryResponse response;
  EXPECT_EQ(Query(session.name(), &response).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::ListSessionsResponse page;
  ASSERT_TRUE(stub_->ListSessions(Context().get(), v1::ListSessionsRequest(), &page).ok());
  EXPECT_EQ(page.sessions_size(), 0);
}

}  // namespace
}  // namespace mdr::service_testing
