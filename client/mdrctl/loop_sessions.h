// The loading paths mdrctl drives through sessions for the loop analysis: a sinusoidal actuator
// run that synthesize records, and the replay of a measured actuator path through a fitted scene
// (exactly the path FitLoops replays: docs/analysis.md, "Identification").
#pragma once

#include <vector>

#include "mdr/client/contact_client.h"
#include "mdr/v1/scene.pb.h"

namespace mdrctl {

// What a run records after each step: the actuator's displacement and F_x (a torsional run: the
// actuator's twist and the twisting moment).
struct RecordedRun {
  std::vector<double> displacement;  // m (rad)
  std::vector<double> force;         // N (N m)
};

// A session of `scene` pressed to `normal_force` with the actuator at 0 (sample 0), then the
// actuator at u_k = amplitude sin(2 pi k / samples_per_cycle), k = 1 .. cycles *
// samples_per_cycle (one sample each). The session is deleted afterwards.
mdr::client::RpcResult<RecordedRun> RecordSineRun(mdr::client::ContactClient& client,
                                                  const mdr::v1::Scene& scene, double normal_force,
                                                  double amplitude, int cycles,
                                                  int samples_per_cycle);

// A torsional scene's run: a session of the contact alone (sessions hold no shaft) pressed to
// `normal_force` at twist 0 (sample 0), then twisted to phi_k = amplitude sin(2 pi k /
// samples_per_cycle), k = 1 .. cycles * samples_per_cycle. The recorded twist is the actuator's
// behind the scene's shaft, phi_k + C M_k (C: scene.torsion.rig_compliance). The session is
// deleted afterwards.
mdr::client::RpcResult<RecordedRun> RecordSineTwistRun(mdr::client::ContactClient& client,
                                                       const mdr::v1::Scene& scene,
                                                       double normal_force, double amplitude,
                                                       int cycles, int samples_per_cycle);

// The twisting moment after each twist of the contact of a torsional scene (without its shaft,
// which sessions do not hold): pressed to normal_force at twist 0, then twisted to each twist.
mdr::client::RpcResult<std::vector<double>> ReplayTwists(mdr::client::ContactClient& client,
                                                         const mdr::v1::Scene& scene,
                                                         double normal_force,
                                                         const std::vector<double>& twists);

// F_x after each step of the replay in a session of `scene` (as FitLoops replays a set): the
// contact pressed to normal_force (or normal.front()) with the actuator at 0, then the actuator at
// each displacement, with the normal force of `normal` at each step when it is not empty (else
// held).
mdr::client::RpcResult<std::vector<double>> ReplayForces(mdr::client::ContactClient& client,
                                                         const mdr::v1::Scene& scene,
                                                         double normal_force,
                                                         const std::vector<double>& normal,
                                                         const std::vector<double>& displacement);

}  // namespace mdrctl
