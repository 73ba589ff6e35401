#include "glomap/io/database_reader.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "base/database.h"
#include "estimators/two_view_geometry.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

using colmap::TwoViewGeometry;

colmap::FeatureKeypoints MakeKeypoints(int num, float offset) {
  colmap::FeatureKeypoints keypoints;
  for (int i = 0; i < num; ++i) {
    keypoints.emplace_back(offset + i, 2 * offset + 0.5f * i);
  }
  return keypoints;
}

colmap::FeatureMatches MakeMatches(int num, int shift = 0) {
  colmap::FeatureMatches matches;
  for (int i = 0; i < num; ++i) matches.emplace_back(i, (i + shift) % num);
  return matches;
}

Eigen::Matrix3d MakeMatrix(double start) {
  Eigen::Matrix3d m;
  m << start, start + 1, start + 2, start + 3, start + 4, start + 5, start + 6,
      start + 7, start + 8;
  return m;
}

TwoViewGeometry MakeGeometry(int config, colmap::FeatureMatches matches,
                             double start) {
  TwoViewGeometry geometry;
  geometry.config = config;
  geometry.inlier_matches = std::move(matches);
  geometry.F = MakeMatrix(start);
  geometry.E = MakeMatrix(start + 10);
  // Invertible, so that swapping the pair can invert it.
  geometry.H = Eigen::Matrix3d::Identity() + 0.01 * MakeMatrix(start);
  return geometry;
}

// Four images (ids 1..4) on two cameras and six stored pairs covering every
// filter of the reader.
std::string MakeTestDatabase(const std::string& dir) {
  const std::string path = dir + "/database.db";
  colmap::Database database(path);
  colmap::Camera camera1;
  camera1.InitializeWithName("SIMPLE_RADIAL", 800, 640, 480);
  camera1.Params(3) = -0.01;
  camera1.SetPriorFocalLength(true);
  colmap::Camera camera2;
  camera2.InitializeWithName("PINHOLE", 1000, 800, 600);
  camera2.SetPriorFocalLength(false);
  colmap::Camera unused_camera;
  unused_camera.InitializeWithName("OPENCV", 500, 100, 100);
  const colmap::camera_t camera_id1 = database.WriteCamera(camera1);
  const colmap::camera_t camera_id2 = database.WriteCamera(camera2);
  database.WriteCamera(unused_camera);

  const colmap::camera_t camera_of_image[4] = {camera_id1, camera_id2,
                                               camera_id1, camera_id1};
  const int num_keypoints[4] = {30, 30, 30, 20};
  for (int i = 0; i < 4; ++i) {
    colmap::Image image;
    image.SetName("img" + std::to_string(i + 1) + ".jpg");
    image.SetCameraId(camera_of_image[i]);
    if (i == 1) {
      image.SetQvecPrior(Eigen::Vector4d(1, 0, 0, 0));
      image.SetTvecPrior(Eigen::Vector3d(1, 2, 3));
    }
    const colmap::image_t image_id = database.WriteImage(image);
    EXPECT_EQ(image_id, static_cast<colmap::image_t>(i + 1));
    database.WriteKeypoints(image_id, MakeKeypoints(num_keypoints[i], i * 100));
  }

  // (1,2): calibrated, 20 inliers, 25 raw matches.
  database.WriteMatches(1, 2, MakeMatches(25));
  database.WriteTwoViewGeometry(
      1, 2, MakeGeometry(TwoViewGeometry::CALIBRATED, MakeMatches(20, 1), 1));
  // (3,1) written the other way round: stored canonically as (1,3).
  database.WriteMatches(3, 1, MakeMatches(22));
  database.WriteTwoViewGeometry(
      3, 1,
      MakeGeometry(TwoViewGeometry::UNCALIBRATED, MakeMatches(17, 2), 20));
  // (1,4): only 10 inliers.
  database.WriteTwoViewGeometry(
      1, 4, MakeGeometry(TwoViewGeometry::CALIBRATED, MakeMatches(10), 30));
  // (2,3): a watermark.
  database.WriteTwoViewGeometry(
      2, 3, MakeGeometry(TwoViewGeometry::WATERMARK, MakeMatches(20), 40));
  // (3,4): degenerate.
  database.WriteTwoViewGeometry(
      3, 4, MakeGeometry(TwoViewGeometry::DEGENERATE, MakeMatches(20), 50));
  // (2,4): image 4 has 20 keypoints, so two of these 22 matches are invalid.
  colmap::FeatureMatches out_of_range = MakeMatches(20);
  out_of_range.emplace_back(20, 20);
  out_of_range.emplace_back(3, 25);
  database.WriteTwoViewGeometry(
      2, 4, MakeGeometry(TwoViewGeometry::PLANAR, out_of_range, 60));
  return path;
}

// Runs one SQL statement on a database through SQLite directly (to make
// broken databases that colmap::Database would refuse to write).
void ExecuteSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  EXPECT_EQ(rc, SQLITE_OK) << (message ? message : "");
  sqlite3_free(message);
  sqlite3_close(db);
}

// Runs one SQL statement with one blob parameter (?1).
void ExecuteSqlWithBlob(const std::string& path, const std::string& sql,
                        const void* data, size_t num_bytes) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_bind_blob(stmt, 1, data, static_cast<int>(num_bytes),
                    SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(stmt), SQLITE_DONE) << sqlite3_errmsg(db);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

// A fresh copy of the test database in its own folder, changed by `sql`.
std::string DamagedCopy(const std::string& name, const std::string& sql = "") {
  const std::string path =
      MakeTestDatabase(testing::CreateTestDir("database_reader_" + name));
  if (!sql.empty()) ExecuteSql(path, sql);
  return path;
}

colmap::image_pair_t PairId(colmap::image_t id1, colmap::image_t id2) {
  return colmap::Database::ImagePairToPairId(id1, id2);
}

size_t CountOccurrences(const std::string& text, const std::string& what) {
  size_t count = 0;
  for (size_t pos = text.find(what); pos != std::string::npos;
       pos = text.find(what, pos + 1)) {
    ++count;
  }
  return count;
}

// What the reader made of one database.
struct ReadResult {
  colmap::Reconstruction reconstruction;
  ViewGraph view_graph;
  Status status;
  std::string log;  // the lines it wrote, where ReadAndCaptureLog caught them
};

ReadResult Read(const std::string& path, const DatabaseReaderOptions& options =
                                             DatabaseReaderOptions()) {
  ReadResult result;
  result.status =
      ReadDatabase(path, options, &result.reconstruction, &result.view_graph);
  return result;
}

Status ReadStatus(const std::string& path) { return Read(path).status; }

// Read() with the default options, catching the log lines the reader wrote.
ReadResult ReadAndCaptureLog(const std::string& path) {
  ::testing::internal::CaptureStderr();
  ReadResult result = Read(path);
  result.log = ::testing::internal::GetCapturedStderr();
  return result;
}

// Whether the reader's `log` has `text`; if not, the failure shows the log.
::testing::AssertionResult LogHas(const std::string& log,
                                  const std::string& text) {
  if (log.find(text) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "The log lacks \"" << text << "\":\n"
                                       << log;
}

// Overwrites the parameters of camera `camera_id` in the database at `path`.
void SetCameraParams(const std::string& path, colmap::camera_t camera_id,
                     const std::vector<double>& params) {
  ExecuteSqlWithBlob(path,
                     "UPDATE cameras SET params = ?1 WHERE camera_id = " +
                         std::to_string(camera_id) + ";",
                     params.data(), params.size() * sizeof(double));
}

// SQL that replaces `table` by a copy without its primary key, in which an id
// may repeat.
std::string DropPrimaryKey(const std::string& table) {
  return "CREATE TABLE " + table + "_copy AS SELECT * FROM " + table + ";" +
         "DROP TABLE " + table + ";" + "ALTER TABLE " + table +
         "_copy RENAME TO " + table + ";";
}

TEST(DatabaseReader, ReadsEveryField) {
  const std::string dir = testing::CreateTestDir("database_reader_fields");
  const std::string path = MakeTestDatabase(dir);
  const std::string digest = testing::FileDigest(path);

  const auto& [reconstruction, view_graph, status, log] = Read(path);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(testing::FileDigest(path), digest);
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));

  // Cameras: only the two used ones, with their parameters and prior flags.
  ASSERT_EQ(reconstruction.NumCameras(), 2);
  const colmap::Camera& camera1 = reconstruction.Camera(1);
  EXPECT_EQ(camera1.ModelName(), "SIMPLE_RADIAL");
  EXPECT_EQ(camera1.Width(), 640);
  EXPECT_EQ(camera1.Height(), 480);
  EXPECT_EQ(camera1.Params(), std::vector<double>({800, 320, 240, -0.01}));
  EXPECT_TRUE(camera1.HasPriorFocalLength());
  const colmap::Camera& camera2 = reconstruction.Camera(2);
  EXPECT_EQ(camera2.ModelName(), "PINHOLE");
  EXPECT_EQ(camera2.Params(), std::vector<double>({1000, 1000, 400, 300}));
  EXPECT_FALSE(camera2.HasPriorFocalLength());
  EXPECT_FALSE(reconstruction.ExistsCamera(3));

  // Images: keypoints as Points2D, not registered, identity pose, priors.
  ASSERT_EQ(reconstruction.NumImages(), 4);
  EXPECT_EQ(reconstruction.NumRegImages(), 0);
  for (colmap::image_t image_id = 1; image_id <= 4; ++image_id) {
    const colmap::Image& image = reconstruction.Image(image_id);
    EXPECT_EQ(image.Name(), "img" + std::to_string(image_id) + ".jpg");
    EXPECT_FALSE(image.IsRegistered());
    EXPECT_EQ(image.Qvec(), Eigen::Vector4d(1, 0, 0, 0));
    EXPECT_EQ(image.Tvec(), Eigen::Vector3d::Zero());
    const float offset = (image_id - 1) * 100;
    ASSERT_EQ(image.NumPoints2D(), image_id == 4 ? 20 : 30);
    EXPECT_EQ(image.Point2D(7).XY(),
              Eigen::Vector2d(offset + 7, 2 * offset + 3.5));
  }
  EXPECT_EQ(reconstruction.Image(1).CameraId(), 1);
  EXPECT_EQ(reconstruction.Image(2).CameraId(), 2);
  EXPECT_TRUE(reconstruction.Image(1).QvecPrior().array().isNaN().all());
  EXPECT_EQ(reconstruction.Image(2).TvecPrior(), Eigen::Vector3d(1, 2, 3));

  // Pairs: (1,2), (1,3), (2,3) watermark and (2,4) with 18 valid matches;
  // (1,4) has too few inliers and (3,4) is degenerate.
  const auto& pairs = view_graph.Pairs();
  ASSERT_EQ(pairs.size(), 4);
  const auto pair_id = [](colmap::image_t id1, colmap::image_t id2) {
    return colmap::Database::ImagePairToPairId(id1, id2);
  };
  ASSERT_EQ(pairs.count(pair_id(1, 2)), 1);
  ASSERT_EQ(pairs.count(pair_id(1, 3)), 1);
  ASSERT_EQ(pairs.count(pair_id(2, 3)), 1);
  ASSERT_EQ(pairs.count(pair_id(2, 4)), 1);

  const ImagePair& pair12 = pairs.at(pair_id(1, 2));
  EXPECT_EQ(pair12.image_id1, 1);
  EXPECT_EQ(pair12.image_id2, 2);
  EXPECT_EQ(pair12.config, TwoViewGeometry::CALIBRATED);
  EXPECT_EQ(pair12.num_raw_matches, 25);
  EXPECT_EQ(pair12.F, MakeMatrix(1));  // F(0, 1) == 2: not transposed
  EXPECT_EQ(pair12.E, MakeMatrix(11));
  EXPECT_EQ(pair12.H, Eigen::Matrix3d::Identity() + 0.01 * MakeMatrix(1));
  ASSERT_EQ(pair12.matches.size(), 20);
  EXPECT_EQ(pair12.matches[5].point2D_idx1, 5);
  EXPECT_EQ(pair12.matches[5].point2D_idx2, 6);
  EXPECT_FALSE(pair12.has_relative_pose);
  EXPECT_TRUE(pair12.is_valid);

  // Written as (3,1): stored canonically, so (1,3) sees the swapped matches
  // and the transposed F.
  const ImagePair& pair13 = pairs.at(pair_id(1, 3));
  EXPECT_EQ(pair13.image_id1, 1);
  EXPECT_EQ(pair13.image_id2, 3);
  EXPECT_EQ(pair13.config, TwoViewGeometry::UNCALIBRATED);
  EXPECT_EQ(pair13.num_raw_matches, 22);
  EXPECT_EQ(pair13.F, MakeMatrix(20).transpose());
  ASSERT_EQ(pair13.matches.size(), 17);
  EXPECT_EQ(pair13.matches[4].point2D_idx1, 6);
  EXPECT_EQ(pair13.matches[4].point2D_idx2, 4);

  EXPECT_EQ(pairs.at(pair_id(2, 3)).config, TwoViewGeometry::WATERMARK);
  EXPECT_EQ(pairs.at(pair_id(2, 3)).num_raw_matches, 0);

  const ImagePair& pair24 = pairs.at(pair_id(2, 4));
  EXPECT_EQ(pair24.config, TwoViewGeometry::PLANAR);
  EXPECT_EQ(pair24.matches.size(), 20);
  for (const auto& match : pair24.matches) {
    EXPECT_LT(match.point2D_idx2, 20);
  }
}

TEST(DatabaseReader, Filters) {
  const std::string dir = testing::CreateTestDir("database_reader_filters");
  const std::string path = MakeTestDatabase(dir);
  const auto pair_id = [](colmap::image_t id1, colmap::image_t id2) {
    return colmap::Database::ImagePairToPairId(id1, id2);
  };
  {
    DatabaseReaderOptions options;
    options.min_num_matches = 5;
    const auto& [reconstruction, view_graph, status, log] = Read(path, options);
    ASSERT_TRUE(status.ok());
    EXPECT_EQ(view_graph.NumPairs(), 5);
    EXPECT_EQ(view_graph.Pairs().count(pair_id(1, 4)), 1);
    EXPECT_EQ(view_graph.Pairs().count(pair_id(3, 4)), 0);
  }
  {
    DatabaseReaderOptions options;
    options.min_num_matches = 21;
    const Status status = Read(path, options).status;
    EXPECT_FALSE(status.ok());
    // (2,4) has 22 matches, but only 20 valid ones.
    EXPECT_NE(status.message().find("no verified image pairs with at least 21 "
                                    "matches that can be used (1 pair was left "
                                    "out as unusable"),
              std::string::npos)
        << status.message();
  }
  {
    DatabaseReaderOptions options;
    options.ignore_watermarks = true;
    const auto& [reconstruction, view_graph, status, log] = Read(path, options);
    ASSERT_TRUE(status.ok());
    EXPECT_EQ(view_graph.NumPairs(), 3);
    EXPECT_EQ(view_graph.Pairs().count(pair_id(2, 3)), 0);
  }
  {
    DatabaseReaderOptions options;
    options.image_names = {"img1.jpg", "img3.jpg", "not_there.jpg"};
    const auto& [reconstruction, view_graph, status, log] = Read(path, options);
    ASSERT_TRUE(status.ok());
    EXPECT_EQ(reconstruction.NumImages(), 2);
    EXPECT_TRUE(reconstruction.ExistsImage(1));
    EXPECT_TRUE(reconstruction.ExistsImage(3));
    EXPECT_EQ(reconstruction.NumCameras(), 1);
    ASSERT_EQ(view_graph.NumPairs(), 1);
    EXPECT_EQ(view_graph.Pairs().begin()->first, pair_id(1, 3));
  }
  {
    DatabaseReaderOptions options;
    options.image_names = {"nothing.jpg"};
    EXPECT_FALSE(Read(path, options).status.ok());
  }
}

TEST(DatabaseReader, ReadsWhileWriterHasLog) {
  // A database still open in COLMAP has a write-ahead log: read-only mode
  // (not immutable) must see its content.
  const std::string dir = testing::CreateTestDir("database_reader_wal");
  const std::string path = dir + "/database with ?#% chars.db";
  colmap::Database database(path);
  colmap::Camera camera;
  camera.InitializeWithName("SIMPLE_PINHOLE", 500, 100, 100);
  database.WriteCamera(camera);
  for (int i = 0; i < 2; ++i) {
    colmap::Image image;
    image.SetName("a" + std::to_string(i));
    image.SetCameraId(1);
    database.WriteKeypoints(database.WriteImage(image), MakeKeypoints(40, 1));
  }
  database.WriteTwoViewGeometry(
      1, 2, MakeGeometry(TwoViewGeometry::CALIBRATED, MakeMatches(30), 1));
  ASSERT_TRUE(std::filesystem::exists(path + "-wal"));
  ASSERT_GT(std::filesystem::file_size(path + "-wal"), 0);

  const auto& [reconstruction, view_graph, status, log] = Read(path);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(reconstruction.NumImages(), 2);
  EXPECT_EQ(view_graph.NumPairs(), 1);
}

// Another process writes to the database while it is read, committing
// again and again a change to two tables that are read far apart: camera 1's
// focal (read first) and one verified pair (read last, after every
// keypoint), both changed or both as they were. Every read must see one
// committed state or fail with an error that says why; never a mix. In
// rollback-journal mode the writes rewrite the file under an immutable read;
// in WAL mode they stay in the log, which the reader must go through.
class DatabaseReaderConcurrentWriter
    : public ::testing::TestWithParam<const char*> {};

TEST_P(DatabaseReaderConcurrentWriter, ReadsOneCommittedStateOrRefuses) {
  const std::string journal_mode = GetParam();
  const std::string dir =
      testing::CreateTestDir("database_reader_concurrent_" + journal_mode);
  const std::string path = dir + "/database.db";
  SyntheticSceneOptions scene;
  scene.num_images = 30;
  colmap::Reconstruction ground_truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, path, &ground_truth).ok());
  ASSERT_FALSE(std::filesystem::exists(path + "-wal"));
  const ReadResult original = Read(path);
  ASSERT_TRUE(original.status.ok());
  const double focal = original.reconstruction.Camera(1).Params(0);
  const colmap::image_pair_t pair_id =
      original.view_graph.Pairs().rbegin()->first;

  const pid_t writer = fork();
  ASSERT_GE(writer, 0);
  if (writer == 0) {
    sqlite3* db = nullptr;
    if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) _exit(2);
    sqlite3_busy_timeout(db, 10000);
    auto exec = [db](const std::string& sql) {
      if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) !=
          SQLITE_OK) {
        _exit(3);
      }
    };
    exec("PRAGMA journal_mode=" + journal_mode + ";");
    exec(
        "CREATE TEMP TABLE saved AS SELECT * FROM two_view_geometries "
        "WHERE pair_id=" +
        std::to_string(pair_id) + ";");
    for (int i = 0;; ++i) {
      exec("BEGIN IMMEDIATE;");
      if (i % 2 == 0) {
        exec("DELETE FROM two_view_geometries WHERE pair_id=" +
             std::to_string(pair_id) + ";");
      } else {
        exec("INSERT INTO two_view_geometries SELECT * FROM saved;");
      }
      colmap::Camera camera = original.reconstruction.Camera(1);
      camera.Params(0) = i % 2 == 0 ? 1.5 * focal : focal;
      sqlite3_stmt* stmt = nullptr;
      sqlite3_prepare_v2(db, "UPDATE cameras SET params=? WHERE camera_id=1;",
                         -1, &stmt, nullptr);
      sqlite3_bind_blob(stmt, 1, camera.ParamsData(),
                        sizeof(double) * camera.NumParams(), SQLITE_TRANSIENT);
      sqlite3_step(stmt);
      sqlite3_finalize(stmt);
      exec("COMMIT;");
      usleep(200);  // As a matcher does between blocks.
    }
  }

  int num_reads = 0, num_changed = 0, num_refused = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < end) {
    const auto& [reconstruction, view_graph, status, log] = Read(path);
    ++num_reads;
    if (!status.ok()) {
      ++num_refused;
      EXPECT_NE(status.message().find("another program is writing"),
                std::string::npos)
          << status.message();
      continue;
    }
    const bool camera_changed = reconstruction.Camera(1).Params(0) != focal;
    const bool pair_changed = view_graph.Pairs().count(pair_id) == 0;
    EXPECT_EQ(camera_changed, pair_changed) << "a mix of two states";
    EXPECT_EQ(view_graph.NumPairs() + pair_changed,
              original.view_graph.NumPairs());
    num_changed += camera_changed;
  }
  int status = 0;
  EXPECT_EQ(waitpid(writer, &status, WNOHANG), 0) << "the writer stopped";
  kill(writer, SIGKILL);
  waitpid(writer, &status, 0);
  printf("%s: %d reads, %d saw the changed state, %d refused\n",
         journal_mode.c_str(), num_reads, num_changed, num_refused);
  EXPECT_GT(num_reads, num_refused);
}

INSTANTIATE_TEST_SUITE_P(JournalModes, DatabaseReaderConcurrentWriter,
                         ::testing::Values("WAL", "DELETE"));

// Inputs the fuzzer (tests/fuzz/) found: a verified-match count whose byte
// size overflows int64, and a generated column that makes a 7 KB file read
// as gigabytes of keypoints. Both must be one error, quickly.
TEST(DatabaseReader, FuzzRegressionsAreErrors) {
  const std::filesystem::path dir =
      std::filesystem::path(GLOMAP_SOURCE_DIR) / "tests/fuzz/regressions";
  int num_files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".db") continue;
    ++num_files;
    const std::string copy =
        testing::CreateTestDir("database_reader_fuzz_regression") + "/" +
        entry.path().filename().string();
    std::filesystem::copy_file(entry.path(), copy);
    const Status status = ReadStatus(copy);
    EXPECT_FALSE(status.ok()) << entry.path();
    EXPECT_EQ(status.message().find("Internal error"), std::string::npos)
        << status.message();
    printf("%s: %s\n", entry.path().filename().c_str(),
           status.message().c_str());
  }
  EXPECT_GE(num_files, 2);
}

TEST(DatabaseReader, Errors) {
  const std::string dir = testing::CreateTestDir("database_reader_errors");
  const auto expect_error = [](const Status& status, const std::string& text) {
    EXPECT_FALSE(status.ok());
    EXPECT_NE(status.message().find(text), std::string::npos)
        << status.message();
    EXPECT_EQ(status.message().find('\n'), std::string::npos);
  };

  expect_error(ReadStatus(dir + "/missing.db"), "does not exist");
  expect_error(ReadStatus(dir), "is a folder");

  const std::string text_path = dir + "/text.db";
  std::ofstream(text_path) << "this is not a database, just some text that is "
                              "long enough to be a header\n";
  expect_error(ReadStatus(text_path), "is not a COLMAP database");

  const std::string other_path = dir + "/other.db";
  ExecuteSql(other_path, "CREATE TABLE foo (a INTEGER);");
  expect_error(ReadStatus(other_path), "is not a COLMAP database");

  const std::string empty_path = dir + "/empty.db";
  { colmap::Database database(empty_path); }
  expect_error(ReadStatus(empty_path), "contains no images");

  const std::string one_image_path = dir + "/one_image.db";
  const std::string no_pairs_path = dir + "/no_pairs.db";
  for (const std::string& path : {one_image_path, no_pairs_path}) {
    colmap::Database database(path);
    colmap::Camera camera;
    camera.InitializeWithName("SIMPLE_PINHOLE", 500, 100, 100);
    database.WriteCamera(camera);
    for (const char* name : {"a", "b"}) {
      colmap::Image image;
      image.SetName(name);
      image.SetCameraId(1);
      database.WriteImage(image);
      if (path == one_image_path) break;
    }
  }
  expect_error(ReadStatus(one_image_path),
               "Only one image of " + one_image_path +
                   " can be used (a): a reconstruction needs at least two.");
  expect_error(ReadStatus(no_pairs_path),
               "no verified image pairs with at least 15 matches: run a "
               "matcher first");

  // Damage to a copy of the test database, and the error it gives.
  const struct {
    std::string name;
    std::string sql;
    std::string error;
  } damages[] = {
      {"model", "UPDATE cameras SET model = 42 WHERE camera_id = 1;",
       "unsupported camera model id 42"},
      {"params",
       "UPDATE cameras SET params = zeroblob(24) WHERE camera_id = 2;",
       "has 3 parameters, but its model PINHOLE needs 4"},
      {"camera_ref", "UPDATE images SET camera_id = 99 WHERE image_id = 2;",
       "refers to camera 99"},
      {"keypoints", "UPDATE keypoints SET cols = 3;", "is corrupt"},
      {"no_table", "DROP TABLE two_view_geometries;",
       "is not a COLMAP database (no table two_view_geometries)"},
  };
  for (const auto& damage : damages) {
    SCOPED_TRACE(damage.name);
    expect_error(ReadStatus(DamagedCopy("errors_" + damage.name, damage.sql)),
                 damage.error);
  }
}

// Keypoints with NaN or infinite coordinates keep their index (so that the
// model's point2D indices stay the database's) but no match that uses them
// is read; one warning per image says how much was dropped.
TEST(DatabaseReader, NonFiniteKeypointsAndTheirMatchesAreDropped) {
  const std::string path = DamagedCopy("nonfinite_keypoints");
  // Image 1: keypoint 5 has x = NaN and keypoint 6 y = inf (two columns).
  std::vector<float> keypoints1;
  for (const colmap::FeatureKeypoint& keypoint : MakeKeypoints(30, 0)) {
    keypoints1.push_back(keypoint.x);
    keypoints1.push_back(keypoint.y);
  }
  keypoints1[2 * 5] = std::numeric_limits<float>::quiet_NaN();
  keypoints1[2 * 6 + 1] = std::numeric_limits<float>::infinity();
  ExecuteSqlWithBlob(path,
                     "UPDATE keypoints SET rows = 30, cols = 2, data = ?1 "
                     "WHERE image_id = 1;",
                     keypoints1.data(), keypoints1.size() * sizeof(float));
  // Image 4: every keypoint is NaN.
  const std::vector<float> keypoints4(20 * 6,
                                      -std::numeric_limits<float>::quiet_NaN());
  ExecuteSqlWithBlob(path, "UPDATE keypoints SET data = ?1 WHERE image_id = 4;",
                     keypoints4.data(), keypoints4.size() * sizeof(float));

  const auto& [reconstruction, view_graph, status, log] =
      ReadAndCaptureLog(path);
  ASSERT_TRUE(status.ok()) << status.message();

  // (1,2) matches keypoint i of image 1 to i+1 of image 2, (1,3) keypoint
  // (i+2) mod 17 of image 1 to i of image 3: both lose two matches. (2,4)
  // keeps none and is dropped; (2,3) is untouched.
  const auto& pairs = view_graph.Pairs();
  ASSERT_EQ(pairs.size(), 3);
  EXPECT_EQ(pairs.at(PairId(1, 2)).matches.size(), 18);
  EXPECT_EQ(pairs.at(PairId(1, 3)).matches.size(), 15);
  EXPECT_EQ(pairs.at(PairId(2, 3)).matches.size(), 20);
  EXPECT_EQ(pairs.count(PairId(2, 4)), 0);
  for (const auto& [pair_id, pair] : pairs) {
    for (const colmap::FeatureMatch& match : pair.matches) {
      EXPECT_TRUE(reconstruction.Image(pair.image_id1)
                      .Point2D(match.point2D_idx1)
                      .XY()
                      .allFinite());
      EXPECT_TRUE(reconstruction.Image(pair.image_id2)
                      .Point2D(match.point2D_idx2)
                      .XY()
                      .allFinite());
    }
  }
  ASSERT_EQ(reconstruction.Image(1).NumPoints2D(), 30);
  EXPECT_TRUE(std::isnan(reconstruction.Image(1).Point2D(5).X()));
  EXPECT_EQ(reconstruction.Image(1).Point2D(7).XY(), Eigen::Vector2d(7, 3.5));

  EXPECT_EQ(CountOccurrences(log, "non-finite coordinates"), 2) << log;
  EXPECT_TRUE(
      LogHas(log, "Image img1.jpg in " + path +
                      " has non-finite coordinates (NaN or infinite) in 2 of "
                      "30 keypoints: they are not used, nor the 4 verified "
                      "matches that use them."));
  EXPECT_TRUE(
      LogHas(log, "Image img4.jpg in " + path +
                      " has non-finite coordinates (NaN or infinite) in 20 of "
                      "20 keypoints: they are not used, nor the 20 verified "
                      "matches that use them."));
  EXPECT_TRUE(
      LogHas(log, "Ignored 1 verified pair in " + path +
                      " left with fewer than 15 usable matches (e.g. images "
                      "img2.jpg and img4.jpg)."));
}

// A camera whose values no camera has leaves its images out, as COLMAP's
// incremental mapper skips images whose camera has bogus parameters; the
// warning names the camera, and the error does when nothing is left.
TEST(DatabaseReader, UnusableCameraLeavesItsImagesOut) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const struct {
    std::string name;
    // PINHOLE parameters of camera 2 (800x600): fx, fy, cx, cy.
    std::vector<double> params;
    std::string problem;
  } cases[] = {
      {"nan", {nan, 1000, 400, 300}, "has non-finite parameters (nan, 1000"},
      {"inf", {1000, 1000, 400, -HUGE_VAL}, "has non-finite parameters"},
      {"negative_focal",
       {1000, -5, 400, 300},
       "has the focal length -5 px, which is not positive"},
      {"zero_focal",
       {0, 1000, 400, 300},
       "has the focal length 0 px, which is not positive"},
      {"principal_point",
       {1000, 1000, 1e7, 300},
       "has its principal point at (1e+07, 300) px, far outside its 800x600 "
       "image"},
  };
  for (const auto& c : cases) {
    const std::string path = DamagedCopy("camera_" + c.name);
    SetCameraParams(path, 2, c.params);
    const auto& [reconstruction, view_graph, status, log] =
        ReadAndCaptureLog(path);
    ASSERT_TRUE(status.ok()) << c.name << ": " << status.message();
    EXPECT_EQ(reconstruction.NumImages(), 3) << c.name;
    EXPECT_FALSE(reconstruction.ExistsImage(2)) << c.name;
    EXPECT_FALSE(reconstruction.ExistsCamera(2)) << c.name;
    ASSERT_EQ(view_graph.NumPairs(), 1) << c.name;
    EXPECT_EQ(view_graph.Pairs().begin()->first, PairId(1, 3)) << c.name;
    EXPECT_TRUE(LogHas(log, "Camera 2 in " + path + " " + c.problem)) << c.name;
    EXPECT_TRUE(LogHas(log, "its 1 image is left out.")) << c.name;
    EXPECT_EQ(CountOccurrences(log, "Camera 2"), 1) << c.name << ": " << log;
    // Pairs with a left-out image are no damage of their own.
    EXPECT_EQ(log.find("do not name two images"), std::string::npos) << log;
  }

  // An unused camera is never looked at.
  {
    const std::string path = DamagedCopy("camera_unused");
    const std::vector<double> params(8, nan);
    SetCameraParams(path, 3, params);
    const auto& [reconstruction, view_graph, status, log] =
        ReadAndCaptureLog(path);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(reconstruction.NumImages(), 4);
    EXPECT_EQ(log.find("Camera 3"), std::string::npos) << log;
  }

  // Camera 1 has three of the four images: one image is too few.
  const std::vector<double> bad_camera1 = {-800, 320, 240, -0.01};
  const std::string one_left_path = DamagedCopy("camera_one_left");
  SetCameraParams(one_left_path, 1, bad_camera1);
  Status status = ReadStatus(one_left_path);
  EXPECT_EQ(status.message(),
            "Only one image of " + one_left_path +
                " can be used (img2.jpg): a reconstruction needs at least two "
                "(3 more are left out: their cameras are unusable, see the "
                "warnings above).");

  // No usable camera at all: the error names one.
  const std::vector<double> bad_camera2 = {1000, 1000, 400, nan};
  SetCameraParams(one_left_path, 2, bad_camera2);
  status = ReadStatus(one_left_path);
  EXPECT_EQ(status.message(),
            "No image of " + one_left_path +
                " can be used: camera 1 has the focal length -800 px, which "
                "is not positive, and the other camera of its images is "
                "unusable too.");
}

// Tables without their primary key may repeat an id. COLMAP reads the first
// row of an id (and its matchers used it), so the reader does too, and
// warns; a repeated keypoint row used to abort in Image::SetPoints2D.
TEST(DatabaseReader, RepeatedRowsUseTheFirst) {
  const std::string pair12 = std::to_string(PairId(1, 2));
  const std::string path = DamagedCopy(
      "repeated_rows",
      DropPrimaryKey("keypoints") +
          "INSERT INTO keypoints SELECT * FROM keypoints WHERE image_id = 2;"
          "INSERT INTO keypoints VALUES (1, 3, 2, zeroblob(24));"
          "INSERT INTO keypoints VALUES (1, 1, 2, zeroblob(8));" +
          DropPrimaryKey("images") +
          "INSERT INTO images (image_id, name, camera_id) "
          "VALUES (3, 'again3.jpg', 2);" +
          DropPrimaryKey("two_view_geometries") +
          "INSERT INTO two_view_geometries SELECT * FROM two_view_geometries "
          "WHERE pair_id = " +
          pair12 +
          ";"
          "UPDATE two_view_geometries SET config = 4 "
          "WHERE rowid = last_insert_rowid();");
  const auto& [reconstruction, view_graph, status, log] =
      ReadAndCaptureLog(path);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(reconstruction.NumImages(), 4);
  EXPECT_EQ(reconstruction.Image(1).NumPoints2D(), 30);
  EXPECT_EQ(reconstruction.Image(2).NumPoints2D(), 30);
  EXPECT_EQ(reconstruction.Image(3).Name(), "img3.jpg");
  EXPECT_EQ(reconstruction.Image(3).CameraId(), 1);
  EXPECT_EQ(view_graph.NumPairs(), 4);
  EXPECT_EQ(view_graph.Pairs().at(PairId(1, 2)).config,
            TwoViewGeometry::CALIBRATED);
  EXPECT_TRUE(
      LogHas(log, "Image img1.jpg has 3 keypoint rows in " + path +
                      "; the first is used, as COLMAP does, and 2 later rows "
                      "ignored."));
  EXPECT_TRUE(
      LogHas(log, "Image img2.jpg has 2 keypoint rows in " + path +
                      "; the first is used, as COLMAP does, and 1 later row "
                      "ignored."));
  EXPECT_TRUE(LogHas(log, "Ignored 1 row of the images table of " + path +
                              " that repeat an image id"));
  EXPECT_TRUE(LogHas(log, "Ignored 1 repeated row of two_view_geometries in " +
                              path + " (e.g. images img1.jpg and img2.jpg)"));
}

// Pairs that name no two images of the database and configs that COLMAP
// never writes are ignored; unusable stored matrices are ignored, but the
// pair's inlier matches are kept. One warning per kind, with an example.
TEST(DatabaseReader, UnknownImagesAndUnusableGeometries) {
  const auto copy_of_12 = [](colmap::image_pair_t pair_id) {
    return "INSERT INTO two_view_geometries (pair_id, rows, cols, data, "
           "config, F, E, H) SELECT " +
           std::to_string(pair_id) +
           ", rows, cols, data, config, F, E, H FROM two_view_geometries "
           "WHERE pair_id = " +
           std::to_string(PairId(1, 2)) + ";";
  };
  const std::string path = DamagedCopy(
      "unusable_geometries",
      copy_of_12(PairId(1, 99)) + copy_of_12(PairId(2, 2)) +
          "UPDATE two_view_geometries SET config = 42 WHERE pair_id = " +
          std::to_string(PairId(1, 3)) +
          ";"
          "UPDATE two_view_geometries SET F = NULL, E = zeroblob(0) "
          "WHERE pair_id = " +
          std::to_string(PairId(1, 2)) + ";");
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> nonfinite_h =
      Eigen::Matrix3d::Identity();
  nonfinite_h(1, 2) = std::numeric_limits<double>::infinity();
  ExecuteSqlWithBlob(path,
                     "UPDATE two_view_geometries SET H = ?1 WHERE pair_id = " +
                         std::to_string(PairId(2, 4)) + ";",
                     nonfinite_h.data(), 9 * sizeof(double));

  const auto& [reconstruction, view_graph, status, log] =
      ReadAndCaptureLog(path);
  ASSERT_TRUE(status.ok()) << status.message();
  const auto& pairs = view_graph.Pairs();
  ASSERT_EQ(pairs.size(), 3);
  const ImagePair& pair12 = pairs.at(PairId(1, 2));
  EXPECT_EQ(pair12.F, Eigen::Matrix3d::Zero());
  EXPECT_EQ(pair12.E, Eigen::Matrix3d::Zero());
  EXPECT_EQ(pair12.H, Eigen::Matrix3d::Identity() + 0.01 * MakeMatrix(1));
  EXPECT_EQ(pair12.matches.size(), 20);
  EXPECT_EQ(pairs.count(PairId(1, 3)), 0);
  EXPECT_EQ(pairs.at(PairId(2, 4)).H, Eigen::Matrix3d::Zero());
  EXPECT_EQ(pairs.at(PairId(2, 4)).matches.size(), 20);
  EXPECT_EQ(pairs.count(PairId(2, 3)), 1);

  EXPECT_TRUE(LogHas(
      log, "Ignored 2 verified pairs in " + path +
               " that do not name two images of the database (e.g. "
               "pair id " +
               std::to_string(PairId(1, 99)) + ": image ids 1 and 99)."));
  EXPECT_TRUE(
      LogHas(log, "Ignored 1 verified pair in " + path +
                      " whose config is not a COLMAP two-view geometry type "
                      "(0 to 8; e.g. images img1.jpg and img3.jpg: config "
                      "42)."));
  EXPECT_TRUE(LogHas(
      log, "Ignored the stored F, E or H of 2 verified pairs in " + path +
               " (NULL, empty or not finite; e.g. images img1.jpg and "
               "img2.jpg): their inlier matches are used"));
}

// A run with too little left fails with an error that says why.
TEST(DatabaseReader, NothingUsableLeftIsAnError) {
  const std::string path = DamagedCopy(
      "nothing_left", "UPDATE two_view_geometries SET config = 42;");
  const Status status = ReadStatus(path);
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.message(),
            "The database " + path +
                " has no verified image pairs with at least 15 matches that "
                "can be used (5 pairs were left out as unusable, see the "
                "warnings above).");
}

TEST(DatabaseReader, RealDatabaseStaysUnchanged) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "shared datasets are absent";
  const std::string path = datasets + "/fountain-P11/database.db";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent";
  const std::string digest = testing::FileDigest(path);
  const auto mtime = std::filesystem::last_write_time(path);

  const auto& [reconstruction, view_graph, status, log] = Read(path);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(reconstruction.NumImages(), 11);
  EXPECT_GT(view_graph.NumPairs(), 0);
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    EXPECT_LT(pair.image_id1, pair.image_id2);
    EXPECT_GE(pair.matches.size(), 15);
    EXPECT_GE(pair.num_raw_matches, static_cast<int>(pair.matches.size()));
    EXPECT_NE(pair.F.norm(), 0);
  }
  EXPECT_EQ(testing::FileDigest(path), digest);
  EXPECT_EQ(std::filesystem::last_write_time(path), mtime);
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
}

}  // namespace
}  // namespace glomap
