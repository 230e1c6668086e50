// Scene files: YAML and JSON give the same message, lines are remembered for every field, and
// the loading path expands to the steps it promises.
#include "mdr/bridge/scene_file.h"

#include <gmock/gmock.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mdr/client/loading_path.h"

namespace {

using mdr::bridge::SceneDocument;
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
  ASSERT_TRUE(mdr::bridge::ParseYamlMessage("{depth: .inf, tangential_force: -.inf}", &step).ok());
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
  EXPECT_EQ(syntax.status().field(), "");  // the document's error, not a field's
  auto scalar = SceneDocument::Parse("just text", "f.yaml");
  EXPECT_THAT(scalar.status().ToString(), HasSubstr("must be a mapping"));
  // yaml-cpp stops at its nesting limit with the message "bad file", as if it could not open it.
  const std::string deep = "scene: " + std::string(1000, '[') + std::string(1000, ']') + "\n";
  auto nested = SceneDocument::Parse(deep, "f.yaml");
  ASSERT_FALSE(nested.ok());
  EXPECT_THAT(nested.status().ToString(),
              HasSubstr("nested too deep for the YAML parser (it stops at depth 500)"));
}

// A state as the server reports it without a rig: the actuator where the contact is.
mdr::v1::ContactState State(double depth, double normal_force, double ux, double fx) {
  mdr::v1::ContactState state;
  state.set_depth(depth);
  state.set_normal_force(normal_force);
  state.set_tangential_displacement(ux);
  state.set_tangential_force(fx);
  state.set_actuator_depth(depth);
  state.set_actuator_displacement(ux);
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
            "path[0].ramp.target: must set a normal, a tangential or a twist channel");
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
            "path[3]: must set one of step, ramp, cycles, hold, contact_ramp, contact_cycles");
  file.mutable_path()->RemoveLast();
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());
}

constexpr char kContactList[] = R"(scene:
  sphere: {radius: 1e-4}
  rigid_on_half_space: {shear_modulus: 80e9, poisson_ratio: 0.3}
  friction: 0.3
  interface:
    kind: KIND_CONTACT_LIST
    explicit_list: {heights: [0, 0, 0], radii: [1e-4, 1e-4, 2e-4]}
path:
  - contact_ramp:
      depth_increments: {values: [1e-6, 2e-6, 3e-6]}
      steps: 4
  - contact_cycles:
      quantity: TANGENTIAL_DISPLACEMENT
      amplitudes: {linear: {first: 1e-8, last: -1e-8}}
      count: 2
      steps_per_quarter: 3
)";

TEST(SceneFileTest, InterfacesAndTheirSegmentsParse) {
  auto document = SceneDocument::Parse(kContactList, "list.yaml");
  ASSERT_TRUE(document.ok()) << document.status().ToString();
  const mdr::v1::SceneFile& file = document->file();
  EXPECT_EQ(mdr::client::KindOf(file.scene()), mdr::client::SceneKind::kContactList);
  EXPECT_EQ(mdr::client::ContactCount(file.scene()), 3u);
  EXPECT_EQ(document->Where("scene.interface.explicit_list.radii"), "list.yaml:7");
  EXPECT_EQ(document->Where("path[1].contact_cycles.amplitudes.linear.last"), "list.yaml:14");
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());
  EXPECT_EQ(mdr::client::StepCount(file), 4u + 24u);

  auto generated = SceneDocument::Parse(
      "scene: {sphere: {radius: 1e-4}, interface: {kind: KIND_SHARED_MOTION, generated: "
      "{count: 3000, height_scale: 1e-6, seed: 7}}}\npath: [{ramp: {target: {normal_force: 5}}}]",
      "g.yaml");
  ASSERT_TRUE(generated.ok()) << generated.status().ToString();
  EXPECT_EQ(mdr::client::KindOf(generated->file().scene()), mdr::client::SceneKind::kSharedMotion);
  EXPECT_EQ(mdr::client::ContactCount(generated->file().scene()), 3000u);
}

TEST(LoadingPathTest, ContactRampSplitsEachContactsIncrement) {
  auto document = SceneDocument::Parse(kContactList, "list.yaml");
  ASSERT_TRUE(document.ok());
  const auto steps = mdr::client::ExpandSegment(document->file().path(0), {}, 3);
  ASSERT_EQ(steps.size(), 4u);
  for (const Step& step : steps) {
    EXPECT_EQ(step.normal_case(), Step::kDepthIncrement);
    EXPECT_EQ(step.depth_increment(), 0);
    EXPECT_THAT(step.contact_normal_values(), ::testing::ElementsAre(1e-6 / 4, 2e-6 / 4, 3e-6 / 4));
    EXPECT_EQ(step.tangential_case(), Step::TANGENTIAL_NOT_SET);
    EXPECT_TRUE(step.contact_tangential_values().empty());
  }
}

TEST(LoadingPathTest, ContactCyclesGoUpDownUpAroundTheStart) {
  auto document = SceneDocument::Parse(kContactList, "list.yaml");
  ASSERT_TRUE(document.ok());
  const auto steps = mdr::client::ExpandSegment(document->file().path(1), {}, 3);
  ASSERT_EQ(steps.size(), 24u);
  double u[3] = {0, 0, 0};  // each contact's displacement, summed as the service does
  double peak = 0;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    ASSERT_EQ(steps[k].contact_tangential_values_size(), 3);
    EXPECT_EQ(steps[k].normal_case(), Step::NORMAL_NOT_SET);
    for (int i = 0; i < 3; ++i) u[i] += steps[k].contact_tangential_values(i);
    if (k == 2) peak = u[0];
    if (k == 8) {
      EXPECT_NEAR(u[0], -1e-8, 1e-22);  // end of the third quarter
    }
  }
  EXPECT_NEAR(peak, 1e-8, 1e-22);  // linear: first = 1e-8, middle 0, last -1e-8
  EXPECT_NEAR(u[0], 0, 1e-22);
  EXPECT_EQ(steps[0].contact_tangential_values(1), 0);
  EXPECT_DOUBLE_EQ(steps[0].contact_tangential_values(2), -1e-8 / 3);
}

TEST(LoadingPathTest, InterfaceRulesNameTheFieldAndRange) {
  auto parsed = SceneDocument::Parse(kContactList, "list.yaml");
  ASSERT_TRUE(parsed.ok());
  mdr::v1::SceneFile file = parsed->file();
  auto* ramp = file.mutable_path(0)->mutable_contact_ramp();
  ramp->mutable_depth_increments()->add_values(4e-6);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[0].contact_ramp.depth_increments.values: must hold one value per contact (3), "
            "got 4");
  ramp->mutable_depth_increments()->mutable_linear();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[0].contact_ramp.depth_increments: must set either values (one per contact) or "
            "linear");
  ramp->mutable_depth_increments()->clear_values();
  ramp->mutable_depth_increments()->mutable_linear()->set_last(
      std::numeric_limits<double>::infinity());
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(),
            "path[0].contact_ramp.depth_increments.linear.last");
  ramp->clear_depth_increments();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path[0].contact_ramp");
  ramp->mutable_displacement_increments()->add_values(1);
  ramp->mutable_displacement_increments()->add_values(std::nan(""));
  ramp->mutable_displacement_increments()->add_values(1);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(),
            "path[0].contact_ramp.displacement_increments.values[1]");
  ramp->mutable_displacement_increments()->set_values(1, 0);
  file.mutable_path(1)->mutable_contact_cycles()->set_quantity(mdr::v1::Cycles::NORMAL_FORCE);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[1].contact_cycles.quantity: must be DEPTH or TANGENTIAL_DISPLACEMENT");
  file.mutable_path(1)->mutable_contact_cycles()->set_quantity(mdr::v1::Cycles::DEPTH);
  file.mutable_path(1)->mutable_contact_cycles()->set_count(0);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).field(), "path[1].contact_cycles.count");
  file.mutable_path(1)->mutable_contact_cycles()->set_count(1);
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());

  // Segments and columns against the scene's kind.
  file.add_path()->mutable_cycles();
  EXPECT_THAT(mdr::client::ValidateSceneFile(file).ToString(),
              HasSubstr("path[2].cycles: not for a contact list"));
  file.mutable_path()->RemoveLast();
  file.mutable_scene()->mutable_interface()->set_kind(mdr::v1::Interface::KIND_SHARED_MOTION);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[0].contact_ramp: needs a contact list (scene.interface.kind KIND_CONTACT_LIST)");
  file.clear_path();
  file.add_path()->mutable_step()->set_normal_force(10);
  file.add_outputs(mdr::v1::SceneFile::GROSS_SLIP);
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());
  file.mutable_scene()->clear_interface();
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "outputs[0]: GROSS_SLIP needs an interface (scene.interface)");
}

TEST(LoadingPathTest, DefaultColumnsFollowTheSceneKind) {
  using mdr::v1::SceneFile;
  SceneFile file;
  EXPECT_FALSE(mdr::client::NeedsInterfaceTotals(mdr::client::TableOutputs(file)));
  file.mutable_scene()->mutable_interface()->set_kind(mdr::v1::Interface::KIND_SHARED_MOTION);
  EXPECT_EQ(mdr::client::TableOutputs(file).front(), SceneFile::DEPTH);  // the approach
  EXPECT_TRUE(mdr::client::NeedsInterfaceTotals(mdr::client::TableOutputs(file)));
  file.mutable_scene()->mutable_interface()->set_kind(mdr::v1::Interface::KIND_CONTACT_LIST);
  EXPECT_EQ(mdr::client::TableOutputs(file).front(), SceneFile::NORMAL_FORCE);
  file.add_outputs(SceneFile::NORMAL_FORCE);  // the file's own columns need no query
  EXPECT_FALSE(mdr::client::NeedsInterfaceTotals(mdr::client::TableOutputs(file)));
}

// A torsional scene (scene.torsion): ramps and cycles of the twist from the start's twist and
// moment, its own default columns, and the rules that keep the channels apart.
TEST(LoadingPathTest, TorsionalScenesRampAndCycleTheTwist) {
  mdr::v1::ContactState start = State(2e-6, 50, 0, 0);
  start.set_twist(1e-3);
  start.set_twisting_moment(2e-4);
  mdr::v1::Segment ramp;
  ramp.mutable_ramp()->mutable_target()->set_twisting_moment(5e-4);
  ramp.mutable_ramp()->set_steps(3);
  auto steps = mdr::client::ExpandSegment(ramp, start);
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_NEAR(steps[0].twisting_moment(), 3e-4, 1e-18);
  EXPECT_EQ(steps[2].twisting_moment(), 5e-4);
  ramp.mutable_ramp()->mutable_target()->set_twist_increment(3e-3);
  for (const Step& step : mdr::client::ExpandSegment(ramp, start)) {
    EXPECT_EQ(step.twist_increment(), 1e-3);
    EXPECT_EQ(step.normal_case(), Step::NORMAL_NOT_SET);
  }
  mdr::v1::Segment cycles;
  cycles.mutable_cycles()->set_quantity(mdr::v1::Cycles::TWIST);
  cycles.mutable_cycles()->set_amplitude(2e-3);
  cycles.mutable_cycles()->set_count(1);
  cycles.mutable_cycles()->set_steps_per_quarter(2);
  steps = mdr::client::ExpandSegment(cycles, start);
  ASSERT_EQ(steps.size(), 8u);
  EXPECT_EQ(steps[1].twist(), 1e-3 + 2e-3);
  EXPECT_EQ(steps[5].twist(), 1e-3 - 2e-3);
  EXPECT_EQ(steps[7].twist(), 1e-3);
  cycles.mutable_cycles()->set_quantity(mdr::v1::Cycles::TWISTING_MOMENT);
  EXPECT_EQ(mdr::client::ExpandSegment(cycles, start)[7].twisting_moment(), 2e-4);

  using mdr::v1::SceneFile;
  SceneFile file;
  file.mutable_scene()->mutable_torsion();
  *file.add_path() = cycles;
  EXPECT_TRUE(mdr::client::ValidateSceneFile(file).ok());
  EXPECT_EQ(mdr::client::KindOf(file.scene()), mdr::client::SceneKind::kTorsion);
  const auto columns = mdr::client::TableOutputs(file);
  EXPECT_NE(std::find(columns.begin(), columns.end(), SceneFile::TWISTING_MOMENT), columns.end());
  EXPECT_EQ(std::find(columns.begin(), columns.end(), SceneFile::TANGENTIAL_FORCE), columns.end());
  file.mutable_path(0)->mutable_cycles()->set_quantity(mdr::v1::Cycles::TANGENTIAL_FORCE);
  EXPECT_THAT(mdr::client::ValidateSceneFile(file).ToString(),
              HasSubstr("path[0].cycles.quantity: TANGENTIAL_FORCE is not for a torsional scene"));
  file.mutable_scene()->clear_torsion();
  file.mutable_path(0)->mutable_cycles()->set_quantity(mdr::v1::Cycles::TWIST);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "path[0].cycles.quantity: TWIST needs a torsional scene (scene.torsion)");
  file.mutable_path(0)->mutable_cycles()->set_quantity(mdr::v1::Cycles::TANGENTIAL_FORCE);
  file.add_outputs(SceneFile::TWIST);
  EXPECT_EQ(mdr::client::ValidateSceneFile(file).ToString(),
            "outputs[0]: TWIST needs a torsional scene (scene.torsion)");
}

}  // namespace
