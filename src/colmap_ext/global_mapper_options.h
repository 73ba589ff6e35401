// The `GlobalMapper.*` options: one table of every pipeline option with its
// key, stage group, tier and help text, shared by the command line
// (`colmap global_mapper --GlobalMapper.<key>`), the GUI's options dialog and
// the GUI's per-project settings file. Keys carry their unit (`_deg`, `_px`).
//
// Two tiers: the basic options (those a user tunes; every one's help ends
// with its unit and range in brackets) are what `colmap global_mapper -h`
// lists and what the GUI dialog shows; the advanced ones (stage details) are
// listed by `--help_all` and shown under the dialog's "Advanced" toggle.
// Both tiers are options alike: set on the command line, in the GUI and in a
// project file under the same names. Solver internals (tolerances, RANSAC
// and ADMM internals, linear-solver switch sizes, ...) are not options:
// they are struct fields whose comment says so (RemovedGlobalMapperOptions).
#pragma once

#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "glomap/controllers/global_mapper.h"

namespace colmap {
class OptionManager;
}

namespace glomap {

enum class GlobalMapperOptionTier {
  // Listed by `-h` and shown in the GUI dialog; at most about 45.
  kBasic,
  // Listed by `--help_all` and shown under the dialog's "Advanced" toggle.
  kAdvanced,
};

struct GlobalMapperOptionEntry {
  // Stage the option belongs to, for grouping ("General", "Rotation
  // averaging", ...), in pipeline order.
  std::string group;
  // Key without the "GlobalMapper." prefix.
  std::string key;
  std::variant<bool*, int*, double*> value;
  std::string help;
  GlobalMapperOptionTier tier = GlobalMapperOptionTier::kAdvanced;
};

// Every option of `options` (both tiers), bound by pointer, in pipeline
// order.
std::vector<GlobalMapperOptionEntry> GlobalMapperOptionTable(
    GlobalMapperOptions* options);

// The keys that were options before they became struct fields (solver
// internals), each with the reason, e.g. {"ra_admm_relative_tolerance", "an
// ADMM stopping tolerance of rotation averaging"}. A removed key is refused
// on the command line and in a project file with a line that says so, and
// skipped with a warning in the GUI's options file.
const std::vector<std::pair<std::string, std::string>>&
RemovedGlobalMapperOptions();

// Which help the command line asks for: none, `-h` / `--help` (COLMAP's
// general options and the basic GlobalMapper.* options) or `--help_all`
// (every option).
enum class GlobalMapperHelp { kNone, kBasic, kAll };
GlobalMapperHelp FindGlobalMapperHelp(int argc, char** argv);

// Adds the options as `GlobalMapper.<key>` to `manager` with their current
// values as defaults: every option, or with `help` kBasic only the basic
// tier (what `-h` lists). The keys are not *registered*, so
// OptionManager::Write never puts them in a project file and stock COLMAP
// 3.8 keeps reading ours.
void AddGlobalMapperOptions(colmap::OptionManager* manager,
                            GlobalMapperOptions* options,
                            GlobalMapperHelp help = GlobalMapperHelp::kNone);

// Prints `manager`'s help (COLMAP's header and every option added to it) and
// ends the process with exit code 0, as COLMAP's help does. After `-h`
// (kBasic) its last line names the rest: "N more options (solver and stage
// details): colmap <command> --help_all".
[[noreturn]] void PrintGlobalMapperHelpAndExit(colmap::OptionManager* manager,
                                               const char* program,
                                               const std::string& command,
                                               GlobalMapperHelp help);

// A one-line error for the first `--GlobalMapper.<key>` in `argv` or
// `GlobalMapper.<key>` in the project file `project_path` (if not empty)
// whose key is no longer an option (RemovedGlobalMapperOptions); empty if
// there is none.
std::string CheckForRemovedGlobalMapperOptions(
    int argc, char** argv, const std::string& project_path = "");

// Sets the option `key` (without the "GlobalMapper." prefix) from its text
// ("0"/"1"/"true"/"false" for switches); false with a one-line `error` for an
// unknown or removed key or a value that is not entirely a number of the
// option's type.
bool SetGlobalMapperOption(const std::string& key, const std::string& text,
                           GlobalMapperOptions* options, std::string* error);

// Reads / writes the options (both tiers) as an INI file with a
// [GlobalMapper] section (the GUI keeps them beside the project, in
// `<project>.global_mapper.ini`). Unknown and removed keys are ignored with a
// warning; returns false if the file cannot be read or holds an invalid
// value.
bool ReadGlobalMapperOptionsFile(const std::string& path,
                                 GlobalMapperOptions* options);
bool WriteGlobalMapperOptionsFile(const std::string& path,
                                  const GlobalMapperOptions& options);

}  // namespace glomap
