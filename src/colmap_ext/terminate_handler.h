// Last resort for an exception that leaves a thread we do not own (a Ceres
// worker, an OpenMP region; our own threads catch everything): one error line
// on stderr and exit code 1, as for any other error, instead of "terminate
// called" and SIGABRT. Installed by the global_mapper command and by the
// GUI's global reconstruction.
#pragma once

namespace colmap {

[[noreturn]] void ReportTerminationAndExit();

// std::set_terminate(&ReportTerminationAndExit).
void InstallTerminateHandler();

}  // namespace colmap
