// gRPC 1.51's callback server answers a unary request whose bytes do not parse as its message
// type with UNIMPLEMENTED and no message, before any handler runs (server_callback_handlers.h:
// a failed Deserialize leaves no reactor, and an UnimplementedUnaryReactor finishes the call).
// This server interceptor sees that the received message is missing and turns exactly that
// status into INVALID_ARGUMENT naming the method, so the client learns what is wrong.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include <memory>

namespace mdr::service {

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
UnparseableRequestInterceptorFactory();

}  // namespace mdr::service
