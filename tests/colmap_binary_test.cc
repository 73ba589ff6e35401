// The built `colmap` binary: our commands are registered and the stock
// commands still work, end to end on a small real dataset.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/support/test_paths.h"

namespace glomap {
namespace {

namespace fs = std::filesystem;
using testing::ColmapExecutable;
using testing::RunCommand;

TEST(ColmapBinary, HelpListsOurCommands) {
  std::string output;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " help", &output), 0) << output;
  EXPECT_NE(output.find("global_mapper"), std::string::npos) << output;
  EXPECT_NE(output.find("model_evaluator"), std::string::npos) << output;
  // A few stock commands, to be sure the table is otherwise intact.
  for (const char* command :
       {"feature_extractor", "exhaustive_matcher", "mapper",
        "hierarchical_mapper", "model_analyzer", "model_converter", "gui"}) {
    EXPECT_NE(output.find(command), std::string::npos) << command;
  }
}

TEST(ColmapBinary, UnknownCommandFails) {
  std::string output;
  EXPECT_NE(RunCommand(ColmapExecutable() + " no_such_command", &output), 0);
}

// feature_extractor -> exhaustive_matcher -> mapper -> model_analyzer with
// the stock commands of our binary, on Herz-Jesus-P8 (8 images).
TEST(ColmapBinary, StockPipelineOnRealImages) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const std::string image_path = datasets + "/Herz-Jesus-P8/images";
  if (!std::filesystem::is_directory(image_path) ||
      std::filesystem::is_empty(image_path)) {
    GTEST_SKIP() << image_path << " is absent or empty";
  }
  const std::string dir = testing::CreateTestDir("colmap_binary_stock");
  const std::string database_path = dir + "/database.db";
  const std::string colmap = ColmapExecutable();
  std::string log;

  ASSERT_EQ(RunCommand(colmap + " feature_extractor --database_path " +
                           database_path + " --image_path " + image_path +
                           " --ImageReader.single_camera 1"
                           " --SiftExtraction.use_gpu 0"
                           " --SiftExtraction.max_image_size 1000",
                       &log),
            0)
      << log;
  ASSERT_EQ(RunCommand(colmap + " exhaustive_matcher --database_path " +
                           database_path + " --SiftMatching.use_gpu 0",
                       &log),
            0)
      << log;
  const std::string sparse = dir + "/sparse";
  fs::create_directories(sparse);
  ASSERT_EQ(
      RunCommand(colmap + " mapper --database_path " + database_path +
                     " --image_path " + image_path + " --output_path " + sparse,
                 &log),
      0)
      << log;
  ASSERT_EQ(
      RunCommand(colmap + " model_analyzer --path " + sparse + "/0", &log), 0)
      << log;
  EXPECT_NE(log.find("Registered images: 8"), std::string::npos) << log;

  // Our global mapper on the database the stock commands just made.
  ASSERT_EQ(RunCommand(colmap + " global_mapper --database_path " +
                           database_path + " --image_path " + image_path +
                           " --output_path " + dir + "/global",
                       &log),
            0)
      << log;
  ASSERT_EQ(
      RunCommand(colmap + " model_analyzer --path " + dir + "/global/0", &log),
      0)
      << log;
  EXPECT_NE(log.find("Registered images: 8"), std::string::npos) << log;
}

}  // namespace
}  // namespace glomap
