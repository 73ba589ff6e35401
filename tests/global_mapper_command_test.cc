// The `colmap global_mapper` command as a user runs it: its help, its errors
// on bad input, that it never changes the database, and that stock COLMAP
// 3.8 reads what it writes.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "base/gps.h"
#include "base/reconstruction.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

namespace fs = std::filesystem;
using testing::ColmapExecutable;
using testing::CreateTestDir;
using testing::FileDigest;
using testing::RunCommand;

size_t CountLines(const std::string& text) {
  size_t lines = 0;
  for (const char c : text) lines += c == '\n';
  return lines;
}

// A small synthetic project: database, empty image folder, ground truth.
struct Project {
  std::string dir, database_path, image_path;
  colmap::Reconstruction ground_truth;
};

// `shapes` (optional) receives what the generator picked, e.g. the priors.
Project MakeProject(const std::string& name, SyntheticSceneOptions options,
                    SyntheticSceneShapes* shapes = nullptr) {
  Project project;
  project.dir = CreateTestDir(name);
  project.database_path = project.dir + "/database.db";
  project.image_path = project.dir + "/images";
  fs::create_directories(project.image_path);
  options.random_seed = 3;
  const Status status = WriteSyntheticScene(options, project.database_path,
                                            &project.ground_truth, shapes);
  EXPECT_TRUE(status.ok()) << status.message();
  return project;
}

Project MakeProject(const std::string& name, int num_images = 12) {
  SyntheticSceneOptions options;
  options.num_images = num_images;
  return MakeProject(name, options);
}

std::string MapperCommand(const Project& project, const std::string& output) {
  return ColmapExecutable() + " global_mapper --database_path " +
         project.database_path + " --image_path " + project.image_path +
         " --output_path " + output;
}

TEST(GlobalMapperCommand, HelpListsEveryGroup) {
  std::string output;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper -h", &output), 0)
      << output;
  for (const char* key :
       {"--database_path", "--image_path", "--output_path", "--project_path",
        "--GlobalMapper.min_num_matches", "--GlobalMapper.random_seed",
        "--GlobalMapper.ra_max_rotation_error_deg",
        "--GlobalMapper.gp_max_num_iterations", "--GlobalMapper.ba_num_rounds",
        "--GlobalMapper.tri_min_angle_deg",
        "--GlobalMapper.use_position_priors", "--GlobalMapper.prior_is_gps",
        "--GlobalMapper.prior_use_ecef", "--GlobalMapper.prior_position_std_m",
        "--GlobalMapper.prior_loss_scale",
        "--GlobalMapper.prior_max_error_std"}) {
    EXPECT_NE(output.find(key), std::string::npos) << key;
  }
}

// The GlobalMapper.* options of a help text, in order, each with its help
// (whitespace collapsed to single spaces, as it is in the option table).
std::vector<std::pair<std::string, std::string>> HelpOptions(
    const std::string& help) {
  std::vector<std::pair<std::string, std::string>> options;
  std::istringstream lines(help);
  std::string line;
  bool in_option = false;
  while (std::getline(lines, line)) {
    // An option starts its line ("  --name arg (=default)  help"); its help
    // goes on in lines that start with more spaces.
    if (line.rfind("  --", 0) == 0) {
      in_option = line.rfind("  --GlobalMapper.", 0) == 0;
      if (!in_option) continue;
      std::istringstream words(line);
      std::string name, arg, value;
      words >> name >> arg >> value;  // "--GlobalMapper.key" "arg" "(=x)"
      options.emplace_back(name.substr(std::strlen("--GlobalMapper.")), "");
      line = line.substr(line.find(value) + value.size());
    } else if (!in_option || line.rfind("   ", 0) != 0) {
      in_option = false;
      continue;
    }
    std::istringstream words(line);
    std::string word;
    while (words >> word) {
      std::string& text = options.back().second;
      text += (text.empty() ? "" : " ") + word;
    }
  }
  return options;
}

// The keys of GlobalMapperOptionTable as its source declares them
// (b.Basic("key", ...) or b.Advanced("key", ...)), in order.
std::vector<std::string> TableKeys(const std::string& tier) {
  std::ifstream file(std::string(GLOMAP_SOURCE_DIR) +
                     "/src/colmap_ext/global_mapper_options.cc");
  const std::string source((std::istreambuf_iterator<char>(file)),
                           std::istreambuf_iterator<char>());
  std::vector<std::string> keys;
  const std::regex call("b\\.(Basic|Advanced)\\(\\s*\"([A-Za-z0-9_]+)\"");
  for (auto it = std::sregex_iterator(source.begin(), source.end(), call);
       it != std::sregex_iterator(); ++it) {
    if (tier.empty() || (*it)[1] == tier) keys.push_back((*it)[2]);
  }
  return keys;
}

std::vector<std::string> Keys(
    const std::vector<std::pair<std::string, std::string>>& options) {
  std::vector<std::string> keys;
  for (const auto& option : options) keys.push_back(option.first);
  return keys;
}

// Issue 30: `-h` lists COLMAP's general options and the basic GlobalMapper.*
// options, at most 45, each with its unit and range: its help ends with a
// bracket that states them ("[deg, > 0]", "[px, > 0]", "[0 to 1]", "[0 or
// 1]", "[threads; -1: all cores, or >= 1]"): a bound (a digit) or, for the
// seed, "any integer". Its last line names `--help_all` and how many more
// options that lists.
TEST(GlobalMapperCommand, HelpListsTheBasicOptionsWithUnitAndRange) {
  std::string help;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper -h", &help), 0)
      << help;
  const auto options = HelpOptions(help);
  EXPECT_LE(options.size(), 45u);
  EXPECT_GE(options.size(), 30u);
  EXPECT_EQ(Keys(options), TableKeys("Basic"));
  for (const auto& [key, text] : options) {
    const size_t open = text.rfind('[');
    ASSERT_FALSE(text.empty()) << key;
    ASSERT_EQ(text.back(), ']') << key << ": " << text;
    ASSERT_NE(open, std::string::npos) << key;
    const std::string marker = text.substr(open + 1, text.size() - open - 2);
    EXPECT_TRUE(marker.find_first_of("0123456789") != std::string::npos ||
                marker.find("any") != std::string::npos)
        << key << ": [" << marker << "]";
  }
  // COLMAP's general options come first.
  for (const char* name : {"--database_path", "--image_path", "--output_path",
                           "--log_level", "--project_path"}) {
    EXPECT_LT(help.find(name), help.find("--GlobalMapper.")) << name;
  }
  const std::string last_line = [&help] {
    std::string text = help;
    while (!text.empty() && text.back() == '\n') text.pop_back();
    return text.substr(text.rfind('\n') + 1);
  }();
  const size_t num_advanced = TableKeys("Advanced").size();
  EXPECT_EQ(last_line, std::to_string(num_advanced) +
                           " more options (solver and stage details): colmap "
                           "global_mapper --help_all");
  EXPECT_EQ(help.find("--GlobalMapper.gp_random_start_max_num_images"),
            std::string::npos);
  std::string long_help;
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " global_mapper --help", &long_help), 0);
  EXPECT_EQ(long_help, help);

  // automatic_reconstructor lists the same basic options.
  std::string automatic_help;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " automatic_reconstructor -h",
                       &automatic_help),
            0)
      << automatic_help;
  EXPECT_EQ(Keys(HelpOptions(automatic_help)), TableKeys("Basic"));
  EXPECT_NE(automatic_help.find(" more options (solver and stage details): "
                                "colmap automatic_reconstructor --help_all"),
            std::string::npos);
}

// `--help_all` lists every option of the table, both tiers, in its order.
TEST(GlobalMapperCommand, HelpAllListsEveryOption) {
  std::string help;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper --help_all", &help),
            0)
      << help;
  const std::vector<std::string> keys = TableKeys("");
  ASSERT_GT(keys.size(), 100u);  // The source's table was found.
  EXPECT_EQ(Keys(HelpOptions(help)), keys);
  EXPECT_EQ(help.find("more options"), std::string::npos);
  EXPECT_NE(help.find("--database_path"), std::string::npos);
  std::string automatic_help;
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " automatic_reconstructor --help_all",
                 &automatic_help),
      0);
  EXPECT_EQ(Keys(HelpOptions(automatic_help)), keys);
}

TEST(GlobalMapperCommand, ReconstructsAndKeepsDatabaseUnchanged) {
  const Project project = MakeProject("command_reconstructs");
  const std::string digest_before = FileDigest(project.database_path);
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path), &log), 0) << log;
  EXPECT_EQ(FileDigest(project.database_path), digest_before);
  EXPECT_FALSE(fs::exists(project.database_path + "-wal"));
  EXPECT_FALSE(fs::exists(project.database_path + "-shm"));
  for (const char* file : {"cameras.bin", "images.bin", "points3D.bin"}) {
    EXPECT_TRUE(fs::exists(output_path + "/0/" + file)) << file;
  }
  // Every stage logs its time.
  for (const char* stage :
       {"Stage Database:", "Stage Rotation averaging:",
        "Stage Global positioning:", "Stage Bundle adjustment:",
        "Stage Retriangulation:"}) {
    EXPECT_NE(log.find(stage), std::string::npos) << stage;
  }
  colmap::Reconstruction model;
  model.Read(output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 12);
  EXPECT_GT(model.NumPoints3D(), 100);
  // No temporary folder is left behind.
  for (const auto& entry : fs::directory_iterator(output_path)) {
    EXPECT_NE(entry.path().filename().string().rfind(".", 0), 0u)
        << entry.path();
  }
  // Without position priors the frame is arbitrary: no georegistration.
  EXPECT_FALSE(fs::exists(output_path + "/0/georegistration.txt"));
  EXPECT_EQ(log.find("georegistered"), std::string::npos) << log;
}

// At COLMAP 3.8's default verbosity (2) a run prints its stage lines, and
// neither Ceres' internals nor per-solve detail; --log_level 3 adds them.
TEST(GlobalMapperCommand, DefaultLogIsOneLinePerStage) {
  const Project project = MakeProject("command_log_level");
  const std::vector<std::string> solver_internals = {
      "trust_region_minimizer.cc", "block_sparse_matrix.cc",
      "detect_structure.cc", "CHOLMOD"};
  const std::vector<std::string> detail = {
      "BA solve (", "Rotation averaging round", "Pose verification round"};
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, project.dir + "/default"), &log),
            0)
      << log;
  EXPECT_NE(log.find("Stage Bundle adjustment:"), std::string::npos) << log;
  for (const auto* lines : {&solver_internals, &detail}) {
    for (const std::string& line : *lines) {
      EXPECT_EQ(log.find(line), std::string::npos) << line << "\n" << log;
    }
  }
  const size_t num_default_lines = std::count(log.begin(), log.end(), '\n');
  EXPECT_LT(num_default_lines, 60u) << log;
  ASSERT_EQ(RunCommand(MapperCommand(project, project.dir + "/detailed") +
                           " --log_level 3",
                       &log),
            0)
      << log;
  for (const std::string& line : detail) {
    EXPECT_NE(log.find(line), std::string::npos) << line;
  }
}

TEST(GlobalMapperCommand, StockColmapReadsOurModel) {
  const std::string stock = "/usr/bin/colmap";
  if (!fs::exists(stock)) {
    GTEST_SKIP() << "Debian's colmap package is not installed";
  }
  const Project project = MakeProject("command_stock_reads");
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path), &log), 0) << log;
  ASSERT_EQ(
      RunCommand(stock + " model_analyzer --path " + output_path + "/0", &log),
      0)
      << log;
  EXPECT_NE(log.find("Registered images: 12"), std::string::npos) << log;
  EXPECT_EQ(log.find("Mean reprojection error: -1"), std::string::npos) << log;
  const std::string text_path = project.dir + "/text";
  fs::create_directories(text_path);
  ASSERT_EQ(
      RunCommand(stock + " model_converter --input_path " + output_path +
                     "/0 --output_path " + text_path + " --output_type TXT",
                 &log),
      0)
      << log;
  colmap::Reconstruction text_model;
  text_model.ReadText(text_path);
  EXPECT_EQ(text_model.NumRegImages(), 12);
}

struct BadInputCase {
  std::string name;
  std::string database_path, image_path, output_path;
  std::string expected_message;
};

TEST(GlobalMapperCommand, BadInputGivesOneLineError) {
  const Project project = MakeProject("command_bad_input", 10);
  const std::string dir = project.dir;
  std::ofstream(dir + "/not_a_database.db") << "hello, I am a text file\n";
  std::ofstream(dir + "/a_file") << "x";
  std::vector<BadInputCase> cases = {
      {"missing database", dir + "/missing.db", project.image_path,
       dir + "/out1", "does not exist"},
      {"not a database", dir + "/not_a_database.db", project.image_path,
       dir + "/out2", "not a COLMAP database"},
      {"missing image folder", project.database_path, dir + "/no_images",
       dir + "/out3", "image"},
      {"output below a file", project.database_path, project.image_path,
       dir + "/a_file/out", "output"},
  };
  for (const auto& c : cases) {
    // Only what the user sees on stderr counts.
    const std::string stderr_path = dir + "/stderr.txt";
    const int code = RunCommand(
        ColmapExecutable() + " global_mapper --database_path " +
        c.database_path + " --image_path " + c.image_path + " --output_path " +
        c.output_path + " 2>" + stderr_path + " >/dev/null");
    std::ifstream stderr_file(stderr_path);
    const std::string log((std::istreambuf_iterator<char>(stderr_file)),
                          std::istreambuf_iterator<char>());
    EXPECT_NE(code, 0) << c.name;
    EXPECT_LT(code, 128) << c.name << " died from a signal: " << log;
    EXPECT_NE(log.find(c.expected_message), std::string::npos)
        << c.name << ": " << log;
    EXPECT_EQ(log.find("Check failed"), std::string::npos) << c.name;
    EXPECT_LE(CountLines(log), 2u) << c.name << ": " << log;
    EXPECT_FALSE(fs::exists(c.output_path + "/0")) << c.name;
  }
  EXPECT_FALSE(fs::exists(dir + "/missing.db"));
}

// Runs `colmap global_mapper` on an empty database file (the options are
// checked before the database is read) with `args`; returns the exit code
// and what the user sees on stderr.
int RunMapperOnEmptyProject(const std::string& dir, const std::string& output,
                            const std::string& args, std::string* stderr_text) {
  if (!fs::exists(dir + "/database.db")) {
    std::ofstream(dir + "/database.db");
    fs::create_directories(dir + "/images");
  }
  const std::string stderr_path = dir + "/stderr.txt";
  const int code =
      RunCommand(ColmapExecutable() + " global_mapper --database_path " + dir +
                 "/database.db --image_path " + dir + "/images --output_path " +
                 output + " " + args + " 2>" + stderr_path + " >/dev/null");
  std::ifstream stderr_file(stderr_path);
  stderr_text->assign(std::istreambuf_iterator<char>(stderr_file),
                      std::istreambuf_iterator<char>());
  return code;
}

// Issue 13: a value out of range is one error line that names the option as
// the user typed it, its allowed range and the value; exit code 1.
TEST(GlobalMapperCommand, BadOptionValueNamesKeyAndRange) {
  const std::string dir = CreateTestDir("command_bad_option");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--GlobalMapper.rp_max_epipolar_error_px -1",
       "GlobalMapper.rp_max_epipolar_error_px must be > 0, is -1"},
      {"--GlobalMapper.num_threads 0",
       "GlobalMapper.num_threads must be -1 or >= 1, is 0"},
      {"--GlobalMapper.rp_min_inlier_ratio 1.5",
       "GlobalMapper.rp_min_inlier_ratio must be in [0, 1], is 1.5"},
      {"--GlobalMapper.track_max_num_views_per_track 2",
       "GlobalMapper.track_max_num_views_per_track must be >= "
       "GlobalMapper.track_min_num_views_per_track (3), is 2"},
      {"--GlobalMapper.min_num_matches -3",
       "GlobalMapper.min_num_matches must be >= 0, is -3"},
      // Options that were constants in the code before issue 13 (advanced
      // options since issue 30: not in `-h`, set the same way).
      {"--GlobalMapper.gp_random_start_max_num_images -5",
       "GlobalMapper.gp_random_start_max_num_images must be >= 0, is -5"},
      {"--GlobalMapper.gp_min_inlier_observation_ratio 1.5",
       "GlobalMapper.gp_min_inlier_observation_ratio must be in [0, 1], is "
       "1.5"},
      {"--GlobalMapper.min_residuals_per_ceres_thread 0",
       "GlobalMapper.min_residuals_per_ceres_thread must be >= 1, is 0"},
      // Issue 12: the position-prior keys have no stage prefix.
      {"--GlobalMapper.prior_position_std_m 0",
       "GlobalMapper.prior_position_std_m must be > 0, is 0"},
      {"--GlobalMapper.prior_loss_scale -2",
       "GlobalMapper.prior_loss_scale must be > 0, is -2"},
  };
  for (const auto& [args, message] : cases) {
    std::string log;
    const int code = RunMapperOnEmptyProject(dir, dir + "/sparse", args, &log);
    EXPECT_EQ(code, 1) << args << ": " << log;
    EXPECT_EQ(log, "ERROR: " + message + "\n") << args;
    EXPECT_FALSE(fs::exists(dir + "/sparse")) << args;
  }
}

// Every option of `--help_all` (the GlobalMapper.* table, both tiers) passes
// the check at its default, and every number is refused under its own key
// when it is far out of range: a field whose name differs from its key would
// be named wrongly.
TEST(GlobalMapperCommand, EveryOptionIsCheckedUnderItsKey) {
  std::string help;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper --help_all", &help),
            0)
      << help;
  std::vector<std::pair<std::string, std::string>> defaults;
  const std::string prefix = "--GlobalMapper.";
  for (size_t pos = help.find(prefix); pos != std::string::npos;
       pos = help.find(prefix, pos + 1)) {
    const size_t key_end = help.find(' ', pos);
    const size_t value_begin = help.find("(=", key_end);
    ASSERT_NE(value_begin, std::string::npos);
    const size_t value_end = help.find(')', value_begin);
    defaults.emplace_back(
        help.substr(pos + prefix.size(), key_end - pos - prefix.size()),
        help.substr(value_begin + 2, value_end - value_begin - 2));
  }
  ASSERT_EQ(defaults.size(), TableKeys("").size());  // The whole table.

  // Past the check, the output path (below a file) is the first error.
  const std::string dir = CreateTestDir("command_every_option");
  std::ofstream(dir + "/a_file") << "x";
  const std::string output = dir + "/a_file/out";
  const std::string output_error = "ERROR: Cannot create the output folder";
  std::string all_defaults;
  for (const auto& [key, value] : defaults) {
    all_defaults += " " + prefix + key + " " + value;
  }
  std::string log;
  EXPECT_EQ(RunMapperOnEmptyProject(dir, output, all_defaults, &log), 1);
  EXPECT_EQ(log.rfind(output_error, 0), 0u) << log;

  // Switches are refused by the parser; the seed has no range.
  const std::set<std::string> without_range = {"random_seed"};
  size_t num_checked = 0;
  for (const auto& [key, value] : defaults) {
    bool refused = false;
    for (const std::string bad : {"-1000000000", "1000000000"}) {
      RunMapperOnEmptyProject(dir, output, prefix + key + " " + bad, &log);
      if (log.rfind("ERROR: GlobalMapper." + key + " must be ", 0) == 0) {
        refused = true;
        break;
      }
      if (log.find("for option '" + prefix + key + "' is invalid") !=
          std::string::npos) {
        EXPECT_TRUE(value == "0" || value == "1") << key << ": " << log;
        refused = true;
        break;
      }
      // Not refused: the run got as far as the output path.
      EXPECT_EQ(log.rfind(output_error, 0), 0u) << key << ": " << log;
    }
    EXPECT_EQ(refused, without_range.count(key) == 0) << key << ": " << log;
    num_checked += refused;
  }
  EXPECT_EQ(num_checked, defaults.size() - without_range.size());
}

// Issue 30: solver internals are no longer options. On the command line
// (whichever help there is) and in a project file, such a key is one error
// line that names it and says why; an advanced option (not in `-h`) is read
// from both like a basic one.
TEST(GlobalMapperCommand, RemovedOptionIsOneErrorLineAdvancedOneIsAccepted) {
  const std::string dir = CreateTestDir("command_removed_option");
  std::ofstream(dir + "/a_file") << "x";
  std::string log;
  for (const char* key :
       {"ba_max_num_images_dense_schur", "ra_admm_relative_tolerance",
        "pv_ransac_confidence", "tri_structure_gradient_tolerance"}) {
    EXPECT_EQ(RunMapperOnEmptyProject(
                  dir, dir + "/sparse",
                  std::string("--GlobalMapper.") + key + " 1", &log),
              1)
        << key;
    EXPECT_EQ(log.rfind(std::string("ERROR: Command line: GlobalMapper.") +
                            key + " is no longer an option (",
                        0),
              0u)
        << log;
    EXPECT_NE(log.find("fixed in the code)."), std::string::npos) << log;
    EXPECT_EQ(CountLines(log), 1u) << log;
  }
  EXPECT_FALSE(fs::exists(dir + "/sparse"));
  // An advanced option with a good value: the run gets past the options, as
  // far as the output path (below a file).
  EXPECT_EQ(RunMapperOnEmptyProject(
                dir, dir + "/a_file/out",
                "--GlobalMapper.gp_random_start_max_num_images 20", &log),
            1);
  EXPECT_EQ(log.rfind("ERROR: Cannot create the output folder", 0), 0u) << log;

  // A project file: an advanced option is read (and checked) from its
  // [GlobalMapper] section; a removed one is refused by name.
  const std::string ini = dir + "/project.ini";
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " project_generator --output_path " + ini,
                 &log),
      0)
      << log;
  std::ifstream in(ini);
  std::string content, line;
  while (std::getline(in, line)) {
    if (line == "database_path=") line += dir + "/database.db";
    if (line == "image_path=") line += dir + "/images";
    content += line + "\n";
  }
  in.close();
  for (const auto& [entry, message] :
       std::vector<std::pair<std::string, std::string>>{
           {"gp_random_start_max_num_images=-5",
            "ERROR: GlobalMapper.gp_random_start_max_num_images must be >= "
            "0, is -5\n"},
           {"gp_init_box_size=10", "ERROR: " + ini +
                                       ": GlobalMapper.gp_init_box_size is no "
                                       "longer an option ("}}) {
    std::ofstream(ini) << content << "[GlobalMapper]\n" << entry << "\n";
    const std::string stderr_path = dir + "/stderr.txt";
    EXPECT_EQ(RunCommand(ColmapExecutable() + " global_mapper --project_path " +
                         ini + " --output_path " + dir + "/sparse 2>" +
                         stderr_path + " >/dev/null"),
              1)
        << entry;
    std::ifstream stderr_file(stderr_path);
    log.assign(std::istreambuf_iterator<char>(stderr_file),
               std::istreambuf_iterator<char>());
    EXPECT_EQ(log.rfind(message, 0), 0u) << entry << ": " << log;
    EXPECT_EQ(CountLines(log), 1u) << log;
  }
}

TEST(GlobalMapperCommand, ReadsStockProjectFile) {
  const Project project = MakeProject("command_project_file");
  const std::string ini = project.dir + "/project.ini";
  std::string log;
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " project_generator --output_path " + ini,
                 &log),
      0)
      << log;
  // project_generator leaves the paths empty; set them as a user would.
  std::ifstream in(ini);
  std::string content, line;
  while (std::getline(in, line)) {
    if (line == "database_path=") line += project.database_path;
    if (line == "image_path=") line += project.image_path;
    content += line + "\n";
  }
  in.close();
  std::ofstream(ini) << content;
  const std::string output_path = project.dir + "/sparse";
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper --project_path " +
                           ini + " --output_path " + output_path,
                       &log),
            0)
      << log;
  EXPECT_TRUE(fs::exists(output_path + "/0/images.bin"));

  // Options on the command line count next to a project file, and win.
  const int code =
      RunCommand(ColmapExecutable() + " global_mapper --project_path " + ini +
                     " --output_path " + project.dir + "/sparse_big" +
                     " --GlobalMapper.min_model_size 1000",
                 &log);
  EXPECT_NE(code, 0) << log;
  EXPECT_NE(log.find("at least 1000 images"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(project.dir + "/sparse_big/0"));
  EXPECT_NE(RunCommand(ColmapExecutable() + " global_mapper --project_path " +
                           ini + " --output_path " + project.dir +
                           "/sparse_bad --GlobalMapper.min_model_size x3",
                       &log),
            0);
  EXPECT_NE(log.find("x3"), std::string::npos) << log;
}

// A rerun into a folder that holds more models from an earlier run leaves
// exactly this run's models; other files stay.
TEST(GlobalMapperCommand, RerunRemovesStaleModels) {
  const Project project = MakeProject("command_stale_models");
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path), &log), 0) << log;
  for (const char* stale : {"1", "2"}) {
    fs::copy(output_path + "/0", output_path + "/" + stale);
  }
  fs::create_directories(output_path + "/7_notes");
  std::ofstream(output_path + "/readme.txt") << "mine";
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path), &log), 0) << log;
  EXPECT_TRUE(fs::exists(output_path + "/0/images.bin"));
  EXPECT_FALSE(fs::exists(output_path + "/1"));
  EXPECT_FALSE(fs::exists(output_path + "/2"));
  EXPECT_TRUE(fs::exists(output_path + "/7_notes"));
  EXPECT_TRUE(fs::exists(output_path + "/readme.txt"));
  for (const auto& entry : fs::directory_iterator(output_path)) {
    EXPECT_EQ(entry.path().filename().string().rfind(".global_mapper_tmp", 0),
              std::string::npos)
        << entry.path();
  }
}

// Every file and folder under `dir` with a digest of its content ("" for a
// folder); empty if `dir` does not exist.
std::map<std::string, std::string> Snapshot(const std::string& dir) {
  std::map<std::string, std::string> files;
  if (!fs::exists(dir)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    files[fs::relative(entry.path(), dir).string()] =
        entry.is_directory() ? "" : FileDigest(entry.path().string());
  }
  return files;
}

// SIGINT (Ctrl-C) and SIGTERM during each stage: the command stops within a
// second with exit code 128 + signal and one error line, and the output
// folder is exactly as it was (an earlier model stays; a folder that did not
// exist is not created).
TEST(GlobalMapperCommand, SignalStopsEveryStageWithinASecond) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.prior_focal_length = false;  // View-graph calibration runs.
  options.wrong_match_ratio = 0.3;
  const Project project = MakeProject("command_signals", options);
  // An earlier run's model (its content does not matter here).
  const std::string existing_output = project.dir + "/sparse";
  fs::create_directories(existing_output + "/0");
  for (const char* file :
       {"cameras.bin", "images.bin", "points3D.bin", "project.ini"}) {
    std::ofstream(existing_output + "/0/" + file) << "earlier model " << file;
  }
  const std::map<std::string, std::string> before = Snapshot(existing_output);
  const std::string missing_output = project.dir + "/new/sparse";

  const char* stages[] = {"Database",
                          "View graph calibration",
                          "Relative poses",
                          "Rotation averaging",
                          "Tracks",
                          "Global positioning",
                          "Pose verification",
                          "Bundle adjustment",
                          "Retriangulation",
                          "Final pose verification",
                          "Camera clustering"};
  int run = 0;
  for (const char* stage : stages) {
    const int signal = run % 2 == 0 ? SIGINT : SIGTERM;
    const std::string& output_path =
        run % 2 == 0 ? existing_output : missing_output;
    ++run;
    SCOPED_TRACE(std::string(stage) +
                 (signal == SIGINT ? ", SIGINT" : ", SIGTERM"));
    int pipe_fds[2];
    ASSERT_EQ(pipe(pipe_fds), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(pipe_fds[0]);
      dup2(pipe_fds[1], STDOUT_FILENO);
      dup2(pipe_fds[1], STDERR_FILENO);
      const std::string exe = ColmapExecutable();
      execl(exe.c_str(), exe.c_str(), "global_mapper", "--database_path",
            project.database_path.c_str(), "--image_path",
            project.image_path.c_str(), "--output_path", output_path.c_str(),
            static_cast<char*>(nullptr));
      _exit(127);
    }
    close(pipe_fds[1]);
    // Reads the log as it is written; when the stage begins, the run is
    // frozen (SIGSTOP) so that the signal lands in that stage however short
    // it is, and the time counts from when it runs again.
    const std::string begin_line = std::string("Stage ") + stage + " ...";
    std::string text;
    char buffer[4096];
    ssize_t n;
    bool begun = false;
    auto signalled = std::chrono::steady_clock::now();
    while ((n = read(pipe_fds[0], buffer, sizeof(buffer))) > 0) {
      text.append(buffer, n);
      if (!begun && text.find(begin_line) != std::string::npos) {
        begun = true;
        kill(pid, SIGSTOP);
        kill(pid, signal);
        signalled = std::chrono::steady_clock::now();
        kill(pid, SIGCONT);
      }
    }
    close(pipe_fds[0]);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    const double stop_ms = std::chrono::duration<double, std::milli>(
                               std::chrono::steady_clock::now() - signalled)
                               .count();
    ASSERT_TRUE(begun) << "The run ended before stage " << stage << ":\n"
                       << text;
    printf("%s: stopped %.0f ms after the signal\n", stage, stop_ms);
    EXPECT_LT(stop_ms, 1000.0);
    ASSERT_TRUE(WIFEXITED(status)) << text;
    EXPECT_EQ(WEXITSTATUS(status), 128 + signal) << text;
    EXPECT_NE(text.find("ERROR: Interrupted by"), std::string::npos) << text;
    EXPECT_EQ(text.find("Model 0:"), std::string::npos) << text;
    EXPECT_EQ(Snapshot(existing_output), before);
    EXPECT_FALSE(fs::exists(missing_output));
    EXPECT_FALSE(fs::exists(project.dir + "/new")) << "made by the run";
  }
}

// A project on a read-only mount (a bind mount here, which needs root):
// the run works and nothing is created beside the database, which a
// read-only SQLite connection to a WAL-mode database would otherwise try
// (-wal, -shm).
TEST(GlobalMapperCommand, ProjectOnReadOnlyMount) {
  const Project project = MakeProject("command_read_only_mount");
  const std::string mount_point = project.dir + "_ro";
  fs::remove_all(mount_point);
  fs::create_directories(mount_point);
  std::string log;
  if (RunCommand("mount --bind '" + project.dir + "' '" + mount_point +
                     "' && mount -o remount,bind,ro '" + mount_point + "'",
                 &log) != 0) {
    RunCommand("umount '" + mount_point + "'");
    GTEST_SKIP() << "Cannot make a read-only bind mount (needs root): " << log;
  }
  struct Unmount {
    std::string path;
    ~Unmount() { RunCommand("umount '" + path + "'"); }
  } unmount{mount_point};
  ASSERT_NE(RunCommand("touch '" + mount_point + "/probe'"), 0)
      << "the mount is writable";
  const std::map<std::string, std::string> before = Snapshot(project.dir);
  const std::string output_path =
      CreateTestDir("command_read_only_mount_out") + "/sparse";
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper --database_path " +
                           mount_point + "/database.db --image_path " +
                           mount_point + "/images --output_path " + output_path,
                       &log),
            0)
      << log;
  EXPECT_EQ(Snapshot(project.dir), before);
  colmap::Reconstruction model;
  model.Read(output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 12);
}

// A full disk (here: a file-size limit, with SIGXFSZ ignored so that writes
// fail as they do on a full disk) gives an error and leaves the earlier
// model in place, never a truncated one with exit code 0.
TEST(GlobalMapperCommand, FullDiskIsAnErrorAndKeepsTheOldModel) {
  const Project project = MakeProject("command_full_disk", 30);
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path), &log), 0) << log;
  const std::string digest = FileDigest(output_path + "/0/points3D.bin");
  const uintmax_t size = fs::file_size(output_path + "/0/points3D.bin");
  ASSERT_GT(size, 20 * 1024u);
  // ulimit -f counts 1024-byte blocks; trap '' XFSZ ignores the signal.
  const std::string limited = "bash -c \"trap '' XFSZ; ulimit -f " +
                              std::to_string(size / 1024 / 2) + "; " +
                              MapperCommand(project, output_path) + "\"";
  const int code = RunCommand(limited, &log);
  EXPECT_NE(code, 0) << log;
  EXPECT_LT(code, 128) << log;
  EXPECT_NE(log.find("disk full"), std::string::npos) << log;
  EXPECT_EQ(FileDigest(output_path + "/0/points3D.bin"), digest);
  for (const auto& entry : fs::directory_iterator(output_path)) {
    EXPECT_EQ(entry.path().filename().string().rfind(".global_mapper_tmp", 0),
              std::string::npos)
        << entry.path();
  }
}

// Lines of `log` that the command writes as its error ("ERROR: ...").
std::vector<std::string> ErrorLines(const std::string& log) {
  std::vector<std::string> lines;
  std::istringstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("ERROR: ", 0) == 0) lines.push_back(line);
  }
  return lines;
}

// What a user must see when a run fails: exit code 1 (no signal), exactly
// one error line that says `expected`, no CHECK or terminate, no model.
void ExpectOneLineError(const std::string& name, int code,
                        const std::string& log, const std::string& expected,
                        const std::string& output_path) {
  EXPECT_EQ(code, 1) << name << ": " << log;
  const std::vector<std::string> errors = ErrorLines(log);
  ASSERT_EQ(errors.size(), 1u) << name << ": " << log;
  EXPECT_NE(errors.front().find(expected), std::string::npos)
      << name << ": " << errors.front();
  EXPECT_EQ(log.find("Check failed"), std::string::npos) << name;
  EXPECT_EQ(log.find("terminate called"), std::string::npos) << name;
  EXPECT_FALSE(fs::exists(output_path + "/0")) << name;
}

// A run that succeeds although the database was damaged: a model, no CHECK,
// and the warning that says what was left out.
void ExpectModelWithWarning(const std::string& name, int code,
                            const std::string& log, const std::string& warning,
                            const std::string& output_path) {
  EXPECT_EQ(code, 0) << name << ": " << log;
  EXPECT_NE(log.find(warning), std::string::npos) << name << ": " << log;
  EXPECT_EQ(log.find("Check failed"), std::string::npos) << name;
  EXPECT_TRUE(ErrorLines(log).empty()) << name << ": " << log;
  EXPECT_TRUE(fs::exists(output_path + "/0/images.bin")) << name;
}

void ExecuteSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message),
            SQLITE_OK)
      << (message ? message : "");
  sqlite3_free(message);
  sqlite3_close(db);
}

// Changes the keypoints of one image in place: `change` gets the float32
// values, row-major with `cols` per keypoint.
void ChangeKeypoints(
    const std::string& path, int image_id,
    const std::function<void(std::vector<float>*, int)>& change) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  const std::string id = std::to_string(image_id);
  ASSERT_EQ(
      sqlite3_prepare_v2(
          db,
          ("SELECT cols, data FROM keypoints WHERE image_id = " + id).c_str(),
          -1, &stmt, nullptr),
      SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  const int cols = sqlite3_column_int(stmt, 0);
  std::vector<float> values(sqlite3_column_bytes(stmt, 1) / sizeof(float));
  std::memcpy(values.data(), sqlite3_column_blob(stmt, 1),
              values.size() * sizeof(float));
  sqlite3_finalize(stmt);
  change(&values, cols);
  ASSERT_EQ(
      sqlite3_prepare_v2(
          db, ("UPDATE keypoints SET data = ?1 WHERE image_id = " + id).c_str(),
          -1, &stmt, nullptr),
      SQLITE_OK);
  sqlite3_bind_blob(stmt, 1, values.data(),
                    static_cast<int>(values.size() * sizeof(float)),
                    SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(stmt), SQLITE_DONE);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

void SetCameraParams(const std::string& path, int camera_id,
                     const std::vector<double>& params) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(
      sqlite3_prepare_v2(db,
                         ("UPDATE cameras SET params = ?1 WHERE camera_id = " +
                          std::to_string(camera_id))
                             .c_str(),
                         -1, &stmt, nullptr),
      SQLITE_OK);
  sqlite3_bind_blob(stmt, 1, params.data(),
                    static_cast<int>(params.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(stmt), SQLITE_DONE);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

// Issue 11, part 1: damaged content is left out with a warning, or is one
// error line that names the camera; never a CHECK, a crash or a lost run.
TEST(GlobalMapperCommand, DamagedDatabaseContent) {
  const Project project = MakeProject("command_damaged_content");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // SIMPLE_RADIAL, 1024x768: f, cx, cy, k.
  const struct {
    std::string name;
    std::function<void(const std::string&)> damage;
    // True: the run fails with `message` in its error line; false: it
    // succeeds, with `message` in a warning.
    bool fails;
    std::string message;
  } cases[] = {
      {"nonfinite_keypoints",
       [](const std::string& path) {
         ChangeKeypoints(path, 1, [](std::vector<float>* values, int cols) {
           for (size_t i = 0; i * cols < values->size(); i += 3) {
             (*values)[i * cols] = std::numeric_limits<float>::quiet_NaN();
           }
           (*values)[cols + 1] = std::numeric_limits<float>::infinity();
         });
       },
       false, "has non-finite coordinates (NaN or infinite) in"},
      {"nan_focal",
       [nan](const std::string& path) {
         SetCameraParams(path, 1, {nan, 512, 384, 0});
       },
       true, "camera 1 has non-finite parameters (nan, 512, 384, 0)"},
      {"negative_focal",
       [](const std::string& path) {
         SetCameraParams(path, 1, {-900, 512, 384, 0});
       },
       true, "camera 1 has the focal length -900 px, which is not positive"},
      {"far_principal_point",
       [](const std::string& path) {
         SetCameraParams(path, 1, {900, 1e7, 384, 0});
       },
       true, "camera 1 has its principal point at (1e+07, 384) px"},
      {"duplicate_keypoint_rows",
       [](const std::string& path) {
         ExecuteSql(path,
                    "CREATE TABLE keypoints_copy AS SELECT * FROM keypoints;"
                    "DROP TABLE keypoints;"
                    "ALTER TABLE keypoints_copy RENAME TO keypoints;"
                    "INSERT INTO keypoints SELECT * FROM keypoints "
                    "WHERE image_id = 3;");
       },
       false, "has 2 keypoint rows in"},
      {"unusable_geometries",
       [](const std::string& path) {
         ExecuteSql(path,
                    "UPDATE two_view_geometries SET config = 42 "
                    "WHERE pair_id % 5 = 0;"
                    "UPDATE two_view_geometries SET F = NULL, E = NULL, "
                    "H = NULL WHERE pair_id % 5 = 1;");
       },
       false, "whose config is not a COLMAP two-view geometry type"},
      {"unknown_images",
       [](const std::string& path) {
         ExecuteSql(path,
                    "INSERT INTO two_view_geometries SELECT pair_id + 998, "
                    "rows, cols, data, config, F, E, H, qvec, tvec "
                    "FROM two_view_geometries;");
       },
       false, "that do not name two images of the database"},
  };
  for (const auto& c : cases) {
    const std::string dir = project.dir + "/" + c.name;
    fs::create_directories(dir);
    const std::string database_path = dir + "/database.db";
    fs::copy_file(project.database_path, database_path);
    c.damage(database_path);
    const std::string output_path = dir + "/sparse";
    std::string log;
    const int code =
        RunCommand(ColmapExecutable() + " global_mapper --database_path " +
                       database_path + " --image_path " + project.image_path +
                       " --output_path " + output_path,
                   &log);
    if (c.fails) {
      ExpectOneLineError(c.name, code, log, c.message, output_path);
    } else {
      ExpectModelWithWarning(c.name, code, log, c.message, output_path);
    }
  }
}

// A camera that cannot be used leaves out its images, with a warning, and
// the other cameras' images are reconstructed.
TEST(GlobalMapperCommand, UnusableCameraLeavesOutItsImages) {
  SyntheticSceneOptions options;
  options.num_images = 16;
  options.num_cameras = 2;
  const Project project = MakeProject("command_unusable_camera", options);
  SetCameraParams(project.database_path, 2,
                  {900, 512, 384, std::numeric_limits<double>::infinity()});
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  const int code = RunCommand(MapperCommand(project, output_path), &log);
  ExpectModelWithWarning(
      "unusable camera", code, log,
      "Camera 2 in " + project.database_path +
          " has non-finite parameters (900, 512, 384, inf): its 8 images are "
          "left out.",
      output_path);
  colmap::Reconstruction model;
  model.Read(output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 8);
  EXPECT_EQ(model.NumCameras(), 1);
}

// Issue 11, part 2: a two-image project gives a two-view model when the
// user allows models that small, and otherwise says which option does.
TEST(GlobalMapperCommand, TwoAndOneImageProjects) {
  const Project project = MakeProject("command_two_images", 10);
  // Keep images 1 and 2 (neighbours on the ring) and their pair only.
  const std::string pair12 = std::to_string(2147483647ll + 2);
  ExecuteSql(project.database_path,
             "DELETE FROM images WHERE image_id > 2;"
             "DELETE FROM keypoints WHERE image_id > 2;"
             "DELETE FROM descriptors WHERE image_id > 2;"
             "DELETE FROM matches WHERE pair_id != " +
                 pair12 +
                 ";"
                 "DELETE FROM two_view_geometries WHERE pair_id != " +
                 pair12 + ";");
  std::string log;
  const std::string default_output = project.dir + "/sparse_default";
  int code = RunCommand(MapperCommand(project, default_output), &log);
  ExpectOneLineError("two images, default", code, log,
                     "Only 2 images are connected by consistent matches, but "
                     "models need at least 3 images "
                     "(GlobalMapper.min_model_size): set it to 2",
                     default_output);

  const std::string output_path = project.dir + "/sparse";
  code = RunCommand(
      MapperCommand(project, output_path) + " --GlobalMapper.min_model_size 2",
      &log);
  ASSERT_EQ(code, 0) << log;
  EXPECT_NE(log.find("Pose verification skipped"), std::string::npos) << log;
  colmap::Reconstruction model;
  model.Read(output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 2);
  EXPECT_GT(model.NumPoints3D(), 100);
  EXPECT_LT(model.ComputeMeanReprojectionError(), 2.0);

  // One image: nothing to reconstruct, whatever the options.
  ExecuteSql(project.database_path, "DELETE FROM images WHERE image_id = 2;");
  const std::string one_output = project.dir + "/sparse_one";
  code = RunCommand(
      MapperCommand(project, one_output) + " --GlobalMapper.min_model_size 2",
      &log);
  ExpectOneLineError("one image", code, log,
                     "can be used (image0001.png): a reconstruction needs at "
                     "least two.",
                     one_output);
}

// Issue 11, part 3: running out of memory (here: an address-space limit) at
// any point of the run is one error line and exit code 1, never an abort,
// a crash or a hang. The limit grows until the run succeeds, so that every
// stage gets its turn to fail on any machine.
TEST(GlobalMapperCommand, OutOfMemoryIsOneErrorLine) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves more address space than any "
                  "limit allows";
#endif
  const Project project = MakeProject("command_out_of_memory", 10);
  size_t num_out_of_memory = 0;
  bool succeeded = false;
  for (double limit_kb = 64 * 1024; limit_kb < 4 * 1024 * 1024 && !succeeded;
       limit_kb *= 1.1) {
    const std::string output_path =
        project.dir + "/sparse_" + std::to_string(static_cast<int>(limit_kb));
    std::string log;
    const int code =
        RunCommand("ulimit -v " + std::to_string(static_cast<int>(limit_kb)) +
                       "; timeout 300 " + MapperCommand(project, output_path),
                   &log);
    // Below some limit the dynamic loader itself fails (exit code 127).
    if (log.find("error while loading shared libraries") != std::string::npos) {
      continue;
    }
    if (code == 0) {
      succeeded = true;
      break;
    }
    const std::string name = "limit " + std::to_string(limit_kb) + " KB";
    EXPECT_NE(code, 124) << name << ": the run hung";
    ExpectOneLineError(name, code, log, "", output_path);
    num_out_of_memory += log.find("ERROR: Out of memory") != std::string::npos;
  }
  EXPECT_TRUE(succeeded);
  EXPECT_GT(num_out_of_memory, 0u);
}

// Issue 12: priors in a different frame than claimed (metric values, here
// a projected frame with eastings and northings in the hundred thousands,
// read as GPS) are one error line that says which option to change.
TEST(GlobalMapperCommand, MetricPriorsReadAsGpsAreOneErrorLine) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.prior_position_noise_m = 0.2;
  const Project project = MakeProject("command_priors_not_gps", options);
  ExecuteSql(project.database_path,
             "UPDATE images SET prior_tx = prior_tx + 500000, "
             "prior_ty = prior_ty + 5200000;");
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  int code = RunCommand(MapperCommand(project, output_path) +
                            " --GlobalMapper.use_position_priors 1"
                            " --GlobalMapper.prior_is_gps 1",
                        &log);
  ExpectOneLineError("metric priors as GPS", code, log,
                     "the priors look like metric values: set "
                     "GlobalMapper.prior_is_gps 0",
                     output_path);
  EXPECT_NE(log.find("The position prior of image image0001.png (id 1)"),
            std::string::npos)
      << log;

  // Without use_position_priors they are not used, and the log says so.
  code = RunCommand(
      MapperCommand(project, output_path) + " --GlobalMapper.prior_is_gps 1",
      &log);
  EXPECT_EQ(code, 0) << log;
  EXPECT_NE(log.find("12 images have position priors; set "
                     "--GlobalMapper.use_position_priors 1 to use them."),
            std::string::npos)
      << log;
  EXPECT_FALSE(fs::exists(output_path + "/0/georegistration.txt"));
}

// Key-value lines of a georegistration.txt (comments skipped).
std::map<std::string, std::string> ReadKeyValues(const std::string& path) {
  std::map<std::string, std::string> values;
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    values[line.substr(0, space)] = line.substr(space + 1);
  }
  return values;
}

// Issue 12: infinite or partly unset priors in the database are no reader
// error: those images are solved without a prior, a warning counts them,
// and the other priors still georegister the model (metric: in their own
// frame).
TEST(GlobalMapperCommand, NonFinitePriorsAreLeftOutWithAWarning) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.prior_position_noise_m = 0.1;
  const Project project = MakeProject("command_priors_non_finite", options);
  // SQLite reads 1e999 as infinity.
  ExecuteSql(project.database_path,
             "UPDATE images SET prior_tx = 1e999 WHERE image_id = 2;"
             "UPDATE images SET prior_ty = NULL WHERE image_id = 3;");
  const std::string output_path = project.dir + "/sparse";
  std::string log;
  const int code = RunCommand(MapperCommand(project, output_path) +
                                  " --GlobalMapper.use_position_priors 1",
                              &log);
  ExpectModelWithWarning("non-finite priors", code, log,
                         "2 images have a position prior that is not finite",
                         output_path);
  const std::map<std::string, std::string> geo =
      ReadKeyValues(output_path + "/0/georegistration.txt");
  ASSERT_EQ(geo.count("frame"), 1u) << log;
  EXPECT_EQ(geo.at("frame"), "metric");
  EXPECT_EQ(geo.at("priors_used"), "10");
  EXPECT_NE(log.find("Model 0 is georegistered: frame metric"),
            std::string::npos)
      << log;
}

// Issue 12: with GPS priors the model comes out in metres in an ENU frame
// around the first image's prior, says so in the log and in
// OUT/0/georegistration.txt, and stock COLMAP still reads the folder.
TEST(GlobalMapperCommand, GpsPriorsGiveAGeoregisteredModel) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.prior_position_noise_m = 0.1;
  options.prior_as_gps = true;
  SyntheticSceneShapes shapes;
  const Project project = MakeProject("command_gps_priors", options, &shapes);
  ASSERT_FALSE(HasFailure());
  ASSERT_EQ(shapes.prior_positions.size(), 12u);

  const std::string output_path = project.dir + "/sparse";
  std::string log;
  ASSERT_EQ(RunCommand(MapperCommand(project, output_path) +
                           " --GlobalMapper.use_position_priors 1"
                           " --GlobalMapper.prior_is_gps 1"
                           " --GlobalMapper.prior_position_std_m 0.1",
                       &log),
            0)
      << log;
  EXPECT_NE(log.find("Model 0 is georegistered: frame ENU, origin latitude "),
            std::string::npos)
      << log;
  const std::string geo_path = output_path + "/0/georegistration.txt";
  ASSERT_TRUE(fs::exists(geo_path)) << log;
  const std::map<std::string, std::string> geo = ReadKeyValues(geo_path);
  EXPECT_EQ(geo.at("frame"), "ENU");
  // The origin is image 1's prior: its true centre plus 0.1 m noise,
  // converted to GPS around the scene's origin.
  const Eigen::Vector3d origin_lla =
      colmap::GPSTransform(colmap::GPSTransform::WGS84)
          .ENUToEll({shapes.prior_positions[0]}, options.prior_gps_origin.x(),
                    options.prior_gps_origin.y(), options.prior_gps_origin.z())
          .front();
  EXPECT_NEAR(std::stod(geo.at("origin_latitude_deg")), origin_lla.x(), 1e-9);
  EXPECT_NEAR(std::stod(geo.at("origin_longitude_deg")), origin_lla.y(), 1e-9);
  EXPECT_NEAR(std::stod(geo.at("origin_altitude_m")), origin_lla.z(), 1e-6);
  EXPECT_EQ(geo.at("priors_used"), "12");

  // Camera centres in metres, ENU around image 1's prior: the true centres
  // moved by that prior (the tangent planes of the two origins, 10 m apart,
  // differ by far less than a millimetre here).
  colmap::Reconstruction model;
  model.Read(output_path + "/0");
  ASSERT_EQ(model.NumRegImages(), 12u);
  for (const colmap::image_t image_id : model.RegImageIds()) {
    const Eigen::Vector3d expected =
        project.ground_truth.Image(image_id).ProjectionCenter() -
        shapes.prior_positions[0];
    EXPECT_LT((model.Image(image_id).ProjectionCenter() - expected).norm(), 1.0)
        << "image " << image_id;
  }

  const std::string stock = "/usr/bin/colmap";
  if (fs::exists(stock)) {
    ASSERT_EQ(RunCommand(stock + " model_analyzer --path " + output_path + "/0",
                         &log),
              0)
        << log;
    EXPECT_NE(log.find("Registered images: 12"), std::string::npos) << log;
  }
}

}  // namespace
}  // namespace glomap
