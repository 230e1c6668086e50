#include "mdr/base/log_value.h"

#include <algorithm>
#include <cstdio>

namespace mdr {
namespace {

bool IsBareByte(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '/' || c == ':' || c == '@' || c == '+' || c == '-';
}

void AppendEscaped(char c, std::string* out) {
  switch (c) {
    case '"':
      *out += "\\\"";
      return;
    case '\\':
      *out += "\\\\";
      return;
    case '\n':
      *out += "\\n";
      return;
    case '\r':
      *out += "\\r";
      return;
    case '\t':
      *out += "\\t";
      return;
    default:
      break;
  }
  const auto byte = static_cast<unsigned char>(c);
  if (byte >= 0x20 && byte < 0x7F) {
    *out += c;
    return;
  }
  char hex[5];
  std::snprintf(hex, sizeof hex, "\\x%02X", byte);
  *out += hex;
}

}  // namespace

std::string Quoted(std::string_view value, std::size_t max_bytes) {
  const std::string_view shown = value.substr(0, max_bytes);
  std::string out = "\"";
  out.reserve(shown.size() + 2);
  for (char c : shown) AppendEscaped(c, &out);
  if (shown.size() < value.size()) out += "...(" + std::to_string(value.size()) + " bytes)";
  out += '"';
  return out;
}

std::string LogValue(std::string_view value, std::size_t max_bytes) {
  const bool bare = !value.empty() && value.size() <= max_bytes &&
                    std::all_of(value.begin(), value.end(), IsBareByte);
  return bare ? std::string(value) : Quoted(value, max_bytes);
}

}  // namespace mdr
