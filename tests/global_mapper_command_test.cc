// The `colmap global_mapper` command as a user runs it: its help, its errors
// on bad input, that it never changes the database, and that stock COLMAP
// 3.8 reads what it writes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/reconstruction.h"
#include "glomap/synthetic_scene.h"
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
};

Project MakeProject(const std::string& name, int num_images = 12) {
  Project project;
  project.dir = CreateTestDir(name);
  project.database_path = project.dir + "/database.db";
  project.image_path = project.dir + "/images";
  fs::create_directories(project.image_path);
  SyntheticSceneOptions options;
  options.num_images = num_images;
  options.random_seed = 3;
  colmap::Reconstruction ground_truth;
  const Status status =
      WriteSyntheticScene(options, project.database_path, &ground_truth);
  EXPECT_TRUE(status.ok()) << status.message();
  return project;
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
        "--GlobalMapper.gp_loss_scale", "--GlobalMapper.ba_num_rounds",
        "--GlobalMapper.tri_min_angle_deg"}) {
    EXPECT_NE(output.find(key), std::string::npos) << key;
  }
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

}  // namespace
}  // namespace glomap
