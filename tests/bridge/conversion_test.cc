// Unit tests of the proto <-> core conversion (conversion.h), without a server: field paths of
// errors, effective options, step and snapshot round trips.
#include "mdr/bridge/conversion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "bridge_test_util.h"

namespace mdr::bridge_testing {
namespace {

constexpr std::size_t kServerVertexLimit = 4096;

Status ConfigError(const v1::Scene& scene) {
  return bridge::ToContactConfig(scene, kServerVertexLimit).status();
}

TEST(ConversionTest, TheReferenceSceneBecomesItsCoreConfig) {
  Result<ContactConfig> config =
      bridge::ToContactConfig(SteelSphereOnSteelFlat(), kServerVertexLimit);
  ASSERT_TRUE(config.ok()) << config.status().ToString();
  EXPECT_EQ(config->friction, kFriction);
  EXPECT_DOUBLE_EQ(config->material.e_star, EffectiveYoungsModulus());
  EXPECT_DOUBLE_EQ(config->material.kappa(), Kappa());
  EXPECT_DOUBLE_EQ(config->profile->G(1e-4), 1e-8 / kRadius);  // g = x^2 / R
  EXPECT_EQ(config->method, Method::kExact);
  EXPECT_TRUE(config->track_energy);
  // The server's limit is the default when it is below the core's.
  EXPECT_EQ(config->max_memory_vertices, kServerVertexLimit);
}

TEST(ConversionTest, ErrorsNameTheSceneField) {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(-1);
  EXPECT_EQ(ConfigError(scene).field(), "scene.sphere.radius");

  scene = SteelSphereOnSteelFlat();
  scene.set_friction(-0.1);
  EXPECT_EQ(ConfigError(scene).field(), "scene.friction");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_force_path_tolerance(0.5);
  EXPECT_EQ(ConfigError(scene).field(), "scene.options.force_path_tolerance");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_options()->set_max_memory_vertices(kServerVertexLimit + 1);
  const Status too_many = ConfigError(scene);
  EXPECT_EQ(too_many.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(too_many.field(), "scene.options.max_memory_vertices");
  EXPECT_NE(too_many.message().find(std::to_string(kServerVertexLimit)), std::string::npos);

  scene = SteelSphereOnSteelFlat();
  scene.set_method(v1::METHOD_GRID);  // without grid.max_radius
  EXPECT_EQ(ConfigError(scene).field().rfind("scene.grid", 0), 0u) << ConfigError(scene).field();
}

TEST(ConversionTest, CoreFieldsAreRenamedToTheirScenePaths) {
  EXPECT_EQ(bridge::ToSceneStatus(InvalidArgument("friction", "x")).field(), "scene.friction");
  EXPECT_EQ(bridge::ToSceneStatus(InvalidArgument("grid_size", "x")).field(), "scene.grid.size");
  EXPECT_TRUE(bridge::ToSceneStatus(OkStatus()).ok());
  const Status other = bridge::ToSceneStatus(FailedPrecondition("x", "y"));
  EXPECT_EQ(other.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(other.message(), "y");
}

// The effective options spell out every default, and the scene they describe resolves to the same
// config on a server with other defaults.
TEST(ConversionTest, EffectiveOptionsResolveToTheSameConfig) {
  v1::Scene grid = SteelSphereOnSteelFlat();
  grid.set_method(v1::METHOD_GRID);
  grid.mutable_grid()->set_max_radius(3e-4);
  for (const v1::Scene& scene : {SteelSphereOnSteelFlat(), grid}) {
    const ContactConfig config = *bridge::ToContactConfig(scene, kServerVertexLimit);
    const v1::Scene effective = bridge::WithEffectiveOptions(scene, config);
    EXPECT_TRUE(effective.options().has_force_path_tolerance());
    EXPECT_EQ(effective.options().force_path_tolerance(), config.force_path_tolerance);
    EXPECT_EQ(effective.options().max_memory_vertices(), config.max_memory_vertices);
    const ContactConfig again = *bridge::ToContactConfig(effective, 1u << 20);
    EXPECT_EQ(again.max_memory_vertices, config.max_memory_vertices);
    EXPECT_EQ(again.force_path_tolerance, config.force_path_tolerance);
    EXPECT_EQ(again.track_energy, config.track_energy);
    EXPECT_EQ(again.method, config.method);
    EXPECT_EQ(again.grid_size, config.grid_size);
    EXPECT_EQ(again.grid_max_radius, config.grid_max_radius);
  }
}

TEST(ConversionTest, AnUnsetChannelHolds) {
  const Step held = bridge::ToCoreStep(v1::Step());
  EXPECT_EQ(held.normal, NormalControl::kDepthIncrement);
  EXPECT_EQ(held.normal_value, 0);
  EXPECT_EQ(held.tangential, TangentialControl::kDisplacementIncrement);
  EXPECT_EQ(held.tangential_value, 0);
  const Step force = bridge::ToCoreStep(TangentialForceStep(12.5));
  EXPECT_EQ(force.tangential, TangentialControl::kForce);
  EXPECT_EQ(force.tangential_value, 12.5);
  EXPECT_EQ(force.normal_value, 0);
}

// Snapshot -> proto -> snapshot is the identity over random histories (the export's form).
TEST(ConversionTest, SnapshotsRoundTripBitForBit) {
  Contact contact = *Contact::Create(*bridge::ToContactConfig(SteelSphereOnSteelFlat(), 1 << 16));
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> depth(-0.1 * kDepth, 1.5 * kDepth);
  std::uniform_real_distribution<double> slide(-1, 1);
  int in_contact = 0;
  for (int i = 0; i < 300; ++i) {
    ASSERT_TRUE(contact.MoveTo(depth(random), slide(random) * kFriction * Kappa() * kDepth).ok());
    const ContactSnapshot snapshot = contact.Snapshot();
    v1::ContactSnapshot proto;
    bridge::ToProtoSnapshot(snapshot, &proto);
    const ContactSnapshot back = bridge::ToCoreSnapshot(proto).value();
    ASSERT_EQ(back.depth, snapshot.depth);
    ASSERT_EQ(back.tangential_displacement, snapshot.tangential_displacement);
    ASSERT_EQ(back.dissipated_energy, snapshot.dissipated_energy);
    ASSERT_EQ(back.last_step_dissipation, snapshot.last_step_dissipation);
    ASSERT_EQ(back.z, snapshot.z);
    ASSERT_EQ(back.u, snapshot.u);
    ASSERT_EQ(back.tags, snapshot.tags);
    ASSERT_TRUE(Contact::Restore(contact.config(), back).ok());
    in_contact += snapshot.depth > 0;
  }
  EXPECT_GT(in_contact, 200);
}

TEST(ConversionTest, AnUnknownBoundIsOneTheCoreRejects) {
  for (std::uint8_t tag : {kInside, kOnUpper, kOnLower, kOnBoth}) {
    v1::ContactSnapshot proto;
    proto.set_depth(1e-6);
    v1::MemoryVertex* first = proto.add_memory();
    first->set_z(0);
    first->set_bound(bridge::ToProtoBound(tag));
    v1::MemoryVertex* edge = proto.add_memory();
    edge->set_z(1e-6);
    EXPECT_EQ(bridge::ToCoreSnapshot(proto)->tags.front(), tag);
  }
  v1::ContactSnapshot proto;
  proto.set_depth(1e-6);
  proto.add_memory()->set_bound(static_cast<v1::MemoryBound>(77));
  proto.add_memory()->set_z(1e-6);
  EXPECT_GT(bridge::ToCoreSnapshot(proto)->tags.front(), kOnBoth);
}

TEST(ConversionTest, RadialSamplingNamesTheBadRadiusAndRoute) {
  google::protobuf::RepeatedField<double> radii;
  radii.Add(1e-5);
  radii.Add(-1e-5);
  EXPECT_EQ(bridge::ToRadialSampling(radii, v1::TRACTION_ROUTE_JAGER).status().field(), "radii[1]");
  radii.Set(1, NAN);
  EXPECT_EQ(bridge::ToRadialSampling(radii, v1::TRACTION_ROUTE_JAGER).status().field(), "radii[1]");
  radii.Set(1, 2e-5);
  EXPECT_TRUE(bridge::ToRadialSampling(radii, v1::TRACTION_ROUTE_BOTH).ok());
  const Status route = bridge::ToRadialSampling(radii, static_cast<v1::TractionRoute>(99)).status();
  EXPECT_EQ(route.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(route.field(), "traction_route");
}

}  // namespace
}  // namespace mdr::bridge_testing
