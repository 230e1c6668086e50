#include "mdr/core/contact.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_roots.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "gsl_errors.h"
#include "mdr/core/validate.h"

namespace mdr {
namespace {

// Largest grid the config accepts (32 MiB of spring state).
constexpr std::size_t kMaxGridSize = std::size_t{1} << 22;

// Curved force paths: bisection depth cap (at most 2^13 intervals, 3 exact sub-steps each), so
// a pathological request ends; a depth cap rather than a sub-step budget keeps the resolution
// uniform along the path when it is reached.
constexpr int kMaxBisections = 13;

// Largest |u_a(z) - u_b(z)| over the vertices of both memories (both are polylines).
double MaxDifference(const PiecewiseLinearMemory& a, const PiecewiseLinearMemory& b) {
  double diff = 0;
  for (double z : a.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  for (double z : b.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  return diff;
}

}  // namespace

double Contact::MemoryDifference(const Contact& a, const Contact& b) {
  if (const GridMemory* grid = a.grid_memory()) return grid->MaxDifference(*b.grid_memory());
  return MaxDifference(a.memory(), b.memory());
}

namespace {

const char* NormalField(NormalControl c) {
  switch (c) {
    case NormalControl::kDepth:
      return "depth";
    case NormalControl::kDepthIncrement:
      return "depth_increment";
    case NormalControl::kForce:
      return "normal_force";
  }
  return "normal";
}

const char* TangentialField(TangentialControl c) {
  switch (c) {
    case TangentialControl::kDisplacement:
      return "displacement";
    case TangentialControl::kDisplacementIncrement:
      return "displacement_increment";
    case TangentialControl::kForce:
      return "tangential_force";
  }
  return "tangential";
}

}  // namespace

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
  return OkStatus();
}

Result<Contact> Contact::Create(ContactConfig config) {
  if (Status s = ValidateContactConfig(config); !s.ok()) return s;
  Contact contact(std::move(config));
  const ContactConfig& c = contact.config_;
  if (c.method == Method::kGrid) {
    contact.memory_.emplace<GridMemory>(*c.profile, c.grid_size, c.grid_max_radius,
                                        c.grid_step_rule);
  }
  return contact;
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
    if (Status s = grid->Restore(snapshot.depth, snapshot.grid_u, contact->mu_kappa()); !s.ok()) {
      return s;
    }
    return contact;
  }
  Result<PiecewiseLinearMemory> memory =
      PiecewiseLinearMemory::Restore(snapshot.depth, snapshot.z, snapshot.u, snapshot.tags);
  if (!memory.ok()) return memory.status();
  // The same mu_kappa() that every step clamps with: the check is exact (memory.h).
  if (Status s = memory->CheckCoulomb(contact->mu_kappa()); !s.ok()) return s;
  contact->memory_ = std::move(memory).value();
  return contact;
}

ContactSnapshot Contact::Snapshot() const {
  if (const GridMemory* grid = grid_memory()) {
    const Eigen::ArrayXd& u = grid->u();
    return {depth(), ux_, dissipated_, last_dissipated_,
            {},      {},  {},          std::vector<double>(u.data(), u.data() + u.size())};
  }
  const PiecewiseLinearMemory& m = memory();
  return {m.depth(), ux_, dissipated_, last_dissipated_, m.z(), m.u(), m.tags(), {}};
}

double Contact::NormalForceAtDepth(double depth) const {
  return config_.material.e_star * config_.profile->NormalForcePerModulus(depth);
}

double Contact::DepthAtNormalForce(double normal_force) const {
  return config_.profile->DepthAtNormalForcePerModulus(normal_force / config_.material.e_star);
}

double Contact::contact_radius() const {
  return depth() > 0 ? config_.profile->RadiusAtDepth(depth()) : 0;
}

double Contact::normal_force() const { return NormalForceAtDepth(depth()); }

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
    return {k * (a - grid->MeasureOnBound(mu_kappa(), kOnUpper)),
            k * (a - grid->MeasureOnBound(mu_kappa(), kOnLower))};
  }
  const double a = contact_radius();
  return {k * (a - memory().MeasureOnBound(*config_.profile, kOnUpper)),
          k * (a - memory().MeasureOnBound(*config_.profile, kOnLower))};
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
    const double h = grid->spacing(), a = contact_radius(), m = mu_kappa();
    for (std::size_t j = 0; j < grid->size(); ++j) {
      const BoundTag tag = grid->Tag(j, m);
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
  if (auto* exact = std::get_if<PiecewiseLinearMemory>(&memory_)) [[likely]] {
    const Profile* energy_profile = config_.track_energy ? config_.profile.get() : nullptr;
    per_modulus = exact->Step(depth1, dux, mu_kappa(), energy_profile);
  } else {
    per_modulus = std::get<GridMemory>(memory_).Step(depth1, dux, mu_kappa(), config_.track_energy);
  }
  // Every spring's dissipation is >= 0; the sum's round-off must not make it negative, or the
  // state would not pass Restore (energies >= 0).
  per_modulus = std::max(per_modulus, 0.0);
  ux_ = ux1;
  const double dissipated = config_.material.g_star * per_modulus;
  dissipated_ += dissipated;
  return dissipated;
}

double Contact::TangentialForceAfterStep(double depth1, double dux) const {
  double integral = 0;
  if (const GridMemory* grid = grid_memory()) {
    integral = grid->IntegralUAfterStep(depth1, dux, mu_kappa());
  } else {
    PiecewiseLinearMemory memory = this->memory();
    memory.Step(depth1, dux, mu_kappa(), nullptr);
    integral = memory.IntegralU(*config_.profile);
  }
  return 2 * config_.material.g_star * integral;
}

Result<double> Contact::SolveTangentialIncrement(double depth1, double fx) const {
  const double limit = config_.friction * NormalForceAtDepth(depth1);
  if (!(std::abs(fx) <= limit * (1 + 1e-12))) {
    return FailedPrecondition("tangential_force",
                              "|F_x| = " + FormatNumber(std::abs(fx)) +
                                  " N exceeds the friction limit mu F_N = " + FormatNumber(limit) +
                                  " N at the step's end (no tangential force without contact)");
  }
  if (limit == 0) return 0.0;  // F_x = 0 holds for any ux: keep it
  // The unknown is the increment, not ux itself: after long sliding |ux| can exceed the memory's
  // scale mu kappa delta by many orders, and a root in ux would carry eps |ux| of noise.
  const double m = mu_kappa();
  const GridMemory* grid = grid_memory();
  const double lo =
      grid ? grid->GrossSlipIncrement(depth1, m, -1) : memory().GrossSlipIncrement(depth1, m, -1);
  const double hi =
      grid ? grid->GrossSlipIncrement(depth1, m, +1) : memory().GrossSlipIncrement(depth1, m, +1);
  if (fx >= limit) return hi;  // onset of gross slip
  if (fx <= -limit) return lo;

  struct Trial {
    const Contact* contact;
    double depth1, fx;
  } trial{this, depth1, fx};
  gsl_function f;
  f.params = &trial;
  f.function = [](double dux, void* p) {
    const auto* t = static_cast<const Trial*>(p);
    return t->contact->TangentialForceAfterStep(t->depth1, dux) - t->fx;
  };
  const double f_lo = f.function(lo, f.params), f_hi = f.function(hi, f.params);
  if (f_lo >= 0) return lo;
  if (f_hi <= 0) return hi;

  internal::ReturnGslErrorCodes();
  gsl_root_fsolver* solver = gsl_root_fsolver_alloc(gsl_root_fsolver_brent);
  gsl_root_fsolver_set(solver, &f, lo, hi);
  const double tolerance = 1e-15 * std::max({std::abs(lo), std::abs(hi), hi - lo});
  double root = 0.5 * (lo + hi);
  for (int iteration = 0; iteration < 200; ++iteration) {
    if (gsl_root_fsolver_iterate(solver) != GSL_SUCCESS) break;
    root = gsl_root_fsolver_root(solver);
    const double x_lo = gsl_root_fsolver_x_lower(solver), x_hi = gsl_root_fsolver_x_upper(solver);
    if (x_hi - x_lo <= tolerance) break;
  }
  gsl_root_fsolver_free(solver);
  return root;
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

Status Contact::Apply(const Step& step, StepReport* report, const Interrupt& interrupt) {
  const char* normal_field = NormalField(step.normal);
  const char* tangential_field = TangentialField(step.tangential);
  if (Status s = RequireFinite(normal_field, step.normal_value); !s.ok()) return s;
  if (Status s = RequireFinite(tangential_field, step.tangential_value); !s.ok()) return s;

  double depth1 = depth();
  switch (step.normal) {
    case NormalControl::kDepth:
      depth1 = step.normal_value;
      break;
    case NormalControl::kDepthIncrement:
      depth1 = depth() + step.normal_value;
      break;
    case NormalControl::kForce: {
      if (Status s = RequireNonNegative(normal_field, step.normal_value); !s.ok()) return s;
      // A normal force equal to the current one (to round-off) holds the depth exactly.
      const double now = normal_force();
      if (std::abs(step.normal_value - now) > 1e-14 * now) {
        depth1 = DepthAtNormalForce(step.normal_value);
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

  Contact trial = *this;
  StepReport local;
  const bool tangential_force = step.tangential == TangentialControl::kForce;
  const bool depth_changes = depth1 != depth();
  const double ux1 = step.tangential == TangentialControl::kDisplacement ? step.tangential_value
                     : step.tangential == TangentialControl::kDisplacementIncrement
                         ? ux_ + step.tangential_value
                         : ux_;
  // Straight in (delta, ux): both channels displacements, or one channel not moving.
  const bool straight =
      tangential_force ? !depth_changes
                       : (step.normal != NormalControl::kForce || !depth_changes || ux1 == ux_);
  if (straight) {
    double dux = ux1 - ux_;
    if (tangential_force) {
      Result<double> solved = SolveTangentialIncrement(depth1, step.tangential_value);
      if (!solved.ok()) return solved.status();
      dux = *solved;
    }
    local = {1, 0, trial.LinearStep(depth1, tangential_force ? ux_ + dux : ux1, dux)};
  } else if (Status s = trial.ApplyCurvedPath(step, depth1, &local, interrupt); !s.ok()) {
    return s;
  }
  if (!std::isfinite(trial.dissipated_energy())) {
    return InvalidArgument(tangential_field,
                           "the energy dissipated by this step overflows a double");
  }
  if (trial.memory().vertex_count() > config_.max_memory_vertices) {
    return ResourceExhausted("max_memory_vertices",
                             "the step needs " + std::to_string(trial.memory().vertex_count()) +
                                 " memory vertices, above the session limit of " +
                                 std::to_string(config_.max_memory_vertices));
  }
  trial.last_dissipated_ = local.dissipated;
  *this = std::move(trial);
  if (report) *report = local;
  return OkStatus();
}

Status Contact::ApplyCurvedPath(const Step& step, double depth_target, StepReport* report,
                                const Interrupt& interrupt) {
  const double depth0 = depth(), ux0 = ux_;
  const double fn0 = normal_force(), fx0 = tangential_force();
  const double ux_target = step.tangential == TangentialControl::kDisplacement
                               ? step.tangential_value
                               : ux0 + step.tangential_value;
  auto depth_at = [&](double s) {
    if (s == 1) return depth_target;
    if (step.normal == NormalControl::kForce) {
      return DepthAtNormalForce(fn0 + s * (step.normal_value - fn0));
    }
    return depth0 + s * (depth_target - depth0);
  };
  // One exact linear sub-step of `contact` to the path point at s.
  auto advance = [&](Contact& contact, double s, double* dissipated) -> Status {
    const double d = depth_at(s);
    double ux = ux0 + s * (ux_target - ux0);
    double dux = ux - contact.ux_;
    if (step.tangential == TangentialControl::kForce) {
      Result<double> solved =
          contact.SolveTangentialIncrement(d, fx0 + s * (step.tangential_value - fx0));
      if (!solved.ok()) return solved.status();
      dux = *solved;
      ux = contact.ux_ + dux;
    }
    *dissipated += contact.LinearStep(d, ux, dux);
    return OkStatus();
  };
  const double scale = std::max(mu_kappa() * std::max(depth0, depth_target), 1e-300);

  // Adaptive bisection: accept [s0, s1] when one sub-step and two half sub-steps agree to the
  // tolerance. A chord's error sits in the springs that enter or slide during that interval and
  // is not accumulated afterwards (sticking springs move rigidly with exact sub-step ends, the
  // clamp is non-expansive), so the estimate of the whole step is the largest local one; it
  // converges at second order in the sub-step length.
  StepReport total;
  // Up to 2^kMaxBisections intervals: the interrupt is checked at each.
  auto refine = [&](auto&& self, double s0, double s1, int level) -> Status {
    if (Status s = interrupt.Check(); !s.ok()) return s;
    Contact one = *this, two = *this;
    double d_one = 0, d_two = 0;
    const double mid = 0.5 * (s0 + s1);
    if (Status s = advance(one, s1, &d_one); !s.ok()) return s;
    if (Status s = advance(two, mid, &d_two); !s.ok()) return s;
    if (Status s = advance(two, s1, &d_two); !s.ok()) return s;
    const double error = MemoryDifference(one, two) / scale;
    if (error <= config_.force_path_tolerance || level >= kMaxBisections) {
      *this = std::move(two);
      total.substeps += 2;
      total.path_error = std::max(total.path_error, error);
      total.dissipated += d_two;
      return OkStatus();
    }
    if (Status s = self(self, s0, mid, level + 1); !s.ok()) return s;
    return self(self, mid, s1, level + 1);
  };
  if (Status s = refine(refine, 0.0, 1.0, 0); !s.ok()) return s;
  // The largest local difference bounds the chords' error by itself: the accepted two half
  // sub-steps err by about a third of it (second order; measured 0.25..0.35 of it against a
  // much finer reference, which contact_test.cc checks). Each exact sub-step adds its own rounding,
  // a few eps of mu kappa delta per spring (u += dux, the clamp), which the difference of two runs
  // does not show.
  constexpr double kSubstepRounding = 4 * std::numeric_limits<double>::epsilon();
  total.path_error += total.substeps * kSubstepRounding;
  *report = total;
  return OkStatus();
}

}  // namespace mdr
