#include "glomap/database_reader.h"

#include <sqlite3.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "base/camera_models.h"
#include "estimators/two_view_geometry.h"
#include "util/logging.h"

namespace glomap {
namespace {

// COLMAP 3.8's Database::kMaxNumImages: pair_id = id1 * kMax + id2.
constexpr int64_t kPairIdFactor = 2147483647;

using colmap::TwoViewGeometry;

struct SqliteCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StatementFinalizer {
  void operator()(sqlite3_stmt* stmt) const { sqlite3_finalize(stmt); }
};
using SqlitePtr = std::unique_ptr<sqlite3, SqliteCloser>;
using StatementPtr = std::unique_ptr<sqlite3_stmt, StatementFinalizer>;

// SQLite URIs take a percent-encoded path; everything but unreserved
// characters and '/' is encoded so that '?', '#', '%' or spaces in a user's
// path cannot be read as URI syntax.
std::string PercentEncodePath(const std::string& path) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string encoded;
  encoded.reserve(path.size() * 3);
  for (const unsigned char c : path) {
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ||
        (c >= '0' && c <= '9') || c == '-' || c == '.' || c == '_' ||
        c == '~' || c == '/') {
      encoded.push_back(static_cast<char>(c));
    } else {
      encoded.push_back('%');
      encoded.push_back(kHex[c >> 4]);
      encoded.push_back(kHex[c & 15]);
    }
  }
  return encoded;
}

bool NonEmptyFileExists(const std::string& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  return !error && size > 0;
}

// Reads a database through one read-only connection and turns every SQLite
// failure into a one-line Status.
class Reader {
 public:
  Reader(std::string path, const DatabaseReaderOptions& options)
      : path_(std::move(path)), options_(options) {}

  Status Open();
  Status CheckSchema();
  Status ReadCameras();
  Status ReadImages();
  Status ReadKeypoints();
  Status ReadRawMatchCounts();
  Status ReadVerifiedPairs(ViewGraph* view_graph);
  void MoveInto(colmap::Reconstruction* reconstruction);

  size_t NumImages() const { return images_.size(); }

 private:
  Status Prepare(const char* sql, StatementPtr* stmt);
  Status StepError(const char* what) const;
  Status Corrupt(const std::string& what) const {
    return Status::Error("The database " + path_ + " is corrupt: " + what +
                         ".");
  }

  const std::string path_;
  const DatabaseReaderOptions& options_;
  SqlitePtr db_;

  std::unordered_map<colmap::camera_t, colmap::Camera> cameras_;
  std::unordered_map<colmap::image_t, colmap::Image> images_;
  std::unordered_map<colmap::image_t, uint32_t> num_points2D_;
  std::unordered_map<colmap::image_pair_t, int> num_raw_matches_;
};

Status Reader::Open() {
  std::error_code error;
  const std::filesystem::file_status status =
      std::filesystem::status(path_, error);
  if (error || !std::filesystem::exists(status)) {
    return Status::Error("The database file " + path_ + " does not exist.");
  }
  if (std::filesystem::is_directory(status)) {
    return Status::Error("The database path " + path_ +
                         " is a folder, not a database file.");
  }
  if (!std::ifstream(path_, std::ios::binary).is_open()) {
    return Status::Error("The database file " + path_ +
                         " cannot be read (check its permissions).");
  }

  // immutable=1 tells SQLite that nobody changes the file while we read it,
  // so it takes no locks and creates no -shm or -journal files next to it.
  // That is only true when no write-ahead log or hot journal holds pending
  // changes; then plain read-only mode lets SQLite read them.
  const bool pending_changes = NonEmptyFileExists(path_ + "-wal") ||
                               NonEmptyFileExists(path_ + "-journal");
  const std::string uri =
      "file:" + PercentEncodePath(path_) +
      (pending_changes ? "?mode=ro" : "?mode=ro&immutable=1");
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  db_.reset(db);
  if (rc != SQLITE_OK) {
    return Status::Error("The database file " + path_ + " cannot be opened: " +
                         (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)) + ".");
  }
  return Status::Ok();
}

Status Reader::Prepare(const char* sql, StatementPtr* stmt) {
  sqlite3_stmt* raw = nullptr;
  const int rc = sqlite3_prepare_v2(db_.get(), sql, -1, &raw, nullptr);
  stmt->reset(raw);
  if (rc == SQLITE_NOTADB) {
    return Status::Error(path_ +
                         " is not a COLMAP database (not an SQLite file).");
  }
  if (rc != SQLITE_OK) {
    // A missing column means another schema (e.g. COLMAP 4's).
    return Status::Error(path_ + " is not a COLMAP 3.8 database: " +
                         sqlite3_errmsg(db_.get()) + ".");
  }
  return Status::Ok();
}

Status Reader::StepError(const char* what) const {
  return Status::Error("Reading " + std::string(what) + " from " + path_ +
                       " failed: " + sqlite3_errmsg(db_.get()) + ".");
}

Status Reader::CheckSchema() {
  StatementPtr stmt;
  Status status =
      Prepare("SELECT name FROM sqlite_master WHERE type='table';", &stmt);
  if (!status.ok()) return status;
  std::unordered_set<std::string> tables;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    const unsigned char* name = sqlite3_column_text(stmt.get(), 0);
    if (name) tables.insert(reinterpret_cast<const char*>(name));
  }
  if (rc == SQLITE_NOTADB) {
    return Status::Error(path_ +
                         " is not a COLMAP database (not an SQLite file).");
  }
  if (rc != SQLITE_DONE) return StepError("the table list");

  std::string missing;
  for (const char* table :
       {"cameras", "images", "keypoints", "matches", "two_view_geometries"}) {
    if (tables.count(table) == 0) missing += std::string(" ") + table;
  }
  if (!missing.empty()) {
    if (tables.count("inlier_matches") > 0) {
      return Status::Error(
          path_ +
          " is a COLMAP database from before version 3.5; open it once with "
          "COLMAP 3.8 to upgrade it.");
    }
    return Status::Error(path_ + " is not a COLMAP database (no table" +
                         missing + ").");
  }
  return Status::Ok();
}

Status Reader::ReadCameras() {
  StatementPtr stmt;
  Status status = Prepare(
      "SELECT camera_id, model, width, height, params, prior_focal_length "
      "FROM cameras;",
      &stmt);
  if (!status.ok()) return status;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t camera_id = sqlite3_column_int64(row, 0);
    const int64_t model_id = sqlite3_column_int64(row, 1);
    const int64_t width = sqlite3_column_int64(row, 2);
    const int64_t height = sqlite3_column_int64(row, 3);
    const std::string camera_name = "camera " + std::to_string(camera_id);
    if (camera_id < 0 ||
        camera_id >= std::numeric_limits<colmap::camera_t>::max()) {
      return Corrupt("invalid camera id " + std::to_string(camera_id));
    }
    if (model_id < 0 || model_id > std::numeric_limits<int>::max() ||
        !colmap::ExistsCameraModelWithId(static_cast<int>(model_id))) {
      return Status::Error(camera_name + " in " + path_ +
                           " has the unsupported camera model id " +
                           std::to_string(model_id) +
                           " (COLMAP 3.8 knows the ids 0 to 10).");
    }
    if (width <= 0 || height <= 0) {
      return Status::Error(
          camera_name + " in " + path_ + " has an invalid image size " +
          std::to_string(width) + "x" + std::to_string(height) + ".");
    }
    const int num_bytes = sqlite3_column_bytes(row, 4);
    const size_t expected_params =
        colmap::CameraModelNumParams(static_cast<int>(model_id));
    if (num_bytes % sizeof(double) != 0 ||
        num_bytes / sizeof(double) != expected_params) {
      return Status::Error(
          camera_name + " in " + path_ + " has " +
          (num_bytes % sizeof(double) == 0
               ? std::to_string(num_bytes / sizeof(double))
               : std::string("a broken list of")) +
          " parameters, but its model " +
          colmap::CameraModelIdToName(static_cast<int>(model_id)) + " needs " +
          std::to_string(expected_params) + ".");
    }
    colmap::Camera camera;
    camera.SetCameraId(static_cast<colmap::camera_t>(camera_id));
    camera.SetModelId(static_cast<int>(model_id));
    camera.SetWidth(static_cast<size_t>(width));
    camera.SetHeight(static_cast<size_t>(height));
    if (num_bytes > 0) {
      std::memcpy(camera.ParamsData(), sqlite3_column_blob(row, 4), num_bytes);
    }
    camera.SetPriorFocalLength(sqlite3_column_int64(row, 5) != 0);
    cameras_.emplace(camera.CameraId(), std::move(camera));
  }
  if (rc != SQLITE_DONE) return StepError("cameras");
  return Status::Ok();
}

Status Reader::ReadImages() {
  const std::unordered_set<std::string> selected(options_.image_names.begin(),
                                                 options_.image_names.end());
  StatementPtr stmt;
  Status status = Prepare(
      "SELECT image_id, name, camera_id, prior_qw, prior_qx, prior_qy, "
      "prior_qz, prior_tx, prior_ty, prior_tz FROM images;",
      &stmt);
  if (!status.ok()) return status;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t image_id = sqlite3_column_int64(row, 0);
    const unsigned char* name_text = sqlite3_column_text(row, 1);
    const std::string name =
        name_text ? reinterpret_cast<const char*>(name_text) : "";
    if (!selected.empty() && selected.count(name) == 0) continue;
    if (image_id < 0 || image_id >= kPairIdFactor) {
      return Corrupt("invalid image id " + std::to_string(image_id));
    }
    const int64_t camera_id = sqlite3_column_int64(row, 2);
    if (camera_id < 0 ||
        cameras_.count(static_cast<colmap::camera_t>(camera_id)) == 0) {
      return Status::Error("Image " + name + " (id " +
                           std::to_string(image_id) + ") in " + path_ +
                           " refers to camera " + std::to_string(camera_id) +
                           ", which is not in the database.");
    }
    colmap::Image image;
    image.SetImageId(static_cast<colmap::image_t>(image_id));
    image.SetName(name);
    image.SetCameraId(static_cast<colmap::camera_t>(camera_id));
    // COLMAP stores unset priors (NaN) as NULL; Image's defaults are NaN.
    for (int i = 0; i < 4; ++i) {
      if (sqlite3_column_type(row, 3 + i) != SQLITE_NULL) {
        image.QvecPrior(i) = sqlite3_column_double(row, 3 + i);
      }
    }
    for (int i = 0; i < 3; ++i) {
      if (sqlite3_column_type(row, 7 + i) != SQLITE_NULL) {
        image.TvecPrior(i) = sqlite3_column_double(row, 7 + i);
      }
    }
    images_.emplace(image.ImageId(), std::move(image));
  }
  if (rc != SQLITE_DONE) return StepError("images");

  if (images_.empty()) {
    if (selected.empty()) {
      return Status::Error("The database " + path_ + " contains no images.");
    }
    return Status::Error("None of the " + std::to_string(selected.size()) +
                         " requested image names is in the database " + path_ +
                         ".");
  }
  if (!selected.empty() && images_.size() < selected.size()) {
    LOG(WARNING) << selected.size() - images_.size()
                 << " of the requested image names are not in the database "
                 << path_ << "; ignoring them.";
  }
  return Status::Ok();
}

Status Reader::ReadKeypoints() {
  StatementPtr stmt;
  Status status =
      Prepare("SELECT image_id, rows, cols, data FROM keypoints;", &stmt);
  if (!status.ok()) return status;
  std::vector<Eigen::Vector2d> points;
  std::vector<float> row_values;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t image_id = sqlite3_column_int64(row, 0);
    const auto image_it = images_.find(static_cast<colmap::image_t>(image_id));
    if (image_id < 0 || image_it == images_.end()) continue;
    const int64_t rows = sqlite3_column_int64(row, 1);
    const int64_t cols = sqlite3_column_int64(row, 2);
    const std::string what =
        "the keypoints of image " + image_it->second.Name();
    if (rows < 0 || rows >= std::numeric_limits<uint32_t>::max()) {
      return Corrupt(what + " have an invalid count");
    }
    if (rows == 0) continue;
    if (cols != 2 && cols != 4 && cols != 6) {
      return Corrupt(what + " have " + std::to_string(cols) +
                     " columns (expected 2, 4 or 6)");
    }
    const void* blob = sqlite3_column_blob(row, 3);
    const int64_t num_bytes = sqlite3_column_bytes(row, 3);
    if (blob == nullptr ||
        num_bytes != rows * cols * static_cast<int64_t>(sizeof(float))) {
      return Corrupt(what + " do not have the stored size");
    }
    // The blob is row-major float32 (x, y first); copy it once and pick the
    // coordinates, since SQLite does not promise aligned blob memory.
    row_values.resize(static_cast<size_t>(rows * cols));
    std::memcpy(row_values.data(), blob, static_cast<size_t>(num_bytes));
    points.resize(static_cast<size_t>(rows));
    for (int64_t i = 0; i < rows; ++i) {
      points[i] =
          Eigen::Vector2d(row_values[i * cols], row_values[i * cols + 1]);
    }
    image_it->second.SetPoints2D(points);
    num_points2D_[image_it->first] = static_cast<uint32_t>(rows);
  }
  if (rc != SQLITE_DONE) return StepError("keypoints");
  return Status::Ok();
}

Status Reader::ReadRawMatchCounts() {
  // Only the count column: the match blobs themselves are never loaded.
  StatementPtr stmt;
  Status status = Prepare("SELECT pair_id, rows FROM matches;", &stmt);
  if (!status.ok()) return status;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    num_raw_matches_[static_cast<colmap::image_pair_t>(
        sqlite3_column_int64(stmt.get(), 0))] =
        static_cast<int>(sqlite3_column_int64(stmt.get(), 1));
  }
  if (rc != SQLITE_DONE) return StepError("matches");
  return Status::Ok();
}

// Reads a 3x3 float64 matrix stored row-major (COLMAP transposes Eigen's
// column-major matrices before writing); an empty blob means "not set".
bool ReadMatrixBlob(sqlite3_stmt* row, int col, Eigen::Matrix3d* matrix) {
  const int num_bytes = sqlite3_column_bytes(row, col);
  if (num_bytes == 0) {
    matrix->setZero();
    return true;
  }
  if (num_bytes != 9 * sizeof(double)) return false;
  double values[9];
  std::memcpy(values, sqlite3_column_blob(row, col), sizeof(values));
  *matrix =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(values);
  return true;
}

Status Reader::ReadVerifiedPairs(ViewGraph* view_graph) {
  StatementPtr stmt;
  Status status = Prepare(
      "SELECT pair_id, rows, cols, data, config, F, E, H "
      "FROM two_view_geometries WHERE rows >= ?1;",
      &stmt);
  if (!status.ok()) return status;
  const int min_num_matches = std::max(options_.min_num_matches, 1);
  sqlite3_bind_int64(stmt.get(), 1, min_num_matches);

  size_t num_dropped_matches = 0;
  size_t num_pairs_with_dropped = 0;
  std::vector<uint32_t> blob_values;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t pair_id = sqlite3_column_int64(row, 0);
    if (pair_id < 0) continue;
    const int64_t id2 = pair_id % kPairIdFactor;
    const int64_t id1 = pair_id / kPairIdFactor;
    if (id1 >= kPairIdFactor || id1 == id2) continue;
    const auto image1 = images_.find(static_cast<colmap::image_t>(id1));
    const auto image2 = images_.find(static_cast<colmap::image_t>(id2));
    if (image1 == images_.end() || image2 == images_.end()) continue;

    const int config = static_cast<int>(sqlite3_column_int64(row, 4));
    if (config == TwoViewGeometry::UNDEFINED ||
        config == TwoViewGeometry::DEGENERATE ||
        config == TwoViewGeometry::MULTIPLE ||
        (options_.ignore_watermarks && config == TwoViewGeometry::WATERMARK)) {
      continue;
    }

    const std::string what = "the verified matches of images " +
                             image1->second.Name() + " and " +
                             image2->second.Name();
    const int64_t rows = sqlite3_column_int64(row, 1);
    const int64_t cols = sqlite3_column_int64(row, 2);
    const void* blob = sqlite3_column_blob(row, 3);
    const int64_t num_bytes = sqlite3_column_bytes(row, 3);
    if (cols != 2 || blob == nullptr ||
        num_bytes != rows * 2 * static_cast<int64_t>(sizeof(uint32_t))) {
      return Corrupt(what + " do not have the stored size");
    }

    ImagePair pair;
    pair.image_id1 = image1->first;
    pair.image_id2 = image2->first;
    pair.config = config;
    if (!ReadMatrixBlob(row, 5, &pair.F) || !ReadMatrixBlob(row, 6, &pair.E) ||
        !ReadMatrixBlob(row, 7, &pair.H)) {
      return Corrupt("the two-view geometry of images " +
                     image1->second.Name() + " and " + image2->second.Name() +
                     " has a matrix of the wrong size");
    }

    // Matches may only name keypoints that exist; a stale or foreign
    // database must not make later stages index out of bounds.
    const auto n1_it = num_points2D_.find(pair.image_id1);
    const auto n2_it = num_points2D_.find(pair.image_id2);
    const uint32_t num_points1 =
        n1_it == num_points2D_.end() ? 0 : n1_it->second;
    const uint32_t num_points2 =
        n2_it == num_points2D_.end() ? 0 : n2_it->second;
    blob_values.resize(static_cast<size_t>(rows * 2));
    std::memcpy(blob_values.data(), blob, static_cast<size_t>(num_bytes));
    pair.matches.reserve(static_cast<size_t>(rows));
    for (int64_t i = 0; i < rows; ++i) {
      const uint32_t idx1 = blob_values[2 * i];
      const uint32_t idx2 = blob_values[2 * i + 1];
      if (idx1 < num_points1 && idx2 < num_points2) {
        pair.matches.emplace_back(idx1, idx2);
      }
    }
    if (pair.matches.size() < static_cast<size_t>(rows)) {
      num_dropped_matches += static_cast<size_t>(rows) - pair.matches.size();
      ++num_pairs_with_dropped;
      if (pair.matches.size() < static_cast<size_t>(min_num_matches)) continue;
    }

    const auto raw_it =
        num_raw_matches_.find(static_cast<colmap::image_pair_t>(pair_id));
    pair.num_raw_matches =
        raw_it == num_raw_matches_.end() ? 0 : raw_it->second;
    view_graph->AddPair(std::move(pair));
  }
  if (rc != SQLITE_DONE) return StepError("two-view geometries");

  if (num_dropped_matches > 0) {
    LOG(WARNING) << "Dropped " << num_dropped_matches << " matches in "
                 << num_pairs_with_dropped << " image pairs of " << path_
                 << " whose keypoint indices are out of range.";
  }
  if (view_graph->NumPairs() == 0) {
    return Status::Error("The database " + path_ +
                         " has no verified image pairs with at least " +
                         std::to_string(min_num_matches) +
                         " matches: run a matcher first.");
  }
  return Status::Ok();
}

void Reader::MoveInto(colmap::Reconstruction* reconstruction) {
  // Insert in id order so that the reconstruction is built the same way on
  // every run (its containers are unordered).
  std::vector<colmap::image_t> image_ids;
  image_ids.reserve(images_.size());
  std::unordered_set<colmap::camera_t> used_camera_ids;
  for (const auto& [image_id, image] : images_) {
    image_ids.push_back(image_id);
    used_camera_ids.insert(image.CameraId());
  }
  std::sort(image_ids.begin(), image_ids.end());
  std::vector<colmap::camera_t> camera_ids(used_camera_ids.begin(),
                                           used_camera_ids.end());
  std::sort(camera_ids.begin(), camera_ids.end());

  for (const colmap::camera_t camera_id : camera_ids) {
    reconstruction->AddCamera(std::move(cameras_.at(camera_id)));
  }
  for (const colmap::image_t image_id : image_ids) {
    reconstruction->AddImage(std::move(images_.at(image_id)));
  }
  cameras_.clear();
  images_.clear();
}

}  // namespace

bool DatabaseReaderOptions::Check() const { return min_num_matches >= 0; }

Status ReadDatabase(const std::string& database_path,
                    const DatabaseReaderOptions& options,
                    colmap::Reconstruction* reconstruction,
                    ViewGraph* view_graph) {
  if (!options.Check()) {
    return Status::Error(
        "Invalid database reader options: min_num_matches "
        "must not be negative.");
  }
  if (reconstruction->NumCameras() > 0 || reconstruction->NumImages() > 0 ||
      view_graph->NumPairs() > 0) {
    return Status::Error(
        "ReadDatabase needs an empty reconstruction and view graph.");
  }
  Reader reader(database_path, options);
  for (Status (Reader::*step)() :
       {&Reader::Open, &Reader::CheckSchema, &Reader::ReadCameras,
        &Reader::ReadImages, &Reader::ReadKeypoints,
        &Reader::ReadRawMatchCounts}) {
    Status status = (reader.*step)();
    if (!status.ok()) return status;
  }
  ViewGraph pairs;
  Status status = reader.ReadVerifiedPairs(&pairs);
  if (!status.ok()) return status;
  reader.MoveInto(reconstruction);
  *view_graph = std::move(pairs);
  return Status::Ok();
}

}  // namespace glomap
