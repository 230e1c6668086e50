#include "boundary.h"

#include <string>

namespace mdr::capi {

// Per thread, so that callers on several threads (one handle each) read their own error. The
// strings are written only by failing calls: a successful step touches none of this.
struct LastError {
  int code = MDR_OK;
  std::string message;
  std::string field;
};

namespace {

int ToCode(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return MDR_OK;
    case StatusCode::kInvalidArgument:
      return MDR_INVALID_ARGUMENT;
    case StatusCode::kFailedPrecondition:
      return MDR_FAILED_PRECONDITION;
    case StatusCode::kResourceExhausted:
      return MDR_RESOURCE_EXHAUSTED;
    case StatusCode::kNotFound:
      return MDR_NOT_FOUND;
    case StatusCode::kDeadlineExceeded:
      return MDR_DEADLINE_EXCEEDED;
    case StatusCode::kCancelled:
      return MDR_CANCELLED;
    case StatusCode::kDataLoss:
      return MDR_DATA_LOSS;
    case StatusCode::kAlreadyExists:
    case StatusCode::kUnauthenticated:
    case StatusCode::kPermissionDenied:
    case StatusCode::kUnavailable:
    case StatusCode::kInternal:
      break;
  }
  return MDR_INTERNAL;
}

}  // namespace

LastError& ThreadError() {
  thread_local LastError error;
  return error;
}

int SetError(const CallStatus& call) {
  LastError& error = ThreadError();
  error.code = call.code != MDR_OK ? call.code : ToCode(call.status.code());
  error.message = call.status.ToString();
  error.field = call.status.field();
  return error.code;
}

Status RequireNonNull(const void* pointer, const char* argument) {
  if (pointer != nullptr) return OkStatus();
  return InvalidArgument(argument, "must not be NULL");
}

CallStatus RequireCapacity(std::size_t capacity, std::size_t needed, const char* argument) {
  if (capacity >= needed) return OkStatus();
  return CallStatus(
      MDR_OUT_OF_RANGE,
      InvalidArgument(argument, "must be at least " + std::to_string(needed) +
                                    " (the values to write), got " + std::to_string(capacity)));
}

}  // namespace mdr::capi

extern "C" {

int mdr_last_error_code(void) { return mdr::capi::ThreadError().code; }
const char* mdr_last_error_message(void) { return mdr::capi::ThreadError().message.c_str(); }
const char* mdr_last_error_field(void) { return mdr::capi::ThreadError().field.c_str(); }

}  // extern "C"
