#include "mdr/service/auth.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

namespace mdr::service {
namespace {

constexpr char kField[] = "tokens-file";
constexpr std::size_t kMaxNameLength = 64;
constexpr std::string_view kScheme = "Bearer ";

bool IsValidName(std::string_view name) {
  return !name.empty() && name.size() <= kMaxNameLength &&
         std::all_of(name.begin(), name.end(), [](char c) {
           return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '.' || c == '_' || c == '-';
         });
}

bool IsValidToken(std::string_view token) {
  return token.size() >= Authenticator::kMinTokenLength &&
         std::all_of(token.begin(), token.end(), [](char c) { return c > 0x20 && c < 0x7F; });
}

Status Unauthenticated(const std::string& why) {
  return mdr::Unauthenticated(
      "", why +
              "; send \"authorization: Bearer <token>\" metadata with a token of "
              "mdrd's --tokens-file");
}

}  // namespace

bool ConstantTimeEquals(std::string_view a, std::string_view b) {
  // Reads b cyclically so that the loop runs a.size() times whatever b is; the length check is
  // folded into the result instead of returning early.
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  if (b.empty()) return a.empty();
  for (std::size_t i = 0; i < a.size(); ++i) {
    difference |= static_cast<unsigned char>(a[i] ^ b[i % b.size()]);
  }
  return difference == 0;
}

Result<Authenticator> Authenticator::FromText(std::string_view text) {
  std::vector<Entry> principals;
  std::set<std::string, std::less<>> names;
  std::set<std::string, std::less<>> tokens;
  std::istringstream lines{std::string(text)};
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line.front() == '#') continue;
    const std::string where = "line " + std::to_string(number) + ": ";
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) {
      return InvalidArgument(kField, where + "expected \"name:token\"");
    }
    std::string name = line.substr(0, colon);
    std::string token = line.substr(colon + 1);
    if (!IsValidName(name)) {
      return InvalidArgument(kField, where + "the name must be 1-64 characters of [A-Za-z0-9._-]");
    }
    if (!IsValidToken(token)) {
      return InvalidArgument(kField, where + "the token must be at least " +
                                         std::to_string(kMinTokenLength) +
                                         " printable ASCII characters without spaces");
    }
    if (!names.insert(name).second) {
      return InvalidArgument(kField, where + "the name \"" + name + "\" appears twice");
    }
    if (!tokens.insert(token).second) {
      return InvalidArgument(kField, where + "this token is already given to another name");
    }
    principals.push_back({std::move(name), std::move(token)});
  }
  if (principals.empty()) {
    return InvalidArgument(kField,
                           "no \"name:token\" line (an empty file would lock out everyone)");
  }
  return Authenticator(std::move(principals));
}

Result<Authenticator> Authenticator::FromFile(const std::string& path) {
  std::ifstream file(path);
  if (!file) return FailedPrecondition(kField, "cannot read \"" + path + "\"");
  std::ostringstream text;
  text << file.rdbuf();
  Result<Authenticator> authenticator = FromText(text.str());
  if (!authenticator.ok()) {
    return InvalidArgument(kField, path + ": " + authenticator.status().message());
  }
  return authenticator;
}

Status Authenticator::Authenticate(
    const std::multimap<grpc::string_ref, grpc::string_ref>& metadata, Principal* principal) const {
  const auto header = metadata.find("authorization");
  if (header == metadata.end()) return Unauthenticated("no authorization metadata");
  const std::string_view value(header->second.data(), header->second.size());
  if (!value.starts_with(kScheme))
    return Unauthenticated("the authorization is not a bearer token");
  const std::string_view presented = value.substr(kScheme.size());
  // Every entry is compared (no early exit), so the time does not tell which one matched.
  const Entry* match = nullptr;
  for (const Entry& entry : principals_) {
    if (ConstantTimeEquals(presented, entry.token)) match = &entry;
  }
  if (match == nullptr) return Unauthenticated("unknown token");
  *principal = match->name;
  return OkStatus();
}

}  // namespace mdr::service
