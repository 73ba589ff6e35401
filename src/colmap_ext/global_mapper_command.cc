// `colmap global_mapper`: global Structure-from-Motion from a COLMAP 3.8
// project. Reads the database read-only, runs the pipeline in a
// GlobalMapperController (the same thread the GUI runs) and writes one binary
// model per camera cluster to OUTPUT/0, OUTPUT/1, ..., largest first, each
// atomically (written to a temporary folder, then renamed into place).
#include <string>

#include "base/reconstruction_manager.h"
#include "colmap_ext/commands.h"
#include "colmap_ext/global_mapper_options.h"
#include "colmap_ext/global_mapper_run.h"
#include "util/misc.h"
#include "util/option_manager.h"

namespace colmap {
namespace {

int RunGlobalMapperOrThrow(int argc, char** argv, SignalWatcher& signals,
                           OutputGuard* output_guard) {
  glomap::GlobalMapperOptions mapper_options;
  std::string output_path;
  std::string image_list_path;

  OptionManager options;
  const bool has_project = HasArgument(argc, argv, "project_path");
  if (has_project) {
    // A stock COLMAP 3.8 project file holds every section; all must be known
    // to the parser.
    options.AddAllOptions();
  } else {
    options.AddDatabaseOptions();
    options.AddImageOptions();
  }
  if (has_project) {
    // Values on the command line are not parsed next to a project file, so
    // the output path cannot be required there; it is taken from argv below.
    options.AddDefaultOption("output_path", &output_path,
                             "Folder for the models (created if missing)");
  } else {
    options.AddRequiredOption("output_path", &output_path,
                              "Folder for the models (created if missing)");
  }
  options.AddDefaultOption("image_list_path", &image_list_path,
                           "Optional file with one image name per line: "
                           "reconstruct only these images");
  // `-h` lists the basic GlobalMapper.* options and names `--help_all`,
  // which lists them all; a run accepts them all.
  const glomap::GlobalMapperHelp help =
      glomap::FindGlobalMapperHelp(argc, argv);
  glomap::AddGlobalMapperOptions(&options, &mapper_options, help);
  if (help != glomap::GlobalMapperHelp::kNone) {
    glomap::PrintGlobalMapperHelpAndExit(&options, argv[0], "global_mapper",
                                         help);
  }

  {
    const std::string error = glomap::CheckForRemovedGlobalMapperOptions(
        argc, argv, FindArgument(argc, argv, "project_path"));
    if (!error.empty()) return Fail(error);
  }
  {
    const std::string error =
        CheckInputPaths(FindArgument(argc, argv, "database_path"),
                        FindArgument(argc, argv, "image_path"));
    if (!error.empty()) return Fail(error);
  }
  options.Parse(argc, argv);
  // Logs go to stderr as they happen, in glog's format, unless the user
  // decided otherwise (OptionManager resets the flag to COLMAP's default).
  if (!HasArgument(argc, argv, "log_to_stderr")) FLAGS_logtostderr = true;
  if (has_project) {
    // Parse() ignores command-line values when a project file is given; the
    // command line still decides: it overrides the file.
    const std::string cli_output = FindArgument(argc, argv, "output_path");
    if (!cli_output.empty()) output_path = cli_output;
    for (const char* name : {"database_path", "image_path"}) {
      const std::string value = FindArgument(argc, argv, name);
      if (!value.empty()) {
        *(std::string(name) == "database_path" ? options.database_path
                                               : options.image_path) = value;
      }
    }
    const std::string cli_image_list =
        FindArgument(argc, argv, "image_list_path");
    if (!cli_image_list.empty()) image_list_path = cli_image_list;
    const std::string prefix = "--GlobalMapper.";
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg.rfind(prefix, 0) != 0) continue;
      if (i + 1 >= argc) return Fail("No value given for " + arg + ".");
      std::string error;
      if (!glomap::SetGlobalMapperOption(arg.substr(prefix.size()), argv[++i],
                                         &mapper_options, &error)) {
        return Fail("Command line: " + error + ".");
      }
    }
    const std::string error =
        CheckInputPaths(*options.database_path, *options.image_path);
    if (!error.empty()) return Fail(error);
  }

  if (!image_list_path.empty()) {
    if (!ExistsFile(image_list_path)) {
      return Fail("Image list " + image_list_path + " does not exist.");
    }
    mapper_options.database.image_names = ReadTextFileLines(image_list_path);
  }
  mapper_options.image_path = *options.image_path;
  if (const glomap::Status check = mapper_options.Check(); !check.ok()) {
    return Fail(check.message());
  }
  {
    const std::string error = CheckOutputPath(output_path);
    if (!error.empty()) return Fail(error);
  }

  return RunGlobalMapperAndWriteModels(mapper_options, *options.database_path,
                                       output_path, options, signals,
                                       output_guard);
}

}  // namespace

int RunGlobalMapper(int argc, char** argv) {
  return RunCommandWithSignalWatcher(
      [argc, argv](SignalWatcher& signals, OutputGuard* output_guard) {
        return RunGlobalMapperOrThrow(argc, argv, signals, output_guard);
      });
}

}  // namespace colmap
