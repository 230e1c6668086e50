// The gRPC adapter: decodes a request, calls the session store and the core, encodes the reply.
// No physics and no validation rules of its own beyond the API's shape (names, required oneofs).
#pragma once

#include <cstddef>

#include "mdr/service/session_store.h"
#include "mdr/v1/contact_service.grpc.pb.h"

namespace mdr::service {

class ContactServiceImpl final : public v1::ContactService::CallbackService {
 public:
  explicit ContactServiceImpl(std::size_t max_sessions) : sessions_(max_sessions) {}

  grpc::ServerUnaryReactor* CreateSession(grpc::CallbackServerContext* context,
                                          const v1::CreateSessionRequest* request,
                                          v1::Session* response) override;
  grpc::ServerUnaryReactor* GetSession(grpc::CallbackServerContext* context,
                                       const v1::GetSessionRequest* request,
                                       v1::Session* response) override;
  grpc::ServerUnaryReactor* DeleteSession(grpc::CallbackServerContext* context,
                                          const v1::DeleteSessionRequest* request,
                                          google::protobuf::Empty* response) override;
  grpc::ServerUnaryReactor* Apply(grpc::CallbackServerContext* context,
                                  const v1::ApplyRequest* request,
                                  v1::ApplyResponse* response) override;
  grpc::ServerUnaryReactor* Query(grpc::CallbackServerContext* context,
                                  const v1::QueryRequest* request,
                                  v1::QueryResponse* response) override;

 private:
  SessionStore sessions_;
};

}  // namespace mdr::service
