// `colmap automatic_reconstructor` with a choice of mapper. `--mapper
// incremental` (the default) is COLMAP 3.8's command, unchanged. `--mapper
// global` runs COLMAP 3.8's feature extraction and matching, unchanged, into
// WORKSPACE/database.db, then the global mapper on it, and writes
// WORKSPACE/sparse/0, 1, ... atomically (a failed or interrupted run leaves
// the models of an earlier run as they were). It takes every option of the
// stock command, every `--GlobalMapper.*` option of `colmap global_mapper`,
// the extraction and matching sections (`--SiftExtraction.*`,
// `--SiftMatching.*`, ...) and `--project_path` (a COLMAP project file whose
// sections are the starting values; the command line overrides them).
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

#include "colmap_ext/commands.h"
#include "colmap_ext/extraction_and_matching.h"
#include "colmap_ext/global_mapper_options.h"
#include "colmap_ext/global_mapper_run.h"
#include "exe/gui.h"
#include "exe/sfm.h"
#include "feature/extraction.h"
#include "feature/matching.h"
#include "util/misc.h"
#include "util/opengl_utils.h"
#include "util/option_manager.h"
#include "util/threading.h"

#ifdef GUI_ENABLED
#include <QApplication>
#endif

namespace colmap {
namespace {

namespace fs = std::filesystem;

// The stock command's own options (COLMAP 3.8's RunAutomaticReconstructor),
// as the global path reads them.
struct AutomaticOptions {
  std::string workspace_path;
  std::string mask_path;
  std::string vocab_tree_path;
  std::string data_type = "individual";
  std::string quality = "high";
  std::string camera_model = "SIMPLE_RADIAL";
  bool single_camera = false;
  bool sparse = true;
#ifdef CUDA_ENABLED
  bool dense = true;
#else
  bool dense = false;
#endif
  std::string mesher = "poisson";
  int num_threads = -1;
  bool use_gpu = true;
  std::string gpu_index = "-1";
  std::string mapper = "incremental";
};

// argv without `--name value`, for the stock command, which does not know
// `--mapper`. The strings stay owned by the caller's argv.
std::vector<char*> WithoutArgument(int argc, char** argv,
                                   const std::string& name) {
  std::vector<char*> kept;
  for (int i = 0; i < argc; ++i) {
    if (argv[i] == "--" + name && i + 1 < argc) {
      ++i;
      continue;
    }
    kept.push_back(argv[i]);
  }
  kept.push_back(nullptr);
  return kept;
}

// Copies the sections a project file sets for extraction and matching into
// `options` (before its options are registered, so that they become the
// defaults that the command line overrides).
void CopyProjectSections(const OptionManager& project, OptionManager* options) {
  *options->image_path = *project.image_path;
  *options->image_reader = *project.image_reader;
  *options->sift_extraction = *project.sift_extraction;
  *options->sift_matching = *project.sift_matching;
  *options->exhaustive_matching = *project.exhaustive_matching;
  *options->sequential_matching = *project.sequential_matching;
  *options->vocab_tree_matching = *project.vocab_tree_matching;
}

// Extraction and matching, then the global mapper, in one thread (SiftGPU
// needs that thread to own an OpenGL context). Stop() reaches the step that
// runs.
class GlobalAutomaticReconstruction : public Thread {
 public:
  GlobalAutomaticReconstruction(const AutomaticOptions& automatic,
                                const OptionManager& options,
                                const glomap::GlobalMapperOptions& mapper,
                                SignalWatcher* watcher, OutputGuard* guard)
      : automatic_(automatic),
        options_(options),
        mapper_options_(mapper),
        watcher_(watcher),
        guard_(guard),
        extraction_and_matching_(options, automatic.data_type,
                                 automatic.vocab_tree_path) {}

  void Stop() override {
    extraction_and_matching_.Stop();
    Thread::Stop();
  }

  int ExitCode() const { return exit_code_; }

 private:
  void Run() override {
    extraction_and_matching_.Start();
    extraction_and_matching_.Wait();
    if (IsStopped()) return;
    if (!extraction_and_matching_.Error().empty()) {
      Fail(extraction_and_matching_.Error());
      return;
    }
    exit_code_ = EXIT_SUCCESS;
    if (automatic_.sparse) {
      exit_code_ = RunGlobalMapperAndWriteModels(
          mapper_options_, *options_.database_path,
          JoinPaths(automatic_.workspace_path, "sparse"), options_, *watcher_,
          guard_);
      if (exit_code_ != EXIT_SUCCESS) return;
    }
    if (automatic_.dense) {
      // Stock 3.8 undistorts the images and then stops at patch-match stereo
      // without CUDA; the sparse models stay either way.
      std::cout << "WARNING: Skipping dense reconstruction: patch-match "
                   "stereo needs CUDA, which this COLMAP was built without; "
                   "the sparse models stay in "
                << JoinPaths(automatic_.workspace_path, "sparse") << "."
                << std::endl;
    }
  }

  const AutomaticOptions automatic_;
  const OptionManager& options_;
  const glomap::GlobalMapperOptions mapper_options_;
  SignalWatcher* watcher_;
  OutputGuard* guard_;
  ExtractionAndMatching extraction_and_matching_;
  int exit_code_ = EXIT_FAILURE;
};

// Presets first (data type and quality from the command line or their
// defaults), then the sections of the project file (--project_path) into
// `options`; the command line overrides both later. Returns an error, or "".
std::string ReadPresetsAndProject(int argc, char** argv,
                                  const AutomaticOptions& automatic,
                                  const std::string& project_path,
                                  OptionManager* options) {
  {
    std::string data_type = FindArgument(argc, argv, "data_type");
    std::string quality = FindArgument(argc, argv, "quality");
    const std::string error = ApplyGlobalPresets(
        data_type.empty() ? automatic.data_type : data_type,
        quality.empty() ? automatic.quality : quality, options);
    if (!error.empty()) return error;
  }
  if (!project_path.empty()) {
    OptionManager project;
    project.AddAllOptions();
    if (!ExistsFile(project_path)) {
      return "Project file " + project_path + " does not exist.";
    }
    if (!project.Read(project_path)) {
      return "Project file " + project_path + " could not be read.";
    }
    CopyProjectSections(project, options);
  }
  return "";
}

// The stock command's own options (workspace, data type, quality, camera,
// sparse / dense, mesher, threads, GPU, and `mapper`), bound to `automatic`.
void AddAutomaticOptions(AutomaticOptions* automatic_out,
                         OptionManager* options_out) {
  AutomaticOptions& automatic = *automatic_out;
  OptionManager& options = *options_out;
  options.AddRequiredOption("workspace_path", &automatic.workspace_path);
  options.AddDefaultOption("mask_path", &automatic.mask_path);
  options.AddDefaultOption("vocab_tree_path", &automatic.vocab_tree_path);
  options.AddDefaultOption("data_type", &automatic.data_type,
                           "{individual, video, internet}");
  options.AddDefaultOption("quality", &automatic.quality,
                           "{low, medium, high, extreme}");
  automatic.camera_model = options.image_reader->camera_model;
  automatic.single_camera = options.image_reader->single_camera;
  options.AddDefaultOption("camera_model", &automatic.camera_model);
  options.AddDefaultOption("single_camera", &automatic.single_camera);
  options.AddDefaultOption("sparse", &automatic.sparse);
  options.AddDefaultOption("dense", &automatic.dense);
  options.AddDefaultOption("mesher", &automatic.mesher, "{poisson, delaunay}");
  options.AddDefaultOption("num_threads", &automatic.num_threads);
  options.AddDefaultOption("use_gpu", &automatic.use_gpu);
  options.AddDefaultOption("gpu_index", &automatic.gpu_index);
  options.AddDefaultOption("mapper", &automatic.mapper,
                           "{incremental, global}");
}

// The stock command's own options set the sections as its controller does
// (for a project, only when given on the command line): camera model and
// single camera, paths, threads, GPU (the CPU without a display). Returns
// an error, or "".
std::string ApplyAutomaticOptions(int argc, char** argv,
                                  const AutomaticOptions& automatic,
                                  const std::string& project_path,
                                  OptionManager* options_out,
                                  glomap::GlobalMapperOptions* mapper_out) {
  OptionManager& options = *options_out;
  glomap::GlobalMapperOptions& mapper_options = *mapper_out;
  const bool from_cli_or_no_project = project_path.empty();
  ImageReaderOptions& reader = *options.image_reader;
  if (from_cli_or_no_project || HasArgument(argc, argv, "camera_model")) {
    reader.camera_model = automatic.camera_model;
  }
  if (from_cli_or_no_project || HasArgument(argc, argv, "single_camera")) {
    reader.single_camera = automatic.single_camera;
  }
  if (!ExistsCameraModelWithName(reader.camera_model)) {
    return "Unknown camera model " + reader.camera_model + ".";
  }
  reader.database_path = *options.database_path;
  reader.image_path = *options.image_path;
  if (!automatic.mask_path.empty()) reader.mask_path = automatic.mask_path;
  if (HasArgument(argc, argv, "num_threads")) {
    options.sift_extraction->num_threads = automatic.num_threads;
    options.sift_matching->num_threads = automatic.num_threads;
    if (!HasArgument(argc, argv, "GlobalMapper.num_threads")) {
      mapper_options.num_threads = automatic.num_threads;
    }
  }
  options.sift_extraction->gpu_index = automatic.gpu_index;
  options.sift_matching->gpu_index = automatic.gpu_index;
  bool use_gpu = automatic.use_gpu;
#ifndef CUDA_ENABLED
  // Without CUDA, SiftGPU runs in an OpenGL context, which needs a display;
  // without one, stock 3.8 aborts in Qt. Here the CPU takes over.
  if (use_gpu && (!kUseOpenGL || std::getenv("DISPLAY") == nullptr)) {
    std::cout << "No display for an OpenGL context: feature extraction and "
                 "matching run on the CPU (as with --use_gpu 0)."
              << std::endl;
    use_gpu = false;
  }
#endif
  options.sift_extraction->use_gpu = use_gpu;
  options.sift_matching->use_gpu = use_gpu;
  mapper_options.image_path = *options.image_path;

  return "";
}

// Runs extraction, matching and the global mapper
// (GlobalAutomaticReconstruction) until it ends or a signal stops it; returns
// the exit code.
int RunReconstruction(int argc, char** argv, const AutomaticOptions& automatic,
                      const OptionManager& options,
                      const glomap::GlobalMapperOptions& mapper_options,
                      SignalWatcher& watcher, OutputGuard* guard) {
  const bool use_gpu = options.sift_extraction->use_gpu;
  GlobalAutomaticReconstruction reconstruction(automatic, options,
                                               mapper_options, &watcher, guard);
  watcher.SetStop([&reconstruction]() { reconstruction.Stop(); });
  const std::unique_ptr<SignalWatcher, void (*)(SignalWatcher*)> unbind(
      &watcher, [](SignalWatcher* bound) { bound->SetStop(nullptr); });
#ifdef GUI_ENABLED
  if (use_gpu && kUseOpenGL) {
    QApplication app(argc, argv);
    RunThreadWithOpenGLContext(&reconstruction);
  } else {
    reconstruction.Start();
    reconstruction.Wait();
  }
#else
  reconstruction.Start();
  reconstruction.Wait();
#endif
  if (watcher.Signal() != 0 && reconstruction.ExitCode() != EXIT_SUCCESS) {
    return Fail(InterruptedMessage(watcher.Signal()), 128 + watcher.Signal());
  }
  return reconstruction.ExitCode();
}

int RunGlobalAutomaticReconstructor(int argc, char** argv,
                                    SignalWatcher& watcher,
                                    OutputGuard* guard) {
  // `-h` lists the basic GlobalMapper.* options, `--help_all` all of them.
  const glomap::GlobalMapperHelp help =
      glomap::FindGlobalMapperHelp(argc, argv);
  const bool wants_help = help != glomap::GlobalMapperHelp::kNone;
  AutomaticOptions automatic;
  glomap::GlobalMapperOptions mapper_options;

  // Presets first, then the project's sections, then the command line: each
  // later source overrides the earlier ones.
  OptionManager options;
  const std::string project_path = FindArgument(argc, argv, "project_path");
  if (const std::string error =
          ReadPresetsAndProject(argc, argv, automatic, project_path, &options);
      !error.empty()) {
    return Fail(error);
  }
  // The database is the workspace's; the stock command has no option for it.
  if (HasArgument(argc, argv, "database_path")) {
    return Fail(
        "automatic_reconstructor writes WORKSPACE/database.db; "
        "--database_path is not one of its options.");
  }
  automatic.workspace_path = FindArgument(argc, argv, "workspace_path");
  *options.database_path = JoinPaths(
      automatic.workspace_path.empty() ? "." : automatic.workspace_path,
      "database.db");
  options.AddAllOptions();
  AddAutomaticOptions(&automatic, &options);
  glomap::AddGlobalMapperOptions(&options, &mapper_options, help);
  if (wants_help) {
    glomap::PrintGlobalMapperHelpAndExit(&options, argv[0],
                                         "automatic_reconstructor", help);
  }
  {
    const std::string error =
        glomap::CheckForRemovedGlobalMapperOptions(argc, argv);
    if (!error.empty()) return Fail(error);
  }

  // The project was read above; Parse must not read it again (it would then
  // ignore the command line).
  std::vector<char*> args = WithoutArgument(argc, argv, "project_path");
  // AddAllOptions requires --database_path; it is the workspace's.
  std::string database_flag = "--database_path";
  std::string database_value = *options.database_path;
  args.insert(args.end() - 1, {database_flag.data(), database_value.data()});
  // It requires --image_path too, which a project file may give instead.
  std::string image_flag = "--image_path";
  std::string image_value = *options.image_path;
  if (!HasArgument(argc, argv, "image_path") && !image_value.empty()) {
    args.insert(args.end() - 1, {image_flag.data(), image_value.data()});
  }
  {
    const std::string error =
        CheckInputPaths("", FindArgument(argc, argv, "image_path"));
    if (!error.empty()) return Fail(error);
  }
  // The workspace is made before Parse, whose check wants the database's
  // folder to exist (stock 3.8 wants the user to make it).
  if (automatic.workspace_path.empty()) {
    return Fail("No workspace given (--workspace_path).");
  }
  std::error_code fs_error;
  fs::create_directories(automatic.workspace_path, fs_error);
  if (fs_error || !fs::is_directory(automatic.workspace_path)) {
    return Fail("Cannot create the workspace " + automatic.workspace_path +
                (fs_error ? ": " + fs_error.message() : "."));
  }
  options.Parse(static_cast<int>(args.size()) - 1, args.data());
  if (!HasArgument(argc, argv, "log_to_stderr")) FLAGS_logtostderr = true;

  if (const std::string error = ApplyAutomaticOptions(
          argc, argv, automatic, project_path, &options, &mapper_options);
      !error.empty()) {
    return Fail(error);
  }
  if (const glomap::Status check = mapper_options.Check(); !check.ok()) {
    return Fail(check.message());
  }
  if (automatic.mesher != "poisson" && automatic.mesher != "delaunay") {
    return Fail("--mesher must be poisson or delaunay, not " +
                automatic.mesher + ".");
  }
  {
    const std::string output_error =
        CheckOutputPath(JoinPaths(automatic.workspace_path, "sparse"));
    if (!output_error.empty()) return Fail(output_error);
  }
  std::cout << "Global pipeline: COLMAP 3.8's feature extraction and "
               "matching into "
            << *options.database_path
            << " (features and matches already there are kept), then the "
               "global mapper into "
            << JoinPaths(automatic.workspace_path, "sparse")
            << ". For the global mapper: SiftExtraction.estimate_affine_shape "
            << options.sift_extraction->estimate_affine_shape
            << ", SiftMatching.guided_matching "
            << options.sift_matching->guided_matching
            << " (off unless set: they cost the global mapper accuracy)."
            << std::endl;

  return RunReconstruction(argc, argv, automatic, options, mapper_options,
                           watcher, guard);
}

}  // namespace

int RunAutomaticReconstructorWithMapperChoice(int argc, char** argv) {
  std::string mapper = FindArgument(argc, argv, "mapper");
  StringToLower(&mapper);
  const bool wants_help = glomap::FindGlobalMapperHelp(argc, argv) !=
                          glomap::GlobalMapperHelp::kNone;
  if (!wants_help && (mapper.empty() || mapper == "incremental")) {
    std::vector<char*> args = WithoutArgument(argc, argv, "mapper");
    return RunAutomaticReconstructor(static_cast<int>(args.size()) - 1,
                                     args.data());
  }
  if (!wants_help && mapper != "global") {
    return Fail("--mapper must be incremental or global, not " + mapper + ".");
  }
  return RunCommandWithSignalWatcher(
      [argc, argv](SignalWatcher& watcher, OutputGuard* guard) {
        return RunGlobalAutomaticReconstructor(argc, argv, watcher, guard);
      });
}

}  // namespace colmap
