// `colmap automatic_reconstructor --mapper global` (issue 28) as a user runs
// it on a folder of images: COLMAP 3.8's extraction and matching, then the
// global mapper into WORKSPACE/sparse; `--GlobalMapper.*` options reach the
// mapper; a rerun reuses the database and replaces the models; an interrupt
// keeps the previous models. Without `--mapper global` the stock command runs.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "base/database.h"
#include "base/reconstruction.h"
#include "colmap_ext/model_evaluation.h"
#include "feature/extraction.h"
#include "tests/support/test_paths.h"
#include "util/option_manager.h"

namespace glomap {
namespace {

namespace fs = std::filesystem;
using testing::ColmapExecutable;
using testing::CreateTestDir;
using testing::FileDigest;
using testing::RunCommand;

// Rows of `table` in the SQLite database at `path`, opened read-only; -1 if
// it cannot be read.
long CountRows(const std::string& path, const std::string& table) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) !=
      SQLITE_OK) {
    sqlite3_close(db);
    return -1;
  }
  long rows = -1;
  sqlite3_stmt* statement = nullptr;
  const std::string sql = "SELECT COUNT(*) FROM " + table + ";";
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr) ==
          SQLITE_OK &&
      sqlite3_step(statement) == SQLITE_ROW) {
    rows = sqlite3_column_int64(statement, 0);
  }
  sqlite3_finalize(statement);
  sqlite3_close(db);
  return rows;
}

// PRAGMA integrity_check of the database at `path`: "ok" if it is sound.
std::string IntegrityCheck(const std::string& path) {
  sqlite3* db = nullptr;
  std::string result = "cannot open";
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) ==
      SQLITE_OK) {
    sqlite3_stmt* statement = nullptr;
    if (sqlite3_prepare_v2(db, "PRAGMA integrity_check;", -1, &statement,
                           nullptr) == SQLITE_OK &&
        sqlite3_step(statement) == SQLITE_ROW) {
      result = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
    }
    sqlite3_finalize(statement);
  }
  sqlite3_close(db);
  return result;
}

// A folder with the first `num_images` images of `source` (symbolic links:
// the shared images are never touched).
std::string LinkImages(const std::string& source, const std::string& target,
                       int num_images) {
  fs::create_directories(target);
  std::vector<fs::path> images;
  for (const auto& entry : fs::directory_iterator(source)) {
    images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  for (int i = 0; i < num_images && i < static_cast<int>(images.size()); ++i) {
    fs::create_symlink(images[i], fs::path(target) / images[i].filename());
  }
  return target;
}

std::string GlobalCommand(const std::string& image_path,
                          const std::string& workspace) {
  return ColmapExecutable() + " automatic_reconstructor --image_path " +
         image_path + " --workspace_path " + workspace +
         " --mapper global --use_gpu 0";
}

TEST(AutomaticReconstructor, HelpNamesTheMapperChoiceAndGlobalOptions) {
  std::string output;
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " automatic_reconstructor -h", &output),
      0)
      << output;
  for (const char* key :
       {"--workspace_path", "--image_path", "--mapper", "--data_type",
        "--quality", "--camera_model", "--single_camera", "--dense",
        "--GlobalMapper.random_seed", "--SiftExtraction.max_image_size"}) {
    EXPECT_NE(output.find(key), std::string::npos) << key;
  }
}

TEST(AutomaticReconstructor, BadInputGivesOneLineError) {
  const std::string dir = CreateTestDir("automatic_bad_input");
  const std::string images = dir + "/images";
  fs::create_directories(images);
  struct Case {
    std::string arguments;
    std::string message;
  };
  const Case cases[] = {
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper hierarchical",
       "--mapper must be incremental or global"},
      {" --image_path " + dir + "/missing --workspace_path " + dir +
           "/ws --mapper global",
       "does not exist"},
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper global --data_type photos",
       "--data_type must be"},
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper global --camera_model PINHOL",
       "Unknown camera model"},
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper global --GlobalMapper.ba_max_num_iterations -3",
       "ba_max_num_iterations"},
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper global --database_path " + dir + "/other.db",
       "--database_path is not one of its options"},
      // No images: stock 3.8's matcher would abort.
      {" --image_path " + images + " --workspace_path " + dir +
           "/ws --mapper global --use_gpu 0",
       "Found 0 image(s) with features"},
  };
  for (const Case& c : cases) {
    std::string output;
    EXPECT_EQ(RunCommand(
                  ColmapExecutable() + " automatic_reconstructor" + c.arguments,
                  &output),
              1)
        << c.arguments << "\n"
        << output;
    EXPECT_NE(output.find(c.message), std::string::npos) << c.arguments << "\n"
                                                         << output;
    EXPECT_EQ(output.find("Check failed"), std::string::npos) << output;
  }
  EXPECT_FALSE(fs::exists(dir + "/ws/sparse"));
}

// Without --mapper, and with --mapper incremental, COLMAP 3.8's own command
// runs (here without the sparse step, so that it is quick): it writes the
// workspace's database and no sparse folder.
TEST(AutomaticReconstructor, IncrementalIsTheStockCommand) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const std::string source = datasets + "/templeRing/images";
  if (!fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << source << " is absent or empty";
  }
  const std::string dir = CreateTestDir("automatic_incremental");
  const std::string images = LinkImages(source, dir + "/images", 3);
  for (const std::string mapper : {"", " --mapper incremental"}) {
    const std::string workspace = dir + "/ws" + std::to_string(mapper.size());
    fs::create_directories(workspace);
    std::string output;
    ASSERT_EQ(RunCommand(ColmapExecutable() +
                             " automatic_reconstructor --image_path " + images +
                             " --workspace_path " + workspace +
                             " --use_gpu 0 --sparse 0" + mapper,
                         &output),
              0)
        << output;
    EXPECT_EQ(CountRows(workspace + "/database.db", "images"), 3) << output;
    EXPECT_GT(CountRows(workspace + "/database.db", "two_view_geometries"), 0);
    EXPECT_FALSE(fs::exists(workspace + "/sparse"));
    EXPECT_EQ(output.find("Global pipeline"), std::string::npos);
  }
}

// A COLMAP project file gives the image folder and the extraction settings;
// the command line overrides them.
TEST(AutomaticReconstructor, ProjectFileSetsExtractionAndCommandLineWins) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const std::string source = datasets + "/templeRing/images";
  if (!fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << source << " is absent or empty";
  }
  const std::string dir = CreateTestDir("automatic_project_file");
  const std::string images = LinkImages(source, dir + "/images", 3);
  colmap::OptionManager project;
  project.AddAllOptions();
  *project.database_path = dir + "/unused.db";
  *project.image_path = images;
  project.sift_extraction->max_num_features = 300;
  const std::string project_path = dir + "/project.ini";
  project.Write(project_path);

  // Largest number of keypoints of one image in the workspace's database.
  const auto max_keypoints = [](const std::string& workspace) {
    colmap::Database database(workspace + "/database.db");
    size_t max_rows = 0;
    for (const colmap::Image& image : database.ReadAllImages()) {
      max_rows =
          std::max(max_rows, database.NumKeypointsForImage(image.ImageId()));
    }
    return max_rows;
  };
  const std::string command =
      ColmapExecutable() + " automatic_reconstructor --project_path " +
      project_path + " --mapper global --use_gpu 0 --sparse 0";
  std::string output;
  ASSERT_EQ(RunCommand(command + " --workspace_path " + dir + "/ws1", &output),
            0)
      << output;
  EXPECT_EQ(CountRows(dir + "/ws1/database.db", "images"), 3);
  // COLMAP 3.8's CPU SIFT stops at the octave where the limit is passed and
  // adds extra orientations, so the limit is approximate: without it these
  // images have 1,300-1,800 keypoints.
  const size_t from_project = max_keypoints(dir + "/ws1");
  EXPECT_GT(from_project, 200u);
  EXPECT_LT(from_project, 800u);
  EXPECT_FALSE(fs::exists(dir + "/unused.db"));
  ASSERT_EQ(RunCommand(command + " --workspace_path " + dir +
                           "/ws2 --SiftExtraction.max_num_features 100",
                       &output),
            0)
      << output;
  EXPECT_LT(max_keypoints(dir + "/ws2"), 300u);
  EXPECT_LT(max_keypoints(dir + "/ws2"), from_project);
}

// `--data_type video` matches each image with its neighbours in name order
// (3.8's sequential matcher, its section's options from the command line);
// `--dense 1` without CUDA is skipped with one line and the sparse model
// stays.
TEST(AutomaticReconstructor, VideoMatchesSequentiallyAndDenseIsSkipped) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const std::string source = datasets + "/fountain-P11/images";
  if (!fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << source << " is absent or empty";
  }
  const std::string dir = CreateTestDir("automatic_video");
  const int kNumImages = 11;
  const std::string images = LinkImages(source, dir + "/images", kNumImages);
  const std::string workspace = dir + "/ws";
  std::string output;
  ASSERT_EQ(RunCommand(GlobalCommand(images, workspace) +
                           " --data_type video --quality low --dense 1"
                           " --SequentialMatching.overlap 3",
                       &output),
            0)
      << output;
  EXPECT_NE(output.find("sequential (overlap 3"), std::string::npos) << output;
  const std::string dense_line = "WARNING: Skipping dense reconstruction";
  const size_t dense_at = output.find(dense_line);
  EXPECT_NE(dense_at, std::string::npos) << output;
  EXPECT_EQ(output.find(dense_line, dense_at + 1), std::string::npos);
  EXPECT_FALSE(fs::exists(workspace + "/dense"));

  // Only neighbours in name order were matched: 1, 2 and 3 apart, and 4
  // (3.8's quadratic overlap, on by default, adds 1, 2, 4, ... 2^(overlap-1)
  // apart); never all 55 pairs as the exhaustive matcher would.
  colmap::Database database(workspace + "/database.db");
  std::map<colmap::image_t, int> position;
  std::vector<colmap::Image> db_images = database.ReadAllImages();
  std::sort(db_images.begin(), db_images.end(),
            [](const colmap::Image& a, const colmap::Image& b) {
              return a.Name() < b.Name();
            });
  ASSERT_EQ(static_cast<int>(db_images.size()), kNumImages);
  for (size_t i = 0; i < db_images.size(); ++i) {
    position[db_images[i].ImageId()] = static_cast<int>(i);
  }
  const std::vector<std::pair<colmap::image_pair_t, colmap::FeatureMatches>>
      matches = database.ReadAllMatches();
  EXPECT_GT(matches.size(), 0u);
  EXPECT_LT(matches.size(),
            static_cast<size_t>(kNumImages * (kNumImages - 1) / 2));
  for (const auto& [pair_id, pair_matches] : matches) {
    colmap::image_t image_id1 = 0;
    colmap::image_t image_id2 = 0;
    colmap::Database::PairIdToImagePair(pair_id, &image_id1, &image_id2);
    EXPECT_LE(std::abs(position.at(image_id1) - position.at(image_id2)), 4)
        << database.ReadImage(image_id1).Name() << " - "
        << database.ReadImage(image_id2).Name();
  }

  colmap::Reconstruction model;
  ASSERT_TRUE(ReadModel(workspace + "/sparse/0", &model).ok()) << output;
  EXPECT_EQ(static_cast<int>(model.NumRegImages()), kNumImages);
}

struct EndToEndCase {
  std::string dataset;
};

class AutomaticReconstructorEndToEnd
    : public ::testing::TestWithParam<EndToEndCase> {};

// From the shipped images to a model: every image registered, AUC@3 within 1
// of the global mapper's on the dataset's own database (same machine, same
// run of the test), a `--GlobalMapper.*` option reaching the mapper; then a
// rerun that reuses the database's features and matches and replaces the
// model, and an interrupted rerun that keeps it.
TEST_P(AutomaticReconstructorEndToEnd, FromImagesToAModel) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const std::string dataset_dir = datasets + "/" + GetParam().dataset;
  const std::string images = dataset_dir + "/images";
  if (!fs::is_directory(images) || fs::is_empty(images) ||
      !fs::exists(dataset_dir + "/database.db") ||
      !fs::is_directory(dataset_dir + "/gt")) {
    GTEST_SKIP() << GetParam().dataset
                 << " (its images/, database.db and gt/) is not in "
                 << datasets;
  }
  const std::string dir =
      CreateTestDir("automatic_end_to_end_" + GetParam().dataset);
  colmap::Reconstruction truth;
  ASSERT_TRUE(ReadModel(dataset_dir + "/gt", &truth).ok());
  auto evaluate = [&truth](const std::string& model_path) {
    colmap::Reconstruction model;
    EXPECT_TRUE(ReadModel(model_path, &model).ok()) << model_path;
    ModelEvaluation evaluation;
    EXPECT_TRUE(
        EvaluateModel(model, truth, ModelEvaluationOptions(), &evaluation)
            .ok());
    return evaluation;
  };

  // The same mapper on the dataset's own database: the bar.
  std::string output;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " global_mapper --database_path " +
                           dataset_dir + "/database.db --image_path " + images +
                           " --output_path " + dir + "/shared",
                       &output),
            0)
      << output;
  const ModelEvaluation shared = evaluate(dir + "/shared/0");

  // One step from the images.
  const std::string workspace = dir + "/ws";
  const std::string command = GlobalCommand(images, workspace);
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(RunCommand(command + " --GlobalMapper.random_seed 7", &output), 0)
      << output;
  const double first_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  EXPECT_NE(output.find("Global pipeline"), std::string::npos) << output;
  const ModelEvaluation global = evaluate(workspace + "/sparse/0");
  std::cout << GetParam().dataset << ": from images " << global.num_registered
            << "/" << global.num_gt_images << " registered, AUC@3 "
            << global.pose_aucs[1] << "; on the dataset's database "
            << shared.num_registered << "/" << shared.num_gt_images
            << ", AUC@3 " << shared.pose_aucs[1] << "; " << first_s << " s"
            << std::endl;
  EXPECT_EQ(global.num_registered, global.num_gt_images);
  EXPECT_GE(global.pose_aucs[1], shared.pose_aucs[1] - 1);
  const std::string database = workspace + "/database.db";
  // The seed given as --GlobalMapper.random_seed reached the mapper: the
  // global_mapper command with that seed on the workspace's database writes
  // the same model, bit for bit (the same input and seed give the same
  // model); with another seed (below) it differs.
  ASSERT_EQ(
      RunCommand(ColmapExecutable() + " global_mapper --database_path " +
                     database + " --image_path " + images + " --output_path " +
                     dir + "/same_seed --GlobalMapper.random_seed 7",
                 &output),
      0)
      << output;
  EXPECT_EQ(FileDigest(dir + "/same_seed/0/images.bin"),
            FileDigest(workspace + "/sparse/0/images.bin"));
  EXPECT_EQ(FileDigest(dir + "/same_seed/0/points3D.bin"),
            FileDigest(workspace + "/sparse/0/points3D.bin"));
  const long num_keypoint_rows = CountRows(database, "keypoints");
  const long num_pairs = CountRows(database, "two_view_geometries");
  EXPECT_EQ(num_keypoint_rows, global.num_gt_images);

  // A rerun: the database's features and matches are reused (3.8's extractor
  // skips images it has, the matcher pairs it has), the model is replaced.
  const std::string old_model_digest =
      FileDigest(workspace + "/sparse/0/images.bin");
  ASSERT_EQ(RunCommand(command + " --GlobalMapper.random_seed 8", &output), 0)
      << output;
  EXPECT_NE(output.find("already extracted"), std::string::npos) << output;
  EXPECT_EQ(CountRows(database, "keypoints"), num_keypoint_rows);
  EXPECT_EQ(CountRows(database, "two_view_geometries"), num_pairs);
  EXPECT_EQ(IntegrityCheck(database), "ok");
  EXPECT_NE(FileDigest(workspace + "/sparse/0/images.bin"), old_model_digest);
  const ModelEvaluation rerun = evaluate(workspace + "/sparse/0");
  EXPECT_EQ(rerun.num_registered, rerun.num_gt_images);

  // An interrupted rerun (SIGINT while the mapper runs or earlier) keeps the
  // models and the database as they were.
  const std::string kept_digest =
      FileDigest(workspace + "/sparse/0/images.bin");
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string run = command + " --GlobalMapper.random_seed 9";
    execl("/bin/sh", "sh", "-c", ("exec " + run + " > /dev/null 2>&1").c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 128 + SIGINT)
      << "status " << status;
  EXPECT_EQ(FileDigest(workspace + "/sparse/0/images.bin"), kept_digest);
  EXPECT_EQ(IntegrityCheck(database), "ok");
  EXPECT_EQ(CountRows(database, "keypoints"), num_keypoint_rows);
  for (const auto& entry : fs::directory_iterator(workspace + "/sparse")) {
    EXPECT_EQ(entry.path().filename().string().rfind(".global_mapper_tmp", 0),
              std::string::npos)
        << entry.path();
  }
}

INSTANTIATE_TEST_SUITE_P(SharedDatasets, AutomaticReconstructorEndToEnd,
                         ::testing::Values(EndToEndCase{"fountain-P11"},
                                           EndToEndCase{"templeRing"}),
                         [](const auto& info) {
                           std::string name = info.param.dataset;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) {
                               c = '_';
                             }
                           }
                           return name;
                         });

}  // namespace
}  // namespace glomap
