#include "mdr/core/contact.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>

#include "mdr/base/validate.h"

namespace mdr {
namespace {

// Largest grid the config accepts (32 MiB of spring state).
constexpr std::size_t kMaxGridSize = std::size_t{1} << 22;

}  // namespace

const char* FieldName(NormalControl control) {
  switch (control) {
    case NormalControl::kDepth:
      return "depth";
    case NormalControl::kDepthIncrement:
      return "depth_increment";
    case NormalControl::kForce:
      return "normal_force";
  }
  return "normal";
}

const char* FieldName(TangentialControl control) {
  switch (control) {
    case TangentialControl::kDisplacement:
      return "displacement";
    case TangentialControl::kDisplacementIncrement:
      return "displacement_increment";
    case TangentialControl::kForce:
      return "tangential_force";
  }
  return "tangential";
}

Status ValidateContactConfig(const ContactConfig& config) {
  if (!config.profile) {
    return InvalidArgument("profile", "is required (sphere, cone, power_law or flat_punch)");
  }
  if (Status s = RequirePositive("material.e_star", config.material.e_star); !s.ok()) return s;
  if (Status s = RequirePositive("material.g_star", config.material.g_star); !s.ok()) return s;
  if (Status s = RequireNonNegative("friction", config.friction); !s.ok()) return s;
  if (Status s = RequireInRange("force_path_tolerance", config.force_path_tolerance, 0, 0.1,
                                /*lo_open=*/true);
      !s.ok()) {
    return s;
  }
  if (config.max_memory_vertices < 8) {
    return InvalidArgument("max_memory_vertices",
                           "must be >= 8, got " + std::to_string(config.max_memory_vertices));
  }
  if (config.grid_size < 2 || config.grid_size > kMaxGridSize) {
    return InvalidArgument("grid_size", "must be in [2, " + std::to_string(kMaxGridSize) +
                                            "], got " + std::to_string(config.grid_size));
  }
  if (config.method == Method::kGrid) {
    if (Status s = RequirePositive("grid_max_radius", config.grid_max_radius); !s.ok()) return s;
  }
  if (Status s = RequireNonNegative("rig.tangential_compliance", config.rig.tangential); !s.ok()) {
    return s;
  }
  if (Status s = RequireNonNegative("rig.normal_compliance", config.rig.normal); !s.ok()) {
    return s;
  }
  return OkStatus();
}

bool SameConfig(const ContactConfig& a, const ContactConfig& b) {
  return a.profile == b.profile && SameSettings(a, b);
}

bool SameSettings(const ContactConfig& a, const ContactConfig& b) {
  // Every field but the profile: a field added to ContactConfig must be compared here and
  // hashed in HashSettings.
  static_assert(sizeof(ContactConfig) == 112, "compare the new field of ContactConfig");
  return SameBits(a.material.e_star, b.material.e_star) &&
         SameBits(a.material.g_star, b.material.g_star) && SameBits(a.friction, b.friction) &&
         a.track_energy == b.track_energy &&
         SameBits(a.force_path_tolerance, b.force_path_tolerance) &&
         a.max_memory_vertices == b.max_memory_vertices &&
         SameBits(a.rig.tangential, b.rig.tangential) && SameBits(a.rig.normal, b.rig.normal) &&
         a.method == b.method && a.grid_size == b.grid_size &&
         SameBits(a.grid_max_radius, b.grid_max_radius) && a.grid_step_rule == b.grid_step_rule;
}

std::size_t HashSettings(const ContactConfig& c) {
  std::size_t hash = 0;
  const auto mix = [&hash](std::uint64_t value) {
    hash ^= std::hash<std::uint64_t>{}(value) + 0x9e3779b97f4a7c15ULL + (hash << 6) + (hash >> 2);
  };
  for (double value : {c.material.e_star, c.material.g_star, c.friction, c.force_path_tolerance,
                       c.rig.tangential, c.rig.normal, c.grid_max_radius}) {
    mix(std::bit_cast<std::uint64_t>(value));
  }
  for (std::uint64_t value : {std::uint64_t{c.track_energy}, std::uint64_t{c.max_memory_vertices},
                              static_cast<std::uint64_t>(c.method), std::uint64_t{c.grid_size},
                              static_cast<std::uint64_t>(c.grid_step_rule)}) {
    mix(value);
  }
  return hash;
}

double NormalForceAtDepth(const ContactConfig& config, double depth) {
  return NormalForceAtDepth(*config.profile, config.material, depth);
}

double DepthAtNormalForce(const ContactConfig& config, double normal_force) {
  return DepthAtNormalForce(*config.profile, config.material, normal_force);
}

double NormalForceAtDepth(const Profile& profile, const EffectiveMaterial& material, double depth) {
  return material.e_star * profile.NormalForcePerModulus(depth);
}

double DepthAtNormalForce(const Profile& profile, const EffectiveMaterial& material,
                          double normal_force) {
  return profile.DepthAtNormalForcePerModulus(normal_force / material.e_star);
}

double ContactRadiusAtDepth(const ContactConfig& config, double depth) {
  return depth > 0 ? config.profile->RadiusAtDepth(depth) : 0;
}

Contact::Contact(ContactConfig config) : config_(std::move(config)) {
  if (config_.method == Method::kGrid) {
    memory_.emplace<GridMemory>(*config_.profile, config_.grid_size, config_.grid_max_radius,
                                config_.grid_step_rule);
  }
}

Result<Contact> Contact::Create(ContactConfig config) {
  if (Status s = ValidateContactConfig(config); !s.ok()) return s;
  return Contact(std::move(config));
}

std::vector<MemoryPiece> Contact::memory_pieces() const {
  const auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_);
  return exact ? exact->Pieces(*config_.profile) : std::vector<MemoryPiece>{};
}

double Contact::grid_spacing() const {
  const GridMemory* grid = grid_memory();
  return grid ? grid->spacing() : 0.0;
}

Status Contact::CheckGridReach(double depth1) const {
  const GridMemory* grid = grid_memory();
  if (grid == nullptr || !(depth1 > 0)) return OkStatus();
  const double radius = config_.profile->RadiusAtDepth(depth1);
  if (radius <= grid->max_radius()) return OkStatus();
  return FailedPrecondition("grid_max_radius", "the contact radius " + FormatNumber(radius) +
                                                   " m at depth " + FormatNumber(depth1) +
                                                   " m exceeds the grid's radius " +
                                                   FormatNumber(grid->max_radius()) + " m");
}

Result<Contact> Contact::Restore(ContactConfig config, const ContactSnapshot& snapshot) {
  Result<Contact> contact = Create(std::move(config));
  if (!contact.ok()) return contact;
  if (Status s = RequireFinite("tangential_displacement", snapshot.tangential_displacement);
      !s.ok()) {
    return s;
  }
  if (Status s = RequireNonNegative("dissipated_energy", snapshot.dissipated_energy); !s.ok()) {
    return s;
  }
  if (Status s = RequireNonNegative("last_step_dissipation", snapshot.last_step_dissipation);
      !s.ok()) {
    return s;
  }
  contact->ux_ = snapshot.tangential_displacement;
  contact->dissipated_ = snapshot.dissipated_energy;
  contact->last_dissipated_ = snapshot.last_step_dissipation;
  if (auto* grid = std::get_if<GridMemory>(&contact->memory_)) {
    if (Status s = grid->Restore(snapshot.depth, snapshot.grid_u, contact->mu_kappa(),
                                 snapshot.grid_anchors, snapshot.tangential_displacement);
        !s.ok()) {
      return s;
    }
    if (Status s = contact->CheckFiniteForces(); !s.ok()) return s;
    return contact;
  }
  Result<PiecewiseLinearMemory> memory =
      PiecewiseLinearMemory::Restore(snapshot.depth, snapshot.z, snapshot.u, snapshot.tags,
                                     snapshot.anchors, snapshot.tangential_displacement);
  if (!memory.ok()) return memory.status();
  // The same mu_kappa() that every step clamps with: the checks are exact (memory.h).
  if (Status s = memory->CheckReachable(contact->mu_kappa(), snapshot.tangential_displacement);
      !s.ok()) {
    return s;
  }
  contact->memory_ = std::move(memory).value();
  if (Status s = contact->CheckFiniteForces(); !s.ok()) return s;
  return contact;
}

Status Contact::CheckFiniteForces() const {
  if (!std::isfinite(normal_force())) {
    return InvalidArgument("depth", "gives a normal force that is not finite (" +
                                        FormatNumber(normal_force()) +
                                        " N): no loading history reaches it");
  }
  if (!std::isfinite(tangential_force())) {
    return InvalidArgument("tangential_displacement",
                           "the memory gives a tangential force that is not finite");
  }
  return OkStatus();
}

ContactSnapshot Contact::Snapshot() const {
  ContactSnapshot snapshot;
  snapshot.depth = depth();
  snapshot.tangential_displacement = ux_;
  snapshot.dissipated_energy = dissipated_;
  snapshot.last_step_dissipation = last_dissipated_;
  if (const GridMemory* grid = grid_memory()) {
    const Eigen::ArrayXd& u = grid->u();
    snapshot.grid_u.assign(u.data(), u.data() + u.size());
    snapshot.grid_anchors = grid->anchors();
    return snapshot;
  }
  const PiecewiseLinearMemory& m = memory();
  snapshot.z = m.z();
  snapshot.u = m.u();
  snapshot.tags = m.tags();
  snapshot.anchors = m.anchors();
  return snapshot;
}

double Contact::NormalForceAtDepth(double depth) const {
  return mdr::NormalForceAtDepth(config_, depth);
}

double Contact::DepthAtNormalForce(double normal_force) const {
  return mdr::DepthAtNormalForce(config_, normal_force);
}

double Contact::contact_radius() const { return ContactRadiusAtDepth(config_, depth()); }

double Contact::normal_force() const { return NormalForceAtDepth(depth()); }

double Contact::actuator_displacement() const {
  return ActuatorPosition(config_.rig.tangential, ux_, [this] { return tangential_force(); });
}

double Contact::actuator_depth() const {
  return ActuatorPosition(config_.rig.normal, depth(), [this] { return normal_force(); });
}

double Contact::tangential_force() const {
  const GridMemory* grid = grid_memory();
  const double integral = grid ? grid->IntegralU() : memory().IntegralU(*config_.profile);
  return 2 * config_.material.g_star * integral;
}

TangentialStiffness Contact::tangential_stiffness() const {
  // Sticking springs follow ux; those on the bound in the direction of motion slide.
  const double k = 2 * config_.material.g_star;
  if (const GridMemory* grid = grid_memory()) {
    const double a = grid->MeasureInContact();
    return {k * (a - grid->MeasureOnBound(kOnUpper)), k * (a - grid->MeasureOnBound(kOnLower))};
  }
  return {k * memory().MeasureSticking(*config_.profile, kOnUpper),
          k * memory().MeasureSticking(*config_.profile, kOnLower)};
}

namespace {

// Appends [r_begin, r_end] to intervals, merging it with the last one if they touch.
void AddSlipInterval(std::vector<SlipInterval>& intervals, double r_begin, double r_end,
                     BoundTag bound) {
  const int direction = bound == kOnUpper ? +1 : bound == kOnLower ? -1 : 0;
  if (!intervals.empty() && intervals.back().direction == direction &&
      intervals.back().r_end == r_begin) {
    intervals.back().r_end = r_end;
  } else {
    intervals.push_back({r_begin, r_end, direction});
  }
}

}  // namespace

std::vector<SlipInterval> Contact::slip_intervals() const {
  std::vector<SlipInterval> intervals;
  if (const GridMemory* grid = grid_memory()) {
    // Each spring stands for its cell [j h, (j + 1) h], cut at the contact radius.
    const double h = grid->spacing(), a = contact_radius();
    for (std::size_t j = 0; j < grid->size(); ++j) {
      const BoundTag tag = grid->Tag(j);
      const double r_begin = static_cast<double>(j) * h;  // same product as the previous r_end
      const double r_end = std::min(static_cast<double>(j + 1) * h, a);
      if (tag != kInside) AddSlipInterval(intervals, r_begin, r_end, tag);
    }
    return intervals;
  }
  for (const MemoryPiece& piece : memory_pieces()) {
    if (piece.bound != kInside) AddSlipInterval(intervals, piece.x_begin, piece.x_end, piece.bound);
  }
  return intervals;
}

double Contact::tangential_displacement_at(double x) const {
  x = std::abs(x);
  if (!(x < contact_radius())) return 0;
  if (const GridMemory* grid = grid_memory()) return grid->UAtRadius(x);
  return memory().UAtDepth(config_.profile->G(x));
}

double Contact::normal_displacement_at(double x) const {
  x = std::abs(x);
  if (!(x < contact_radius())) return 0;
  return depth() - config_.profile->G(x);
}

double Contact::LinearStep(double depth1, double ux1, double dux) {
  double per_modulus = 0;
  const LinearMove move{depth1, dux, ux_, ux1};
  if (auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_)) [[likely]] {
    const Profile* energy_profile = config_.track_energy ? config_.profile.get() : nullptr;
    per_modulus = exact->ApplyLinearStep(move, mu_kappa(), energy_profile);
  } else {
    per_modulus =
        std::get<GridMemory>(memory_).ApplyLinearStep(move, mu_kappa(), config_.track_energy);
  }
  // Every spring's dissipation is >= 0; the sum's round-off must not make it negative, or the
  // state would not pass Restore (energies >= 0).
  per_modulus = std::max(per_modulus, 0.0);
  ux_ = ux1;
  const double dissipated = config_.material.g_star * per_modulus;
  dissipated_ += dissipated;
  return dissipated;
}

Status Contact::MoveTo(double depth, double tangential_displacement, StepReport* report) {
  if (Status s = RequireFinite("depth", depth); !s.ok()) return s;
  if (Status s = RequireFinite("displacement", tangential_displacement); !s.ok()) return s;
  if (grid_memory() != nullptr) {
    if (Status s = CheckGridReach(depth); !s.ok()) return s;
  }
  last_dissipated_ = LinearStep(depth, tangential_displacement, tangential_displacement - ux_);
  if (report) *report = {1, 0, last_dissipated_};
  return OkStatus();
}

Status Contact::Apply(const Step& step, StepReport* report, const Interrupt& interrupt,
                      OnFailure on_failure) {
  const char* normal_field = FieldName(step.normal);
  const char* tangential_field = FieldName(step.tangential);
  if (Status s = RequireFinite(normal_field, step.normal_value); !s.ok()) return s;
  if (Status s = RequireFinite(tangential_field, step.tangential_value); !s.ok()) return s;

  const RigCompliance& rig = config_.rig;
  // The contact depth at the step's end; with a normal rig, that of the actuator's target depth
  // (an unchanged actuator depth holds the contact's exactly).
  double depth1 = depth(), actuator_depth1 = actuator_depth();
  switch (step.normal) {
    case NormalControl::kDepth:
    case NormalControl::kDepthIncrement: {
      const double target = step.normal == NormalControl::kDepth
                                ? step.normal_value
                                : actuator_depth1 + step.normal_value;
      if (target != actuator_depth1) {
        actuator_depth1 = target;
        depth1 = rig.normal > 0 ? DepthAtActuatorDepth(target) : target;
      }
      break;
    }
    case NormalControl::kForce: {
      if (Status s = RequireNonNegative(normal_field, step.normal_value); !s.ok()) return s;
      // A normal force equal to the current one (to round-off) holds the depth exactly.
      const double now = normal_force();
      if (std::abs(step.normal_value - now) > 1e-14 * now) {
        depth1 = DepthAtNormalForce(step.normal_value);
        actuator_depth1 = depth1 + rig.normal * step.normal_value;
      }
      break;
    }
  }
  if (Status s = RequireFinite(normal_field, depth1); !s.ok()) return s;
  // Finite inputs can still overflow (a depth of 1e200 m). |F_x| <= mu F_N, so checking the
  // closed-form friction limit here keeps both forces finite without a force query per step.
  if (!std::isfinite(NormalForceAtDepth(depth1) * std::max(config_.friction, 1.0))) {
    return InvalidArgument(normal_field, "the normal force at this depth overflows a double");
  }
  if (Status s = CheckGridReach(depth1); !s.ok()) return s;

  StepReport local;
  const bool tangential_force = step.tangential == TangentialControl::kForce;
  const bool depth_changes = depth1 != depth();
  // Displacement targets: the actuator's (the contact's without a rig); with a tangential rig
  // the contact's end follows from the solve below.
  const double actuator_displacement0 = actuator_displacement();
  const double actuator_displacement1 =
      step.tangential == TangentialControl::kDisplacement ? step.tangential_value
      : step.tangential == TangentialControl::kDisplacementIncrement
          ? actuator_displacement0 + step.tangential_value
          : actuator_displacement0;
  const bool through_rig = rig.tangential > 0 && !tangential_force;
  const double ux1 = through_rig ? ux_ : actuator_displacement1;  // unless solved
  // Straight in (delta, ux): both channels displacements that move linearly, or one channel not
  // moving. Through a tangential rig the contact's path is straight only at a fixed depth.
  const bool depth_linear = step.normal != NormalControl::kForce && !(rig.normal > 0);
  const bool straight = tangential_force || through_rig
                            ? !depth_changes
                            : (depth_linear || !depth_changes || ux1 == ux_);
  if (straight) {
    double dux = ux1 - ux_, ux_end = ux1;
    if (tangential_force || (through_rig && actuator_displacement1 != actuator_displacement0)) {
      if (tangential_force) {
        Result<double> solved = SolveTangentialIncrement(depth1, step.tangential_value);
        if (!solved.ok()) return solved.status();
        dux = *solved;
      } else {
        dux = SolveActuatorIncrement(depth1, actuator_displacement1);
      }
      ux_end = LandOnTurningPoint(depth1, ux_ + dux);
    }
    // One exact step in place, undone if its result fails the checks.
    const bool undo = on_failure == OnFailure::kUnchanged;
    if (undo) undo_.memory = memory_;
    const double ux0 = ux_, dissipated0 = dissipated_;
    local = {1, 0, LinearStep(depth1, ux_end, dux)};
    if (Status s = CheckStepResult(tangential_field); !s.ok()) {
      if (undo) {
        std::swap(memory_, undo_.memory);
        ux_ = ux0;
        dissipated_ = dissipated0;
      }
      return s;
    }
  } else {
    // Sub-steps on a trial contact that replaces this one at the end, unless this one is dropped
    // on failure anyway.
    std::optional<Contact> trial;
    if (on_failure == OnFailure::kUnchanged) trial.emplace(*this);
    Contact& stepped = trial ? *trial : *this;
    const StepTargets targets{depth1, actuator_depth1, actuator_displacement1};
    if (Status s = stepped.ApplyCurvedPath(step, targets, &local, interrupt); !s.ok()) return s;
    if (Status s = stepped.CheckStepResult(tangential_field); !s.ok()) return s;
    if (trial) *this = std::move(*trial);
  }
  last_dissipated_ = local.dissipated;
  if (report) *report = local;
  return OkStatus();
}

double Contact::TurningPointResolution(double depth1, double ux1) const {
  constexpr double kResolution = 16 * std::numeric_limits<double>::epsilon();
  return kResolution * (mu_kappa() * depth1 + std::abs(ux1));
}

double Contact::LandOnTurningPoint(double depth1, double ux1) const {
  // The force solve finds the increment to about 1e-15 of mu kappa delta (monotone_solve.h), and
  // ux = ux0 + dux rounds to eps |ux|: a turning point that close is the intended return.
  const double tolerance = TurningPointResolution(depth1, ux1);
  const GridMemory* grid = grid_memory();
  return NearestReturn(grid ? grid->anchors() : memory().anchors(), depth1, ux1, tolerance)
      .value_or(ux1);
}

Status Contact::CheckStepResult(const char* tangential_field) const {
  // Finite increments can add up past the largest double (two of -1e308 m), and a state that is
  // not finite could not be exported, imported or restored from the journal.
  if (!std::isfinite(ux_) || !std::isfinite(actuator_displacement())) {
    return InvalidArgument(tangential_field,
                           "the tangential displacement after this step overflows a double");
  }
  if (!std::isfinite(dissipated_energy())) {
    return InvalidArgument(tangential_field,
                           "the energy dissipated by this step overflows a double");
  }
  // A history across many orders of magnitude (a depth of 90 m, then 2e-6 m) leaves the memory's
  // vertices rounded at its largest scale; past the friction cone's rounding slack (memory.h) the
  // state could not be restored, so the step is refused instead. (The Coulomb bound and the
  // anchors hold structurally: clamping is exact; only the cone check has a slack to exceed.)
  if (const auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_)) {
    if (Status s = exact->CheckFrictionCone(mu_kappa()); !s.ok()) {
      return FailedPrecondition(tangential_field,
                                "this step would leave a memory the doubles cannot hold exactly "
                                "enough at this scale, after a history many orders of magnitude "
                                "larger (" +
                                    s.field() + ": " + s.message() + "); nothing was applied");
    }
  }
  if (memory().vertex_count() > config_.max_memory_vertices) {
    return ResourceExhausted("max_memory_vertices",
                             "the step needs " + std::to_string(memory().vertex_count()) +
                                 " memory vertices, above the session limit of " +
                                 std::to_string(config_.max_memory_vertices));
  }
  return OkStatus();
}

}  // namespace mdr
