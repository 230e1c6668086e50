// Error values of the physics core. No exceptions cross the core's API: every fallible call
// returns a Status (or a Result<T>) that names the offending field and the allowed range.
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace mdr {

enum class StatusCode {
  kOk,
  kInvalidArgument,     // a field is out of its allowed range (NaN, inf, negative modulus ...)
  kFailedPrecondition,  // valid input that the current state cannot reach (|F_x| > mu F_N ...)
  kResourceExhausted,   // a configured limit was hit (memory pieces, grid size ...)
  kNotFound,
  kDeadlineExceeded,  // the caller's deadline passed while the work ran (Interrupt)
  kCancelled,         // the caller (or a server shutdown) cancelled the work (Interrupt)
  // Codes of the service layers (sessions, journal, auth); the core itself does not return them.
  kAlreadyExists,     // a session of that name exists
  kUnauthenticated,   // no valid credentials
  kPermissionDenied,  // credentials valid, but not for that resource
  kUnavailable,       // transient: shutting down, journal write failed; retrying may succeed
  kDataLoss,          // stored state is damaged
  kInternal,          // an invariant of the server broke
};

class Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string field, std::string message)
      : code_(code), field_(std::move(field)), message_(std::move(message)) {}

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  // Dotted path of the offending input, e.g. "material.poisson_ratio"; empty if none.
  const std::string& field() const { return field_; }
  const std::string& message() const { return message_; }
  // "field: message", the form shown to users.
  std::string ToString() const { return field_.empty() ? message_ : field_ + ": " + message_; }
  // Returns a copy whose field is prefixed, e.g. WithFieldPrefix("steps[3]") for an error in a
  // batch.
  Status WithFieldPrefix(const std::string& prefix) const {
    Status s = *this;
    s.field_ = field_.empty() ? prefix : prefix + "." + field_;
    return s;
  }

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string field_;
  std::string message_;
};

inline Status OkStatus() { return {}; }
inline Status InvalidArgument(std::string field, std::string message) {
  return {StatusCode::kInvalidArgument, std::move(field), std::move(message)};
}
inline Status FailedPrecondition(std::string field, std::string message) {
  return {StatusCode::kFailedPrecondition, std::move(field), std::move(message)};
}
inline Status ResourceExhausted(std::string field, std::string message) {
  return {StatusCode::kResourceExhausted, std::move(field), std::move(message)};
}

inline Status DeadlineExceeded(std::string field, std::string message) {
  return {StatusCode::kDeadlineExceeded, std::move(field), std::move(message)};
}
inline Status Cancelled(std::string field, std::string message) {
  return {StatusCode::kCancelled, std::move(field), std::move(message)};
}
inline Status NotFound(std::string field, std::string message) {
  return {StatusCode::kNotFound, std::move(field), std::move(message)};
}
inline Status AlreadyExists(std::string field, std::string message) {
  return {StatusCode::kAlreadyExists, std::move(field), std::move(message)};
}
inline Status Unauthenticated(std::string field, std::string message) {
  return {StatusCode::kUnauthenticated, std::move(field), std::move(message)};
}
inline Status PermissionDenied(std::string field, std::string message) {
  return {StatusCode::kPermissionDenied, std::move(field), std::move(message)};
}
inline Status Unavailable(std::string field, std::string message) {
  return {StatusCode::kUnavailable, std::move(field), std::move(message)};
}
inline Status DataLoss(std::string field, std::string message) {
  return {StatusCode::kDataLoss, std::move(field), std::move(message)};
}
inline Status Internal(std::string field, std::string message) {
  return {StatusCode::kInternal, std::move(field), std::move(message)};
}

// A value or the error that explains why there is none. The error is a Status everywhere but in
// the client library, whose calls return the gRPC status as received (E = grpc::Status, named
// RpcResult in mdr/client/rpc_result.h); a default-constructed E must mean OK.
template <typename T, typename E = Status>
class Result {
 public:
  Result(T value) : data_(std::move(value)) {}    // NOLINT: implicit by design
  Result(E status) : data_(std::move(status)) {}  // NOLINT: implicit by design
  bool ok() const { return std::holds_alternative<T>(data_); }
  const E& status() const {
    static const E kOk;
    return ok() ? kOk : std::get<E>(data_);
  }
  const T& value() const& { return std::get<T>(data_); }
  T& value() & { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }

 private:
  std::variant<T, E> data_;
};

}  // namespace mdr
