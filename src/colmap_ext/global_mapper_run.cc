// See global_mapper_run.h.
#include "colmap_ext/global_mapper_run.h"

#include <pthread.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <system_error>
#include <utility>
#include <vector>

#include "base/reconstruction_manager.h"
#include "colmap_ext/terminate_handler.h"
#include "glomap/controllers/global_mapper_controller.h"
#include "glomap/util/status.h"
#include "util/option_manager.h"

namespace colmap {
namespace {

namespace fs = std::filesystem;

// Size in bytes of COLMAP 3.8's binary model files for `model`, field by
// field as Reconstruction::Write*Binary writes them.
struct BinaryModelSizes {
  uintmax_t cameras = 8;
  uintmax_t images = 8;
  uintmax_t points3D = 8;
};

BinaryModelSizes ExpectedBinarySizes(const Reconstruction& model) {
  BinaryModelSizes sizes;
  for (const auto& [camera_id, camera] : model.Cameras()) {
    sizes.cameras += 4 + 4 + 8 + 8 + 8 * camera.NumParams();
  }
  for (const image_t image_id : model.RegImageIds()) {
    const Image& image = model.Image(image_id);
    sizes.images += 4 + 4 * 8 + 3 * 8 + 4 + image.Name().size() + 1 + 8 +
                    image.NumPoints2D() * (8 + 8 + 8);
  }
  for (const auto& [point3D_id, point3D] : model.Points3D()) {
    sizes.points3D += 8 + 3 * 8 + 3 + 8 + 8 + point3D.Track().Length() * 8;
  }
  return sizes;
}

// COLMAP's writers never check their streams: on a full disk they leave
// truncated files behind and report nothing. Every file is checked against
// the size it must have; "" if all are complete.
std::string CheckWrittenModel(const Reconstruction& model,
                              const fs::path& model_dir) {
  const BinaryModelSizes expected = ExpectedBinarySizes(model);
  const std::pair<const char*, uintmax_t> files[] = {
      {"cameras.bin", expected.cameras},
      {"images.bin", expected.images},
      {"points3D.bin", expected.points3D}};
  for (const auto& [name, size] : files) {
    std::error_code error;
    const uintmax_t written = fs::file_size(model_dir / name, error);
    if (error || written != size) {
      return std::string(name) + " is incomplete (" +
             (error ? error.message()
                    : std::to_string(written) + " of " + std::to_string(size) +
                          " bytes written") +
             "): is the disk full?";
    }
  }
  std::error_code error;
  if (fs::file_size(model_dir / "project.ini", error) == 0 || error) {
    return "project.ini could not be written: is the disk full?";
  }
  return "";
}

// The file beside a model solved with position priors that says its frame
// (stock COLMAP 3.8 ignores other files in a model folder).
constexpr char kGeoregistrationFile[] = "georegistration.txt";

// Writes `text` to `path` and checks that all of it arrived; "" if so.
std::string WriteTextFile(const fs::path& path, const std::string& text) {
  {
    std::ofstream file(path, std::ios::trunc);
    file << text;
    file.close();
    if (!file) {
      return path.filename().string() +
             " could not be written: is the disk full?";
    }
  }
  std::error_code error;
  const uintmax_t written = fs::file_size(path, error);
  if (error || written != text.size()) {
    return path.filename().string() + " is incomplete: is the disk full?";
  }
  return "";
}

// The log line of a georegistered model.
std::string GeoregistrationSummary(const glomap::Georegistration& geo) {
  std::ostringstream text;
  text << "frame " << geo.frame;
  if (geo.frame == "ENU") {
    text << std::setprecision(12) << ", origin latitude " << geo.origin_lla.x()
         << " deg, longitude " << geo.origin_lla.y() << " deg, altitude "
         << geo.origin_lla.z() << " m";
  } else if (geo.frame == "metric") {
    text << " (the priors' own frame)";
  }
  text << "; " << geo.num_priors_used << " priors used, "
       << geo.rejected_prior_image_names.size() << " rejected";
  return text.str();
}

// Whether `dir` is a model folder of an earlier run: named by a number and
// holding a COLMAP model.
bool IsNumberedModelDir(const fs::path& dir) {
  const std::string name = dir.filename().string();
  std::error_code error;
  if (name.empty() ||
      name.find_first_not_of("0123456789") != std::string::npos ||
      !fs::is_directory(dir, error)) {
    return false;
  }
  for (const char* ext : {".bin", ".txt"}) {
    if (fs::exists(dir / (std::string("cameras") + ext), error) &&
        fs::exists(dir / (std::string("images") + ext), error)) {
      return true;
    }
  }
  return false;
}

// Writes each model to OUTPUT/<k> so that a good model is never replaced by a
// half-written one: everything is written to a temporary folder inside
// OUTPUT first and checked, then each model folder is swapped in with
// rename(2). Model folders OUTPUT/<k> of an earlier run with more models are
// removed, so that OUTPUT holds exactly this run's models. A georegistered
// run (position priors) writes georegistration.txt into every model folder,
// checked like the rest. On an error or an interrupt (`signal` set), OUTPUT
// is left as it was.
std::string WriteModelsAtomically(const ReconstructionManager& models,
                                  const glomap::Georegistration& geo,
                                  const std::string& output_path,
                                  const OptionManager& options,
                                  const std::function<int()>& signal,
                                  OutputGuard* guard) {
  std::error_code error;
  const fs::path temp_dir = fs::path(output_path) /
                            (".global_mapper_tmp_" + std::to_string(getpid()));
  // Renames done while swapping, so that a failure can undo them.
  std::vector<std::pair<fs::path, fs::path>> moves;
  auto move = [&moves](const fs::path& from, const fs::path& to) {
    fs::rename(from, to);
    moves.emplace_back(from, to);
  };
  std::vector<std::string> removed;
  try {
    {
      std::lock_guard<std::mutex> lock(guard->mutex);
      if (signal() != 0) return InterruptedMessage(signal());
      if (!fs::exists(output_path)) {
        fs::create_directories(output_path, error);
        if (error) {
          return "Cannot create the output folder " + output_path + ": " +
                 error.message();
        }
        guard->created_output_dir = output_path;
      }
      fs::remove_all(temp_dir, error);
      if (!fs::create_directory(temp_dir, error)) {
        guard->Undo();
        return "Cannot write into " + output_path + ": " + error.message();
      }
      guard->temp_dir = temp_dir;
    }
    for (size_t k = 0; k < models.Size(); ++k) {
      std::lock_guard<std::mutex> lock(guard->mutex);
      if (signal() != 0) {
        guard->Undo();
        return InterruptedMessage(signal());
      }
      const fs::path model_dir = temp_dir / std::to_string(k);
      fs::create_directory(model_dir);
      models.Get(k).WriteBinary(model_dir.string());
      options.Write((model_dir / "project.ini").string());
      std::string incomplete = CheckWrittenModel(models.Get(k), model_dir);
      if (incomplete.empty() && geo.georegistered) {
        incomplete =
            WriteTextFile(model_dir / kGeoregistrationFile, geo.ToText());
      }
      if (!incomplete.empty()) {
        guard->Undo();
        return "Writing model " + std::to_string(k) + " failed: " + incomplete +
               " Nothing in " + output_path + " was changed.";
      }
    }
    {
      std::lock_guard<std::mutex> lock(guard->mutex);
      if (signal() != 0) {
        guard->Undo();
        return InterruptedMessage(signal());
      }
      for (size_t k = 0; k < models.Size(); ++k) {
        const fs::path final_dir = fs::path(output_path) / std::to_string(k);
        if (fs::exists(final_dir)) {
          move(final_dir, temp_dir / ("old_" + std::to_string(k)));
        }
        move(temp_dir / std::to_string(k), final_dir);
      }
      for (const fs::directory_entry& entry :
           fs::directory_iterator(output_path)) {
        const std::string name = entry.path().filename().string();
        if (IsNumberedModelDir(entry.path()) &&
            std::stoull(name.substr(0, 18)) >= models.Size()) {
          move(entry.path(), temp_dir / ("stale_" + name));
          removed.push_back(entry.path().string());
        }
      }
      guard->committed = true;
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(guard->mutex);
    if (!guard->committed) {
      // Puts back what was swapped so far, newest first.
      for (auto it = moves.rbegin(); it != moves.rend(); ++it) {
        fs::rename(it->second, it->first, error);
      }
      guard->Undo();
    }
    return std::string("Writing the model failed: ") + e.what();
  }
  for (const std::string& path : removed) {
    std::cerr << "Removed " << path << ": a model of an earlier run."
              << std::endl;
  }
  fs::remove_all(temp_dir, error);
  return "";
}
}  // namespace

int Fail(const std::string& message, int exit_code) {
  std::cerr << "ERROR: " << message << std::endl;
  return exit_code;
}

std::string FindArgument(int argc, char** argv, const std::string& name) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == "--" + name) return argv[i + 1];
  }
  return "";
}

bool HasArgument(int argc, char** argv, const std::string& name) {
  for (int i = 1; i < argc; ++i) {
    if (argv[i] == "--" + name || argv[i] == "-" + name) return true;
  }
  return false;
}

std::string CheckInputPaths(const std::string& database_path,
                            const std::string& image_path) {
  std::error_code error;
  if (!database_path.empty()) {
    if (!fs::exists(database_path, error)) {
      return "Database " + database_path + " does not exist.";
    }
    if (!fs::is_regular_file(database_path, error)) {
      return "Database " + database_path + " is not a file.";
    }
    if (access(database_path.c_str(), R_OK) != 0) {
      return "Database " + database_path + " is not readable.";
    }
  }
  if (!image_path.empty() && !fs::is_directory(image_path, error)) {
    return "Image folder " + image_path + " does not exist.";
  }
  return "";
}

std::string CheckOutputPath(const std::string& output_path) {
  std::error_code error;
  if (output_path.empty()) return "No output path given (--output_path).";
  if (fs::exists(output_path, error)) {
    if (!fs::is_directory(output_path, error)) {
      return "Output path " + output_path + " exists and is not a folder.";
    }
    if (access(output_path.c_str(), W_OK) != 0) {
      return "Output folder " + output_path + " is not writable.";
    }
    return "";
  }
  fs::path parent = fs::absolute(output_path, error).parent_path();
  while (!parent.empty() && !fs::exists(parent, error)) {
    if (parent == parent.parent_path()) break;
    parent = parent.parent_path();
  }
  if (!fs::is_directory(parent, error)) {
    return "Cannot create the output folder " + output_path + ": " +
           parent.string() + " is not a folder.";
  }
  if (access(parent.c_str(), W_OK) != 0) {
    return "Cannot create the output folder " + output_path + ": " +
           parent.string() + " is not writable.";
  }
  return "";
}

void OutputGuard::Undo() {
  std::error_code error;
  if (!temp_dir.empty()) fs::remove_all(temp_dir, error);
  if (!created_output_dir.empty()) fs::remove(created_output_dir, error);
}

SignalWatcher::SignalWatcher(OutputGuard* output) : output_(output) {
  sigemptyset(&signals_);
  sigaddset(&signals_, SIGINT);
  sigaddset(&signals_, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals_, &old_mask_);
  thread_ = std::thread(&SignalWatcher::Watch, this);
}

SignalWatcher::~SignalWatcher() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = true;
  }
  finished_changed_.notify_all();
  thread_.join();
  pthread_sigmask(SIG_SETMASK, &old_mask_, nullptr);
}

void SignalWatcher::SetStop(std::function<void()> stop) {
  std::lock_guard<std::mutex> lock(mutex_);
  stop_ = std::move(stop);
}

void SignalWatcher::Watch() {
  const timespec poll_interval = {0, 50 * 1000 * 1000};
  std::unique_lock<std::mutex> lock(mutex_);
  while (!finished_) {
    lock.unlock();
    const int signal = sigtimedwait(&signals_, nullptr, &poll_interval);
    lock.lock();
    if (signal != SIGINT && signal != SIGTERM) continue;
    signal_ = signal;
    std::fprintf(stderr, "%s received: stopping the run.\n",
                 signal == SIGINT ? "SIGINT" : "SIGTERM");
    if (stop_) stop_();
    if (finished_changed_.wait_for(lock, kStopDeadline,
                                   [this]() { return finished_; })) {
      return;
    }
    std::lock_guard<std::mutex> output_lock(output_->mutex);
    if (output_->committed) return;
    output_->Undo();
    std::fprintf(stderr,
                 "ERROR: Interrupted by %s; the output folder was left as "
                 "it was.\n",
                 signal == SIGINT ? "SIGINT" : "SIGTERM");
    std::fflush(stderr);
    std::_Exit(128 + signal);
  }
}

std::string InterruptedMessage(int signal) {
  return std::string("Interrupted by ") +
         (signal == SIGINT ? "SIGINT" : "SIGTERM") +
         "; the output folder was left as it was.";
}

int RunGlobalMapperAndWriteModels(
    const glomap::GlobalMapperOptions& mapper_options,
    const std::string& database_path, const std::string& output_path,
    const OptionManager& options, SignalWatcher& watcher, OutputGuard* guard) {
  ReconstructionManager reconstruction_manager;
  glomap::GlobalMapperController controller(mapper_options, database_path,
                                            &reconstruction_manager);
  {
    watcher.SetStop([&controller]() { controller.Stop(); });
    // Unbinds before the controller goes, whichever way this block is left.
    const std::unique_ptr<SignalWatcher, void (*)(SignalWatcher*)> unbind(
        &watcher, [](SignalWatcher* bound) { bound->SetStop(nullptr); });
    controller.Start();
    controller.Wait();
  }
  if (watcher.Signal() != 0) {
    return Fail(InterruptedMessage(watcher.Signal()), 128 + watcher.Signal());
  }

  const glomap::Status status = controller.RunStatus();
  if (!status.ok()) return Fail(status.message());
  if (reconstruction_manager.Size() == 0) {
    return Fail("Nothing was reconstructed.");
  }
  const glomap::Georegistration& geo = controller.GetGeoregistration();
  const std::string error = WriteModelsAtomically(
      reconstruction_manager, geo, output_path, options,
      [&watcher]() { return watcher.Signal(); }, guard);
  if (!error.empty()) {
    return Fail(error, watcher.Signal() != 0 && !guard->committed
                           ? 128 + watcher.Signal()
                           : EXIT_FAILURE);
  }
  for (size_t k = 0; k < reconstruction_manager.Size(); ++k) {
    const auto& model = reconstruction_manager.Get(k);
    std::cout << "Model " << k << ": " << model.NumRegImages() << " images, "
              << model.NumPoints3D() << " points -> " << output_path << "/" << k
              << std::endl;
    if (geo.georegistered) {
      std::cout << "Model " << k
                << " is georegistered: " << GeoregistrationSummary(geo)
                << " -> " << output_path << "/" << k << "/"
                << kGeoregistrationFile << std::endl;
    }
  }
  return EXIT_SUCCESS;
}

std::string WriteModels(const ReconstructionManager& models,
                        const glomap::Georegistration& georegistration,
                        const std::string& output_path,
                        const OptionManager& options) {
  OutputGuard guard;
  return WriteModelsAtomically(
      models, georegistration, output_path, options, []() { return 0; },
      &guard);
}

int RunCommandWithSignalWatcher(
    const std::function<int(SignalWatcher&, OutputGuard*)>& command) {
  InstallTerminateHandler();
  // The pipeline thread reports its own exceptions as a status; this catches
  // those of the command itself (options, paths, writing the models).
  try {
    OutputGuard output_guard;
    SignalWatcher watcher(&output_guard);
    return command(watcher, &output_guard);
  } catch (...) {
    return Fail(glomap::StatusFromCurrentException().message());
  }
}

}  // namespace colmap
