// What `colmap global_mapper` and `colmap automatic_reconstructor --mapper
// global` share once their options are parsed: checks of the paths a user
// gives, Ctrl-C / SIGTERM handling that leaves the output folder as it was,
// and the run of the GlobalMapperController whose models are written
// atomically to OUTPUT/0, OUTPUT/1, ...
#pragma once

#include <signal.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "glomap/controllers/global_mapper.h"

namespace colmap {

class OptionManager;
class ReconstructionManager;

// Prints "ERROR: <message>" on stderr and returns `exit_code`.
int Fail(const std::string& message, int exit_code = EXIT_FAILURE);

// Value of `--name value` in argv, or "" (used before OptionManager::Parse,
// which exits on invalid paths with a less helpful message, and which ignores
// command-line values when a project file is given).
std::string FindArgument(int argc, char** argv, const std::string& name);

// Whether argv holds `--name` or `-name`.
bool HasArgument(int argc, char** argv, const std::string& name);

// Checks the database and image folder a user gave before anything runs;
// "" if fine (an empty path is not checked).
std::string CheckInputPaths(const std::string& database_path,
                            const std::string& image_path);

// Checks before the run that the output folder can be written: the folder
// itself when it exists, else the nearest folder above it that exists (the
// output folder is created only when the models are written, so that an
// interrupted run leaves no trace). Returns "" if fine.
std::string CheckOutputPath(const std::string& output_path);

// What this run has put into the output folder, so that an interrupt can
// take it out again. `mutex` is held while a model is written and while the
// new models are swapped in, so that an interrupt never cuts either short.
struct OutputGuard {
  std::mutex mutex;
  std::filesystem::path temp_dir;  // This run's temporary folder, if made.
  std::filesystem::path created_output_dir;  // The output folder, if made.
  bool committed = false;                    // The new models are in place.

  // Removes what this run wrote (call with `mutex` held).
  void Undo();
};

// SIGINT (Ctrl-C) and SIGTERM stop the run within a second and leave the
// output folder as it was. Both signals are blocked in every thread (threads
// inherit the mask of the thread that starts them, so the watcher is made
// before any other thread) and received by one watcher thread, which asks the
// running step to stop; the pipeline checks between its steps and stops
// within milliseconds. A step that does not return within `kStopDeadline` is
// not waited for: the watcher takes out what this run wrote and ends the
// process. Writing a model and swapping the new models in are never cut
// short; a signal that arrives once the new models are in place lets the run
// finish.
class SignalWatcher {
 public:
  static constexpr std::chrono::milliseconds kStopDeadline{700};

  explicit SignalWatcher(OutputGuard* output);
  ~SignalWatcher();

  // What the watcher calls on a signal (the running thread's Stop); unset it
  // before that thread goes away.
  void SetStop(std::function<void()> stop);

  // The signal received (SIGINT or SIGTERM), or 0.
  int Signal() const { return signal_; }

 private:
  void Watch();

  OutputGuard* output_;
  sigset_t signals_;
  sigset_t old_mask_;
  std::atomic<int> signal_{0};
  std::mutex mutex_;
  std::condition_variable finished_changed_;
  bool finished_ = false;
  std::function<void()> stop_;
  std::thread thread_;
};

// "Interrupted by SIGINT; the output folder was left as it was."
std::string InterruptedMessage(int signal);

// Runs the global mapper on `database_path` (read-only) and writes its models
// to `output_path`/0, 1, ... atomically, each with `options` as its
// project.ini; prints one line per model. Returns the exit code: 0, 1 with
// one error line, or 128 + the signal when interrupted (the output folder
// then as it was).
int RunGlobalMapperAndWriteModels(
    const glomap::GlobalMapperOptions& mapper_options,
    const std::string& database_path, const std::string& output_path,
    const OptionManager& options, SignalWatcher& watcher, OutputGuard* guard);

// Writes `models` to `output_path`/0, 1, ... as RunGlobalMapperAndWriteModels
// does (atomically: on an error the folder is left as it was), without
// signal handling (the GUI's Automatic reconstruction). "" if written, else
// a one-line error.
std::string WriteModels(const ReconstructionManager& models,
                        const glomap::Georegistration& georegistration,
                        const std::string& output_path,
                        const OptionManager& options);

// Runs `command` with the terminate handler installed and a SignalWatcher
// made before any other thread, and turns an exception that escapes it into
// one error line and exit code 1.
int RunCommandWithSignalWatcher(
    const std::function<int(SignalWatcher&, OutputGuard*)>& command);

}  // namespace colmap
