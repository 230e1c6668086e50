// Slip state through the service (issue #23): the Mindlin-Deresiewicz histories of the core's
// SlipStateTest driven through Apply and read back by Query (slip_intervals,
// tangential_stiffness, jager_weights) against the closed forms; a session exported before a
// return to an inner turning point and imported continues with the same slip state bit for bit
// (the anchors travel in the snapshot); and an interface's counts and slip histogram equal those
// of its contacts run as single sessions.
#include <cmath>
#include <numbers>
#include <random>

#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

// A scene of one profile kind and one material kind, with the closed-form inverse of g.
struct SceneCase {
  std::string name;
  v1::Scene scene;
  std::function<double(double)> radius_at;  // g^-1(z); nullptr: a flat punch (no partial slip)
  double kappa;
};

double RigidKappa(double nu) { return (2 - nu) / (2 - 2 * nu); }

// kappa = E*/G* of two elastic bodies (docs/physics.md, "Symbols").
double PairKappa(double e1, double nu1, double e2, double nu2) {
  const double g1 = e1 / (2 * (1 + nu1)), g2 = e2 / (2 * (1 + nu2));
  const double e_star = 1 / ((1 - nu1 * nu1) / e1 + (1 - nu2 * nu2) / e2);
  const double g_star = 1 / ((2 - nu1) / (4 * g1) + (2 - nu2) / (4 * g2));
  return e_star / g_star;
}

std::vector<SceneCase> SceneCases(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<SceneCase> cases;
  for (bool pair : {false, true}) {
    v1::Scene base;
    double kappa = 0;
    const double nu = 0.45 * unit(rng), modulus = 1e8 * std::pow(1e3, unit(rng));
    if (pair) {
      const double nu2 = 0.45 * unit(rng), modulus2 = modulus * (0.5 + unit(rng));
      v1::ElasticPair* material = base.mutable_elastic_pair();
      material->set_youngs_modulus_1(modulus);
      material->set_poisson_ratio_1(nu);
      material->set_youngs_modulus_2(modulus2);
      material->set_poisson_ratio_2(nu2);
      kappa = PairKappa(modulus, nu, modulus2, nu2);
    } else {
      base.mutable_rigid_on_half_space()->set_shear_modulus(modulus);
      base.mutable_rigid_on_half_space()->set_poisson_ratio(nu);
      kappa = RigidKappa(nu);
    }
    base.set_friction(0.1 + unit(rng));
    const std::string material = pair ? " on an elastic pair" : " on a rigid/half-space";
    const double radius = 0.001 + 0.05 * unit(rng);
    SceneCase sphere{"sphere" + material, base, [=](double z) { return std::sqrt(radius * z); },
                     kappa};
    sphere.scene.mutable_sphere()->set_radius(radius);
    const double angle = 0.1 + unit(rng), cone_k = std::numbers::pi / 2 * std::tan(angle);
    SceneCase cone{"cone" + material, base, [=](double z) { return z / cone_k; }, kappa};
    cone.scene.mutable_cone()->set_slope_angle(angle);
    const double n = 3, c = 1e3 * (1 + unit(rng));
    const double k =
        c * std::sqrt(std::numbers::pi) * std::tgamma(n / 2 + 1) / std::tgamma(n / 2 + 0.5);
    SceneCase power{"power law n = 3" + material, base, [=](double z) { return std::cbrt(z / k); },
                    kappa};
    power.scene.mutable_power_law()->set_coefficient(c);
    power.scene.mutable_power_law()->set_exponent(n);
    SceneCase punch{"flat punch" + material, base, nullptr, kappa};
    punch.scene.mutable_flat_punch()->set_radius(1e-3);
    for (SceneCase* each : {&sphere, &cone, &power, &punch}) cases.push_back(std::move(*each));
  }
  return cases;
}

class SlipStateServiceTest : public ServiceTest {
 protected:
  v1::QueryResponse SlipState(const std::string& session) {
    v1::QueryResponse response;
    grpc::Status status = Query(
        session, &response,
        {"state", "slip_intervals", "tangential_stiffness", "jager_weights", "memory_pieces"});
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response;
  }

  std::string Import(v1::SessionSnapshot snapshot) {
    v1::ImportSessionRequest request;
    *request.mutable_snapshot() = std::move(snapshot);
    v1::Session session;
    grpc::Status status = stub_->ImportSession(Context().get(), request, &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.name();
  }
};

// The slip annulus from depth z_c in `direction` (0: none) against what the service reports.
::testing::AssertionResult Matches(const v1::QueryResponse& answer, const SceneCase& scene,
                                   int direction, double z_c) {
  const double a = answer.state().contact_radius();
  // 2 G* = 2 E* / kappa; the stiffness of full stick is 2 G* a, read off the other direction.
  const v1::TangentialStiffness& k = answer.tangential_stiffness();
  if (direction == 0) {
    if (answer.slip_intervals_size() != 0) return ::testing::AssertionFailure() << "slips";
    if (k.positive() != k.negative()) return ::testing::AssertionFailure() << "asymmetric";
    return ::testing::AssertionSuccess();
  }
  if (answer.slip_intervals_size() != 1) {
    return ::testing::AssertionFailure() << answer.slip_intervals_size() << " slip intervals";
  }
  const v1::SlipInterval& slip = answer.slip_intervals(0);
  const double c = scene.radius_at(z_c);
  if (slip.direction() != direction || slip.r_end() != a ||
      !(std::abs(slip.r_begin() - c) <= 1e-12 * c)) {
    return ::testing::AssertionFailure()
           << "slip interval [" << slip.r_begin() << ", " << slip.r_end() << "] direction "
           << slip.direction() << ", expected [" << c << ", " << a << "] " << direction;
  }
  const double toward = direction > 0 ? k.positive() : k.negative();
  const double away = direction > 0 ? k.negative() : k.positive();
  if (!(std::abs(toward - away * c / a) <= 1e-12 * toward)) {
    return ::testing::AssertionFailure()
           << "stiffness toward the slip " << toward << ", expected 2 G* c = " << away * c / a;
  }
  const v1::JagerWeights& weights = answer.jager_weights();
  for (const v1::WeightInterval& w : weights.intervals()) {
    if (std::abs(w.weight()) > 1 || (w.r_begin() >= slip.r_begin() && w.weight() != direction)) {
      return ::testing::AssertionFailure() << "weight " << w.weight() << " at " << w.r_begin();
    }
  }
  return ::testing::AssertionSuccess();
}

TEST_F(SlipStateServiceTest, ReversalsMatchTheClosedForms) {
  std::mt19937_64 rng(2301);
  std::uniform_real_distribution<double> unit(0, 1);
  int states = 0, round_trips = 0;
  for (int round = 0; round < 120; ++round) {
    const double s = 1e-3 * std::pow(999.0, unit(rng));  // of gross slip
    for (const SceneCase& scene : SceneCases(rng)) {
      const std::string session = CreateScene(scene.scene);
      v1::ApplyResponse response;
      const double depth = 1e-7 * std::pow(100.0, unit(rng));
      ASSERT_TRUE(Apply(session, {DepthStep(depth)}, &response).ok());
      const double mk = scene.scene.friction() * scene.kappa, amplitude = s * mk * depth;
      // Each step with the travel since the last turning point that sets its annulus.
      const std::vector<std::pair<double, double>> history = {
          {amplitude, 2 * amplitude},       {-amplitude, 2 * amplitude},
          {amplitude / 2, 1.5 * amplitude}, {-amplitude, 2 * amplitude},
          {amplitude, 2 * amplitude},       {0, amplitude}};
      int direction = 0;
      for (std::size_t i = 0; i < history.size(); ++i) {
        const auto [target, travel] = history[i];
        std::string copy;
        if (i == 3) copy = Import(ExportOrDie(session));  // before the inner loop closes
        for (const std::string& each : {session, copy}) {
          if (each.empty()) continue;
          ASSERT_TRUE(Apply(each, {DisplacementStep(target)}, &response).ok());
        }
        direction = i == 0 ? 1 : -direction;
        const v1::QueryResponse answer = SlipState(session);
        const double z_c = depth - travel / (2 * mk);
        ASSERT_TRUE(Matches(answer, scene, scene.radius_at ? direction : 0, z_c))
            << scene.name << ", s = " << s << ", step " << i;
        ++states;
        if (copy.empty()) continue;
        v1::QueryResponse copied = SlipState(copy);
        copied.clear_compute_seconds();
        v1::QueryResponse original = answer;
        original.clear_compute_seconds();
        ASSERT_EQ(copied.SerializeAsString(), original.SerializeAsString())
            << "the imported copy answers differently after the return, " << scene.name;
        ++round_trips;
      }
    }
  }
  std::printf("[ slip ] %d states through the service, %d imported copies\n", states, round_trips);
}

// A snapshot written before anchors existed (none on any vertex) still imports, with the same
// slip state; one whose anchor contradicts its tags is refused, naming the field.
TEST_F(SlipStateServiceTest, SnapshotsWithoutAnchorsImportAndWrongAnchorsAreRefused) {
  const std::string session = CreateOrDie();
  v1::ApplyResponse response;
  ASSERT_TRUE(Apply(session,
                    {NormalForceStep(100), DisplacementStep(3e-7), DisplacementStep(-3e-7),
                     DisplacementStep(1e-7)},
                    &response)
                  .ok());
  v1::SessionSnapshot snapshot = ExportOrDie(session);
  int anchored = 0;
  for (const v1::MemoryVertex& vertex : snapshot.contact().memory())
    anchored += vertex.has_anchor();
  ASSERT_GE(anchored, 2) << "a slip annulus and the stick piece that left the lower bound";
  v1::SessionSnapshot old = snapshot;
  for (v1::MemoryVertex& vertex : *old.mutable_contact()->mutable_memory()) vertex.clear_anchor();
  const std::string restored = Import(old);
  v1::QueryResponse a = SlipState(session), b = SlipState(restored);
  EXPECT_EQ(a.slip_intervals(0).r_begin(), b.slip_intervals(0).r_begin());
  EXPECT_EQ(a.tangential_stiffness().positive(), b.tangential_stiffness().positive());
  EXPECT_EQ(a.tangential_stiffness().negative(), b.tangential_stiffness().negative());

  v1::SessionSnapshot wrong = snapshot;
  v1::MemoryVertex& last_piece =
      *wrong.mutable_contact()->mutable_memory(wrong.contact().memory_size() - 2);
  ASSERT_EQ(last_piece.anchor().bound(), v1::MEMORY_BOUND_UPPER);
  last_piece.mutable_anchor()->set_tangential_displacement(0);  // not the current state
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = wrong;
  v1::Session imported;
  ExpectInvalidArgument(
      stub_->ImportSession(Context().get(), request, &imported),
      "snapshot.contact.memory[" + std::to_string(wrong.contact().memory_size() - 2) + "].anchor");
}

// An interface's slip counts and histogram are those of its contacts run one by one: summits of
// radii 2-20 mm at heights spread over the depth, under one shared motion cycled through the
// Mindlin-Deresiewicz history (some summits out of contact, some in gross slip).
TEST_F(SlipStateServiceTest, InterfaceCountsAreTheSumOfSingleContacts) {
  constexpr int kSummits = 40, kBins = 8;
  std::mt19937_64 rng(2302);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<double> heights, radii;
  for (int i = 0; i < kSummits; ++i) {
    heights.push_back(kDepth * (1.2 * unit(rng) - 1.2));  // depth kDepth + h: -0.2 .. 1 kDepth
    radii.push_back(0.002 + 0.018 * unit(rng));
  }
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_interface()->set_kind(v1::Interface::KIND_SHARED_MOTION);
  auto* list = scene.mutable_interface()->mutable_explicit_list();
  list->mutable_heights()->Add(heights.begin(), heights.end());
  list->mutable_radii()->Add(radii.begin(), radii.end());
  const std::string interface = CreateScene(scene);
  std::vector<std::string> singles;
  v1::ApplyResponse response;
  for (int i = 0; i < kSummits; ++i) {
    v1::Scene single = SteelSphereOnSteelFlat();
    single.mutable_sphere()->set_radius(radii[i]);
    singles.push_back(CreateScene(single));
    ASSERT_TRUE(Apply(singles.back(), {DepthStep(kDepth + heights[i])}, &response).ok());
  }
  ASSERT_TRUE(Apply(interface, {DepthStep(kDepth)}, &response).ok());
  const double amplitude = 0.5 * 0.3 * Kappa() * kDepth;  // gross slip where depth < kDepth / 2
  int partial_seen = 0, gross_seen = 0;
  for (double target : {amplitude, -amplitude, amplitude / 2, -amplitude, amplitude, 0.0}) {
    ASSERT_TRUE(Apply(interface, {DisplacementStep(target)}, &response).ok());
    std::uint64_t sticking = 0, partial = 0, gross = 0, in_contact = 0;
    std::vector<std::uint64_t> histogram(kBins, 0);
    for (const std::string& single : singles) {
      ASSERT_TRUE(Apply(single, {DisplacementStep(target)}, &response).ok());
      const v1::QueryResponse answer = SlipState(single);
      const double a = answer.state().contact_radius();
      if (!(a > 0)) continue;
      ++in_contact;
      double slipping = 0;
      for (const v1::SlipInterval& slip : answer.slip_intervals()) {
        slipping += slip.r_end() - slip.r_begin();
      }
      if (answer.slip_intervals_size() == 0) {
        ++sticking;
      } else if (answer.slip_intervals(0).r_begin() == 0) {
        ++gross;
      } else {
        ++partial;
      }
      ++histogram[std::min<std::size_t>(static_cast<std::size_t>(slipping / a * kBins), kBins - 1)];
    }
    v1::QueryRequest request;
    request.set_session(interface);
    *request.mutable_read_mask() = Mask({"interface.totals", "interface.slip_histogram"});
    request.set_slip_histogram_bins(kBins);
    v1::QueryResponse answer;
    ASSERT_TRUE(stub_->Query(Context().get(), request, &answer).ok());
    const v1::InterfaceTotals& totals = answer.interface().totals();
    EXPECT_EQ(totals.in_contact(), in_contact) << "ux = " << target;
    EXPECT_EQ(totals.sticking(), sticking) << "ux = " << target;
    EXPECT_EQ(totals.partial_slip(), partial) << "ux = " << target;
    EXPECT_EQ(totals.gross_slip(), gross) << "ux = " << target;
    EXPECT_EQ(std::vector<std::uint64_t>(answer.interface().slip_histogram().begin(),
                                         answer.interface().slip_histogram().end()),
              histogram)
        << "ux = " << target;
    partial_seen += static_cast<int>(partial);
    gross_seen += static_cast<int>(gross);
  }
  EXPECT_GT(partial_seen, 20) << "the history must leave contacts in partial slip";
  EXPECT_GT(gross_seen, 5) << "and some in gross slip";
}

}  // namespace
}  // namespace mdr::service_testing
