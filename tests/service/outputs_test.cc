// Unit tests of the output selection and writers (outputs.h, limits.h) without a server: masks,
// what is computed for what is asked, the radii bound, and the session limits.
#include "mdr/service/outputs.h"

#include <gtest/gtest.h>

#include <chrono>

#include "mdr/service/conversion.h"
#include "mdr/service/limits.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using service::Output;
using service::OutputSelection;

Contact LoadedReferenceContact() {
  Contact contact = *Contact::Create(*service::ToContactConfig(SteelSphereOnSteelFlat(), 1 << 16));
  // Normal load first, then the tangential displacement at constant depth (Cattaneo-Mindlin).
  EXPECT_TRUE(contact.MoveTo(kDepth, 0).ok());
  EXPECT_TRUE(contact.MoveTo(kDepth, kDisplacementAt15N).ok());
  return contact;
}

TEST(OutputsTest, MasksSelectLeavesAndSubtrees) {
  const OutputSelection none = *service::SelectStepOutputs(Mask({}));
  EXPECT_TRUE(none.empty());
  const OutputSelection state = *service::SelectQueryOutputs(Mask({}));
  EXPECT_TRUE(state.has(Output::kNormalForce) && state.has(Output::kMemoryVertices));
  EXPECT_FALSE(state.has(Output::kTractions));
  const OutputSelection step =
      *service::SelectStepOutputs(Mask({"state.tangential_force", "dissipated_energy"}));
  EXPECT_TRUE(step.has(Output::kTangentialForce));
  EXPECT_TRUE(step.has(Output::kStepResultDissipatedEnergy));
  EXPECT_FALSE(step.has(Output::kNormalForce));
  const OutputSelection energy = *service::SelectQueryOutputs(Mask({"energy"}));
  EXPECT_TRUE(energy.has(Output::kEnergyDissipatedEnergy) &&
              energy.has(Output::kEnergyLastStepDissipatedEnergy));
  EXPECT_FALSE(energy.any_state());
}

TEST(OutputsTest, AnUnknownPathNamesItsIndexAndTheValidPaths) {
  const Status status = service::SelectStepOutputs(Mask({"state", "tractions"})).status();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.field(), "step_mask.paths[1]");
  EXPECT_NE(status.message().find("substeps"), std::string::npos) << status.message();
  EXPECT_EQ(service::SelectQueryOutputs(Mask({"state.nope"})).status().field(),
            "read_mask.paths[0]");
}

// Only what is selected is written, and only the selected Query outputs are computed.
TEST(OutputsTest, OnlyTheSelectedOutputsAreWrittenAndComputed) {
  const Contact contact = LoadedReferenceContact();
  OutputSelection selection;
  selection.add(Output::kTangentialForce);
  v1::ContactState state;
  service::WriteState(contact, 7, selection, &state);
  ExpectRelativelyNear(state.tangential_force(), 15, 1e-9);
  EXPECT_EQ(state.normal_force(), 0);
  EXPECT_EQ(state.applied_steps(), 0u);

  service::OutputCounters counters;
  v1::QueryResponse response;
  const OutputSelection jager = *service::SelectQueryOutputs(Mask({"jager_weights"}));
  ASSERT_TRUE(service::WriteQueryOutputs(contact, 7, jager, {}, &response, &counters).ok());
  EXPECT_EQ(counters[Output::kJagerWeights], 1u);
  EXPECT_EQ(counters[Output::kTractions], 0u);
  EXPECT_EQ(counters[Output::kNormalForce], 0u);
  EXPECT_FALSE(response.has_state());
  EXPECT_GT(response.jager_weights().intervals_size(), 0);
}

TEST(OutputsTest, TheRadiiBoundKeepsEveryResponseWithinTheMessageLimit) {
  const OutputSelection state = *service::SelectQueryOutputs(Mask({"state"}));
  EXPECT_EQ(service::MaxRadii(state, 4 << 20), std::numeric_limits<std::size_t>::max());
  const OutputSelection radial =
      *service::SelectQueryOutputs(Mask({"springs", "tractions", "pressure"}));
  const std::size_t max_radii = service::MaxRadii(radial, 1 << 16);
  ASSERT_GT(max_radii, 0u);
  EXPECT_TRUE(service::CheckRadiiCount(static_cast<int>(max_radii), radial, 1 << 16).ok());
  const Status over = service::CheckRadiiCount(static_cast<int>(max_radii) + 1, radial, 1 << 16);
  EXPECT_EQ(over.field(), "radii");

  // A response at the bound, with every radial output at its largest encoding, fits.
  const Contact contact = LoadedReferenceContact();
  service::RadialSampling sampling;
  sampling.traction_options = *service::ToTractionOptions(v1::TRACTION_ROUTE_BOTH, "route");
  for (std::size_t i = 0; i < max_radii; ++i) {
    sampling.radii.push_back(contact.contact_radius() * (i + 0.5) / max_radii);
  }
  v1::QueryResponse response;
  service::OutputCounters counters;
  ASSERT_TRUE(service::WriteQueryOutputs(contact, 1, radial, sampling, &response, &counters).ok());
  EXPECT_LE(response.ByteSizeLong(), std::size_t{1} << 16);
}

TEST(LimitsUnitTest, ServerLimitsNameTheirFlag) {
  service::ServiceLimits limits;
  EXPECT_TRUE(service::ValidateServiceLimits(limits).ok());
  limits.max_message_bytes = 100;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-message-bytes");
  limits = {};
  limits.max_memory_vertices = 4;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-memory-vertices");
  limits = {};
  limits.max_sessions = 0;
  EXPECT_EQ(service::ValidateServiceLimits(limits).field(), "max-sessions");
}

TEST(LimitsUnitTest, SessionLimitsTakeTheServersUnlessSetWithinThem) {
  service::ServiceLimits server;
  server.max_steps_per_batch = 500;
  server.session_idle_timeout = std::chrono::minutes(10);
  const v1::SessionLimits defaults = *service::ResolveSessionLimits({}, server);
  EXPECT_EQ(defaults.max_steps_per_batch(), 500u);
  EXPECT_EQ(service::IdleTimeout(defaults), std::chrono::minutes(10));

  v1::SessionLimits requested;
  requested.set_max_steps_per_batch(20);
  requested.mutable_idle_timeout()->set_seconds(30);
  const v1::SessionLimits own = *service::ResolveSessionLimits(requested, server);
  EXPECT_EQ(own.max_steps_per_batch(), 20u);
  EXPECT_EQ(service::IdleTimeout(own), std::chrono::seconds(30));

  requested.set_max_steps_per_batch(501);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(),
            "max_steps_per_batch");
  requested.set_max_steps_per_batch(20);
  requested.mutable_idle_timeout()->set_seconds(601);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(), "idle_timeout");
  requested.mutable_idle_timeout()->set_seconds(1);
  requested.mutable_idle_timeout()->set_nanos(-5);
  EXPECT_EQ(service::ResolveSessionLimits(requested, server).status().field(),
            "idle_timeout.nanos");
}

}  // namespace
}  // namespace mdr::service_testing
