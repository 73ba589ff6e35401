#include "glomap/io/database_reader.h"

#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "base/camera_models.h"
#include "estimators/two_view_geometry.h"
#include "glomap/util/options_check.h"
#include "util/logging.h"

namespace glomap {
namespace {

// The constants below are not GlobalMapper.* options: they decide how the
// file is read, never what the pipeline makes of its content.

// How long a read waits for another program's write lock on the database
// (the reader's patience with another program, not a property of the data;
// a writer that holds its lock longer is reported as an error).
constexpr int kBusyTimeoutMs = 30000;

// How often a database that changes while it is read is read again (as
// kBusyTimeoutMs: how long to wait for another program).
constexpr int kMaxNumReadAttempts = 3;

// COLMAP 3.8's Database::kMaxNumImages: pair_id = id1 * kMax + id2 (the
// file format).
constexpr int64_t kPairIdFactor = 2147483647;

// A camera whose principal point lies farther outside its image than this
// fraction of the image size (per axis) is damaged: even a crop of a larger
// sensor keeps it near the image, and values like 10 million px put every ray
// almost at right angles to the optical axis. Part of the reader's definition
// of damaged content (with non-finite parameters and focal lengths that are
// not positive, see database_reader.h), not a tuning threshold: no real
// camera comes near it, and a looser value would only let damaged cameras
// into the pipeline.
constexpr double kMaxPrincipalPointOutsideRatio = 1.0;

// Warnings that name one image each stop after this many; one more line
// counts the rest (log policy).
constexpr size_t kMaxNamedWarnings = 10;

using colmap::TwoViewGeometry;

// "1 pair", "2 pairs".
std::string CountOf(size_t count, const std::string& noun,
                    const std::string& plural = "") {
  return std::to_string(count) + " " +
         (count == 1       ? noun
          : plural.empty() ? noun + "s"
                           : plural);
}

std::string FormatValue(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Why a camera cannot be used, or "" if it can: values that no real camera
// has and that would reach the solvers as NaN or a degenerate projection.
std::string CameraProblem(const colmap::Camera& camera) {
  if (!std::all_of(camera.Params().begin(), camera.Params().end(),
                   [](double param) { return std::isfinite(param); })) {
    std::string params;
    for (const double param : camera.Params()) {
      params += (params.empty() ? "" : ", ") + FormatValue(param);
    }
    return "has non-finite parameters (" + params + ")";
  }
  for (const size_t idx : camera.FocalLengthIdxs()) {
    if (!(camera.Params(idx) > 0)) {
      return "has the focal length " + FormatValue(camera.Params(idx)) +
             " px, which is not positive";
    }
  }
  const double width = static_cast<double>(camera.Width());
  const double height = static_cast<double>(camera.Height());
  const double margin_x = kMaxPrincipalPointOutsideRatio * width;
  const double margin_y = kMaxPrincipalPointOutsideRatio * height;
  const double cx = camera.PrincipalPointX();
  const double cy = camera.PrincipalPointY();
  if (cx < -margin_x || cx > width + margin_x || cy < -margin_y ||
      cy > height + margin_y) {
    return "has its principal point at (" + FormatValue(cx) + ", " +
           FormatValue(cy) + ") px, far outside its " +
           std::to_string(camera.Width()) + "x" +
           std::to_string(camera.Height()) + " image";
  }
  return "";
}

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

// One version of a database file. Every change another process commits
// either rewrites the file (its size, mtime or ctime change, to the
// nanosecond) or stays in a write-ahead log or journal beside it: a file whose
// version is the same before and after a read, without such a log, did not
// change during the read.
struct FileVersion {
  bool exists = false;
  dev_t device = 0;
  ino_t inode = 0;
  off_t size = 0;
  timespec mtime = {0, 0};
  timespec ctime = {0, 0};
  bool has_pending_changes = false;  // A non-empty -wal or -journal file.

  bool operator==(const FileVersion& other) const {
    return exists == other.exists && device == other.device &&
           inode == other.inode && size == other.size &&
           mtime.tv_sec == other.mtime.tv_sec &&
           mtime.tv_nsec == other.mtime.tv_nsec &&
           ctime.tv_sec == other.ctime.tv_sec &&
           ctime.tv_nsec == other.ctime.tv_nsec &&
           has_pending_changes == other.has_pending_changes;
  }
};

FileVersion ReadFileVersion(const std::string& path) {
  FileVersion version;
  struct stat info;
  if (stat(path.c_str(), &info) != 0) return version;
  version.exists = true;
  version.device = info.st_dev;
  version.inode = info.st_ino;
  version.size = info.st_size;
  version.mtime = info.st_mtim;
  version.ctime = info.st_ctim;
  version.has_pending_changes = NonEmptyFileExists(path + "-wal") ||
                                NonEmptyFileExists(path + "-journal");
  return version;
}

// Reads a database through one read-only connection and turns every SQLite
// failure into a one-line Status.
class Reader {
 public:
  // `immutable`: read without locks and without files beside the database
  // (SQLite's immutable=1); only correct if nobody writes meanwhile, which
  // the caller checks. Otherwise everything is read in one read transaction
  // of a normal read-only connection, which sees one committed state.
  Reader(std::string path, const DatabaseReaderOptions& options, bool immutable)
      : path_(std::move(path)), options_(options), immutable_(immutable) {}

  Status Open();
  Status CheckSchema();
  Status ReadCameras();
  Status ReadImages();
  Status ReadKeypoints();
  Status ReadRawMatchCounts();
  Status ReadVerifiedPairs(ViewGraph* view_graph);
  void MoveInto(colmap::Reconstruction* reconstruction);

  // What ReadVerifiedPairs skipped or changed, by kind.
  struct PairDamage;

  size_t NumImages() const { return images_.size(); }

 private:
  Status Prepare(const char* sql, StatementPtr* stmt);
  Status StepError(const char* what) const;
  Status Corrupt(const std::string& what) const {
    return Status::Error("The database " + path_ + " is corrupt: " + what +
                         ".");
  }
  // The `num_matches` matches at `match_indices` (keypoint index pairs) of
  // `pair` that name keypoints that exist and have finite coordinates, into
  // pair->matches; the others counted in `damage`.
  void KeepUsableMatches(const uint32_t* match_indices, size_t num_matches,
                         ImagePair* pair, PairDamage* damage);
  // One warning per kind of damage: what was dropped, and how much.
  void WarnOfDamage(const PairDamage& damage, int min_num_matches) const;
  // The error when no pair can be used, saying whether there were none.
  Status NoUsablePairsError(const PairDamage& damage,
                            int min_num_matches) const;

  // Keypoints of one image whose coordinates are NaN or infinite: they keep
  // their index (so that the model's point2D indices stay the database's
  // keypoint indices) but no match that uses them is read.
  struct NonFiniteKeypoints {
    std::vector<char> is_nonfinite;  // One flag per keypoint.
    size_t num_keypoints = 0;
    size_t num_dropped_matches = 0;
  };

  const std::string path_;
  const DatabaseReaderOptions& options_;
  const bool immutable_;
  SqlitePtr db_;

  std::unordered_map<colmap::camera_t, colmap::Camera> cameras_;
  // Why a camera is unusable (see CameraProblem), for unusable cameras only.
  std::map<colmap::camera_t, std::string> camera_problems_;
  std::unordered_map<colmap::image_t, colmap::Image> images_;
  // Images in the database that are not read (not among the requested
  // names, or on an unusable camera): pairs that name them are skipped
  // without a warning.
  std::unordered_set<colmap::image_t> left_out_image_ids_;
  // Number of keypoints per image with a keypoints row (0 for an empty row).
  std::unordered_map<colmap::image_t, uint32_t> num_points2D_;
  std::unordered_map<colmap::image_t, NonFiniteKeypoints> nonfinite_keypoints_;
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
  // so it takes no locks and creates no -shm, -wal or -journal files next to
  // it (a normal read-only connection to a database in WAL mode, as COLMAP
  // writes them, creates and leaves -wal and -shm files; on a read-only
  // mount it cannot open it at all).
  const std::string uri = "file:" + PercentEncodePath(path_) +
                          (immutable_ ? "?mode=ro&immutable=1" : "?mode=ro");
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  db_.reset(db);
  if (rc != SQLITE_OK) {
    return Status::Error("The database file " + path_ + " cannot be opened: " +
                         (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)) + ".");
  }
  // No value can be longer than the file and its log hold; a computed one
  // that is (zeroblob() in a generated column) is refused by SQLite instead
  // of allocated.
  std::error_code size_error;
  uintmax_t num_file_bytes = std::filesystem::file_size(path_, size_error);
  if (size_error) num_file_bytes = 0;
  const uintmax_t num_wal_bytes =
      std::filesystem::file_size(path_ + "-wal", size_error);
  if (!size_error) num_file_bytes += num_wal_bytes;
  sqlite3_limit(db_.get(), SQLITE_LIMIT_LENGTH,
                static_cast<int>(std::min<uintmax_t>(
                    num_file_bytes + 1024, std::numeric_limits<int>::max())));
  if (!immutable_) {
    // Another program may hold a write lock for a moment (COLMAP's matchers
    // commit in blocks): wait for it rather than fail at once.
    sqlite3_busy_timeout(db_.get(), kBusyTimeoutMs);
    char* message = nullptr;
    if (sqlite3_exec(db_.get(), "BEGIN;", nullptr, nullptr, &message) !=
        SQLITE_OK) {
      const std::string text = message ? message : "unknown error";
      sqlite3_free(message);
      return Status::Error("The database file " + path_ +
                           " cannot be read: " + text + ".");
    }
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
  // COLMAP never writes generated (computed) columns; one could make a few
  // bytes of file read as gigabytes of keypoints.
  StatementPtr columns;
  status = Prepare(
      "SELECT m.name, c.name FROM sqlite_master AS m, "
      "pragma_table_xinfo(m.name) AS c WHERE m.type = 'table' AND m.name IN "
      "('cameras', 'images', 'keypoints', 'matches', 'two_view_geometries') "
      "AND c.hidden != 0;",
      &columns);
  if (!status.ok()) return status;
  rc = sqlite3_step(columns.get());
  if (rc == SQLITE_ROW) {
    const unsigned char* table = sqlite3_column_text(columns.get(), 0);
    const unsigned char* column = sqlite3_column_text(columns.get(), 1);
    return Status::Error(path_ + " is not a COLMAP 3.8 database: column " +
                         (table ? reinterpret_cast<const char*>(table) : "") +
                         "." +
                         (column ? reinterpret_cast<const char*>(column) : "") +
                         " is computed (a generated column).");
  }
  if (rc != SQLITE_DONE) return StepError("the table columns");
  return Status::Ok();
}

Status Reader::ReadCameras() {
  StatementPtr stmt;
  Status status = Prepare(
      "SELECT camera_id, model, width, height, params, prior_focal_length "
      "FROM cameras;",
      &stmt);
  if (!status.ok()) return status;
  size_t num_duplicate_rows = 0;
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
    // A table without its primary key may repeat an id; the first row is
    // the one COLMAP's Database::ReadCamera returns.
    if (cameras_.count(camera.CameraId()) > 0) {
      ++num_duplicate_rows;
      continue;
    }
    std::string problem = CameraProblem(camera);
    if (!problem.empty()) {
      camera_problems_.emplace(camera.CameraId(), std::move(problem));
    }
    cameras_.emplace(camera.CameraId(), std::move(camera));
  }
  if (rc != SQLITE_DONE) return StepError("cameras");
  if (num_duplicate_rows > 0) {
    LOG(WARNING) << "Ignored " << CountOf(num_duplicate_rows, "row")
                 << " of the cameras table of " << path_
                 << " that repeat a camera id; the first row of each camera "
                    "is used, as COLMAP does.";
  }
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
  // Images left out because their camera is unusable, by camera.
  std::map<colmap::camera_t, size_t> num_images_of_unusable_camera;
  size_t num_duplicate_rows = 0;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t image_id = sqlite3_column_int64(row, 0);
    const unsigned char* name_text = sqlite3_column_text(row, 1);
    const std::string name =
        name_text ? reinterpret_cast<const char*>(name_text) : "";
    if (!selected.empty() && selected.count(name) == 0) {
      if (image_id >= 0 && image_id < kPairIdFactor) {
        left_out_image_ids_.insert(static_cast<colmap::image_t>(image_id));
      }
      continue;
    }
    if (image_id < 0 || image_id >= kPairIdFactor) {
      return Corrupt("invalid image id " + std::to_string(image_id));
    }
    // The first row of a repeated id is the one COLMAP reads.
    if (images_.count(static_cast<colmap::image_t>(image_id)) > 0 ||
        left_out_image_ids_.count(static_cast<colmap::image_t>(image_id)) > 0) {
      ++num_duplicate_rows;
      continue;
    }
    const int64_t camera_id = sqlite3_column_int64(row, 2);
    if (camera_id < 0 ||
        cameras_.count(static_cast<colmap::camera_t>(camera_id)) == 0) {
      return Status::Error("Image " + name + " (id " +
                           std::to_string(image_id) + ") in " + path_ +
                           " refers to camera " + std::to_string(camera_id) +
                           ", which is not in the database.");
    }
    // COLMAP's incremental mapper skips images whose camera has bogus
    // parameters; so do we, and say so below.
    if (camera_problems_.count(static_cast<colmap::camera_t>(camera_id)) > 0) {
      ++num_images_of_unusable_camera[static_cast<colmap::camera_t>(camera_id)];
      left_out_image_ids_.insert(static_cast<colmap::image_t>(image_id));
      continue;
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

  if (num_duplicate_rows > 0) {
    LOG(WARNING) << "Ignored " << CountOf(num_duplicate_rows, "row")
                 << " of the images table of " << path_
                 << " that repeat an image id; the first row of each image is "
                    "used, as COLMAP does.";
  }
  for (const auto& [camera_id, num_images] : num_images_of_unusable_camera) {
    LOG(WARNING) << "Camera " << camera_id << " in " << path_ << " "
                 << camera_problems_.at(camera_id) << ": its "
                 << CountOf(num_images, "image")
                 << (num_images == 1 ? " is" : " are") << " left out.";
  }
  if (images_.empty() && !num_images_of_unusable_camera.empty()) {
    const auto& [camera_id, num_images] =
        *num_images_of_unusable_camera.begin();
    std::string message = "No image of " + path_ + " can be used: camera " +
                          std::to_string(camera_id) + " " +
                          camera_problems_.at(camera_id);
    const size_t num_others = num_images_of_unusable_camera.size() - 1;
    if (num_others == 1) {
      message += ", and the other camera of its images is unusable too";
    } else if (num_others > 1) {
      message += ", and the " + std::to_string(num_others) +
                 " other cameras of its images are unusable too";
    }
    return Status::Error(message + ".");
  }
  if (images_.empty()) {
    if (selected.empty()) {
      return Status::Error("The database " + path_ + " contains no images.");
    }
    return Status::Error("None of the " + std::to_string(selected.size()) +
                         " requested image names is in the database " + path_ +
                         ".");
  }
  size_t num_found = images_.size();
  for (const auto& [camera_id, num_images] : num_images_of_unusable_camera) {
    num_found += num_images;
  }
  if (!selected.empty() && num_found < selected.size()) {
    LOG(WARNING) << selected.size() - num_found
                 << " of the requested image names are not in the database "
                 << path_ << "; ignoring them.";
  }
  if (images_.size() == 1) {
    const size_t num_left_out = num_found - 1;
    return Status::Error("Only one image of " + path_ + " can be used (" +
                         images_.begin()->second.Name() +
                         "): a reconstruction needs at least two" +
                         (num_left_out == 0
                              ? std::string(".")
                              : " (" + std::to_string(num_left_out) +
                                    " more are left out: their cameras are "
                                    "unusable, see the warnings above)."));
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
  // Extra keypoint rows per image (a table without its primary key).
  std::map<colmap::image_t, size_t> num_extra_rows;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t image_id = sqlite3_column_int64(row, 0);
    const auto image_it = images_.find(static_cast<colmap::image_t>(image_id));
    if (image_id < 0 || image_it == images_.end()) continue;
    // A table scan returns rows in rowid order, so the first row of an image
    // is the one COLMAP's Database::ReadKeypoints returns, and the one its
    // matchers used: later rows are ignored.
    const auto [num_points_it, is_first_row] =
        num_points2D_.emplace(image_it->first, 0);
    if (!is_first_row) {
      ++num_extra_rows[image_it->first];
      continue;
    }
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
    size_t num_nonfinite = 0;
    for (int64_t i = 0; i < rows; ++i) {
      const float x = row_values[i * cols];
      const float y = row_values[i * cols + 1];
      points[i] = Eigen::Vector2d(x, y);
      num_nonfinite += !(std::isfinite(x) && std::isfinite(y));
    }
    if (num_nonfinite > 0) {
      NonFiniteKeypoints& nonfinite = nonfinite_keypoints_[image_it->first];
      nonfinite.num_keypoints = num_nonfinite;
      nonfinite.is_nonfinite.resize(static_cast<size_t>(rows));
      for (int64_t i = 0; i < rows; ++i) {
        nonfinite.is_nonfinite[i] = !points[i].allFinite();
      }
    }
    image_it->second.SetPoints2D(points);
    num_points_it->second = static_cast<uint32_t>(rows);
  }
  if (rc != SQLITE_DONE) return StepError("keypoints");

  size_t num_named = 0;
  for (const auto& [image_id, num_rows] : num_extra_rows) {
    if (++num_named > kMaxNamedWarnings) {
      LOG(WARNING) << "... and " << num_extra_rows.size() - kMaxNamedWarnings
                   << " more images with repeated keypoint rows.";
      break;
    }
    LOG(WARNING) << "Image " << images_.at(image_id).Name() << " has "
                 << num_rows + 1 << " keypoint rows in " << path_
                 << "; the first is used, as COLMAP does, and "
                 << CountOf(num_rows, "later row") << " ignored.";
  }
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

// What a matrix column of two_view_geometries holds.
enum class MatrixBlob { kSet, kUnusable, kWrongSize };

// Reads a 3x3 float64 matrix stored row-major (COLMAP transposes Eigen's
// column-major matrices before writing). A zero matrix means "not
// estimated", as COLMAP writes it; NULL, an empty blob or non-finite values
// (which COLMAP never writes) leave a zero matrix and are kUnusable.
MatrixBlob ReadMatrixBlob(sqlite3_stmt* row, int col, Eigen::Matrix3d* matrix) {
  const int num_bytes = sqlite3_column_bytes(row, col);
  matrix->setZero();
  if (num_bytes == 0) return MatrixBlob::kUnusable;
  if (num_bytes != 9 * sizeof(double)) return MatrixBlob::kWrongSize;
  double values[9];
  std::memcpy(values, sqlite3_column_blob(row, col), sizeof(values));
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> stored(
      values);
  if (!stored.allFinite()) return MatrixBlob::kUnusable;
  *matrix = stored;
  return MatrixBlob::kSet;
}

// Pairs of one kind that the reader skips or changes: how many, and one of
// them for the warning.
struct PairCount {
  size_t num_pairs = 0;
  std::string example;

  void Add(const std::string& pair_text) {
    if (num_pairs++ == 0) example = pair_text;
  }
};

struct Reader::PairDamage {
  PairCount unknown_images;
  PairCount duplicate_rows;
  PairCount unknown_config;
  PairCount unusable_matrices;
  // Pairs left with fewer than min_num_matches matches once the matches
  // that use missing or non-finite keypoints are dropped.
  PairCount too_few_left;
  size_t num_out_of_range_matches = 0;
  size_t num_pairs_out_of_range = 0;
  size_t num_nonfinite_matches = 0;
};

// Matches may only name keypoints that exist and have finite coordinates; a
// stale or foreign database must not make later stages index out of
// bounds, nor bring NaN into the solvers.
void Reader::KeepUsableMatches(const uint32_t* match_indices,
                               size_t num_matches, ImagePair* pair,
                               PairDamage* damage) {
  const auto n1_it = num_points2D_.find(pair->image_id1);
  const auto n2_it = num_points2D_.find(pair->image_id2);
  const uint32_t num_points1 = n1_it == num_points2D_.end() ? 0 : n1_it->second;
  const uint32_t num_points2 = n2_it == num_points2D_.end() ? 0 : n2_it->second;
  const auto nonfinite1_it = nonfinite_keypoints_.find(pair->image_id1);
  const auto nonfinite2_it = nonfinite_keypoints_.find(pair->image_id2);
  NonFiniteKeypoints* nonfinite1 = nonfinite1_it == nonfinite_keypoints_.end()
                                       ? nullptr
                                       : &nonfinite1_it->second;
  NonFiniteKeypoints* nonfinite2 = nonfinite2_it == nonfinite_keypoints_.end()
                                       ? nullptr
                                       : &nonfinite2_it->second;
  pair->matches.reserve(num_matches);
  size_t num_nonfinite_in_pair = 0;
  for (size_t i = 0; i < num_matches; ++i) {
    const uint32_t idx1 = match_indices[2 * i];
    const uint32_t idx2 = match_indices[2 * i + 1];
    if (idx1 >= num_points1 || idx2 >= num_points2) continue;
    if (nonfinite1 != nullptr || nonfinite2 != nullptr) {
      const bool nonfinite_in1 =
          nonfinite1 != nullptr && nonfinite1->is_nonfinite[idx1];
      const bool nonfinite_in2 =
          nonfinite2 != nullptr && nonfinite2->is_nonfinite[idx2];
      if (nonfinite_in1 || nonfinite_in2) {
        if (nonfinite_in1) ++nonfinite1->num_dropped_matches;
        if (nonfinite_in2) ++nonfinite2->num_dropped_matches;
        ++num_nonfinite_in_pair;
        continue;
      }
    }
    pair->matches.emplace_back(idx1, idx2);
  }
  damage->num_nonfinite_matches += num_nonfinite_in_pair;
  const size_t num_out_of_range =
      num_matches - pair->matches.size() - num_nonfinite_in_pair;
  if (num_out_of_range > 0) {
    damage->num_out_of_range_matches += num_out_of_range;
    ++damage->num_pairs_out_of_range;
  }
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

  const auto is_known = [this](int64_t image_id) {
    return images_.count(static_cast<colmap::image_t>(image_id)) > 0 ||
           left_out_image_ids_.count(static_cast<colmap::image_t>(image_id)) >
               0;
  };
  // Pair ids read so far. Rows of a table with its primary key come in
  // increasing pair id order (their rowid), so a pair can only repeat once
  // that order breaks; only then do the ids go into a hash set.
  std::vector<colmap::image_pair_t> seen_in_order;
  std::unordered_set<colmap::image_pair_t> seen_set;
  const auto first_time = [&](colmap::image_pair_t pair_id) {
    if (seen_set.empty()) {
      if (seen_in_order.empty() || pair_id > seen_in_order.back()) {
        seen_in_order.push_back(pair_id);
        return true;
      }
      seen_set.insert(seen_in_order.begin(), seen_in_order.end());
    }
    return seen_set.insert(pair_id).second;
  };
  PairDamage damage;
  std::vector<uint32_t> blob_values;
  int rc;
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    sqlite3_stmt* row = stmt.get();
    const int64_t pair_id = sqlite3_column_int64(row, 0);
    const int64_t id2 = pair_id < 0 ? -1 : pair_id % kPairIdFactor;
    const int64_t id1 = pair_id < 0 ? -1 : pair_id / kPairIdFactor;
    const bool valid_ids = id2 >= 0 && id1 < kPairIdFactor && id1 != id2;
    const auto image1 = valid_ids
                            ? images_.find(static_cast<colmap::image_t>(id1))
                            : images_.end();
    const auto image2 = valid_ids
                            ? images_.find(static_cast<colmap::image_t>(id2))
                            : images_.end();
    if (image1 == images_.end() || image2 == images_.end()) {
      // Pairs with an image that is left out are no damage of their own.
      if (!valid_ids || !is_known(id1) || !is_known(id2)) {
        damage.unknown_images.Add("pair id " + std::to_string(pair_id) +
                                  ": image ids " + std::to_string(id1) +
                                  " and " + std::to_string(id2));
      }
      continue;
    }
    const auto pair_text = [&image1, &image2]() {
      return "images " + image1->second.Name() + " and " +
             image2->second.Name();
    };
    // The first row of a repeated pair is the one COLMAP reads.
    if (!first_time(std::min(id1, id2) * kPairIdFactor + std::max(id1, id2))) {
      damage.duplicate_rows.Add(pair_text());
      continue;
    }

    const int64_t config = sqlite3_column_int64(row, 4);
    if (config < TwoViewGeometry::UNDEFINED ||
        config > TwoViewGeometry::MULTIPLE) {
      damage.unknown_config.Add(pair_text() + ": config " +
                                std::to_string(config));
      continue;
    }
    if (config == TwoViewGeometry::UNDEFINED ||
        config == TwoViewGeometry::DEGENERATE ||
        config == TwoViewGeometry::MULTIPLE ||
        (options_.ignore_watermarks && config == TwoViewGeometry::WATERMARK)) {
      continue;
    }

    const int64_t rows = sqlite3_column_int64(row, 1);
    const int64_t cols = sqlite3_column_int64(row, 2);
    const void* blob = sqlite3_column_blob(row, 3);
    const int64_t num_bytes = sqlite3_column_bytes(row, 3);
    // rows comes from the file: compare it with the blob's size instead of
    // multiplying it (rows * 8 overflows for rows >= 2^60).
    constexpr int64_t kMatchBytes = 2 * sizeof(uint32_t);
    if (cols != 2 || blob == nullptr || num_bytes % kMatchBytes != 0 ||
        rows != num_bytes / kMatchBytes) {
      return Corrupt("the verified matches of " + pair_text() +
                     " do not have the stored size");
    }

    ImagePair pair;
    pair.image_id1 = image1->first;
    pair.image_id2 = image2->first;
    pair.config = static_cast<int>(config);
    bool has_unusable_matrix = false;
    for (const auto& [col, matrix] :
         {std::make_pair(5, &pair.F), std::make_pair(6, &pair.E),
          std::make_pair(7, &pair.H)}) {
      const MatrixBlob read = ReadMatrixBlob(row, col, matrix);
      if (read == MatrixBlob::kWrongSize) {
        return Corrupt("the two-view geometry of " + pair_text() +
                       " has a matrix of the wrong size");
      }
      has_unusable_matrix |= read == MatrixBlob::kUnusable;
    }
    if (has_unusable_matrix) damage.unusable_matrices.Add(pair_text());

    blob_values.resize(static_cast<size_t>(rows * 2));
    std::memcpy(blob_values.data(), blob, static_cast<size_t>(num_bytes));
    KeepUsableMatches(blob_values.data(), static_cast<size_t>(rows), &pair,
                      &damage);
    if (pair.matches.size() < static_cast<size_t>(min_num_matches)) {
      damage.too_few_left.Add(pair_text());
      continue;
    }

    const auto raw_it =
        num_raw_matches_.find(static_cast<colmap::image_pair_t>(pair_id));
    pair.num_raw_matches =
        raw_it == num_raw_matches_.end() ? 0 : raw_it->second;
    view_graph->AddPair(std::move(pair));
  }
  if (rc != SQLITE_DONE) return StepError("two-view geometries");

  WarnOfDamage(damage, min_num_matches);
  if (view_graph->NumPairs() == 0) {
    return NoUsablePairsError(damage, min_num_matches);
  }
  return Status::Ok();
}

void Reader::WarnOfDamage(const PairDamage& damage, int min_num_matches) const {
  if (damage.unknown_images.num_pairs > 0) {
    LOG(WARNING) << "Ignored "
                 << CountOf(damage.unknown_images.num_pairs, "verified pair")
                 << " in " << path_
                 << " that do not name two images of the database (e.g. "
                 << damage.unknown_images.example << ").";
  }
  if (damage.duplicate_rows.num_pairs > 0) {
    LOG(WARNING) << "Ignored "
                 << CountOf(damage.duplicate_rows.num_pairs, "repeated row")
                 << " of two_view_geometries in " << path_ << " (e.g. "
                 << damage.duplicate_rows.example
                 << "); the first row of each pair is used, as COLMAP does.";
  }
  if (damage.unknown_config.num_pairs > 0) {
    LOG(WARNING) << "Ignored "
                 << CountOf(damage.unknown_config.num_pairs, "verified pair")
                 << " in " << path_
                 << " whose config is not a COLMAP two-view geometry type "
                    "(0 to 8; e.g. "
                 << damage.unknown_config.example << ").";
  }
  if (damage.unusable_matrices.num_pairs > 0) {
    LOG(WARNING) << "Ignored the stored F, E or H of "
                 << CountOf(damage.unusable_matrices.num_pairs, "verified pair")
                 << " in " << path_ << " (NULL, empty or not finite; e.g. "
                 << damage.unusable_matrices.example
                 << "): their inlier matches are used, and their relative "
                    "poses estimated from them as for every pair.";
  }
  if (damage.num_out_of_range_matches > 0) {
    LOG(WARNING) << "Dropped "
                 << CountOf(damage.num_out_of_range_matches, "match", "matches")
                 << " in "
                 << CountOf(damage.num_pairs_out_of_range, "image pair")
                 << " of " << path_
                 << " whose keypoint indices are out of range.";
  }
  size_t num_named = 0;
  std::vector<colmap::image_t> nonfinite_image_ids;
  for (const auto& [image_id, nonfinite] : nonfinite_keypoints_) {
    nonfinite_image_ids.push_back(image_id);
  }
  std::sort(nonfinite_image_ids.begin(), nonfinite_image_ids.end());
  for (const colmap::image_t image_id : nonfinite_image_ids) {
    if (++num_named > kMaxNamedWarnings) {
      LOG(WARNING) << "... and "
                   << nonfinite_image_ids.size() - kMaxNamedWarnings
                   << " more images with non-finite keypoints ("
                   << damage.num_nonfinite_matches
                   << " matches dropped in all).";
      break;
    }
    const NonFiniteKeypoints& nonfinite = nonfinite_keypoints_.at(image_id);
    LOG(WARNING) << "Image " << images_.at(image_id).Name() << " in " << path_
                 << " has non-finite coordinates (NaN or infinite) in "
                 << nonfinite.num_keypoints << " of "
                 << num_points2D_.at(image_id)
                 << " keypoints: they are not used, nor the "
                 << CountOf(nonfinite.num_dropped_matches, "verified match",
                            "verified matches")
                 << " that use them.";
  }
  if (damage.too_few_left.num_pairs > 0) {
    LOG(WARNING) << "Ignored "
                 << CountOf(damage.too_few_left.num_pairs, "verified pair")
                 << " in " << path_ << " left with fewer than "
                 << min_num_matches << " usable matches (e.g. "
                 << damage.too_few_left.example << ").";
  }
}

Status Reader::NoUsablePairsError(const PairDamage& damage,
                                  int min_num_matches) const {
  const size_t num_unusable = damage.unknown_images.num_pairs +
                              damage.unknown_config.num_pairs +
                              damage.too_few_left.num_pairs;
  const std::string message = "The database " + path_ +
                              " has no verified image pairs with at least " +
                              std::to_string(min_num_matches) + " matches";
  if (num_unusable == 0) {
    return Status::Error(message + ": run a matcher first.");
  }
  return Status::Error(message + " that can be used (" +
                       (num_unusable == 1
                            ? std::string("1 pair was")
                            : std::to_string(num_unusable) + " pairs were") +
                       " left out as unusable, see the warnings above).");
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

Status DatabaseReaderOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("min_num_matches", min_num_matches, 0);
  return check.status();
}

Status ReadDatabase(const std::string& database_path,
                    const DatabaseReaderOptions& options,
                    colmap::Reconstruction* reconstruction,
                    ViewGraph* view_graph) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid database reader options: " + check.message());
  }
  if (reconstruction->NumCameras() > 0 || reconstruction->NumImages() > 0 ||
      view_graph->NumPairs() > 0) {
    return Status::Error(
        "ReadDatabase needs an empty reconstruction and view graph.");
  }
  // Without a write-ahead log or journal beside it, the file is read
  // immutably and its version compared before and after: if another program
  // wrote meanwhile, the read is thrown away and repeated. With one, the
  // read goes through SQLite's locks in one transaction.
  for (int attempt = 1;; ++attempt) {
    const FileVersion before = ReadFileVersion(database_path);
    const bool immutable = !before.has_pending_changes;
    Reader reader(database_path, options, immutable);
    Status status = Status::Ok();
    for (Status (Reader::*step)() :
         {&Reader::Open, &Reader::CheckSchema, &Reader::ReadCameras,
          &Reader::ReadImages, &Reader::ReadKeypoints,
          &Reader::ReadRawMatchCounts}) {
      status = (reader.*step)();
      if (!status.ok()) break;
    }
    ViewGraph pairs;
    if (status.ok()) status = reader.ReadVerifiedPairs(&pairs);
    if (immutable && !(ReadFileVersion(database_path) == before)) {
      if (attempt < kMaxNumReadAttempts) {
        LOG(WARNING) << "The database " << database_path
                     << " changed while it was read (another program is "
                        "writing to it); reading it again.";
        continue;
      }
      return Status::Error(
          "The database " + database_path +
          " changed every time it was read (" +
          std::to_string(kMaxNumReadAttempts) +
          " times): another program is writing to it. Run the mapper when "
          "it has finished.");
    }
    if (!status.ok()) return status;
    reader.MoveInto(reconstruction);
    *view_graph = std::move(pairs);
    return Status::Ok();
  }
}

}  // namespace glomap
