#include "colmap_ext/terminate_handler.h"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "glomap/util/status.h"

namespace colmap {

void ReportTerminationAndExit() {
  // Nothing may leave a terminate handler (the runtime would abort), and
  // building the message needs memory that may be gone.
  try {
    std::string message =
        "Internal error: the run was terminated (please report it).";
    // Only an uncaught exception can be rethrown here; without one, `throw;`
    // would call std::terminate again.
    if (std::current_exception()) {
      message = glomap::StatusFromCurrentException().message();
    }
    std::fprintf(stderr, "ERROR: %s\n", message.c_str());
  } catch (...) {
    std::fprintf(stderr, "ERROR: %s\n", glomap::kOutOfMemoryMessage);
  }
  std::fflush(stderr);
  std::_Exit(EXIT_FAILURE);
}

void InstallTerminateHandler() {
  std::set_terminate(&ReportTerminationAndExit);
}

}  // namespace colmap
