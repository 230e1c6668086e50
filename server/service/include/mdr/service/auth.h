// Bearer-token authentication: a tokens file names the principals ("name:token" per line) and
// every ContactService call must carry "authorization: Bearer <token>" metadata of one of them.
// The principal owns the sessions it creates (Session::VisibleTo). Health checking and
// reflection are not authenticated.
#pragma once

#include <grpcpp/support/string_ref.h>

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/service/principal.h"

namespace mdr::service {

class Authenticator {
 public:
  // Shortest token accepted (bytes): guessing must be hopeless.
  static constexpr std::size_t kMinTokenLength = 16;

  // Parses the tokens file's text: one "name:token" per line, blank lines and lines starting
  // with '#' ignored. Names are 1-64 characters of [A-Za-z0-9._-]; tokens are at least
  // kMinTokenLength printable ASCII characters without spaces; both unique. Errors
  // (INVALID_ARGUMENT, field "tokens-file") name the line, never a token.
  static Result<Authenticator> FromText(std::string_view text);
  // Reads and parses the file (FAILED_PRECONDITION if it cannot be read).
  static Result<Authenticator> FromFile(const std::string& path);

  // The principal of a call's metadata: OK with *principal set for a known bearer token,
  // UNAUTHENTICATED for a missing, malformed or unknown one. Every token is compared in constant
  // time, so the time taken tells nothing about any token.
  Status Authenticate(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata,
                      Principal* principal) const;

  std::size_t size() const { return principals_.size(); }

 private:
  struct Entry {
    std::string name;
    std::string token;
  };
  explicit Authenticator(std::vector<Entry> principals) : principals_(std::move(principals)) {}

  std::vector<Entry> principals_;
};

// Whether a and b are equal, in time that depends only on a's length (the presented token's),
// not on where they differ nor on b.
bool ConstantTimeEquals(std::string_view a, std::string_view b);

}  // namespace mdr::service
