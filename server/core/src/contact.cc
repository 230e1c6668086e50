#include "mdr/core/contact.h"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_roots.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mdr/core/validate.h"

namespace mdr {
namespace {

// Curved force paths: cap on exact sub-steps per step, so a pathological request ends.
constexpr int kMaxSubsteps = 1 << 14;

std::string Format(double v) {
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

// Largest |u_a(z) - u_b(z)| over the vertices of both memories (both are polylines).
double MaxDifference(const PiecewiseLinearMemory& a, const PiecewiseLinearMemory& b) {
  double diff = 0;
  for (double z : a.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  for (double z : b.z()) diff = std::max(diff, std::abs(a.UAtDepth(z) - b.UAtDepth(z)));
  return diff;
}

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
  return OkStatus();
}

Result<Contact> Contact::Create(ContactConfig config) {
  if (Status s = ValidateContactConfig(config); !s.ok()) return s;
  return Contact(std::move(config));
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
  Result<PiecewiseLinearMemory> memory =
      PiecewiseLinearMemory::Restore(snapshot.depth, snapshot.z, snapshot.u, snapshot.tags);
  if (!memory.ok()) return memory.status();
  const double m = contact->mu_kappa();
  for (std::size_t i = 0; i < snapshot.z.size(); ++i) {
    if (std::abs(snapshot.u[i]) > m * (snapshot.depth - snapshot.z[i]) * (1 + 1e-12)) {
      return InvalidArgument("memory[" + std::to_string(i) + "]",
                             "u exceeds the Coulomb bound mu kappa (depth - z)");
    }
  }
  contact->memory_ = std::move(memory).value();
  contact->ux_ = snapshot.tangential_displacement;
  contact->dissipated_ = snapshot.dissipated_energy;
  contact->last_dissipated_ = snapshot.last_step_dissipation;
  return contact;
}

ContactSnapshot Contact::Snapshot() const {
  return {memory_.depth(), ux_,         dissipated_,   last_dissipated_,
          memory_.z(),     memory_.u(), memory_.tags()};
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
  return 2 * config_.material.g_star * memory_.IntegralU(*config_.profile);
}

TangentialStiffness Contact::tangential_stiffness() const {
  // Sticking springs follow ux; those on the bound in the direction of motion slide.
  const double a = contact_radius();
  const double k = 2 * config_.material.g_star;
  return {k * (a - memory_.MeasureOnBound(*config_.profile, kOnUpper)),
          k * (a - memory_.MeasureOnBound(*config_.profile, kOnLower))};
}

std::vector<SlipInterval> Contact::slip_intervals() const {
  std::vector<SlipInterval> intervals;
  for (const MemoryPiece& piece : memory_pieces()) {
    if (piece.bound == kInside) continue;
    const int direction = piece.bound == kOnUpper ? +1 : piece.bound == kOnLower ? -1 : 0;
    if (!intervals.empty() && intervals.back().direction == direction &&
        intervals.back().r_end == piece.x_begin) {
      intervals.back().r_end = piece.x_end;
    } else {
      intervals.push_back({piece.x_begin, piece.x_end, direction});
    }
  }
  return intervals;
}

double Contact::tangential_displacement_at(double x) const {
  x = std::abs(x);
  if (!(x < contact_radius())) return 0;
  return memory_.UAtDepth(config_.profile->G(x));
}

double Contact::normal_displacement_at(double x) const {
  x = std::abs(x);
  if (!(x < contact_radius())) return 0;
  return depth() - config_.profile->G(x);
}

double Contact::LinearStep(double depth1, double ux1) {
  const Profile* energy_profile = config_.track_energy ? config_.profile.get() : nullptr;
  const double per_modulus = memory_.Step(depth1, ux1 - ux_, mu_kappa(), energy_profile);
  ux_ = ux1;
  const double dissipated = config_.material.g_star * per_modulus;
  dissipated_ += dissipated;
  return dissipated;
}

Result<double> Contact::SolveTangentialDisplacement(double depth1, double fx) const {
  const double limit = config_.friction * NormalForceAtDepth(depth1);
  if (!(std::abs(fx) <= limit * (1 + 1e-12))) {
    return FailedPrecondition("tangential_force",
                              "|F_x| = " + Format(std::abs(fx)) +
                                  " N exceeds the friction limit mu F_N = " + Format(limit) +
                                  " N at the step's end (no tangential force without contact)");
  }
  if (limit == 0) return ux_;  // F_x = 0 holds for any ux: keep it
  const double m = mu_kappa();
  const double lo = ux_ + memory_.GrossSlipIncrement(depth1, m, -1);
  const double hi = ux_ + memory_.GrossSlipIncrement(depth1, m, +1);
  if (fx >= limit) return hi;  // onset of gross slip
  if (fx <= -limit) return lo;

  struct Trial {
    const Contact* contact;
    double depth1, fx;
  } trial{this, depth1, fx};
  gsl_function f;
  f.params = &trial;
  f.function = [](double ux1, void* p) {
    const auto* t = static_cast<const Trial*>(p);
    PiecewiseLinearMemory memory = t->contact->memory_;
    memory.Step(t->depth1, ux1 - t->contact->ux_, t->contact->mu_kappa(), nullptr);
    return 2 * t->contact->config_.material.g_star *
               memory.IntegralU(*t->contact->config_.profile) -
           t->fx;
  };
  const double f_lo = f.function(lo, f.params), f_hi = f.function(hi, f.params);
  if (f_lo >= 0) return lo;
  if (f_hi <= 0) return hi;

  gsl_error_handler_t* previous = gsl_set_error_handler_off();
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
  gsl_set_error_handler(previous);
  return root;
}

Status Contact::MoveTo(double depth, double tangential_displacement, StepReport* report) {
  if (Status s = RequireFinite("depth", depth); !s.ok()) return s;
  if (Status s = RequireFinite("displacement", tangential_displacement); !s.ok()) return s;
  last_dissipated_ = LinearStep(depth, tangential_displacement);
  if (report) *report = {1, 0, last_dissipated_};
  return OkStatus();
}

Status Contact::Apply(const Step& step, StepReport* report) {
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
    double target_ux = ux1;
    if (tangential_force) {
      Result<double> solved = SolveTangentialDisplacement(depth1, step.tangential_value);
      if (!solved.ok()) return solved.status();
      target_ux = *solved;
    }
    local = {1, 0, trial.LinearStep(depth1, target_ux)};
  } else if (Status s = trial.ApplyCurvedPath(step, depth1, &local); !s.ok()) {
    return s;
  }
  if (trial.memory_.vertex_count() > config_.max_memory_vertices) {
    return ResourceExhausted("max_memory_vertices",
                             "the step needs " + std::to_string(trial.memory_.vertex_count()) +
                                 " memory vertices, above the session limit of " +
                                 std::to_string(config_.max_memory_vertices));
  }
  trial.last_dissipated_ = local.dissipated;
  *this = std::move(trial);
  if (report) *report = local;
  return OkStatus();
}

Status Contact::ApplyCurvedPath(const Step& step, double depth_target, StepReport* report) {
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
    if (step.tangential == TangentialControl::kForce) {
      Result<double> solved =
          contact.SolveTangentialDisplacement(d, fx0 + s * (step.tangential_value - fx0));
      if (!solved.ok()) return solved.status();
      ux = *solved;
    }
    *dissipated += contact.LinearStep(d, ux);
    return OkStatus();
  };
  const double scale = std::max(mu_kappa() * std::max(depth0, depth_target), 1e-300);

  // Adaptive bisection: accept [s0, s1] when one sub-step and two half sub-steps agree.
  StepReport total;
  auto refine = [&](auto&& self, double s0, double s1) -> Status {
    Contact one = *this, two = *this;
    double d_one = 0, d_two = 0;
    const double mid = 0.5 * (s0 + s1);
    if (Status s = advance(one, s1, &d_one); !s.ok()) return s;
    if (Status s = advance(two, mid, &d_two); !s.ok()) return s;
    if (Status s = advance(two, s1, &d_two); !s.ok()) return s;
    const double error = MaxDifference(one.memory_, two.memory_) / scale;
    if (error <= config_.force_path_tolerance || total.substeps + 2 >= kMaxSubsteps) {
      *this = std::move(two);
      total.substeps += 2;
      total.path_error += error;
      total.dissipated += d_two;
      return OkStatus();
    }
    if (Status s = self(self, s0, mid); !s.ok()) return s;
    return self(self, mid, s1);
  };
  if (Status s = refine(refine, 0.0, 1.0); !s.ok()) return s;
  *report = total;
  return OkStatus();
}

}  // namespace mdr
