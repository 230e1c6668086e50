// Runs a scene file against the service: creates a session, applies the steps and the path
// segment by segment (in batches within the session's limit), records the states, the energy of
// every cycle and the profiles at hold points, and deletes the session unless asked to keep it.
// An interface's per-step outputs beyond its state (counts, slip histogram, one contact) come
// from one Query after every step that asks for exactly those.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>

#include "mdr/bridge/scene_file.h"
#include "mdr/client/contact_client.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdr::client {

struct RunOptions {
  // Keep the session after the run (its name is in RunReport.session).
  bool keep_session = false;
  // Interface scenes (mdrctl --contact-index): after every step, the state of this contact
  // (RunReport.Row.contact); hold segments record its profiles. Its range is the service's.
  std::optional<std::uint64_t> contact_index;
  // Interface scenes (mdrctl --histogram-bins): after every step, the slip histogram in this
  // many bins (RunReport.Row.slip_histogram); 0: none. Its range is the service's.
  std::uint32_t slip_histogram_bins = 0;
  // Called after every batch with the steps done and the total.
  std::function<void(std::uint64_t done, std::uint64_t total)> progress;
};

// Errors point at the scene file: "scene.sphere.radius: ... (file:line)" for the scene,
// "path[2] (step 4 of 40): tangential_force: ... (file:line)" for a step.
RpcResult<v1::RunReport> RunScene(ContactClient& client, const bridge::SceneDocument& document,
                                  const RunOptions& options = {});

}  // namespace mdr::client
