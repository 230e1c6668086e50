// Torsion of an axisymmetric contact about its own axis, exact (docs/physics.md, "Torsion").
//
// A twist phi maps to independent 1D play springs: v(x) (a rotation) with |v(x)| <= B(x; a),
// weight 16 G_t x^2, the same input phi for every spring. The memory v is kept exactly as a list
// of pieces, each a constant or +-B(x; a_k) + constant for the contact radius a_k at which it was
// made; a twist clips it to the current bound, a normal-load decrease clips it to the smaller
// bound and forgets the springs outside the new radius, a growth adds springs at v = 0.
//
// The spring state is the exact 3D state while Jager's |F| <= 1 holds. That is decided
// structurally: every piece on a bound belongs to a radius a_k <= a (its slope can then not
// exceed the current bound's). A normal-load decrease that would leave a piece of a larger radius
// is refused (FailedPrecondition): a ring model of the half-space is the state's exact solver
// there, and the springs would be wrong by up to a few percent of the full-slip moment.
//
// This is the core of the torsion channel: the Hertz bound in closed form (Carlson's integrals,
// no cancellation at either end of the contact), the power laws by a quadrature to round-off and
// tabulated profiles by the same quadrature over their own g'; sessions and the proto build on it.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/profile.h"

namespace mdr {

// The bound B(x; a) of the torsional springs of one profile and its slope in x; x in [0, a).
class TorsionBound {
 public:
  virtual ~TorsionBound() = default;
  // B(x; a) >= 0, strictly decreasing in x and increasing in a; 0 for x >= a; +inf at x = 0.
  virtual double Bound(double x, double a) const = 0;
  // dB/dx (x; a) < 0 for 0 < x < a.
  virtual double Slope(double x, double a) const = 0;
  // mu p(r; a) / G_t: the traction of full sliding per torsional modulus; 0 for r >= a.
  virtual double SlidingTractionPerModulus(double r, double a) const = 0;
  // The full-slip moment per torsional modulus, 16 integral_0^a x^2 B(x; a) dx. The default
  // integrates the bound; a bound that is itself a quadrature overrides it with the equal
  // single integral (pi mu E* / (2 G_t)) integral_0^a x^2 g'(x) dx.
  virtual double FullSlipMomentPerModulus(double a) const;
  // The tails integral_x^a u^2 B(u; a) du and integral_x^a u^2 B(u; a)^2 du, 0 <= x (both 0
  // for x >= a): a piece [lo, hi) of the memory has the moment and energies of the tails at lo
  // less those at hi. The default integrates the bound (split at the breakpoints); the Hertz
  // bound reads them off its universal function.
  struct Integrals {
    double first = 0, second = 0;
  };
  virtual Integrals TailIntegrals(double x, double a) const;
  // The x in (0, a) where B(x; a) = value > 0, when the bound knows its inverse (Hertz: to a few
  // ulps); NaN when it does not, and the memory then finds it by a bracketed Newton iteration.
  virtual double RadiusAtBound(double value, double a) const;
  // Radii (increasing) where B is not smooth in x: a tabulated profile's sample radii, where its
  // g' is continuous but its slope jumps like a square root. Every integral over x of the memory
  // (moment, energies, the full-slip moment) is split there. None for the closed forms.
  virtual const std::vector<double>& Breakpoints() const {
    static const std::vector<double> kNone;
    return kNone;
  }
};

// Hertz (g = x^2/R): B = (mu p0 / (2 G_t)) [K(m) - E(m)], m = 1 - x^2/a^2, p0 = 2 E* a / (pi R).
// Fields of the errors: friction, effective_modulus, torsional_modulus, radius.
Result<std::shared_ptr<const TorsionBound>> MakeHertzTorsionBound(double friction,
                                                                  double effective_modulus,
                                                                  double torsional_modulus,
                                                                  double radius);

// A power law g = k x^n (the engine's MakePowerLaw gives k from f = C r^n), 0.3 <= n <= 10; the
// cone is n = 1 and Hertz n = 2 (MakeHertzTorsionBound's closed form is the faster equal).
// Fields: friction, effective_modulus, torsional_modulus, coefficient, exponent.
Result<std::shared_ptr<const TorsionBound>> MakePowerLawTorsionBound(double friction,
                                                                     double effective_modulus,
                                                                     double torsional_modulus,
                                                                     double coefficient,
                                                                     double exponent);

// The bound of a profile: Hertz's closed form for a sphere, the power-law quadrature for cones and
// power laws, and for a tabulated profile the same quadrature over the profile's own g' (it keeps
// the profile). The flat punch is not supported yet (field profile): its bound scales with the
// depth at a fixed radius. Fields: profile, friction, effective_modulus, torsional_modulus.
Result<std::shared_ptr<const TorsionBound>> MakeTorsionBound(const ProfilePtr& profile,
                                                             double friction,
                                                             double effective_modulus,
                                                             double torsional_modulus);

// One piece of the torsional memory on [start, end): v = sign * B(x; radius) + offset.
struct TorsionPiece {
  double end = 0;
  std::int8_t sign = 0;  // -1, 0 (a constant) or +1
  double radius = 0;     // a_k of the bound (unused for a constant)
  double offset = 0;

  friend bool operator==(const TorsionPiece&, const TorsionPiece&) = default;
};

// The circumferential traction tau_phi(r) (Pa) by the two routes of docs/physics.md: value is
// the Abel transform of v' piece by piece; the second route takes each piece's full-sliding
// traction mu p(r; a_k) (closed form for Hertz) less the integrals over the rest of its contact.
// route_difference = |first - second|: in a slip annulus the second is the closed form itself.
struct TorsionTraction {
  double value = 0;
  double route_difference = 0;
};

// A slip interval [start, end) of the springs on the bound of the given sign.
struct TorsionSlipInterval {
  double start = 0, end = 0;
  int sign = 0;
};

// The exact, portable state of a TorsionalMemory.
struct TorsionSnapshot {
  double contact_radius = 0;
  double twist = 0;
  double dissipated_energy = 0;
  double last_step_dissipation = 0;
  std::vector<TorsionPiece> pieces;

  friend bool operator==(const TorsionSnapshot&, const TorsionSnapshot&) = default;
};

class TorsionalMemory {
 public:
  // An unloaded contact of radius contact_radius >= 0 at twist 0; torsional_modulus G_t > 0
  // (1/G_t = 1/G_1 + 1/G_2). Fields: bound, torsional_modulus, contact_radius.
  static Result<TorsionalMemory> Create(std::shared_ptr<const TorsionBound> bound,
                                        double torsional_modulus, double contact_radius);

  // The memory of a snapshot, checked: pieces in increasing order covering [0, contact_radius),
  // signs -1, 0, +1, finite values, every bound piece of a radius in (0, contact_radius] (an
  // exact state), and |v| <= B at both ends of every piece (where |v| - B is largest: it is
  // monotone on a piece), to 1e-9 of the terms of v plus what a root exact to 1e-15 of the
  // radius moves v - B by; a contact radius that CheckRepresentable refuses is refused. Fields:
  // contact_radius, twist, dissipated_energy, last_step_dissipation, pieces[i].<member>.
  static Result<TorsionalMemory> Restore(std::shared_ptr<const TorsionBound> bound,
                                         double torsional_modulus, const TorsionSnapshot& snapshot);
  TorsionSnapshot Snapshot() const;

  // Twists by increment (rad, finite) at the current contact radius: v <- clamp(v + increment,
  // -B, B), exact for any size. A twist whose sliding work would take the dissipated energy
  // beyond the finite doubles is refused (InvalidArgument, nothing changed): no snapshot could
  // hold it. Field: twist_increment.
  Status Twist(double increment);
  // Twists to the angle (rad, finite): the increment angle - twist(), and twist() == angle
  // exactly afterwards; refused as Twist. Field: twist.
  Status TwistTo(double angle);
  // Twists at the current contact radius until the moment is target (N m, finite), the increment
  // found by a bracketed Newton iteration on the exact moment with the exact stiffness as its
  // slope. |target| must be below the full-slip moment, which only an infinite twist reaches
  // (FailedPrecondition otherwise, nothing changed). Field: moment.
  Status TwistToMoment(double target);
  // Twists the contact behind a torsional spring of compliance C (rad/(N m), finite, >= 0; a
  // rig's shaft and fixtures) whose far end is turned to `actuator` (rad, finite): afterwards
  // twist() + C Moment() = actuator, to the round-off of a bracketed Newton iteration on that
  // (monotone, slope 1 + C stiffness) relation. C = 0 is TwistTo. Fields: actuator, compliance.
  Status TwistThroughCompliance(double actuator, double compliance);
  // The normal load changes at fixed twist so that the contact radius becomes contact_radius
  // (finite, >= 0). Growing adds springs at v = 0; shrinking clips to the smaller bound and
  // forgets the springs outside (their energy is dissipated). A decrease whose result would break
  // |F| <= 1 fails with FailedPrecondition, and a contact the doubles do not carry
  // (CheckRepresentable), or a decrease whose loss would take the dissipated energy beyond them,
  // with InvalidArgument; none changes anything. Field: contact_radius.
  Status SetContactRadius(double contact_radius);
  // Whether the doubles carry a contact of this radius (> 0; 0 always passes): its full-slip
  // moment and full-stick stiffness per modulus neither near the subnormals, where round-off
  // breaks |M| <= M_slip, nor beyond the finite doubles. SetContactRadius and Restore refuse
  // a radius that fails it (InvalidArgument, field contact_radius).
  Status CheckRepresentable(double contact_radius) const;

  double twist() const { return twist_; }
  double contact_radius() const { return radius_; }
  // M = 16 G_t integral_0^a x^2 v dx (N m).
  double Moment() const;
  // The moment of full sliding at the current radius, 16 G_t integral_0^a x^2 B dx: the supremum
  // of |M| (Hertz: 3 pi mu F_N a / 16).
  double FullSlipMoment() const;
  // dM/dphi for a further twist of the given direction (+1 or -1): 16 G_t times the integral of
  // x^2 over the springs not on the bound of that sign.
  double Stiffness(int direction) const;
  // The smallest x on the bound of the given direction (the stick radius of a twist that way);
  // the contact radius if no spring is on it.
  double StickRadius(int direction) const;
  std::vector<TorsionSlipInterval> SlipIntervals() const;
  // tau_phi(r); 0 at r = 0 and outside the contact.
  TorsionTraction Traction(double r) const;
  // Energy dissipated since creation (J) and in the last successful call.
  double dissipated_energy() const { return dissipated_; }
  double last_step_dissipation() const { return last_dissipation_; }
  // Energy held by the springs, 8 G_t integral x^2 v^2 dx (J).
  double StoredEnergy() const;
  // v at x (rad), 0 outside the contact.
  double SpringDisplacement(double x) const;
  // Whether the spring state is the exact 3D state (|F| <= 1, decided from the pieces). Always
  // true for a state this class accepted; kept as the structural check its tests assert.
  bool IsExact() const;
  const std::vector<TorsionPiece>& pieces() const { return pieces_; }

 private:
  TorsionalMemory(std::shared_ptr<const TorsionBound> bound, double torsional_modulus,
                  double contact_radius);
  // The clip of one twist increment, after which the twist is `twist`; refused naming `field`
  // when its loss overflows the dissipated energy.
  Status ApplyTwist(double increment, double twist, const char* field);
  // InvalidArgument naming `field` when the dissipated energy plus `dissipation` is not finite.
  Status CheckDissipation(double dissipation, const char* field) const;
  double Value(const TorsionPiece& piece, double x) const;
  double Slope(const TorsionPiece& piece, double x) const;
  // The pieces v + shift clipped to +-B(x; radius) on [0, radius) into *out, and the energy the
  // clipped springs dissipate: sliding at the bound (twist) or while the bound shrinks (load
  // decrease).
  void Clip(double shift, double radius, bool shrinking, std::vector<TorsionPiece>* out,
            std::vector<TorsionBound::Integrals>* out_tails, double* dissipation) const;
  // Where B(x; radius) = value in [lo, hi]: lo if B(lo) <= value, hi if B(hi) >= value.
  double RadiusAtBound(double value, double radius, double lo, double hi) const;
  // Merges neighbours that are one piece (their tails go with them).
  static void Merge(std::vector<TorsionPiece>& pieces, std::vector<TorsionBound::Integrals>& tails);
  // The tails of every piece at its start (TorsionBound::TailIntegrals for its radius; 0 for a
  // constant), computed afresh, and the moment's or energy's integral of piece i from them.
  void ComputeTails();
  TorsionBound::Integrals PieceIntegrals(std::size_t i) const;

  std::shared_ptr<const TorsionBound> bound_;
  double modulus_ = 0;
  double radius_ = 0;
  double twist_ = 0;
  double dissipated_ = 0;
  double last_dissipation_ = 0;
  std::vector<TorsionPiece> pieces_;  // cover [0, radius_), ends increasing, the last = radius_
  // The tails of each piece at its start: derived from the pieces alone (a restored memory
  // computes the same bits), kept so that a step computes those of the points it moved only.
  std::vector<TorsionBound::Integrals> tails_;
  // Where a step builds the next pieces and tails, kept so that a warm memory steps without
  // allocating; not part of the state.
  std::vector<TorsionPiece> scratch_;
  std::vector<TorsionBound::Integrals> scratch_tails_;
};

// How a step drives the twist: to an angle (rad), by an increment (rad), or to a moment (N m).
enum class TwistControl { kAngle, kAngleIncrement, kMoment };

// One step of a torsional contact: the normal channel (as Contact's NormalControl) or the twist;
// an unset channel holds.
struct TorsionStep {
  std::optional<NormalControl> normal;
  double normal_value = 0;
  std::optional<TwistControl> twist;
  double twist_value = 0;
};

// A contact twisted about its axis under a normal load: the normal problem of its profile (depth,
// F_N, contact radius) and the torsional memory at that radius.
class TorsionalContact {
 public:
  // An unloaded contact at twist 0. friction > 0 (a frictionless contact carries no moment).
  // Fields: profile, friction, effective_modulus, torsional_modulus.
  static Result<TorsionalContact> Create(ProfilePtr profile, double friction,
                                         double effective_modulus, double torsional_modulus);
  // The contact of a snapshot: depth finite, the memory's contact radius exactly the profile's
  // at that depth (what every step leaves), the memory checked by TorsionalMemory::Restore.
  // Fields: depth, contact_radius and those of TorsionalMemory::Restore.
  static Result<TorsionalContact> Restore(ProfilePtr profile, double friction,
                                          double effective_modulus, double torsional_modulus,
                                          double depth, const TorsionSnapshot& memory);

  // Applies the step; on an error nothing changed. A step moves one channel: the normal load at
  // fixed twist, or the twist at fixed normal load, each exact. One that moves both is refused
  // (field step): along a simultaneous ramp each spring detaches at its own instant and the
  // memory is no longer a finite list of pieces (docs/physics.md); two steps do it exactly.
  // Fields: normal_value, twist_value, step, and those of TorsionalMemory.
  Status Apply(const TorsionStep& step);

  // The twist behind a rig's torsional compliance (TorsionalMemory::TwistThroughCompliance) at
  // fixed normal load; on an error nothing changed. Fields: actuator, compliance.
  Status TwistThroughCompliance(double actuator, double compliance) {
    return memory_.TwistThroughCompliance(actuator, compliance);
  }

  double depth() const { return depth_; }
  double normal_force() const;
  const TorsionalMemory& memory() const { return memory_; }

 private:
  TorsionalContact(ProfilePtr profile, double effective_modulus, TorsionalMemory memory)
      : profile_(std::move(profile)),
        effective_modulus_(effective_modulus),
        memory_(std::move(memory)) {}
  Result<double> TargetDepth(NormalControl control, double value) const;

  ProfilePtr profile_;
  double effective_modulus_ = 0;
  double depth_ = 0;
  TorsionalMemory memory_;
};

}  // namespace mdr
