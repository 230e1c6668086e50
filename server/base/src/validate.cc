#include "mdr/base/validate.h"

#include <cmath>
#include <sstream>

namespace mdr {

std::string Indexed(const std::string& name, std::size_t i) {
  std::string field = name;  // (not name + "[" + ...: GCC 12 warns falsely on that form)
  field += '[';
  field += std::to_string(i);
  field += ']';
  return field;
}

std::string FormatNumber(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

Status NotFinite(std::string_view field, double value) {
  return InvalidArgument(std::string(field), "must be a finite number, got " + FormatNumber(value));
}

Status RequirePositive(std::string_view field, double value) {
  if (std::isfinite(value) && value > 0) return OkStatus();
  return InvalidArgument(std::string(field), "must be finite and > 0, got " + FormatNumber(value));
}

Status RequireNonNegative(std::string_view field, double value) {
  if (std::isfinite(value) && value >= 0) return OkStatus();
  return InvalidArgument(std::string(field), "must be finite and >= 0, got " + FormatNumber(value));
}

Status RequireSceneScale(std::string_view field, double value) {
  if (Status s = RequirePositive(field, value); !s.ok()) return s;
  if (value >= kMinSceneScale && value <= kMaxSceneScale) return OkStatus();
  return InvalidArgument(
      std::string(field),
      "must be in [" + FormatNumber(kMinSceneScale) + ", " + FormatNumber(kMaxSceneScale) +
          "] (beyond it the quantities derived from it overflow), got " + FormatNumber(value));
}

Status RequireInRange(std::string_view field, double value, double lo, double hi, bool lo_open) {
  const bool above_lo = lo_open ? value > lo : value >= lo;
  if (std::isfinite(value) && above_lo && value <= hi) return OkStatus();
  return InvalidArgument(std::string(field), "must be in " + std::string(lo_open ? "(" : "[") +
                                                 FormatNumber(lo) + ", " + FormatNumber(hi) +
                                                 "], got " + FormatNumber(value));
}

}  // namespace mdr
