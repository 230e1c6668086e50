// The validation rules for scalar inputs, in one place for the core, the service and the CLI.
#pragma once

#include <string>

#include "mdr/core/status.h"

namespace mdr {

// A number as error messages show it (10 significant digits).
std::string FormatNumber(double value);

// Finite and strictly positive (moduli, radii, tolerances).
Status RequirePositive(const std::string& field, double value);
// Finite and >= 0 (friction coefficient, forces that cannot be negative).
Status RequireNonNegative(const std::string& field, double value);
// Finite (displacements, tangential forces).
Status RequireFinite(const std::string& field, double value);
// Finite and in [lo, hi] (or (lo, hi] when lo_open); the message states the range.
Status RequireInRange(const std::string& field, double value, double lo, double hi,
                      bool lo_open = false);

}  // namespace mdr
