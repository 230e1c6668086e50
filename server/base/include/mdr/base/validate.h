// The validation rules for scalar inputs, in one place for the core, the service and the CLI.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <string_view>

#include "mdr/base/status.h"

namespace mdr {

// A number as error messages show it (10 significant digits).
std::string FormatNumber(double value);

// "name[i]", the field of one element of a list.
std::string Indexed(const std::string& name, std::size_t i);

// The checks take the field as a view and build its string only for an error: a step's checks
// allocate nothing ("tangential_force" is beyond std::string's inline capacity).

// Finite and strictly positive (moduli, radii, tolerances).
Status RequirePositive(std::string_view field, double value);
// Finite and >= 0 (friction coefficient, forces that cannot be negative).
Status RequireNonNegative(std::string_view field, double value);
// The error of RequireFinite, out of line.
Status NotFinite(std::string_view field, double value);
// Finite (displacements, tangential forces). Inline, since every step checks its inputs with it.
inline Status RequireFinite(std::string_view field, double value) {
  if (!std::isfinite(value)) [[unlikely]] {
    return NotFinite(field, value);
  }
  return OkStatus();
}
// The range of a scale that defines a scene (a radius in m, a modulus in Pa, a power-law
// coefficient): beyond it the quantities derived from it (1/R, E* and G*, depths at a force,
// pressures) overflow or lose all precision, so it is refused at the scene, not at a later step.
inline constexpr double kMinSceneScale = 1e-100;
inline constexpr double kMaxSceneScale = 1e100;
// Finite and > 0 (RequirePositive's message), then in [kMinSceneScale, kMaxSceneScale].
Status RequireSceneScale(std::string_view field, double value);
// Finite and in [lo, hi] (or (lo, hi] when lo_open); the message states the range.
Status RequireInRange(std::string_view field, double value, double lo, double hi,
                      bool lo_open = false);

}  // namespace mdr
