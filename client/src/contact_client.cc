#include "mdr/client/contact_client.h"

#include <grpcpp/client_context.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <random>
#include <string_view>
#include <thread>

namespace mdr::client {
namespace {

using google::protobuf::FieldMask;
using google::protobuf::RepeatedPtrField;

}  // namespace

ContactClient::ContactClient(std::shared_ptr<grpc::ChannelInterface> channel, ClientOptions options)
    : stub_(v1::ContactService::NewStub(std::move(channel))), options_(options) {
  options_.max_attempts = std::max(options_.max_attempts, 1);
}

ContactClient::ContactClient(std::shared_ptr<grpc::ChannelInterface> channel,
                             std::chrono::milliseconds timeout)
    : ContactClient(std::move(channel), ClientOptions{.timeout = timeout}) {}

std::string NewSessionId() {
  thread_local std::mt19937_64 generator{std::random_device{}()};
  char id[18];
  std::snprintf(id, sizeof id, "c%016llx", static_cast<unsigned long long>(generator()));
  return id;
}

std::unique_ptr<grpc::ClientContext> ContactClient::NewContext(const std::string& session) const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + options_.timeout);
  if (!session.empty()) {
    const std::string_view prefix = "sessions/";
    const std::string id = session.starts_with(prefix) ? session.substr(prefix.size()) : session;
    context->AddMetadata(kSessionRoutingKey, id);
  }
  return context;
}

template <typename Request, typename Response, typename Rpc>
RpcResult<Response> ContactClient::Call(Rpc rpc, const Request& request, bool idempotent,
                                        const std::string& session) {
  const int attempts = idempotent ? options_.max_attempts : 1;
  std::chrono::milliseconds backoff = options_.initial_backoff;
  grpc::Status status;
  for (int attempt = 1;; ++attempt) {
    Response response;
    status = rpc(NewContext(session).get(), request, &response);
    if (status.ok()) return response;
    if (status.error_code() != grpc::StatusCode::UNAVAILABLE || attempt >= attempts) break;
    std::this_thread::sleep_for(backoff);
    backoff *= 2;
  }
  return status;
}

RpcResult<v1::Session> ContactClient::CreateSession(const v1::Scene& scene,
                                                    const std::string& session_id,
                                                    const v1::SessionLimits& limits) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = scene;
  *request.mutable_session()->mutable_limits() = limits;
  request.set_session_id(session_id.empty() ? NewSessionId() : session_id);
  return Call<v1::CreateSessionRequest, v1::Session>(
      [this](auto* c, const auto& r, auto* o) { return stub_->CreateSession(c, r, o); }, request,
      false, request.session_id());
}

RpcResult<v1::Session> ContactClient::GetSession(const std::string& name) {
  v1::GetSessionRequest request;
  request.set_name(name);
  return Call<v1::GetSessionRequest, v1::Session>(
      [this](auto* c, const auto& r, auto* o) { return stub_->GetSession(c, r, o); }, request, true,
      name);
}

RpcResult<v1::ListSessionsResponse> ContactClient::ListSessions(int page_size,
                                                                const std::string& page_token) {
  v1::ListSessionsRequest request;
  request.set_page_size(page_size);
  request.set_page_token(page_token);
  return Call<v1::ListSessionsRequest, v1::ListSessionsResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->ListSessions(c, r, o); }, request,
      true);
}

RpcResult<std::vector<v1::Session>> ContactClient::ListAllSessions() {
  std::vector<v1::Session> sessions;
  std::string token;
  do {
    auto page = ListSessions(0, token);
    if (!page.ok()) return page.status();
    for (const v1::Session& session : page->sessions()) sessions.push_back(session);
    token = page->next_page_token();
  } while (!token.empty());
  return sessions;
}

grpc::Status ContactClient::DeleteSession(const std::string& name) {
  v1::DeleteSessionRequest request;
  request.set_name(name);
  google::protobuf::Empty response;
  return stub_->DeleteSession(NewContext(name).get(), request, &response);
}

RpcResult<v1::SessionSnapshot> ContactClient::ExportSession(const std::string& name) {
  v1::ExportSessionRequest request;
  request.set_name(name);
  return Call<v1::ExportSessionRequest, v1::SessionSnapshot>(
      [this](auto* c, const auto& r, auto* o) { return stub_->ExportSession(c, r, o); }, request,
      true, name);
}

RpcResult<v1::Session> ContactClient::ImportSession(const v1::SessionSnapshot& snapshot,
                                                    const std::string& session_id) {
  v1::ImportSessionRequest request;
  *request.mutable_snapshot() = snapshot;
  request.set_session_id(session_id.empty() ? NewSessionId() : session_id);
  return Call<v1::ImportSessionRequest, v1::Session>(
      [this](auto* c, const auto& r, auto* o) { return stub_->ImportSession(c, r, o); }, request,
      false, request.session_id());
}

RpcResult<v1::ApplyResponse> ContactClient::Apply(const std::string& session,
                                                  const RepeatedPtrField<v1::Step>& steps,
                                                  const FieldMask& step_mask,
                                                  const std::string& request_id) {
  v1::ApplyRequest request;
  request.set_session(session);
  *request.mutable_steps() = steps;
  *request.mutable_step_mask() = step_mask;
  request.set_request_id(request_id);
  return Apply(request);
}

RpcResult<v1::ApplyResponse> ContactClient::Apply(const std::string& session, const v1::Step& step,
                                                  const FieldMask& step_mask,
                                                  const std::string& request_id) {
  RepeatedPtrField<v1::Step> steps;
  *steps.Add() = step;
  return Apply(session, steps, step_mask, request_id);
}

RpcResult<v1::ApplyResponse> ContactClient::Apply(const v1::ApplyRequest& request) {
  return Call<v1::ApplyRequest, v1::ApplyResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->Apply(c, r, o); }, request,
      !request.request_id().empty(), request.session());
}

RpcResult<std::vector<v1::StreamApplyResponse>> ContactClient::StreamApply(
    const std::vector<v1::ApplyRequest>& requests, const StreamObserver& on_response) {
  // Routed by the first message's session: through a router, one stream per session.
  auto context = NewContext(requests.empty() ? "" : requests.front().session());
  auto stream = stub_->StreamApply(context.get());
  std::jthread writer([&] {
    v1::StreamApplyRequest message;
    for (const v1::ApplyRequest& request : requests) {
      *message.mutable_apply() = request;
      if (!stream->Write(message)) return;  // the stream ended; Finish tells why
    }
    stream->WritesDone();
  });
  std::vector<v1::StreamApplyResponse> responses;
  v1::StreamApplyResponse response;
  while (stream->Read(&response)) {
    if (on_response) on_response(responses.size(), response);
    responses.push_back(response);
  }
  writer.join();
  const grpc::Status status = stream->Finish();
  if (!status.ok()) return status;
  return responses;
}

RpcResult<v1::QueryResponse> ContactClient::Query(const std::string& session,
                                                  const FieldMask& read_mask,
                                                  const std::vector<double>& radii) {
  v1::QueryRequest request;
  request.set_session(session);
  *request.mutable_read_mask() = read_mask;
  request.mutable_radii()->Add(radii.begin(), radii.end());
  return Query(request);
}

RpcResult<v1::QueryResponse> ContactClient::Query(const v1::QueryRequest& request) {
  return Call<v1::QueryRequest, v1::QueryResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->Query(c, r, o); }, request, true,
      request.session());
}

RpcResult<v1::TransformResponse> ContactClient::Transform(const v1::TransformRequest& request) {
  return Call<v1::TransformRequest, v1::TransformResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->Transform(c, r, o); }, request, true);
}

RpcResult<v1::AnalyzeLoopsResponse> ContactClient::AnalyzeLoops(
    const v1::AnalyzeLoopsRequest& request) {
  return Call<v1::AnalyzeLoopsRequest, v1::AnalyzeLoopsResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->AnalyzeLoops(c, r, o); }, request,
      true);
}

RpcResult<v1::FitResult> ContactClient::FitLoopsOnce(const v1::FitLoopsRequest& request,
                                                     const FitProgressObserver& on_progress) {
  auto context = NewContext();
  auto stream = stub_->FitLoops(context.get(), request);
  std::optional<v1::FitResult> result;
  v1::FitLoopsResponse response;
  while (stream->Read(&response)) {
    if (response.has_progress() && on_progress) on_progress(response.progress());
    if (response.has_result()) result = std::move(*response.mutable_result());
  }
  const grpc::Status status = stream->Finish();
  if (!status.ok()) return status;
  if (!result) {
    return grpc::Status(grpc::StatusCode::INTERNAL, "the FitLoops stream ended without a result");
  }
  return *std::move(result);
}

RpcResult<v1::FitResult> ContactClient::FitLoops(const v1::FitLoopsRequest& request,
                                                 const FitProgressObserver& on_progress) {
  std::chrono::milliseconds backoff = options_.initial_backoff;
  for (int attempt = 1;; ++attempt) {
    RpcResult<v1::FitResult> result = FitLoopsOnce(request, on_progress);
    if (result.ok() || result.status().error_code() != grpc::StatusCode::UNAVAILABLE ||
        attempt >= options_.max_attempts) {
      return result;
    }
    std::this_thread::sleep_for(backoff);
    backoff *= 2;
  }
}

RpcResult<v1::FrettingMapResponse> ContactClient::FrettingMap(
    const v1::FrettingMapRequest& request) {
  return Call<v1::FrettingMapRequest, v1::FrettingMapResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->FrettingMap(c, r, o); }, request,
      true);
}

RpcResult<v1::BackboneResponse> ContactClient::Backbone(const v1::BackboneRequest& request) {
  return Call<v1::BackboneRequest, v1::BackboneResponse>(
      [this](auto* c, const auto& r, auto* o) { return stub_->Backbone(c, r, o); }, request, true);
}

}  // namespace mdr::client
