// Numerical building blocks shared by the core's source files. Internal to mdr_core.
#pragma once

namespace mdr::internal {

// The value at z of the straight line through (za, ua) and (zb, ub), from the end a.
inline double Interpolate(double za, double ua, double zb, double ub, double z) {
  return ua + (ub - ua) * ((z - za) / (zb - za));
}

}  // namespace mdr::internal
