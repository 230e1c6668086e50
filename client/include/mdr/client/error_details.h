// The structured parts of a server error, read from its binary error details (google.rpc.Status
// with ErrorInfo and BadRequest, contract in proto/google/rpc/error_details.proto) rather than
// parsed from the message text.
#pragma once

#include <grpcpp/support/status.h>

#include <string>

namespace mdr::client {

struct ErrorDetails {
  // Dotted path of the offending request field ("steps[3].normal_force"); empty if none.
  std::string field;
  // The explanation without the "field: " prefix.
  std::string description;
};

ErrorDetails ReadErrorDetails(const grpc::Status& status);

}  // namespace mdr::client
