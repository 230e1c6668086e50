// Scene files: YAML and JSON give the same message, lines are remembered for every field, and
// the loading path expands to the steps it promises.
#include "mdr/client/scene_file.h"

#include <gmock/gmock.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include "mdr/client/loading_path.h"

namespace {

using mdr::client::SceneDocument;
using mdr::v1::Step;
using ::testing::HasSubstr;

constexpr char kYaml[] = R"(# comment
title: 'quoted: 1e3'
scene:
  sphere: {radius: 1e-2}
  rigidOnHalfSpace:
    shear_modulus: 80e9
    poisson_ratio: .3
  friction: 0.3
path:
  - ramp: {target: {normalForce: 100}, steps: 4}
  - cycles:
      quantity: TANGENTIAL_FORCE
      amplitude: +15
      count: 2
outputs: [NORMAL_FORCE]
)";

constexpr char kJson[] = R"({
  "title": "quoted: 1e3",
  "scene": {"sphere": {"radius": 0.01},
            "rigid_on_half_space": {"shear_modulus": 8e10, "poisson_ratio": 0.3},
            "friction": 0.3},
  "path": [{"ramp": {"target": {"normal_force": 100}, "steps": 4}},
           {"cycles": {"quantity": "TANGENTIAL_FORCE", "amplitude": 15, "count": 2}}],
  "outputs": ["NORMAL_FORCE"]
})";

TEST(SceneFileTest, YamlAndJsonGiveTheSameMessage) {
  auto yaml = SceneDocument::Parse(kYaml, "a.yaml");
  auto json = SceneDocument::Parse(kJson, "a.json");
  ASSERT_TRUE(yaml.ok()) << yaml.status().ToString();
  ASSERT_TRUE(json.ok()) << json.status().ToString();
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(yaml->file(), json->file()))
      << yaml->file().DebugString() << "\n"
      << json->file().DebugString();
  EXPECT_EQ(yaml->file().title(), "quoted: 1e3");  // a quoted scalar stays a string
  EXPECT_EQ(yaml->file().scene().rigid_on_half_space().poisson_ratio(), 0.3);
}

TEST(SceneFileTest, RemembersTheLineOfEveryField) {
  auto yaml = SceneDocument::Parse(kYaml, "a.yaml");
  ASSERT_TRUE(yaml.ok());
  EXPECT_EQ(yaml->Where("scene.sphere.radius"), "a.yaml:4");
  EXPECT_EQ(yaml->Where("scene.rigid_on_half_space.poisson_ratio"), "a.yaml:7");
  EXPECT_EQ(yaml->Where("path[0].ramp.target.normal_force"), "a.yaml:10");
  EXPECT_EQ(yaml->Where("path[1].cycles.amplitude"), "a.yaml:13");
  EXPECT_EQ(yaml->Where("path[1].cycles.no_such_field"), "a.yaml:11");  // the nearest parent
  EXPECT_EQ(yaml->Where(""), "a.yaml");
  EXPECT_EQ(yaml->Error("path[1]", "bad").ToString(), "path[1]: bad (a.yaml:11)");
}

TEST(SceneFileTest, YamlInfinityReachesTheServiceAsInfinity) {
  mdr::v1::Step step;
  ASSERT_TRUE(mdr::client::ParseYamlMessage("{depth: .inf, tangential_force: -.inf}", &step).ok());
  EXPECT_EQ(step.depth(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(step.tangential_force(), -std::numeric_limits<double>::infinity());
}

TEST(SceneFileTest, ErrorsNameFieldAndLine) {
  auto unknown = SceneDocument::Parse("scene:\n  sphere:\n    radiuss: 1\n", "f.yaml");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().ToString(), "scene.sphere.radiuss: Cannot find field. (f.yaml:3)");
  auto syntax = SceneDocument::Parse("scene: [1, 2\n", "f.yaml");
  ASSERT_FALSE(syntax.ok());
  EXPECT_THAT(syntax.status().ToString(), HasSubstr("f.yaml: line "));
  auto scalar = SceneDocument::Parse("just text", "f.yaml");
  EXPECT_THAT(scalar.status().ToString(), HasSubstr("must be a mapping"));
}

mdr::v1::ContactState State(double depth, double normal_force, double ux, double fx) {
  mdr::v1::ContactState state;
  state.set_depth(depth);
  state.set_normal_force(normal_force);
  state.set_tangential_displacement(ux);
  state.set_tangential_force(fx);
  return state;
}

TEST(LoadingPathTest, RampInterpolatesFromTheStartAndHitsTheTarget) {
  mdr::v1::Segment segment;
  segment.mutable_ramp()->mutable_target()->set_tangential_force(0.3);
  segment.mutable_ramp()->mutable_target()->set_depth_increment(1e-6);
  segment.mutable_ramp()->set_steps(3);
  const auto steps = mdr::client::ExpandSegment(segment, State(2e-6, 50, 0, 0.1));
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_NEAR(steps[0].tangential_force(), 0.1 + 0.2 / 3, 1e-15);
  EXPECT_EQ(steps[2].tangential_force(), 0.3);
  for (const Step& step : steps) EXPECT_EQ(step.depth_increment(), 1e-6 / 3);
  EXPECT_EQ(mdr::client::StepCount(segment), 3u);
}

TEST(LoadingPathTest, CyclesTurnExactlyAroundTheStart) {
  mdr::v1::Segment segment;
  auto* cycles = segment.mutable_cycles();
  cycles->set_quantity(mdr::v1::Cycles::TANGENTIAL_DISPLACEMENT);
  cycles->set_amplitude(0.3);
  cycles->set_count(2);
  cycles->set_steps_per_quarter(3);
  const auto steps = mdr::client::ExpandSegment(segment, State(1e-6, 10, 0.1, 0));
  ASSERT_EQ(steps.size(), 24u);
  EXPECT_EQ(mdr::client::StepCount(segment), 24u);
  EXPECT_EQ(steps[2].displacement(), 0.1 + 0.3);  // end of the first quarter
  EXPECT_EQ(steps[8].displacement(), 0.1 - 0.3);  // end of the third
  EXPECT_EQ(steps[11].displacement(), 0.1);       // back at the start
  EXPECT_EQ(steps[23].displacement(), 0.1);
  EXPECT_NEAR(steps[5].displacement(), 0.1, 1e-16);  // zero crossing
  for (const Step& step : steps) EXPECT_EQ(step.normal_case(), Step::NORMAL_NOT_SET);
}

TEST(LoadingPathTest, RulesNameTheField) {
  mdr::v1::SceneFile file;
  file.mutable_scene();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path");
  file.add_path()->mutable_ramp();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[0].ramp.target: must set a normal or a tangential channel");
  file.mutable_path(0)->mutable_ramp()->mutable_target()->set_depth(1e-6);
  file.add_path()->mutable_cycles()->set_amplitude(1);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path[1].cycles.quantity");
  file.mutable_path(1)->mutable_cycles()->set_quantity(mdr::v1::Cycles::DEPTH);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path[1].cycles.count");
  file.mutable_path(1)->mutable_cycles()->set_count(1);
  file.add_path()->mutable_hold()->set_samples(1);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path[2].hold.samples");
  file.mutable_path(2)->mutable_hold()->set_samples(0);
  file.add_path();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[3]: must set one of step, ramp, cycles, hold");
  file.mutable_path()->RemoveLast();
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());
}

}  // namespace
