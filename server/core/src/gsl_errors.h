// GSL's default error handler aborts the process. The core checks GSL's return codes and error
// estimates itself, so the handler is switched off once per process: it is a global, and
// switching it around each call would race between sessions served on different threads.
#pragma once

#include <gsl/gsl_errno.h>

namespace mdr::internal {

inline void ReturnGslErrorCodes() {
  static const bool kSwitchedOff = (gsl_set_error_handler_off(), true);
  (void)kSwitchedOff;
}

}  // namespace mdr::internal
