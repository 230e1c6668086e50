#include "mdr/client/contact_client.h"

#include <grpcpp/client_context.h>

namespace mdr::client {
namespace {

template <typename Response>
RpcResult<Response> ToResult(const grpc::Status& status, Response* response) {
  if (!status.ok()) return status;
  return std::move(*response);
}

}  // namespace

ContactClient::ContactClient(std::shared_ptr<grpc::ChannelInterface> channel,
                             std::chrono::milliseconds timeout)
    : stub_(v1::ContactService::NewStub(std::move(channel))), timeout_(timeout) {}

std::unique_ptr<grpc::ClientContext> ContactClient::NewContext() const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + timeout_);
  return context;
}

RpcResult<v1::Session> ContactClient::CreateSession(const v1::Scene& scene,
                                                    const std::string& session_id) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = scene;
  request.set_session_id(session_id);
  v1::Session response;
  const grpc::Status status = stub_->CreateSession(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

RpcResult<v1::Session> ContactClient::GetSession(const std::string& name) {
  v1::GetSessionRequest request;
  request.set_name(name);
  v1::Session response;
  const grpc::Status status = stub_->GetSession(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

RpcResult<v1::ListSessionsResponse> ContactClient::ListSessions(int page_size,
                                                                const std::string& page_token) {
  v1::ListSessionsRequest request;
  request.set_page_size(page_size);
  request.set_page_token(page_token);
  v1::ListSessionsResponse response;
  const grpc::Status status = stub_->ListSessions(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

grpc::Status ContactClient::DeleteSession(const std::string& name) {
  v1::DeleteSessionRequest request;
  request.set_name(name);
  google::protobuf::Empty response;
  return stub_->DeleteSession(NewContext().get(), request, &response);
}

RpcResult<v1::SessionSnapshot> ContactClient::ExportSession(const std::string& name) {
  v1::ExportSessionRequest request;
  request.set_name(name);
  v1::SessionSnapshot response;
  const grpc::Status status = stub_->ExportSession(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

RpcResult<v1::Session> ContactClient::ImportSession(const v1::SessionSnapshot& snapshot,
                                                    const std::string& session_id) {
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  request.set_session_id(session_id);
  v1::Session response;
  const grpc::Status status = stub_->ImportSession(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

RpcResult<v1::ApplyResponse> ContactClient::Apply(
    const std::string& session, const google::protobuf::RepeatedPtrField<v1::Step>& steps,
    const google::protobuf::FieldMask& step_mask, const std::string& request_id) {
  v1::ApplyRequest request;
  request.set_session(session);
  *request.mutable_steps() = steps;
  *request.mutable_step_mask() = step_mask;
  request.set_request_id(request_id);
  v1::ApplyResponse response;
  const grpc::Status status = stub_->Apply(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

RpcResult<v1::QueryResponse> ContactClient::Query(const std::string& session,
                                                  const google::protobuf::FieldMask& read_mask,
                                                  const std::vector<double>& radii) {
  v1::QueryRequest request;
  request.set_session(session);
  *request.mutable_read_mask() = read_mask;
  request.mutable_radii()->Add(radii.begin(), radii.end());
  v1::QueryResponse response;
  const grpc::Status status = stub_->Query(NewContext().get(), request, &response);
  return ToResult(status, &response);
}

}  // namespace mdr::client
