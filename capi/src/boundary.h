// The boundary between the C callers and the C++ engine: the thread's last error, and the
// wrapper that turns every Status and every exception into an mdr_status code.
#pragma once

#include <cstddef>
#include <exception>
#include <new>
#include <string>
#include <utility>

#include "mdr/base/status.h"
#include "mdr/mdr.h"

namespace mdr::capi {

// What a C function's body returns: a Status, or a Status reported with a code of its own (the
// C interface's MDR_OUT_OF_RANGE, which the engine's codes do not have).
struct CallStatus {
  CallStatus(Status s) : status(std::move(s)) {}  // NOLINT: implicit by design
  CallStatus(int c, Status s) : status(std::move(s)), code(c) {}
  bool ok() const { return status.ok(); }
  Status status;
  int code = MDR_OK;  // MDR_OK: the code of status
};

// Records `call` as the calling thread's last error; returns its mdr_status code.
int SetError(const CallStatus& call);

// InvalidArgument naming `argument` when `pointer` is null.
Status RequireNonNull(const void* pointer, const char* argument);

// OUT_OF_RANGE naming the capacity argument when `needed` elements do not fit in `capacity`.
CallStatus RequireCapacity(std::size_t capacity, std::size_t needed, const char* argument);

// Runs body (returning a Status) so that nothing escapes to C: a failed Status becomes the last
// error, an exception MDR_RESOURCE_EXHAUSTED (out of memory) or MDR_INTERNAL.
template <typename Body>
int Boundary(const char* function, Body&& body) noexcept {
  try {
    const CallStatus call = body();
    return call.ok() ? MDR_OK : SetError(call);
  } catch (const std::bad_alloc&) {
    return SetError(ResourceExhausted("", std::string(function) + ": out of memory"));
  } catch (const std::exception& e) {
    return SetError(Internal("", std::string(function) + ": " + e.what()));
  } catch (...) {
    return SetError(Internal("", std::string(function) + ": unknown exception"));
  }
}

}  // namespace mdr::capi
