// Axisymmetric indenter profiles f(r) in their MDR form: the equivalent 1D profile g(x)
// (docs/physics.md, "MDR"). Everything the engine needs of a profile is here; the per-increment
// update never calls a profile (it works in z = g(x)), only force and profile queries do.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mdr/base/status.h"

namespace mdr {

// The integrals of the profile over one memory piece [x(za), x(zb)] in its normalised depth
// t = (g(x) - za) / (zb - za) in [0, 1]: J_m = integral t^m dx for m = 0, 1, 2. The forces and
// the dissipation of a piece are linear in them (a piece's u and its dissipation density are
// polynomials of degree <= 2 in t), and in t they need no division by the piece's width.
struct PieceIntegrals {
  double j0 = 0, j1 = 0, j2 = 0;
};

// g = k x^n exactly (spheres: n = 2, cones: n = 1, power laws): the form the closed forms beyond
// the MDR mapping use (the torsional bound, torsion.h).
struct PowerLawForm {
  double coefficient = 0;  // k
  double exponent = 0;     // n
};

class Profile {
 public:
  virtual ~Profile() = default;

  // Equivalent profile z = g(x), x >= 0.
  virtual double G(double x) const = 0;
  // Slope g'(x); +inf where g jumps (flat punch edge).
  virtual double Slope(double x) const = 0;
  // Inverse of g: the radius x at which g(x) = z, i.e. the contact radius at depth z.
  // For z = 0 it is the radius of the region where g = 0 (a0 of a flat punch, 0 otherwise).
  virtual double RadiusAtDepth(double z) const = 0;
  // g(x) - g(x_ref) for x >= x_ref, without the cancellation of the plain difference when
  // x is close to x_ref (energy over thin slip annuli).
  virtual double Rise(double x, double x_ref) const { return G(x) - G(x_ref); }
  // Moments M_j(x) = integral_0^x g(t)^j dt for j = 0, 1, 2 (forces and dissipation).
  virtual double Moment(int j, double x) const = 0;
  // J_0, J_1 and (if with_square, else 0) J_2 of the piece za <= zb, given its radii
  // xa = RadiusAtDepth(za) and xb = RadiusAtDepth(zb) (callers have them per vertex), accurate
  // to round-off also for a thin piece (zb - za << za: a slip annulus that has just started),
  // where differences of moments cancel. Zero when xb <= xa. The default combines Moment and,
  // for thin pieces, Gauss-Legendre with Rise; closed forms override it.
  virtual PieceIntegrals IntegratePiece(double za, double zb, double xa, double xb,
                                        bool with_square) const;
  // Pressure of the frictionless normal contact at depth z, per unit E*:
  // p/E* = (1/pi) integral_r^a g'(x)/sqrt(x^2-r^2) dx with a = RadiusAtDepth(z) (a jump of g
  // counts as a delta function in g'); 0 for r >= a. Taking depth, not radius, keeps the flat
  // punch (radius fixed, pressure proportional to depth) in the same form. May be +inf (cone
  // centre, flat punch edge), never NaN.
  virtual double PressurePerModulus(double r, double depth) const = 0;
  // F_N/E* = 2 (z a - M_1(a)) at depth z, and its inverse (depth for F_N/E* >= 0).
  double NormalForcePerModulus(double depth) const;
  virtual double DepthAtNormalForcePerModulus(double force_per_modulus) const = 0;
  // k and n when g = k x^n; nullopt for the flat punch and tabulated profiles.
  virtual std::optional<PowerLawForm> AsPowerLaw() const { return std::nullopt; }
  // Human-readable description, e.g. "power law f = 1e3 r^2".
  virtual std::string Describe() const = 0;
  // Relative tolerance of g against the profile it stands for: 0 for the closed forms, the
  // achieved spline tolerance for a tabulated profile (ErrorEstimate.profile_tolerance).
  virtual double ToleranceEstimate() const { return 0; }
  // Bytes the object holds: itself and what it owns (a name, a tabulated profile's tables), for
  // the memory a session is charged; not its allocation's control block.
  virtual std::size_t MemoryBytes() const = 0;
};

using ProfilePtr = std::shared_ptr<const Profile>;

// f = C r^n, 0.3 <= n <= 10, C > 0: g = k x^n with k = C sqrt(pi) Gamma(n/2+1)/Gamma(n/2+1/2).
Result<ProfilePtr> MakePowerLaw(double coefficient, double exponent);
// Hertz sphere of radius R: f = r^2/(2R), g = x^2/R.
Result<ProfilePtr> MakeSphere(double radius);
// The spheres of the given radii (a rough surface's summits), one pointer per radius, each
// sphere equal to MakeSphere's bit for bit. Equal radii share one sphere; the distinct ones are
// made in one allocation of 32 bytes per sphere, whose ownership every pointer shares. Fields:
// radii[i].
Result<std::vector<ProfilePtr>> MakeSpheres(std::span<const double> radii);
// Cone of slope angle theta (rad, 0 < theta < pi/2) to the surface: g = (pi/2) tan(theta) x.
Result<ProfilePtr> MakeCone(double slope_angle);
// Flat cylindrical punch of radius a0: g = 0 for x < a0; contact radius a0 while delta > 0.
Result<ProfilePtr> MakeFlatPunch(double radius);

}  // namespace mdr
