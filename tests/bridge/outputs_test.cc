// Unit tests of the output selection and writers (outputs.h): masks, what is computed for what is
// asked, and the radii bound.
#include "mdr/bridge/outputs.h"

#include <gtest/gtest.h>

#include <chrono>

#include "bridge_test_util.h"
#include "mdr/bridge/conversion.h"

namespace mdr::bridge_testing {
namespace {

using bridge::Output;
using bridge::OutputSelection;

Contact LoadedReferenceContact() {
  Contact contact = *Contact::Create(*bridge::ToContactConfig(SteelSphereOnSteelFlat(), 1 << 16));
  // Normal load first, then the tangential displacement at constant depth (Cattaneo-Mindlin).
  EXPECT_TRUE(contact.MoveTo(kDepth, 0).ok());
  EXPECT_TRUE(contact.MoveTo(kDepth, kDisplacementAt15N).ok());
  return contact;
}

TEST(OutputsTest, MasksSelectLeavesAndSubtrees) {
  const OutputSelection none = *bridge::SelectStepOutputs(Mask({}));
  EXPECT_TRUE(none.empty());
  const OutputSelection state = *bridge::SelectQueryOutputs(Mask({}));
  EXPECT_TRUE(state.has(Output::kNormalForce) && state.has(Output::kMemoryVertices));
  EXPECT_FALSE(state.has(Output::kTractions));
  const OutputSelection step =
      *bridge::SelectStepOutputs(Mask({"state.tangential_force", "dissipated_energy"}));
  EXPECT_TRUE(step.has(Output::kTangentialForce));
  EXPECT_TRUE(step.has(Output::kStepResultDissipatedEnergy));
  EXPECT_FALSE(step.has(Output::kNormalForce));
  const OutputSelection energy = *bridge::SelectQueryOutputs(Mask({"energy"}));
  EXPECT_TRUE(energy.has(Output::kEnergyDissipatedEnergy) &&
              energy.has(Output::kEnergyLastStepDissipatedEnergy));
  EXPECT_FALSE(energy.any_state());
}

TEST(OutputsTest, AnUnknownPathNamesItsIndexAndTheValidPaths) {
  const Status status = bridge::SelectStepOutputs(Mask({"state", "tractions"})).status();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.field(), "step_mask.paths[1]");
  EXPECT_NE(status.message().find("substeps"), std::string::npos) << status.message();
  EXPECT_EQ(bridge::SelectQueryOutputs(Mask({"state.nope"})).status().field(),
            "read_mask.paths[0]");
}

// Only what is selected is written, and only the selected Query outputs are computed.
TEST(OutputsTest, OnlyTheSelectedOutputsAreWrittenAndComputed) {
  const Contact contact = LoadedReferenceContact();
  OutputSelection selection;
  selection.add(Output::kTangentialForce);
  v1::ContactState state;
  bridge::WriteState(contact, 7, selection, &state);
  ExpectRelativelyNear(state.tangential_force(), 15, 1e-9);
  EXPECT_EQ(state.normal_force(), 0);
  EXPECT_EQ(state.applied_steps(), 0u);

  bridge::OutputCounters counters;
  v1::QueryResponse response;
  const OutputSelection jager = *bridge::SelectQueryOutputs(Mask({"jager_weights"}));
  ASSERT_TRUE(bridge::WriteQueryOutputs(contact, 7, jager, {}, &response, &counters).ok());
  EXPECT_EQ(counters[Output::kJagerWeights], 1u);
  EXPECT_EQ(counters[Output::kTractions], 0u);
  EXPECT_EQ(counters[Output::kNormalForce], 0u);
  EXPECT_FALSE(response.has_state());
  EXPECT_GT(response.jager_weights().intervals_size(), 0);
}

TEST(OutputsTest, TheRadiiBoundKeepsEveryResponseWithinTheMessageLimit) {
  const OutputSelection state = *bridge::SelectQueryOutputs(Mask({"state"}));
  EXPECT_EQ(bridge::MaxRadii(state, 4 << 20), std::numeric_limits<std::size_t>::max());
  const OutputSelection radial =
      *bridge::SelectQueryOutputs(Mask({"springs", "tractions", "pressure"}));
  const std::size_t max_radii = bridge::MaxRadii(radial, 1 << 16);
  ASSERT_GT(max_radii, 0u);
  EXPECT_TRUE(bridge::CheckRadiiCount(static_cast<int>(max_radii), radial, 1 << 16).ok());
  const Status over = bridge::CheckRadiiCount(static_cast<int>(max_radii) + 1, radial, 1 << 16);
  EXPECT_EQ(over.field(), "radii");

  // A response at the bound, with every radial output at its largest encoding, fits.
  const Contact contact = LoadedReferenceContact();
  bridge::RadialSampling sampling;
  sampling.traction_options = *bridge::ToTractionOptions(v1::TRACTION_ROUTE_BOTH, "route");
  for (std::size_t i = 0; i < max_radii; ++i) {
    sampling.radii.push_back(contact.contact_radius() * (i + 0.5) / max_radii);
  }
  v1::QueryResponse response;
  bridge::OutputCounters counters;
  ASSERT_TRUE(bridge::WriteQueryOutputs(contact, 1, radial, sampling, &response, &counters).ok());
  EXPECT_LE(response.ByteSizeLong(), std::size_t{1} << 16);
}

}  // namespace
}  // namespace mdr::bridge_testing
