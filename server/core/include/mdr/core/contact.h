// One contact's state and the loading steps applied to it (docs/physics.md). No gRPC in here.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/grid_memory.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/material.h"
#include "mdr/core/memory.h"
#include "mdr/core/profile.h"

namespace mdr {

// How the tangential memory is represented.
enum class Method {
  kExact,  // PiecewiseLinearMemory: exact for piecewise-linear histories, no discretisation
  kGrid,   // GridMemory: the classical MDR with grid_size springs on [0, grid_max_radius]
};

// A test rig in series with the contact (docs/physics.md, "The rig in series"): between the
// contact and the actuator's sensors the rig deforms elastically by C_t F_x tangentially and C_n
// F_N normally, so the actuator stands at u_x + C_t F_x and delta + C_n F_N.
struct RigCompliance {
  double tangential = 0;  // C_t in m/N, >= 0
  double normal = 0;      // C_n in m/N, >= 0
  bool operator==(const RigCompliance&) const = default;
};

struct ContactConfig {
  ProfilePtr profile;
  EffectiveMaterial material;
  double friction = 0;  // mu >= 0
  // Dissipated energy costs one profile evaluation per slipping piece and step; scenes that do
  // not ask for energy switch it off.
  bool track_energy = true;
  // Tolerance of force-controlled steps whose path is curved in (delta, ux), relative to
  // mu*kappa*delta. The memory records such a path with one vertex per sub-step, and the
  // sub-step count grows like 1/sqrt(tolerance) (about 1300 for 1e-8 on a Hertz contact).
  double force_path_tolerance = 1e-8;
  // Limit on memory vertices (ResourceExhausted beyond it); bounded in practice by the
  // nesting depth of load reversals.
  std::size_t max_memory_vertices = 1 << 16;

  // The rig in series; zero compliances (the default): steps drive the contact itself.
  RigCompliance rig;

  Method method = Method::kExact;
  // Grid method only. Springs at the midpoints of grid_size cells on [0, grid_max_radius]
  // (spacing h = grid_max_radius / grid_size, Contact::grid_spacing()); with the exact step rule
  // forces and energies converge like h^2. A step whose contact radius would exceed
  // grid_max_radius fails (FailedPrecondition, field grid_max_radius).
  std::size_t grid_size = 1024;  // in [2, 2^22]
  double grid_max_radius = 0;    // m, > 0 for Method::kGrid
  GridStepRule grid_step_rule = GridStepRule::kExact;
};

// Bit-identical doubles (0 and -0 differ, a NaN equals itself): what "unchanged" and "the same"
// mean for the state.
inline bool SameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// Same config: the same profile object and every other field equal bit for bit (an interface
// stores each distinct config once; ConfigTable).
bool SameConfig(const ContactConfig& a, const ContactConfig& b);
// Every field but the profile equal bit for bit (the settings ConfigTable shares), and a hash
// of those fields that equal settings share.
bool SameSettings(const ContactConfig& a, const ContactConfig& b);
std::size_t HashSettings(const ContactConfig& config);

// What a config alone fixes: mu kappa, F_N(delta) for its profile and material and the inverse
// (F_N >= 0), and the contact radius at a depth (0 out of contact). Contact's members of these
// names call them.
inline double MuKappa(const ContactConfig& config) {
  return config.friction * config.material.kappa();
}
double NormalForceAtDepth(const ContactConfig& config, double depth);
double DepthAtNormalForce(const ContactConfig& config, double normal_force);
// The same for a profile and material given apart (an interface's contacts share the material).
double NormalForceAtDepth(const Profile& profile, const EffectiveMaterial& material, double depth);
double DepthAtNormalForce(const Profile& profile, const EffectiveMaterial& material,
                          double normal_force);
double ContactRadiusAtDepth(const ContactConfig& config, double depth);
// Where the actuator stands on one channel with a rig of that compliance in series (RigCompliance):
// the contact's position plus compliance times the channel's force, or the contact's position
// without a rig (force, a callable, is then not evaluated: a tangential force is an integral).
template <typename Force>
double ActuatorPosition(double compliance, double position, Force force) {
  return compliance > 0 ? position + compliance * force() : position;
}

// Validates a config: profile present, material moduli > 0, friction >= 0 and finite,
// tolerance in (0, 0.1], vertex limit >= 8, grid_size in [2, 2^22], grid_max_radius > 0 for the
// grid method, rig compliances finite and >= 0. Field names are relative to the proto Scene.
Status ValidateContactConfig(const ContactConfig& config);

// How each channel of a step is driven. "Increment" values are relative to the current state.
enum class NormalControl { kDepth, kDepthIncrement, kForce };
enum class TangentialControl { kDisplacement, kDisplacementIncrement, kForce };

// One loading step. Path semantics: every controlled quantity moves linearly in a common
// parameter s in [0, 1] from its current value to its target. If both channels are
// displacements, or one channel does not change, the path is a straight line in (delta, ux) and
// the step is exact. Otherwise (a force channel changing together with the other channel) the
// path is curved in (delta, ux); it is followed by adaptive sub-steps that are each exact, until
// two successive refinements agree to force_path_tolerance (StepReport::path_error).
// With a rig (ContactConfig::rig), depths and displacements are the actuator's, and an unset
// channel holds the actuator: a tangential move at constant contact depth is exact (the contact
// follows a monotone path to the one end point where actuator and contact agree); a step that
// changes the depth while the tangential rig deforms is a curved path.
// The name of each control's value in a Step (the proto Step's field), for error messages.
const char* FieldName(NormalControl control);
const char* FieldName(TangentialControl control);

struct Step {
  NormalControl normal = NormalControl::kDepthIncrement;
  double normal_value = 0;
  TangentialControl tangential = TangentialControl::kDisplacementIncrement;
  double tangential_value = 0;
};

struct StepReport {
  int substeps = 0;  // exact linear sub-steps used
  // A curved path's estimated error: the larger of max |u error| / (mu kappa delta) and the
  // dissipated energy's error / (mu F_N max(mu kappa delta, actuator travel)) (force_control.cc).
  double path_error = 0;
  double dissipated = 0;  // J, 0 when energy is not tracked
};

// Incremental tangential stiffness dF_x/dux at the current state for a small further move in
// +x and in -x (they differ once part of the contact slips).
struct TangentialStiffness {
  double positive, negative;
};

// A radial interval [r_begin, r_end] where springs slip (at the Coulomb bound).
struct SlipInterval {
  double r_begin, r_end;
  int direction;  // +1: at +mu kappa w, -1: at -mu kappa w
};

// The complete state of a Contact besides its config: what a session export carries so that an
// imported session continues bit-identically.
struct ContactSnapshot {
  double depth = 0;
  double tangential_displacement = 0;
  double dissipated_energy = 0;
  double last_step_dissipation = 0;
  std::vector<double> z, u;        // memory polyline in z = g(x)
  std::vector<std::uint8_t> tags;  // BoundTag of each vertex
  // The anchor of the segment each vertex starts (memory.h); empty in snapshots written before
  // anchors existed, which Restore completes.
  std::vector<SegmentAnchor> anchors;
  std::vector<double> grid_u;  // grid method: u_j of every spring (z, u, tags stay empty)
  // Grid method: the anchor of every spring, or none (older snapshots; Restore completes them).
  std::vector<SegmentAnchor> grid_anchors;
};

class Contact {
 public:
  static Result<Contact> Create(ContactConfig config);

  // Rebuilds a contact from a snapshot, validating it against the config (Coulomb bound included).
  static Result<Contact> Restore(ContactConfig config, const ContactSnapshot& snapshot);
  ContactSnapshot Snapshot() const;

  // What a failed Apply leaves.
  enum class OnFailure {
    kUnchanged,  // the contact as it was (the step keeps what it needs to undo itself)
    // Unspecified, only to be assigned to or destroyed: for a caller that drops the contact when
    // a step fails (a batch on a copy), which saves the step that undo copy.
    kDiscarded,
  };
  // Applies a step atomically: on error the contact is unchanged (or, with kDiscarded, to be
  // dropped). interrupt is checked at every bisection of a curved force path (DeadlineExceeded /
  // Cancelled abandon the step).
  Status Apply(const Step& step, StepReport* report = nullptr, const Interrupt& interrupt = {},
               OnFailure on_failure = OnFailure::kUnchanged);
  // The exact linear step to (delta, ux) without validation of targets beyond finiteness (and,
  // for the grid method, the grid's reach).
  Status MoveTo(double depth, double tangential_displacement, StepReport* report = nullptr);

  const ContactConfig& config() const { return config_; }
  double depth() const {
    const auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_);
    return exact ? exact->depth() : std::get<GridMemory>(memory_).depth();
  }
  double tangential_displacement() const { return ux_; }
  // Where the actuator stands: the contact's displacement and depth plus the rig's deformation
  // (equal to the contact's without a rig).
  double actuator_displacement() const;
  double actuator_depth() const;
  double mu_kappa() const { return MuKappa(config_); }
  // How far a force-controlled step's end ux may be moved onto a turning point (its anchor's ux)
  // that it lands that close to, m: the force solve finds the increment to about 1e-15 of
  // mu kappa delta and ux0 + dux rounds to eps |ux|, so a turning point within 16 eps of both is
  // the intended return. The memory then moves by the solved increment, so its values and ux
  // differ by up to this much.
  double TurningPointResolution(double depth1, double ux1) const;
  double contact_radius() const;
  double normal_force() const;
  double tangential_force() const;
  // mu F_N: the largest |F_x| the contact can carry.
  double friction_limit() const { return config_.friction * normal_force(); }
  double dissipated_energy() const { return dissipated_; }
  double last_step_dissipation() const { return last_dissipated_; }
  TangentialStiffness tangential_stiffness() const;
  std::vector<SlipInterval> slip_intervals() const;
  // Tangential spring displacement u(x) and normal one w(x) = delta - g(x) (0 outside contact).
  double tangential_displacement_at(double x) const;
  double normal_displacement_at(double x) const;
  // The exact memory; for the grid method an empty one (use grid_memory()).
  const PiecewiseLinearMemory& memory() const {
    const auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_);
    return exact ? *exact : kNoExactMemory;
  }
  // The exact memory's pieces; empty for the grid method, whose u is not piecewise affine.
  std::vector<MemoryPiece> memory_pieces() const;
  // The grid memory, or nullptr for the exact method.
  const GridMemory* grid_memory() const { return std::get_if<GridMemory>(&memory_); }
  // Grid spacing h (the grid method's resolution), 0 for the exact method.
  double grid_spacing() const;

  // F_N(delta) for this profile and material, and its inverse (F_N >= 0).
  double NormalForceAtDepth(double depth) const;
  double DepthAtNormalForce(double normal_force) const;

 private:
  // The interface's compact store and its cursor read and write the state directly.
  friend class PackedContacts;
  friend class ContactCursor;

  // A restored state's forces are finite (a snapshot's depth of 1e200 is not).
  Status CheckFiniteForces() const;
  // Out of contact; the config is not validated (Create does that).
  explicit Contact(ContactConfig config);
  // Exact linear step to (depth1, ux1) with tangential increment dux (given with ux1, not
  // derived from it, so that an increment survives a large |ux| exactly); returns the
  // dissipation (J) if tracked.
  double LinearStep(double depth1, double ux1, double dux);
  // FailedPrecondition if the grid method's contact would outgrow the grid at depth1.
  Status CheckGridReach(double depth1) const;
  // Largest |u_a - u_b| between two contacts of this config (curved-path refinement).
  static double MemoryDifference(const Contact& a, const Contact& b);
  // The increment dux that gives tangential force fx at depth1 after a linear step from the
  // current state (force_control.cc, like the curved paths).
  // held_integral: integral u dx of springs a curved path holds apart (force_control.cc).
  Result<double> SolveTangentialIncrement(double depth1, double fx, double held_integral = 0) const;
  // The increment dux after which the actuator stands at u_act: ux + dux + C_t F_x = u_act
  // (one root: the left side increases with dux).
  double SolveActuatorIncrement(double depth1, double u_act, double held_integral = 0) const;
  // The contact depth at which the actuator's depth is `actuator`: delta + C_n F_N(delta).
  double DepthAtActuatorDepth(double actuator) const;
  // Where a step ends: the contact depth, and the actuator's depth and displacement that a rig's
  // channels move to (the contact's own values without a rig).
  struct StepTargets {
    double depth;
    double actuator_depth, actuator_displacement;
  };
  Status ApplyCurvedPath(const Step& step, const StepTargets& targets, StepReport* report,
                         const Interrupt& interrupt);
  // ux1, or the turning point within the force solve's resolution of it where a segment (or a
  // grid spring) anchored at depth1 returns to its bound (memory.h, NearestReturn).
  double LandOnTurningPoint(double depth1, double ux1) const;
  // What a step's result must satisfy to be kept: a finite dissipated energy and at most
  // max_memory_vertices vertices (errors name tangential_field or max_memory_vertices).
  Status CheckStepResult(const char* tangential_field) const;

  static inline const PiecewiseLinearMemory kNoExactMemory{};

  ContactConfig config_;
  // One of the two; the exact path dispatches once per step, never per spring.
  std::variant<PiecewiseLinearMemory, GridMemory> memory_;
  double ux_ = 0;
  double dissipated_ = 0;
  double last_dissipated_ = 0;
  // The memory before a straight step, to undo it if its result fails CheckStepResult: a buffer
  // reused across steps (Apply then allocates nothing once it has grown), not part of the state,
  // so copies start with an empty one.
  struct UndoBuffer {
    UndoBuffer() = default;
    UndoBuffer(const UndoBuffer&) {}
    UndoBuffer& operator=(const UndoBuffer&) { return *this; }
    std::variant<PiecewiseLinearMemory, GridMemory> memory;
  };
  UndoBuffer undo_;
  // The force solves' work arrays: the contact's own, so that a handle warmed up on one thread
  // steps without allocating on any other (a contact is used by one thread at a time).
  mutable ForceSolveBuffers solve_buffers_;
  // Whether a curved path holds apart the springs that stick (force_control.cc); off
  // only in tests that compare against sub-stepping every spring (ContactTestPeer).
  bool hold_sticking_springs_apart_ = true;
  friend class ContactTestPeer;
};

// The Jäger picture and the tangential tractions are functions of the exact memory; the grid
// method's springs are not a piecewise-linear memory. FailedPrecondition naming `field` for a
// grid contact, so that the core's own entry points and the service say the same.
inline Status RequireExactMethod(const Contact& contact, std::string_view field) {
  if (contact.config().method == Method::kExact) return OkStatus();
  return FailedPrecondition(std::string(field),
                            "available for method EXACT; this contact's method is GRID (its "
                            "springs are not a piecewise-linear memory)");
}

}  // namespace mdr
