// The `GlobalMapper.*` options: one table of every pipeline option with its
// key, stage group and help text, shared by the command line
// (`colmap global_mapper --GlobalMapper.<key>`), the GUI's options dialog and
// the GUI's per-project settings file. Keys carry their unit (`_deg`, `_px`).
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "glomap/controllers/global_mapper.h"

namespace colmap {
class OptionManager;
}

namespace glomap {

struct GlobalMapperOptionEntry {
  // Stage the option belongs to, for grouping ("General", "Rotation
  // averaging", ...), in pipeline order.
  std::string group;
  // Key without the "GlobalMapper." prefix.
  std::string key;
  std::variant<bool*, int*, double*> value;
  std::string help;
};

// Every option of `options`, bound by pointer, in pipeline order.
std::vector<GlobalMapperOptionEntry> GlobalMapperOptionTable(
    GlobalMapperOptions* options);

// Adds every option as `GlobalMapper.<key>` to `manager` with its current
// value as default. The keys are not *registered*, so OptionManager::Write
// never puts them in a project file and stock COLMAP 3.8 keeps reading ours.
void AddGlobalMapperOptions(colmap::OptionManager* manager,
                            GlobalMapperOptions* options);

// Sets the option `key` (without the "GlobalMapper." prefix) from its text
// ("0"/"1"/"true"/"false" for switches); false with a one-line `error` for an
// unknown key or a value that is not entirely a number of the option's type.
bool SetGlobalMapperOption(const std::string& key, const std::string& text,
                           GlobalMapperOptions* options, std::string* error);

// Reads / writes the options as an INI file with a [GlobalMapper] section
// (the GUI keeps them beside the project, in `<project>.global_mapper.ini`).
// Unknown keys are ignored with a warning; returns false if the file cannot
// be read or holds an invalid value.
bool ReadGlobalMapperOptionsFile(const std::string& path,
                                 GlobalMapperOptions* options);
bool WriteGlobalMapperOptionsFile(const std::string& path,
                                  const GlobalMapperOptions& options);

}  // namespace glomap
