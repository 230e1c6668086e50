// The value of a call, or the gRPC status (code and the server's "field: message") that explains
// why there is none. Errors are values: the client never throws.
#pragma once

#include <grpcpp/support/status.h>

#include <utility>
#include <variant>

namespace mdr::client {

template <typename T>
class RpcResult {
 public:
  RpcResult(T value) : data_(std::move(value)) {}               // NOLINT: implicit by design
  RpcResult(grpc::Status status) : data_(std::move(status)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(data_); }
  // OK when there is a value.
  const grpc::Status& status() const {
    return ok() ? grpc::Status::OK : std::get<grpc::Status>(data_);
  }
  grpc::StatusCode code() const { return status().error_code(); }
  const T& value() const& { return std::get<T>(data_); }
  T& value() & { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }

 private:
  std::variant<T, grpc::Status> data_;
};

}  // namespace mdr::client
