// A typed client for mdr.v1.ContactService: one method per RPC, a deadline on every call, and
// errors returned as values (the gRPC code and the server's "field: message").
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/support/status.h>

#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "mdr/v1/contact_service.grpc.pb.h"

namespace mdr::client {

// The response of a call, or the status that explains why there is none.
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
  const T& value() const& { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  const T* operator->() const { return &value(); }
  const T& operator*() const& { return value(); }

 private:
  std::variant<T, grpc::Status> data_;
};

class ContactClient {
 public:
  explicit ContactClient(std::shared_ptr<grpc::ChannelInterface> channel,
                         std::chrono::milliseconds timeout = std::chrono::seconds(30));

  // Empty session_id: the server picks one.
  RpcResult<v1::Session> CreateSession(const v1::Scene& scene, const std::string& session_id = "");
  RpcResult<v1::Session> GetSession(const std::string& name);
  // One page of sessions in name order; pass the previous page's next_page_token.
  RpcResult<v1::ListSessionsResponse> ListSessions(int page_size = 0,
                                                   const std::string& page_token = "");
  grpc::Status DeleteSession(const std::string& name);
  RpcResult<v1::SessionSnapshot> ExportSession(const std::string& name);
  RpcResult<v1::Session> ImportSession(const v1::SessionSnapshot& snapshot,
                                       const std::string& session_id = "");
  // Applies the steps as one atomic batch; step_mask selects the per-step results (empty: none).
  // A non-empty request_id makes a retry of the same batch safe.
  RpcResult<v1::ApplyResponse> Apply(const std::string& session,
                                     const google::protobuf::RepeatedPtrField<v1::Step>& steps,
                                     const google::protobuf::FieldMask& step_mask = {},
                                     const std::string& request_id = "");
  // The outputs selected by read_mask (empty: the state); radii for "springs".
  RpcResult<v1::QueryResponse> Query(const std::string& session,
                                     const google::protobuf::FieldMask& read_mask = {},
                                     const std::vector<double>& radii = {});

 private:
  // A context whose deadline is now + timeout_ (deadlines are system_clock time points).
  std::unique_ptr<grpc::ClientContext> NewContext() const;

  std::unique_ptr<v1::ContactService::Stub> stub_;
  std::chrono::milliseconds timeout_;
};

}  // namespace mdr::client
