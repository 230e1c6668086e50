#include "mdr/service/contact_service.h"

#include <chrono>
#include <string>

#include "mdr/service/call.h"

namespace mdr::service {
namespace {

// Handlers run to completion on the calling thread (the work is CPU-bound), so each finishes its
// reactor before returning it, after one structured log line.
class UnaryCall {
 public:
  UnaryCall(grpc::CallbackServerContext* context, const char* method, std::string session,
            const std::string& request_id = "")
      : context_(context),
        method_(method),
        session_(std::move(session)),
        request_id_(RequestIdOf(context, request_id)) {}

  // Authenticates the caller and, if that succeeds, finishes with operation(caller).
  template <typename Operation>
  grpc::ServerUnaryReactor* Run(const Authenticator* authenticator, Operation operation) const {
    Principal caller;
    grpc::Status status = CallerOf(context_, authenticator, &caller);
    return Finish(status.ok() ? operation(caller) : status);
  }

 private:
  grpc::ServerUnaryReactor* Finish(const grpc::Status& status) const {
    LogCall(method_, session_, request_id_, status,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
    grpc::ServerUnaryReactor* reactor = context_->DefaultReactor();
    reactor->Finish(status);
    return reactor;
  }

  grpc::CallbackServerContext* const context_;
  const char* const method_;
  const std::string session_;
  const std::string request_id_;
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace

grpc::ServerUnaryReactor* ContactServiceImpl::CreateSession(grpc::CallbackServerContext* context,
                                                            const v1::CreateSessionRequest* request,
                                                            v1::Session* response) {
  const UnaryCall call(context, "CreateSession", request->session_id());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.CreateSession(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::GetSession(grpc::CallbackServerContext* context,
                                                         const v1::GetSessionRequest* request,
                                                         v1::Session* response) {
  const UnaryCall call(context, "GetSession", request->name());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.GetSession(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ListSessions(grpc::CallbackServerContext* context,
                                                           const v1::ListSessionsRequest* request,
                                                           v1::ListSessionsResponse* response) {
  const UnaryCall call(context, "ListSessions", "");
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.ListSessions(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::DeleteSession(grpc::CallbackServerContext* context,
                                                            const v1::DeleteSessionRequest* request,
                                                            google::protobuf::Empty* /*response*/) {
  const UnaryCall call(context, "DeleteSession", request->name());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.DeleteSession(caller, *request);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ExportSession(grpc::CallbackServerContext* context,
                                                            const v1::ExportSessionRequest* request,
                                                            v1::SessionSnapshot* response) {
  const UnaryCall call(context, "ExportSession", request->name());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.ExportSession(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::ImportSession(grpc::CallbackServerContext* context,
                                                            const v1::ImportSessionRequest* request,
                                                            v1::Session* response) {
  const UnaryCall call(context, "ImportSession", request->session_id());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.ImportSession(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::Apply(grpc::CallbackServerContext* context,
                                                    const v1::ApplyRequest* request,
                                                    v1::ApplyResponse* response) {
  const UnaryCall call(context, "Apply", request->session(), request->request_id());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.Apply(caller, *request, InterruptionOf(context), response);
  });
}

grpc::ServerBidiReactor<v1::StreamApplyRequest, v1::StreamApplyResponse>*
ContactServiceImpl::StreamApply(grpc::CallbackServerContext* context) {
  return new StreamApplyReactor(context, operations_, authenticator_, streams_);
}

grpc::ServerUnaryReactor* ContactServiceImpl::Query(grpc::CallbackServerContext* context,
                                                    const v1::QueryRequest* request,
                                                    v1::QueryResponse* response) {
  const UnaryCall call(context, "Query", request->session());
  return call.Run(authenticator_, [&](const Principal& caller) {
    return operations_.Query(caller, *request, response);
  });
}

grpc::ServerUnaryReactor* ContactServiceImpl::Transform(grpc::CallbackServerContext* context,
                                                        const v1::TransformRequest* request,
                                                        v1::TransformResponse* response) {
  const UnaryCall call(context, "Transform", "");
  return call.Run(authenticator_,
                  [&](const Principal&) { return operations_.Transform(*request, response); });
}

}  // namespace mdr::service
