// The value of a call, or the gRPC status (code and the server's "field: message") that explains
// why there is none: the core's Result with the gRPC status as its error. Errors are values: the
// client never throws.
#pragma once

#include <grpcpp/support/status.h>

#include "mdr/base/status.h"

namespace mdr::client {

template <typename T>
using RpcResult = Result<T, grpc::Status>;

}  // namespace mdr::client
