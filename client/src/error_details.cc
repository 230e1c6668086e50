#include "mdr/client/error_details.h"

#include <grpcpp/support/error_details.h>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace mdr::client {

ErrorDetails ReadErrorDetails(const grpc::Status& status) {
  ErrorDetails details{"", status.error_message()};
  google::rpc::Status rich;
  if (status.ok() || !grpc::ExtractErrorDetails(status, &rich).ok()) return details;
  for (const google::protobuf::Any& any : rich.details()) {
    google::rpc::BadRequest bad_request;
    google::rpc::ErrorInfo info;
    if (any.UnpackTo(&bad_request) && bad_request.field_violations_size() > 0) {
      details.field = bad_request.field_violations(0).field();
      details.description = bad_request.field_violations(0).description();
      return details;
    }
    if (any.UnpackTo(&info) && info.metadata().contains("field")) {
      details.field = info.metadata().at("field");
    }
  }
  const std::string prefix = details.field + ": ";
  if (!details.field.empty() && details.description.starts_with(prefix)) {
    details.description.erase(0, prefix.size());
  }
  return details;
}

}  // namespace mdr::client
