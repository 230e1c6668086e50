// Surface tractions of a contact state: tangential tau(r) and normal p(r), each by two
// independent routes (docs/physics.md, "Tractions, two routes that must agree"):
//   (1) Abel: the inverse MDR transform of the springs,
//       tau(r) = -(G*/pi) integral_r^a u'(x)/sqrt(x^2 - r^2) dx and
//       p(r) = -(E*/pi) integral_r^a w'(x)/sqrt(x^2 - r^2) dx with w = delta - g,
//       by adaptive Gauss-Kronrod quadrature (GSL QAGS) after x = sqrt(r^2 + s^2), split at the
//       memory's radii; where g jumps (flat punch edge a0) the jump of the spring displacement,
//       not a quadrature, gives G* [u] / (pi sqrt(a0^2 - r^2)).
//   (2) Jäger: the superposition of frictionless pressures of the normal problem,
//       tau(r) = sum_k F_k mu [p(r; z_{k+1}) - p(r; z_k)] over the memory segments in z, where
//       mu F_k = -(du/dz)_k / kappa (so it holds for mu = 0 too), and p(r) = E* times
//       Profile::PressurePerModulus(r, delta). No integration beyond the profile's own pressure.
// Values may be infinite (cone centre pressure, slip at a cone's centre, the edge r = a0 of a flat
// punch), never NaN. Radii beyond the contact radius a give 0; r = a gives the limit from inside:
// 0 where g is continuous, +-inf at a flat punch edge (0 if the springs there do not jump).
#pragma once

#include <optional>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/material.h"
#include "mdr/core/memory.h"
#include "mdr/core/profile.h"

namespace mdr {

enum class TractionRoute { kAbel, kJager, kBoth };

struct TractionOptions {
  TractionRoute routes = TractionRoute::kBoth;  // which routes to evaluate
  double abel_relative_tolerance = 1e-12;       // QAGS target of route (1), in (0, 1e-3]
  // Checked before every radius of a traction or pressure profile (DeadlineExceeded /
  // Cancelled abandon it).
  Interrupt interrupt{};
};

struct RadialValue {
  double radius = 0;
  // Each route's value; empty when not requested, or (Jäger) where a term is the difference of two
  // infinite pressures (r = 0 on a cone with a stick zone at the centre).
  std::optional<double> abel, jager;
  // The reported value and where it comes from. kBoth: both routes are defined and `value` is the
  // Jäger one (closed-form pressures; the quadrature is the check). kAbel / kJager: only that
  // route is defined or requested.
  double value = 0;
  TractionRoute chosen = TractionRoute::kBoth;
  // kBoth: |abel - jager| plus kJager's bound. kAbel: the quadrature's own error estimate.
  // kJager: the round-off bound 4 eps * sum_k |term_k| of the superposition. For the tangential
  // traction each adds an a-priori bound of the effect of the memory vertices' own rounding
  // (depths to ~8 eps delta, which both routes share and their difference cannot see; see
  // docs/engine.md). 0 where the value is infinite (a flat punch edge, a cone's centre).
  double error_estimate = 0;
};

// tau(r) (Pa) at the radii (each finite and >= 0, field "radii[i]"; radii > a give 0).
Result<std::vector<RadialValue>> ComputeTangentialTraction(const PiecewiseLinearMemory& memory,
                                                           const Profile& profile,
                                                           const EffectiveMaterial& material,
                                                           const std::vector<double>& radii,
                                                           const TractionOptions& options = {});
Result<std::vector<RadialValue>> ComputeTangentialTraction(const Contact& contact,
                                                           const std::vector<double>& radii,
                                                           const TractionOptions& options = {});

// p(r) (Pa) of the frictionless normal contact at `depth`, same conventions.
Result<std::vector<RadialValue>> ComputeNormalPressure(const Profile& profile,
                                                       const EffectiveMaterial& material,
                                                       double depth,
                                                       const std::vector<double>& radii,
                                                       const TractionOptions& options = {});
Result<std::vector<RadialValue>> ComputeNormalPressure(const Contact& contact,
                                                       const std::vector<double>& radii,
                                                       const TractionOptions& options = {});

struct IntegratedForce {
  double value = 0;           // N
  double error_estimate = 0;  // N, the outer quadrature's estimate
};

// 2 pi integral_0^a tau(r) r dr (= F_x) and 2 pi integral_0^a p(r) r dr (= F_N) by QAGS in r,
// split at the memory's radii, of the value `route` gives (kBoth: the chosen value, both routes
// at every point). relative_tolerance in (0, 1e-3].
Result<IntegratedForce> IntegrateTangentialTraction(const Contact& contact,
                                                    double relative_tolerance = 1e-10,
                                                    TractionRoute route = TractionRoute::kJager);
Result<IntegratedForce> IntegrateNormalPressure(const Contact& contact,
                                                double relative_tolerance = 1e-10,
                                                TractionRoute route = TractionRoute::kJager);

}  // namespace mdr
