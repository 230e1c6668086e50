#include "mdr/service/contact_service.h"

#include <google/protobuf/util/field_mask_util.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <string>
#include <vector>

#include "mdr/service/conversion.h"
#include "mdr/service/status.h"

namespace mdr::service {
namespace {

using google::protobuf::util::FieldMaskUtil;

// Handlers run to completion on the calling thread (the work is short and CPU-bound), so each
// finishes its reactor before returning it.
grpc::ServerUnaryReactor* Finish(grpc::CallbackServerContext* context, const char* method,
                                 const grpc::Status& status) {
  if (!status.ok()) {
    spdlog::debug("{} failed with code {}: {}", method, static_cast<int>(status.error_code()),
                  status.error_message());
  }
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(status);
  return reactor;
}

grpc::Status CheckReadMask(const google::protobuf::FieldMask& mask) {
  for (int i = 0; i < mask.paths_size(); ++i) {
    std::vector<const google::protobuf::FieldDescriptor*> fields;
    if (!FieldMaskUtil::GetFieldDescriptors(v1::QueryResponse::descriptor(), mask.paths(i),
                                            &fields)) {
      return GrpcError(grpc::StatusCode::INVALID_ARGUMENT,
                       "read_mask.paths[" + std::to_string(i) + "]",
                       "\"" + mask.paths(i) +
                           "\" is not a field of QueryResponse (e.g. \"state\", "
                           "\"state.normal_force\")");
    }
  }
  return grpc::Status::OK;
}

}  // namespace

grpc::ServerUnaryReactor* ContactServiceImpl::CreateSession(grpc::CallbackServerContext* context,
                                                            const v1::CreateSessionRequest* request,
                                                            v1::Session* response) {
  Result<ContactConfig> config = ToContactConfig(request->session().scene());
  if (!config.ok())
    return Finish(context, "CreateSession",
                  ToGrpcStatus(config.status().WithFieldPrefix("session")));
  Result<Contact> contact = Contact::Create(std::move(config).value());
  if (!contact.ok()) {
    return Finish(context, "CreateSession",
                  ToGrpcStatus(contact.status().WithFieldPrefix("session")));
  }
  std::shared_ptr<Session> session;
  grpc::Status status = sessions_.Create(request->session_id(), request->session().scene(),
                                         std::move(contact).value(), &session);
  if (!status.ok()) return Finish(context, "CreateSession", status);
  session->ReadResource(response);
  spdlog::info("created {} ({} sessions)", session->name(), sessions_.size());
  return Finish(context, "CreateSession", grpc::Status::OK);
}

grpc::ServerUnaryReactor* ContactServiceImpl::GetSession(grpc::CallbackServerContext* context,
                                                         const v1::GetSessionRequest* request,
                                                         v1::Session* response) {
  std::shared_ptr<Session> session;
  grpc::Status status = sessions_.Find("name", request->name(), &session);
  if (status.ok()) session->ReadResource(response);
  return Finish(context, "GetSession", status);
}

grpc::ServerUnaryReactor* ContactServiceImpl::DeleteSession(grpc::CallbackServerContext* context,
                                                            const v1::DeleteSessionRequest* request,
                                                            google::protobuf::Empty* /*response*/) {
  grpc::Status status = sessions_.Erase("name", request->name());
  if (status.ok()) spdlog::info("deleted {} ({} sessions)", request->name(), sessions_.size());
  return Finish(context, "DeleteSession", status);
}

grpc::ServerUnaryReactor* ContactServiceImpl::Apply(grpc::CallbackServerContext* context,
                                                    const v1::ApplyRequest* request,
                                                    v1::ApplyResponse* response) {
  if (!request->request_id().empty()) {
    return Finish(context, "Apply",
                  GrpcError(grpc::StatusCode::UNIMPLEMENTED, "request_id",
                            "idempotent retries are not implemented yet; leave it empty"));
  }
  if (request->steps().empty()) {
    return Finish(
        context, "Apply",
        GrpcError(grpc::StatusCode::INVALID_ARGUMENT, "steps", "must contain at least one step"));
  }
  std::shared_ptr<Session> session;
  grpc::Status status = sessions_.Find("session", request->session(), &session);
  if (!status.ok()) return Finish(context, "Apply", status);
  return Finish(
      context, "Apply",
      ToGrpcStatus(session->Apply(request->steps(), request->include_step_results(), response)));
}

grpc::ServerUnaryReactor* ContactServiceImpl::Query(grpc::CallbackServerContext* context,
                                                    const v1::QueryRequest* request,
                                                    v1::QueryResponse* response) {
  if (grpc::Status status = CheckReadMask(request->read_mask()); !status.ok()) {
    return Finish(context, "Query", status);
  }
  std::shared_ptr<Session> session;
  grpc::Status status = sessions_.Find("session", request->session(), &session);
  if (!status.ok()) return Finish(context, "Query", status);
  session->ReadState(response->mutable_state());
  if (request->read_mask().paths_size() > 0) {
    FieldMaskUtil::TrimMessage(request->read_mask(), response);
  }
  return Finish(context, "Query", grpc::Status::OK);
}

}  // namespace mdr::service
