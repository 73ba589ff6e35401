#include "tests/support/synthetic_scene.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <unordered_map>
#include <utility>
#include <vector>

#include "base/camera_models.h"
#include "base/database.h"
#include "base/gps.h"
#include "base/pose.h"
#include "estimators/two_view_geometry.h"
#include "glomap/util/parallel_for.h"
#include "tests/support/camera_rotation.h"
#include "util/random.h"

namespace glomap {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

// Each image sees about this many points when num_points3D is automatic.
constexpr double kTargetVisiblePointsPerImage = 600;

// COLMAP's matcher defaults (SiftMatchingOptions) for verification.
constexpr int kMinNumInliers = 15;
constexpr double kMaxEpipolarErrorPx = 4.0;

// Independent random streams, so that e.g. changing wrong_match_ratio does
// not move a single keypoint.
enum RandomStream : uint32_t {
  kCameraStream = 1,
  kPoseStream,
  kPilotStream,
  kPointStream,
  kKeypointStream,
  kPairStream,
  kRansacStream,
  kShapeStream,
  kPatchStream,
  kWrongRotationStream,
  // Which images get outlier or no priors; each image's prior noise.
  kPriorSelectionStream,
  kPriorNoiseStream,
  // Each camera's principal-point offset and focal-prior error.
  kPrincipalPointStream,
  kFocalPriorErrorStream,
};

std::mt19937 MakeRng(int seed, RandomStream stream, uint64_t index = 0) {
  std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(stream),
                    static_cast<uint32_t>(index & 0xffffffffu),
                    static_cast<uint32_t>(index >> 32)};
  return std::mt19937(seq);
}

double Uniform(std::mt19937& rng, double min, double max) {
  return std::uniform_real_distribution<double>(min, max)(rng);
}

std::vector<std::string> SplitModelNames(const std::string& models) {
  std::vector<std::string> names;
  std::stringstream stream(models);
  std::string name;
  while (std::getline(stream, name, ',')) {
    name.erase(0, name.find_first_not_of(" \t"));
    name.erase(name.find_last_not_of(" \t") + 1);
    names.push_back(name);
  }
  return names;
}

// Parses image_sizes ("1024x768,640x480") into (width, height) pairs; an
// empty string gives the one size image_width_px x image_height_px. Returns
// false on a malformed entry.
bool ParseImageSizes(const SyntheticSceneOptions& options,
                     std::vector<std::pair<int, int>>* sizes) {
  sizes->clear();
  if (options.image_sizes.empty()) {
    sizes->emplace_back(options.image_width_px, options.image_height_px);
    return true;
  }
  for (const std::string& entry : SplitModelNames(options.image_sizes)) {
    int width = 0;
    int height = 0;
    char separator = 0;
    std::istringstream stream(entry);
    if (!(stream >> width >> separator >> height) || separator != 'x' ||
        !stream.eof()) {
      return false;
    }
    sizes->emplace_back(width, height);
  }
  return !sizes->empty();
}

std::string OptionsError(const SyntheticSceneOptions& options) {
  if (options.num_images < 10 || options.num_images > 10000) {
    return "num_images must be in [10, 10000]";
  }
  if (options.num_cameras < 1 || options.num_cameras > options.num_images) {
    return "num_cameras must be in [1, num_images]";
  }
  const std::vector<std::string> models = SplitModelNames(options.camera_model);
  if (models.empty()) return "camera_model is empty";
  for (const std::string& model : models) {
    if (!colmap::ExistsCameraModelWithName(model)) {
      return "unknown camera model '" + model + "'";
    }
  }
  if (options.image_width_px < 64 || options.image_height_px < 64) {
    return "image_width_px and image_height_px must be at least 64";
  }
  std::vector<std::pair<int, int>> sizes;
  if (!ParseImageSizes(options, &sizes)) {
    return "image_sizes must be comma-separated WIDTHxHEIGHT entries";
  }
  for (const auto& [width, height] : sizes) {
    if (width < 64 || height < 64) {
      return "every size in image_sizes must be at least 64x64";
    }
  }
  if (!(options.focal_length_px > 0)) return "focal_length_px must be > 0";
  if (!(options.principal_point_offset >= 0 &&
        options.principal_point_offset <= 0.2)) {
    return "principal_point_offset must be in [0, 0.2]";
  }
  if (!(options.distortion_scale >= 0 && options.distortion_scale <= 20)) {
    return "distortion_scale must be in [0, 20]";
  }
  if (options.num_cameras_with_prior < -1) {
    return "num_cameras_with_prior must be -1 or >= 0";
  }
  if (!(options.prior_focal_length_error >= 0 &&
        options.prior_focal_length_error < 0.5)) {
    return "prior_focal_length_error must be in [0, 0.5)";
  }
  if (options.num_points3D < 0) return "num_points3D must be >= 0";
  if (options.max_keypoints_per_image < 32) {
    return "max_keypoints_per_image must be at least 32";
  }
  if (!(options.unmatched_keypoint_ratio >= 0)) {
    return "unmatched_keypoint_ratio must be >= 0";
  }
  if (!(options.pixel_noise_px >= 0)) return "pixel_noise_px must be >= 0";
  if (!(options.wrong_match_ratio >= 0 && options.wrong_match_ratio <= 0.9)) {
    return "wrong_match_ratio must be in [0, 0.9]";
  }
  if (options.max_pairs_per_image < 1) {
    return "max_pairs_per_image must be >= 1";
  }
  if (options.layout != "ring" && options.layout != "forward" &&
      options.layout != "grid") {
    return "layout must be ring, forward or grid";
  }
  if (options.verification != "colmap" &&
      options.verification != "ground_truth") {
    return "verification must be colmap or ground_truth";
  }
  if (options.num_threads == 0 || options.num_threads < -1) {
    return "num_threads must be -1 or positive";
  }
  if (options.weak_group_size < 0) return "weak_group_size must be >= 0";
  if (options.weak_group_num_patch_points < 0) {
    return "weak_group_num_patch_points must be >= 0";
  }
  if (options.weak_group_max_matches_to_rest < 0) {
    return "weak_group_max_matches_to_rest must be >= 0";
  }
  if (options.weak_group_num_anchors < 0 ||
      options.weak_group_num_anchors > 5) {
    return "weak_group_num_anchors must be in [0, 5]";
  }
  if (options.num_wrong_rotation_pairs < 0) {
    return "num_wrong_rotation_pairs must be >= 0";
  }
  if (!(options.wrong_rotation_angle_deg > 0 &&
        options.wrong_rotation_angle_deg < 180)) {
    return "wrong_rotation_angle_deg must be in (0, 180)";
  }
  if (options.wrong_rotation_pairs != "group_to_rest" &&
      options.wrong_rotation_pairs != "group_to_anchors" &&
      options.wrong_rotation_pairs != "any") {
    return "wrong_rotation_pairs must be group_to_rest, group_to_anchors or "
           "any";
  }
  if (options.num_wrong_rotation_pairs > 0 &&
      options.wrong_rotation_pairs != "any" && options.weak_group_size == 0) {
    return "wrong_rotation_pairs " + options.wrong_rotation_pairs +
           " needs weak_group_size > 0";
  }
  if (options.num_wrong_rotation_pairs > 0 &&
      options.wrong_rotation_pairs == "group_to_anchors" &&
      options.weak_group_num_anchors == 0) {
    return "wrong_rotation_pairs group_to_anchors needs "
           "weak_group_num_anchors > 0";
  }
  if (options.num_pure_rotation_images < 0) {
    return "num_pure_rotation_images must be >= 0";
  }
  if (options.num_long_baseline_images < 0) {
    return "num_long_baseline_images must be >= 0";
  }
  if (options.long_baseline_num_skipped_neighbors < 1) {
    return "long_baseline_num_skipped_neighbors must be >= 1";
  }
  if (options.weak_bridge_max_matches < 0) {
    return "weak_bridge_max_matches must be >= 0";
  }
  if (!std::isfinite(options.prior_position_noise_m)) {
    return "prior_position_noise_m must be a number (< 0: no priors)";
  }
  if (options.prior_position_noise_m < 0 &&
      (options.prior_outlier_ratio != 0 || options.prior_missing_ratio != 0 ||
       options.prior_as_gps)) {
    return "prior_outlier_ratio, prior_missing_ratio and prior_as_gps need "
           "prior_position_noise_m >= 0";
  }
  if (!(options.prior_outlier_ratio >= 0 && options.prior_outlier_ratio <= 1)) {
    return "prior_outlier_ratio must be in [0, 1]";
  }
  if (!(options.prior_missing_ratio >= 0 && options.prior_missing_ratio <= 1)) {
    return "prior_missing_ratio must be in [0, 1]";
  }
  if (options.prior_outlier_ratio + options.prior_missing_ratio > 1) {
    return "prior_outlier_ratio + prior_missing_ratio must be at most 1";
  }
  if (!(options.prior_outlier_min_m >= 0 &&
        options.prior_outlier_min_m <= options.prior_outlier_max_m &&
        std::isfinite(options.prior_outlier_max_m))) {
    return "prior_outlier_min_m and prior_outlier_max_m must satisfy 0 <= "
           "min <= max";
  }
  if (!(std::abs(options.prior_gps_origin.x()) < 90 &&
        std::abs(options.prior_gps_origin.y()) <= 180 &&
        std::isfinite(options.prior_gps_origin.z()))) {
    return "prior_gps_origin must be a latitude in (-90, 90) deg, a "
           "longitude in [-180, 180] deg and a finite altitude in m";
  }
  // Each pure-rotation image also claims the image whose centre it takes.
  const int num_special_images =
      (options.weak_group_size > 0
           ? options.weak_group_size + options.weak_group_num_anchors
           : 0) +
      2 * options.num_pure_rotation_images + options.num_long_baseline_images;
  if (num_special_images > options.num_images / 2) {
    return "weak_group_size + weak_group_num_anchors + 2 * "
           "num_pure_rotation_images + num_long_baseline_images must be at "
           "most num_images / 2";
  }
  return "";
}

struct Pose {
  Eigen::Matrix3d cam_from_world_R;
  Eigen::Vector3d cam_from_world_t;
  Eigen::Vector3d center;
};

// COLMAP's camera frame: x right, y down, z along the optical axis.
Pose LookAlong(const Eigen::Vector3d& center, const Eigen::Vector3d& forward,
               const Eigen::Vector3d& up, double roll_rad) {
  const Eigen::Matrix3d R = testing::CamFromWorldLookingAlong(forward, up);
  Pose pose;
  pose.cam_from_world_R =
      Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      R;
  pose.center = center;
  pose.cam_from_world_t = -pose.cam_from_world_R * center;
  return pose;
}

struct ScenePoint {
  Eigen::Vector3d xyz;
  Eigen::Vector3d normal;
};

// Where the cameras are and what surface the points lie on.
struct Layout {
  std::vector<Pose> poses;
  // Points farther than this from a camera are not seen by it.
  double max_depth = std::numeric_limits<double>::infinity();
  // A point is seen only from directions within this angle of its surface
  // normal (features do not match across larger viewpoint changes).
  double max_view_angle_deg = 60;
  std::function<ScenePoint(std::mt19937&)> sample_point;
};

// Object-centred: a bumpy sphere of radius 2 m seen from 8 m (so that
// neighbouring views have triangulation angles of a few degrees to ~30), in
// a room of radius 16 m, centred on the origin, z up.
Layout MakeRingLayout(int num_images, std::mt19937& rng) {
  constexpr double kObjectRadius = 2.0;
  constexpr double kDistance = 8.0;
  Layout layout;
  layout.max_view_angle_deg = 60;
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  const double sin_min = std::sin(-5 * kDegToRad);
  const double sin_max = std::sin(55 * kDegToRad);
  for (int i = 0; i < num_images; ++i) {
    double azimuth, elevation;
    if (num_images <= 60) {
      azimuth = 2 * kPi * (i + Uniform(rng, -0.15, 0.15)) / num_images;
      elevation = (15 + Uniform(rng, -5, 5)) * kDegToRad;
    } else {
      // Above 60 images one ring gets too dense: spread the cameras evenly
      // over a dome (Fibonacci spiral in a band of elevations).
      const double s = sin_min + (i + 0.5) / num_images * (sin_max - sin_min);
      elevation = std::asin(s);
      azimuth = i * golden_angle + Uniform(rng, -0.05, 0.05);
    }
    const double distance = kDistance * (1 + Uniform(rng, -0.05, 0.05));
    const Eigen::Vector3d center =
        distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                   std::cos(elevation) * std::sin(azimuth),
                                   std::sin(elevation));
    const Eigen::Vector3d target(Uniform(rng, -0.2, 0.2),
                                 Uniform(rng, -0.2, 0.2),
                                 Uniform(rng, -0.2, 0.2));
    layout.poses.push_back(LookAlong(center, target - center,
                                     Eigen::Vector3d::UnitZ(),
                                     Uniform(rng, -3, 3) * kDegToRad));
  }
  // The object stands in a room, as in a real capture: half of the points
  // lie on the object, the others on the floor and on the walls. Seen only
  // on the object (a shallow cap at distance 8), rotation and translation of
  // a camera trade against each other (the bas-relief ambiguity) and 1 px of
  // noise moves the best rotations by ~0.1 deg; the room's depth range makes
  // the poses as well determined as in real object captures.
  constexpr double kFloorZ = -kObjectRadius;
  constexpr double kRoomRadius = 16.0;
  constexpr double kWallHeight = 10.0;
  layout.sample_point = [=](std::mt19937& rng) {
    ScenePoint point;
    const double pick = Uniform(rng, 0, 1);
    if (pick < 0.5) {
      std::normal_distribution<double> normal(0, 1);
      Eigen::Vector3d dir(normal(rng), normal(rng), normal(rng));
      dir.normalize();
      point.xyz = kObjectRadius * (1 + Uniform(rng, -0.05, 0.05)) * dir;
      point.normal = dir;
    } else if (pick < 0.75) {
      const double r = kRoomRadius * std::sqrt(Uniform(rng, 0, 1));
      const double a = Uniform(rng, 0, 2 * kPi);
      point.xyz = Eigen::Vector3d(r * std::cos(a), r * std::sin(a),
                                  kFloorZ + Uniform(rng, -0.05, 0.05));
      point.normal = Eigen::Vector3d::UnitZ();
    } else {
      const double a = Uniform(rng, 0, 2 * kPi);
      const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0);
      point.xyz = kRoomRadius * (1 + Uniform(rng, -0.005, 0.005)) * radial +
                  Eigen::Vector3d(0, 0, kFloorZ + Uniform(rng, 0, kWallHeight));
      point.normal = -radial;
    }
    return point;
  };
  return layout;
}

// Driving: one image per metre along a gently curving street, 1.6 m above
// the road, between two 10 m high facades 7 m to each side.
Layout MakeForwardLayout(int num_images, std::mt19937& rng) {
  constexpr double kStepM = 1.0;
  constexpr double kAmplitudeM = 4.0;
  constexpr double kPeriodM = 150.0;
  constexpr double kHalfWidthM = 7.0;
  constexpr double kWallHeightM = 10.0;
  Layout layout;
  layout.max_depth = 40;
  layout.max_view_angle_deg = 80;
  const auto path = [=](double s) {
    return Eigen::Vector3d(s, kAmplitudeM * std::sin(2 * kPi * s / kPeriodM),
                           0);
  };
  const auto tangent = [=](double s) {
    return Eigen::Vector3d(1,
                           kAmplitudeM * 2 * kPi / kPeriodM *
                               std::cos(2 * kPi * s / kPeriodM),
                           0)
        .normalized();
  };
  for (int i = 0; i < num_images; ++i) {
    const double s = i * kStepM;
    const Eigen::Vector3d center =
        path(s) + Eigen::Vector3d(Uniform(rng, -0.05, 0.05),
                                  Uniform(rng, -0.05, 0.05),
                                  1.6 + Uniform(rng, -0.02, 0.02));
    Eigen::Vector3d forward = Eigen::AngleAxisd(Uniform(rng, -2, 2) * kDegToRad,
                                                Eigen::Vector3d::UnitZ()) *
                              tangent(s);
    forward.z() += Uniform(rng, -0.02, 0.02);
    layout.poses.push_back(LookAlong(center, forward, Eigen::Vector3d::UnitZ(),
                                     Uniform(rng, -1, 1) * kDegToRad));
  }
  const double s_min = -10;
  const double s_max = (num_images - 1) * kStepM + layout.max_depth + 5;
  layout.sample_point = [=](std::mt19937& rng) {
    const double s = Uniform(rng, s_min, s_max);
    const Eigen::Vector3d t = tangent(s);
    const Eigen::Vector3d lateral(-t.y(), t.x(), 0);
    ScenePoint point;
    // Ground and both facades, in proportion to their areas.
    const double area_ground = 2 * kHalfWidthM;
    const double pick = Uniform(rng, 0, area_ground + 2 * kWallHeightM);
    if (pick < area_ground) {
      point.xyz = path(s) + Uniform(rng, -kHalfWidthM, kHalfWidthM) * lateral +
                  Eigen::Vector3d(0, 0, Uniform(rng, -0.05, 0.05));
      point.normal = Eigen::Vector3d::UnitZ();
    } else {
      const double side = pick < area_ground + kWallHeightM ? 1.0 : -1.0;
      point.xyz = path(s) + side * kHalfWidthM * lateral +
                  Eigen::Vector3d(0, 0, Uniform(rng, 0, kWallHeightM));
      point.normal = -side * lateral;
    }
    return point;
  };
  return layout;
}

// Aerial survey: nadir images 40 m above hilly terrain, 10 m apart along
// serpentine rows (about 75% overlap), each point seen by ~15 images.
Layout MakeGridLayout(int num_images, std::mt19937& rng) {
  constexpr double kSpacingM = 10.0;
  constexpr double kAltitudeM = 40.0;
  const int num_cols =
      static_cast<int>(std::ceil(std::sqrt(static_cast<double>(num_images))));
  const int num_rows = (num_images + num_cols - 1) / num_cols;
  Layout layout;
  layout.max_depth = 70;
  layout.max_view_angle_deg = 60;
  for (int i = 0; i < num_images; ++i) {
    const int row = i / num_cols;
    const int col = row % 2 == 0 ? i % num_cols : num_cols - 1 - i % num_cols;
    const Eigen::Vector3d center(col * kSpacingM + Uniform(rng, -0.5, 0.5),
                                 row * kSpacingM + Uniform(rng, -0.5, 0.5),
                                 kAltitudeM + Uniform(rng, -1, 1));
    const Eigen::Vector3d forward(Uniform(rng, -0.05, 0.05),
                                  Uniform(rng, -0.05, 0.05), -1);
    layout.poses.push_back(LookAlong(center, forward, Eigen::Vector3d::UnitY(),
                                     Uniform(rng, -3, 3) * kDegToRad));
  }
  const double margin = 30;
  const double x_max = (num_cols - 1) * kSpacingM + margin;
  const double y_max = (num_rows - 1) * kSpacingM + margin;
  layout.sample_point = [=](std::mt19937& rng) {
    const double x = Uniform(rng, -margin, x_max);
    const double y = Uniform(rng, -margin, y_max);
    // Relief of +-4.5 m: far from planar at 40 m, as real terrain is.
    const double h =
        3 * std::sin(x / 17) * std::cos(y / 13) + 1.5 * std::sin(x / 7 + y / 9);
    const double dh_dx = 3 / 17.0 * std::cos(x / 17) * std::cos(y / 13) +
                         1.5 / 7 * std::cos(x / 7 + y / 9);
    const double dh_dy = -3 / 13.0 * std::sin(x / 17) * std::sin(y / 13) +
                         1.5 / 9 * std::cos(x / 7 + y / 9);
    ScenePoint point;
    point.xyz = Eigen::Vector3d(x, y, h);
    point.normal = Eigen::Vector3d(-dh_dx, -dh_dy, 1).normalized();
    return point;
  };
  return layout;
}

// True cameras: the focal length varies by +-10% between cameras; the
// distortion is small, as for ordinary lenses (times distortion_scale).
std::vector<colmap::Camera> MakeTrueCameras(
    const SyntheticSceneOptions& options) {
  const std::vector<std::string> models = SplitModelNames(options.camera_model);
  std::vector<std::pair<int, int>> sizes;
  ParseImageSizes(options, &sizes);
  std::mt19937 rng = MakeRng(options.random_seed, kCameraStream);
  std::mt19937 principal_point_rng =
      MakeRng(options.random_seed, kPrincipalPointStream);
  std::vector<colmap::Camera> cameras;
  for (int c = 0; c < options.num_cameras; ++c) {
    const auto [width, height] = sizes[c % sizes.size()];
    const double width_scale =
        static_cast<double>(width) / options.image_width_px;
    const double focal = width_scale * (options.num_cameras > 1
                                            ? options.focal_length_px *
                                                  (1 + Uniform(rng, -0.1, 0.1))
                                            : options.focal_length_px);
    colmap::Camera camera;
    camera.SetCameraId(static_cast<colmap::camera_t>(c + 1));
    camera.InitializeWithName(models[c % models.size()], focal, width, height);
    if (options.principal_point_offset > 0) {
      const double max_offset = options.principal_point_offset;
      camera.SetPrincipalPointX(
          width *
          (0.5 + Uniform(principal_point_rng, -max_offset, max_offset)));
      camera.SetPrincipalPointY(
          height *
          (0.5 + Uniform(principal_point_rng, -max_offset, max_offset)));
    }
    const std::vector<size_t>& extra_idxs = camera.ExtraParamsIdxs();
    const bool is_fov = camera.ModelName() == "FOV";
    for (size_t k = 0; k < extra_idxs.size(); ++k) {
      double value;
      if (is_fov) {
        value = Uniform(rng, 0.005, 0.02);  // omega: field-of-view distortion
      } else if (k == 0) {
        value = Uniform(rng, -0.02, 0.01);  // k1
      } else if (k == 1) {
        value = Uniform(rng, -0.005, 0.005);  // k2
      } else {
        value = Uniform(rng, -0.0005, 0.0005);  // tangential, higher orders
      }
      camera.Params(extra_idxs[k]) = options.distortion_scale * value;
    }
    camera.SetPriorFocalLength(true);
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

// What the feature extractor would have stored for each camera.
std::vector<colmap::Camera> MakeDatabaseCameras(
    const SyntheticSceneOptions& options,
    const std::vector<colmap::Camera>& true_cameras) {
  std::mt19937 rng = MakeRng(options.random_seed, kFocalPriorErrorStream);
  std::vector<colmap::Camera> cameras;
  for (size_t c = 0; c < true_cameras.size(); ++c) {
    const colmap::Camera& true_camera = true_cameras[c];
    colmap::Camera camera = true_camera;
    const bool has_prior =
        options.prior_focal_length &&
        (options.num_cameras_with_prior < 0 ||
         static_cast<int>(c) < options.num_cameras_with_prior);
    if (!has_prior) {
      camera.InitializeWithId(
          true_camera.ModelId(),
          1.2 * std::max(true_camera.Width(), true_camera.Height()),
          true_camera.Width(), true_camera.Height());
      camera.SetPriorFocalLength(false);
    } else if (options.prior_focal_length_error > 0) {
      const double factor = 1 + Uniform(rng, -options.prior_focal_length_error,
                                        options.prior_focal_length_error);
      for (const size_t idx : camera.FocalLengthIdxs()) {
        camera.Params(idx) *= factor;
      }
    }
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

// Projects `xyz` into an image; false if the point is not seen there.
bool ProjectVisible(const Layout& layout, const Pose& pose,
                    const colmap::Camera& camera, const ScenePoint& point,
                    double min_cos_view, Eigen::Vector2d* pixel) {
  const Eigen::Vector3d xyz_in_cam =
      pose.cam_from_world_R * point.xyz + pose.cam_from_world_t;
  if (xyz_in_cam.z() < 0.3) return false;
  const Eigen::Vector3d to_camera = pose.center - point.xyz;
  const double distance = to_camera.norm();
  if (distance > layout.max_depth) return false;
  if (point.normal.dot(to_camera) < min_cos_view * distance) return false;
  const Eigen::Vector2d normalized = xyz_in_cam.hnormalized();
  // Reject far outside the field of view before distorting, where
  // polynomial distortion can fold points back into the image.
  const double focal = camera.MeanFocalLength();
  if (std::abs(normalized.x()) > 0.7 * camera.Width() / focal ||
      std::abs(normalized.y()) > 0.7 * camera.Height() / focal) {
    return false;
  }
  *pixel = camera.WorldToImage(normalized);
  constexpr double kMarginPx = 2;
  return pixel->x() >= kMarginPx && pixel->y() >= kMarginPx &&
         pixel->x() <= camera.Width() - kMarginPx &&
         pixel->y() <= camera.Height() - kMarginPx;
}

struct Observation {
  uint32_t point_idx;
  Eigen::Vector2d pixel;
};

// For every image, the points it sees (sorted by point index), using a hash
// grid over the camera centres so that each point only tests nearby cameras.
std::vector<std::vector<Observation>> ComputeVisibility(
    const Layout& layout, const std::vector<colmap::Camera>& cameras,
    const std::vector<int>& camera_of_image,
    const std::vector<ScenePoint>& points, int num_threads) {
  const size_t num_images = layout.poses.size();
  const double min_cos_view = std::cos(layout.max_view_angle_deg * kDegToRad);
  const bool finite_depth = std::isfinite(layout.max_depth);
  const auto cell_of = [&](const Eigen::Vector3d& xyz) {
    if (!finite_depth) return Eigen::Vector3i(0, 0, 0);
    return Eigen::Vector3i(
        static_cast<int>(std::floor(xyz.x() / layout.max_depth)),
        static_cast<int>(std::floor(xyz.y() / layout.max_depth)),
        static_cast<int>(std::floor(xyz.z() / layout.max_depth)));
  };
  const auto key_of = [](const Eigen::Vector3i& cell) {
    return (static_cast<int64_t>(cell.x() + (1 << 20)) << 42) |
           (static_cast<int64_t>(cell.y() + (1 << 20)) << 21) |
           static_cast<int64_t>(cell.z() + (1 << 20));
  };
  std::unordered_map<int64_t, std::vector<uint32_t>> images_in_cell;
  for (size_t i = 0; i < num_images; ++i) {
    images_in_cell[key_of(cell_of(layout.poses[i].center))].push_back(i);
  }
  const int reach = finite_depth ? 1 : 0;

  std::vector<std::vector<std::pair<uint32_t, Eigen::Vector2d>>> seen_by(
      points.size());
  ParallelFor(num_threads, points.size(), [&](size_t p) {
    const Eigen::Vector3i cell = cell_of(points[p].xyz);
    std::vector<uint32_t> candidates;
    for (int dx = -reach; dx <= reach; ++dx) {
      for (int dy = -reach; dy <= reach; ++dy) {
        for (int dz = -reach; dz <= reach; ++dz) {
          const auto it =
              images_in_cell.find(key_of(cell + Eigen::Vector3i(dx, dy, dz)));
          if (it == images_in_cell.end()) continue;
          candidates.insert(candidates.end(), it->second.begin(),
                            it->second.end());
        }
      }
    }
    std::sort(candidates.begin(), candidates.end());
    Eigen::Vector2d pixel;
    for (const uint32_t i : candidates) {
      if (ProjectVisible(layout, layout.poses[i], cameras[camera_of_image[i]],
                         points[p], min_cos_view, &pixel)) {
        seen_by[p].emplace_back(i, pixel);
      }
    }
  });

  std::vector<std::vector<Observation>> observations(num_images);
  for (size_t p = 0; p < points.size(); ++p) {
    for (const auto& [image_idx, pixel] : seen_by[p]) {
      observations[image_idx].push_back({static_cast<uint32_t>(p), pixel});
    }
  }
  return observations;
}

// Picks the number of points that gives each image about
// kTargetVisiblePointsPerImage visible points, from a pilot sample seen by a
// few evenly spread images.
size_t AutomaticNumPoints(const SyntheticSceneOptions& options,
                          const Layout& layout,
                          const std::vector<colmap::Camera>& cameras,
                          const std::vector<int>& camera_of_image) {
  constexpr size_t kNumPilotPoints = 20000;
  constexpr size_t kNumPilotImages = 40;
  std::mt19937 rng = MakeRng(options.random_seed, kPilotStream);
  std::vector<ScenePoint> pilot(kNumPilotPoints);
  for (ScenePoint& point : pilot) point = layout.sample_point(rng);
  const size_t num_images = layout.poses.size();
  const size_t num_sampled = std::min(num_images, kNumPilotImages);
  const double min_cos_view = std::cos(layout.max_view_angle_deg * kDegToRad);
  size_t num_visible = 0;
  Eigen::Vector2d pixel;
  for (size_t k = 0; k < num_sampled; ++k) {
    const size_t i = k * num_images / num_sampled;
    for (const ScenePoint& point : pilot) {
      num_visible +=
          ProjectVisible(layout, layout.poses[i], cameras[camera_of_image[i]],
                         point, min_cos_view, &pixel);
    }
  }
  const double visible_per_image =
      std::max(1.0, static_cast<double>(num_visible) / num_sampled);
  return static_cast<size_t>(std::ceil(
      kNumPilotPoints * kTargetVisiblePointsPerImage / visible_per_image));
}

struct SyntheticImage {
  // Stored keypoints (float precision, as in the database).
  std::vector<Eigen::Vector2d> keypoints;
  // (point index, keypoint index) of the points the image sees, sorted.
  std::vector<std::pair<uint32_t, uint32_t>> point_to_keypoint;
};

SyntheticImage MakeKeypoints(const SyntheticSceneOptions& options,
                             const colmap::Camera& camera,
                             std::vector<Observation> observations,
                             std::mt19937& rng) {
  const size_t max_keypoints =
      static_cast<size_t>(options.max_keypoints_per_image);
  if (observations.size() > max_keypoints) {
    std::shuffle(observations.begin(), observations.end(), rng);
    observations.resize(max_keypoints);
    std::sort(observations.begin(), observations.end(),
              [](const Observation& a, const Observation& b) {
                return a.point_idx < b.point_idx;
              });
  }
  const size_t num_unmatched =
      std::min(max_keypoints - observations.size(),
               static_cast<size_t>(std::round(options.unmatched_keypoint_ratio *
                                              observations.size())));
  const size_t num_keypoints = observations.size() + num_unmatched;
  // Detectors list keypoints in no particular relation to the scene.
  std::vector<uint32_t> slots(num_keypoints);
  std::iota(slots.begin(), slots.end(), 0);
  std::shuffle(slots.begin(), slots.end(), rng);

  const double width = static_cast<double>(camera.Width());
  const double height = static_cast<double>(camera.Height());
  // Rounded to float first (the database stores float32), then clamped to
  // bounds that are floats too. The other order lets GCC 12 (-O3
  // -frounding-math) drop the rounding after std::clamp.
  const auto to_stored = [&](const Eigen::Vector2d& xy) {
    const double x = static_cast<float>(xy.x());
    const double y = static_cast<float>(xy.y());
    return Eigen::Vector2d(std::clamp(x, 0.5, width - 0.5),
                           std::clamp(y, 0.5, height - 0.5));
  };
  std::normal_distribution<double> noise(0, 1);
  SyntheticImage image;
  image.keypoints.resize(num_keypoints);
  image.point_to_keypoint.reserve(observations.size());
  for (size_t k = 0; k < observations.size(); ++k) {
    const Eigen::Vector2d offset(noise(rng), noise(rng));
    image.keypoints[slots[k]] =
        to_stored(observations[k].pixel + options.pixel_noise_px * offset);
    image.point_to_keypoint.emplace_back(observations[k].point_idx, slots[k]);
  }
  for (size_t k = observations.size(); k < num_keypoints; ++k) {
    image.keypoints[slots[k]] = to_stored(
        Eigen::Vector2d(Uniform(rng, 0, width), Uniform(rng, 0, height)));
  }
  return image;
}

// Each image with its `k` nearest images by camera centre, as canonical
// (smaller index, larger index) pairs, sorted and unique.
std::vector<std::pair<uint32_t, uint32_t>> SelectPairs(const Layout& layout,
                                                       size_t k,
                                                       int num_threads) {
  const size_t num_images = layout.poses.size();
  k = std::min(k, num_images - 1);
  std::vector<std::vector<uint32_t>> neighbors(num_images);
  ParallelFor(num_threads, num_images, [&](size_t i) {
    std::vector<std::pair<double, uint32_t>> distances;
    for (size_t j = 0; j < num_images; ++j) {
      if (j == i) continue;
      distances.emplace_back(
          (layout.poses[i].center - layout.poses[j].center).squaredNorm(),
          static_cast<uint32_t>(j));
    }
    std::nth_element(distances.begin(), distances.begin() + (k - 1),
                     distances.end());
    for (size_t n = 0; n < k; ++n) neighbors[i].push_back(distances[n].second);
  });
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  pairs.reserve(num_images * k);
  for (size_t i = 0; i < num_images; ++i) {
    for (const uint32_t j : neighbors[i]) {
      pairs.emplace_back(std::min<uint32_t>(i, j), std::max<uint32_t>(i, j));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

struct SyntheticPair {
  colmap::FeatureMatches raw_matches;
  colmap::TwoViewGeometry geometry;
};

// True matches: all points both images see.
colmap::FeatureMatches TrueMatches(const SyntheticImage& image1,
                                   const SyntheticImage& image2) {
  colmap::FeatureMatches matches;
  auto it1 = image1.point_to_keypoint.begin();
  auto it2 = image2.point_to_keypoint.begin();
  while (it1 != image1.point_to_keypoint.end() &&
         it2 != image2.point_to_keypoint.end()) {
    if (it1->first < it2->first) {
      ++it1;
    } else if (it2->first < it1->first) {
      ++it2;
    } else {
      matches.emplace_back(it1->second, it2->second);
      ++it1;
      ++it2;
    }
  }
  return matches;
}

// Raw matches from a pair's true (or symmetric-structure) matches: at most
// `max_true_matches` of them, picked at random, plus wrong ones between
// keypoints that see different points, one-to-one like a cross-checked
// matcher, in random order.
colmap::FeatureMatches MakeRawMatches(colmap::FeatureMatches matches,
                                      const SyntheticImage& image1,
                                      const SyntheticImage& image2,
                                      size_t max_true_matches,
                                      double wrong_match_ratio,
                                      std::mt19937& rng) {
  if (matches.empty()) return matches;
  if (matches.size() > max_true_matches) {
    std::shuffle(matches.begin(), matches.end(), rng);
    matches.resize(max_true_matches);
  }

  const size_t num_wrong = static_cast<size_t>(
      std::round(matches.size() * wrong_match_ratio / (1 - wrong_match_ratio)));
  if (num_wrong > 0) {
    const size_t num_keypoints1 = image1.keypoints.size();
    const size_t num_keypoints2 = image2.keypoints.size();
    std::vector<char> used1(num_keypoints1, 0), used2(num_keypoints2, 0);
    for (const colmap::FeatureMatch& match : matches) {
      used1[match.point2D_idx1] = 1;
      used2[match.point2D_idx2] = 1;
    }
    std::uniform_int_distribution<uint32_t> pick1(0, num_keypoints1 - 1);
    std::uniform_int_distribution<uint32_t> pick2(0, num_keypoints2 - 1);
    size_t num_added = 0;
    for (size_t attempt = 0; attempt < 50 * num_wrong && num_added < num_wrong;
         ++attempt) {
      const uint32_t idx1 = pick1(rng);
      const uint32_t idx2 = pick2(rng);
      if (used1[idx1] || used2[idx2]) continue;
      used1[idx1] = used2[idx2] = 1;
      matches.emplace_back(idx1, idx2);
      ++num_added;
    }
  }
  std::shuffle(matches.begin(), matches.end(), rng);
  return matches;
}

// Image indices sorted by the distance of their camera centre to `xyz`
// (ties by index).
std::vector<uint32_t> ImagesByDistance(const Layout& layout,
                                       const Eigen::Vector3d& xyz) {
  std::vector<std::pair<double, uint32_t>> distances;
  distances.reserve(layout.poses.size());
  for (size_t i = 0; i < layout.poses.size(); ++i) {
    distances.emplace_back((layout.poses[i].center - xyz).squaredNorm(),
                           static_cast<uint32_t>(i));
  }
  std::sort(distances.begin(), distances.end());
  std::vector<uint32_t> order;
  order.reserve(distances.size());
  for (const auto& [distance, idx] : distances) order.push_back(idx);
  return order;
}

// The images that play a part in a failure shape, by index.
struct ShapeRoles {
  std::vector<uint32_t> group;
  std::vector<uint32_t> anchors;
  std::vector<char> in_group;
  std::vector<char> is_anchor;
  // (moved image, image whose centre it takes).
  std::vector<std::pair<uint32_t, uint32_t>> pure_rotation;
  std::vector<uint32_t> long_baseline;
};

// Picks the weak group, its anchors, the pure-rotation and long-baseline
// images, and moves the pure-rotation images (before visibility, so that
// they see what their new centre sees). No image has two roles.
ShapeRoles PickShapeRoles(const SyntheticSceneOptions& options,
                          Layout* layout) {
  const size_t num_images = layout->poses.size();
  ShapeRoles roles;
  roles.in_group.assign(num_images, 0);
  roles.is_anchor.assign(num_images, 0);
  std::vector<char> taken(num_images, 0);
  std::mt19937 rng = MakeRng(options.random_seed, kShapeStream);
  std::uniform_int_distribution<uint32_t> pick_image(
      0, static_cast<uint32_t>(num_images - 1));

  if (options.weak_group_size > 0) {
    const uint32_t first = pick_image(rng);
    roles.group.push_back(first);
    for (const uint32_t i :
         ImagesByDistance(*layout, layout->poses[first].center)) {
      if (roles.group.size() == static_cast<size_t>(options.weak_group_size)) {
        break;
      }
      if (i != first) roles.group.push_back(i);
    }
    Eigen::Vector3d group_center = Eigen::Vector3d::Zero();
    for (const uint32_t i : roles.group) {
      roles.in_group[i] = taken[i] = 1;
      group_center += layout->poses[i].center;
    }
    group_center /= static_cast<double>(roles.group.size());
    for (const uint32_t i : ImagesByDistance(*layout, group_center)) {
      if (roles.anchors.size() ==
          static_cast<size_t>(options.weak_group_num_anchors)) {
        break;
      }
      if (taken[i]) continue;
      roles.anchors.push_back(i);
      roles.is_anchor[i] = taken[i] = 1;
    }
  }

  // OptionsError() allows at most num_images / 2 taken images, so these
  // draws end.
  const auto pick_free_image = [&]() {
    uint32_t i = pick_image(rng);
    while (taken[i]) i = pick_image(rng);
    taken[i] = 1;
    return i;
  };
  for (int k = 0; k < options.num_pure_rotation_images; ++k) {
    const uint32_t moved = pick_free_image();
    uint32_t partner = moved;
    for (const uint32_t i :
         ImagesByDistance(*layout, layout->poses[moved].center)) {
      if (!taken[i]) {
        partner = i;
        break;
      }
    }
    taken[partner] = 1;
    Pose& pose = layout->poses[moved];
    pose.center = layout->poses[partner].center;
    pose.cam_from_world_t = -pose.cam_from_world_R * pose.center;
    roles.pure_rotation.emplace_back(moved, partner);
  }
  for (int k = 0; k < options.num_long_baseline_images; ++k) {
    roles.long_baseline.push_back(pick_free_image());
  }
  return roles;
}

// Adds the weak group's private patch: a flat, richly textured square in
// front of the group, facing it, that only the group and its anchors see
// (a poster or a detail photographed up close). Its points are appended to
// `points`, their observations to those of the group and anchors (whose
// lists stay sorted by point index).
void AddPrivatePatch(const SyntheticSceneOptions& options, const Layout& layout,
                     const std::vector<colmap::Camera>& cameras,
                     const std::vector<int>& camera_of_image,
                     const ShapeRoles& roles, std::vector<ScenePoint>* points,
                     std::vector<std::vector<Observation>>* observations) {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  for (const uint32_t i : roles.group) {
    center += layout.poses[i].center;
    axis += layout.poses[i].cam_from_world_R.row(2).transpose();
  }
  center /= static_cast<double>(roles.group.size());
  axis.normalize();
  // In front of the first image at 3/4 of the median depth of what it sees,
  // so that the patch fills about half of its view.
  const Pose& first_pose = layout.poses[roles.group.front()];
  std::vector<double> depths;
  for (const Observation& observation : (*observations)[roles.group.front()]) {
    const Eigen::Vector3d xyz = points->at(observation.point_idx).xyz;
    depths.push_back(
        (first_pose.cam_from_world_R * xyz + first_pose.cam_from_world_t).z());
  }
  double distance = 1;
  if (!depths.empty()) {
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2,
                     depths.end());
    distance = 0.75 * depths[depths.size() / 2];
  }
  const colmap::Camera& first_camera =
      cameras[camera_of_image[roles.group.front()]];
  const double half_size =
      0.25 * distance * first_camera.Width() / first_camera.MeanFocalLength();
  const Eigen::Vector3d patch_center = center + distance * axis;
  const Eigen::Vector3d u = axis.unitOrthogonal();
  const Eigen::Vector3d v = axis.cross(u);

  std::mt19937 rng = MakeRng(options.random_seed, kPatchStream);
  const size_t first_patch_point = points->size();
  for (int k = 0; k < options.weak_group_num_patch_points; ++k) {
    ScenePoint point;
    point.xyz = patch_center + Uniform(rng, -half_size, half_size) * u +
                Uniform(rng, -half_size, half_size) * v +
                Uniform(rng, -0.01, 0.01) * distance * axis;
    point.normal = -axis;
    points->push_back(point);
  }
  std::vector<uint32_t> viewers = roles.group;
  viewers.insert(viewers.end(), roles.anchors.begin(), roles.anchors.end());
  const double min_cos_view = std::cos(layout.max_view_angle_deg * kDegToRad);
  Eigen::Vector2d pixel;
  for (const uint32_t i : viewers) {
    for (size_t p = first_patch_point; p < points->size(); ++p) {
      if (ProjectVisible(layout, layout.poses[i], cameras[camera_of_image[i]],
                         (*points)[p], min_cos_view, &pixel)) {
        (*observations)[i].push_back({static_cast<uint32_t>(p), pixel});
      }
    }
  }
}

size_t NumCommonPoints(const SyntheticImage& image1,
                       const SyntheticImage& image2) {
  return TrueMatches(image1, image2).size();
}

// Removes the pairs of each long-baseline image with its
// `num_skipped_neighbors` nearest images.
void RemoveShortBaselinePairs(
    const Layout& layout, const std::vector<uint32_t>& long_baseline_images,
    int num_skipped_neighbors,
    std::vector<std::pair<uint32_t, uint32_t>>* pairs) {
  std::vector<std::pair<uint32_t, uint32_t>> removed;
  for (const uint32_t i : long_baseline_images) {
    int num_skipped = 0;
    for (const uint32_t j : ImagesByDistance(layout, layout.poses[i].center)) {
      if (num_skipped == num_skipped_neighbors) break;
      if (j == i) continue;
      removed.emplace_back(std::min(i, j), std::max(i, j));
      ++num_skipped;
    }
  }
  std::sort(removed.begin(), removed.end());
  pairs->erase(std::remove_if(pairs->begin(), pairs->end(),
                              [&](const std::pair<uint32_t, uint32_t>& pair) {
                                return std::binary_search(removed.begin(),
                                                          removed.end(), pair);
                              }),
               pairs->end());
}

// Splits the images into two halves at the median of their camera centres
// along the direction in which the centres spread most, and removes every
// pair across the split except the one with the most common points. Returns
// that pair's index in the filtered `pairs` (or -1 if no pair crosses) and
// sets in_first_half per image.
int KeepOneBridge(const Layout& layout,
                  const std::vector<SyntheticImage>& images,
                  std::vector<std::pair<uint32_t, uint32_t>>* pairs,
                  std::vector<char>* in_first_half) {
  const size_t num_images = layout.poses.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Pose& pose : layout.poses) mean += pose.center;
  mean /= static_cast<double>(num_images);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Pose& pose : layout.poses) {
    covariance += (pose.center - mean) * (pose.center - mean).transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  const Eigen::Vector3d direction = solver.eigenvectors().col(2);
  std::vector<std::pair<double, uint32_t>> along;
  for (size_t i = 0; i < num_images; ++i) {
    along.emplace_back(direction.dot(layout.poses[i].center - mean),
                       static_cast<uint32_t>(i));
  }
  std::sort(along.begin(), along.end());
  in_first_half->assign(num_images, 0);
  for (size_t k = 0; k < num_images / 2; ++k) {
    (*in_first_half)[along[k].second] = 1;
  }

  std::pair<uint32_t, uint32_t> bridge(0, 0);
  size_t bridge_num_points = 0;
  for (const auto& [i, j] : *pairs) {
    if ((*in_first_half)[i] == (*in_first_half)[j]) continue;
    const size_t num_points = NumCommonPoints(images[i], images[j]);
    if (num_points > bridge_num_points) {
      bridge_num_points = num_points;
      bridge = {i, j};
    }
  }
  pairs->erase(std::remove_if(pairs->begin(), pairs->end(),
                              [&](const std::pair<uint32_t, uint32_t>& pair) {
                                return (*in_first_half)[pair.first] !=
                                           (*in_first_half)[pair.second] &&
                                       pair != bridge;
                              }),
               pairs->end());
  if (bridge_num_points == 0) return -1;
  return static_cast<int>(
      std::lower_bound(pairs->begin(), pairs->end(), bridge) - pairs->begin());
}

// A wrong-rotation pair: image B seen as if turned about a vertical axis.
struct WrongRotationPair {
  size_t pair_idx = 0;
  // Whether B is the pair's first image.
  bool turned_first = false;
  // B's pose as the symmetric structure makes it appear.
  Pose turned_pose;
  // Matches (first image's keypoint, second image's keypoint).
  colmap::FeatureMatches matches;
};

// Turns `pose` by `angle_rad` about the vertical line through the point at
// `depth` on its optical axis: what a camera sees of an object that is
// symmetric under that rotation.
Pose TurnedPose(const Pose& pose, double depth, double angle_rad) {
  const Eigen::Vector3d pivot =
      pose.center + depth * pose.cam_from_world_R.row(2).transpose();
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Pose turned;
  turned.center = pivot + turn * (pose.center - pivot);
  turned.cam_from_world_R = pose.cam_from_world_R * turn.transpose();
  turned.cam_from_world_t = -turned.cam_from_world_R * turned.center;
  return turned;
}

// Makes the symmetric matches of a wrong-rotation pair: every scene point
// (index below `num_scene_points`: not the private patch, which has no
// symmetric copy) that image A sees and the turned image B would see becomes
// a new keypoint of B, matched to A's keypoint of the point. These come on
// top of B's max_keypoints_per_image.
void MakeSymmetricMatches(const SyntheticSceneOptions& options,
                          const Layout& layout,
                          const std::vector<colmap::Camera>& cameras,
                          const std::vector<int>& camera_of_image,
                          const std::vector<ScenePoint>& points,
                          size_t num_scene_points, uint32_t image_a,
                          uint32_t image_b, std::vector<SyntheticImage>* images,
                          WrongRotationPair* pair) {
  std::mt19937 rng =
      MakeRng(options.random_seed, kWrongRotationStream, pair->pair_idx + 1);
  const Pose& pose_b = layout.poses[image_b];
  std::vector<double> depths;
  for (const auto& [point_idx, keypoint_idx] :
       (*images)[image_b].point_to_keypoint) {
    depths.push_back((pose_b.cam_from_world_R * points[point_idx].xyz +
                      pose_b.cam_from_world_t)
                         .z());
  }
  double depth = 1;
  if (!depths.empty()) {
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2,
                     depths.end());
    depth = depths[depths.size() / 2];
  }
  // Turned towards A: the symmetric structure is confused with what B would
  // see from nearer to A, which makes the strongest wrong matches.
  const double angle_rad = options.wrong_rotation_angle_deg * kDegToRad;
  const Eigen::Vector3d& center_a = layout.poses[image_a].center;
  const Pose turned_left = TurnedPose(pose_b, depth, angle_rad);
  const Pose turned_right = TurnedPose(pose_b, depth, -angle_rad);
  pair->turned_pose = (turned_left.center - center_a).squaredNorm() <=
                              (turned_right.center - center_a).squaredNorm()
                          ? turned_left
                          : turned_right;

  const colmap::Camera& camera_b = cameras[camera_of_image[image_b]];
  const double min_cos_view = std::cos(layout.max_view_angle_deg * kDegToRad);
  std::vector<std::pair<uint32_t, Eigen::Vector2d>> seen;
  Eigen::Vector2d pixel;
  for (const auto& [point_idx, keypoint_idx] :
       (*images)[image_a].point_to_keypoint) {
    if (point_idx < num_scene_points &&
        ProjectVisible(layout, pair->turned_pose, camera_b, points[point_idx],
                       min_cos_view, &pixel)) {
      seen.emplace_back(keypoint_idx, pixel);
    }
  }
  SyntheticImage& turned_image = (*images)[image_b];
  std::normal_distribution<double> noise(0, 1);
  const double width = static_cast<double>(camera_b.Width());
  const double height = static_cast<double>(camera_b.Height());
  for (const auto& [keypoint_a, xy] : seen) {
    const Eigen::Vector2d noisy =
        xy + options.pixel_noise_px * Eigen::Vector2d(noise(rng), noise(rng));
    // Stored as float, like every keypoint.
    turned_image.keypoints.emplace_back(
        std::clamp<double>(static_cast<float>(noisy.x()), 0.5, width - 0.5),
        std::clamp<double>(static_cast<float>(noisy.y()), 0.5, height - 0.5));
    const uint32_t keypoint_b =
        static_cast<uint32_t>(turned_image.keypoints.size() - 1);
    if (pair->turned_first) {
      pair->matches.emplace_back(keypoint_b, keypoint_a);
    } else {
      pair->matches.emplace_back(keypoint_a, keypoint_b);
    }
  }
}

Eigen::Matrix3d CrossProductMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Verification against the true geometry: cheap enough for 10k images.
colmap::TwoViewGeometry VerifyWithGroundTruth(
    const colmap::FeatureMatches& raw_matches, const Pose& pose1,
    const Pose& pose2, const colmap::Camera& true_camera1,
    const colmap::Camera& true_camera2,
    const std::vector<Eigen::Vector2d>& normalized1,
    const std::vector<Eigen::Vector2d>& normalized2, bool calibrated) {
  const Eigen::Matrix3d R =
      pose2.cam_from_world_R * pose1.cam_from_world_R.transpose();
  const double focal =
      0.5 * (true_camera1.MeanFocalLength() + true_camera2.MeanFocalLength());
  colmap::TwoViewGeometry geometry;
  if ((pose2.center - pose1.center).norm() <=
      1e-9 * (1 + pose1.center.norm())) {
    // No baseline: the homography of the rotation explains every match, E
    // and F are undefined; COLMAP's verifier calls such pairs
    // PLANAR_OR_PANORAMIC.
    const double max_transfer = kMaxEpipolarErrorPx / focal;
    for (const colmap::FeatureMatch& match : raw_matches) {
      const Eigen::Vector3d x1 = normalized1[match.point2D_idx1].homogeneous();
      const Eigen::Vector3d Rx1 = R * x1;
      if (Rx1.z() > 0 &&
          (Rx1.hnormalized() - normalized2[match.point2D_idx2]).norm() <=
              max_transfer) {
        geometry.inlier_matches.push_back(match);
      }
    }
    if (geometry.inlier_matches.size() < static_cast<size_t>(kMinNumInliers)) {
      geometry.inlier_matches.clear();
      geometry.config = colmap::TwoViewGeometry::DEGENERATE;
      return geometry;
    }
    geometry.config = colmap::TwoViewGeometry::PLANAR_OR_PANORAMIC;
    geometry.H = true_camera2.CalibrationMatrix() * R *
                 true_camera1.CalibrationMatrix().inverse();
    geometry.H /= geometry.H.norm();
    return geometry;
  }
  const Eigen::Vector3d t =
      (pose2.cam_from_world_t - R * pose1.cam_from_world_t).normalized();
  const Eigen::Matrix3d E = CrossProductMatrix(t) * R;
  // Sampson distance in normalized coordinates, scaled to pixels.
  const double max_sampson = std::pow(kMaxEpipolarErrorPx / focal, 2);

  for (const colmap::FeatureMatch& match : raw_matches) {
    const Eigen::Vector3d x1 = normalized1[match.point2D_idx1].homogeneous();
    const Eigen::Vector3d x2 = normalized2[match.point2D_idx2].homogeneous();
    const Eigen::Vector3d Ex1 = E * x1;
    const Eigen::Vector3d Etx2 = E.transpose() * x2;
    const double x2tEx1 = x2.dot(Ex1);
    const double sampson =
        x2tEx1 * x2tEx1 /
        (Ex1.head<2>().squaredNorm() + Etx2.head<2>().squaredNorm());
    if (sampson <= max_sampson) geometry.inlier_matches.push_back(match);
  }
  if (geometry.inlier_matches.size() < static_cast<size_t>(kMinNumInliers)) {
    geometry.inlier_matches.clear();
    geometry.config = colmap::TwoViewGeometry::DEGENERATE;
    return geometry;
  }
  geometry.config = calibrated ? colmap::TwoViewGeometry::CALIBRATED
                               : colmap::TwoViewGeometry::UNCALIBRATED;
  geometry.F = true_camera2.CalibrationMatrix().transpose().inverse() * E *
               true_camera1.CalibrationMatrix().inverse();
  geometry.F /= geometry.F.norm();
  if (calibrated) geometry.E = E;
  return geometry;
}

colmap::TwoViewGeometry::Options MatcherVerificationOptions() {
  colmap::TwoViewGeometry::Options options;
  options.min_num_inliers = kMinNumInliers;
  options.ransac_options.max_error = kMaxEpipolarErrorPx;
  options.ransac_options.confidence = 0.999;
  options.ransac_options.min_num_trials = 100;
  options.ransac_options.max_num_trials = 10000;
  options.ransac_options.min_inlier_ratio = 0.25;
  return options;
}

// Simulated position priors: metric positions in the scene frame (NaN where
// an image has none) and the values stored in the database.
struct SimulatedPriors {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> stored;
  std::vector<uint32_t> outliers;  // image indices, sorted
  std::vector<uint32_t> missing;
};

SimulatedPriors MakePriors(const SyntheticSceneOptions& options,
                           const Layout& layout) {
  const size_t num_images = layout.poses.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SimulatedPriors priors;
  // Which images have no prior and which an outlier: disjoint, from one
  // permutation.
  std::vector<uint32_t> order(num_images);
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 selection_rng =
      MakeRng(options.random_seed, kPriorSelectionStream);
  std::shuffle(order.begin(), order.end(), selection_rng);
  const size_t num_missing = std::min(
      num_images, static_cast<size_t>(
                      std::round(options.prior_missing_ratio * num_images)));
  const size_t num_outliers = std::min(
      num_images - num_missing, static_cast<size_t>(std::round(
                                    options.prior_outlier_ratio * num_images)));
  priors.missing.assign(order.begin(), order.begin() + num_missing);
  priors.outliers.assign(order.begin() + num_missing,
                         order.begin() + num_missing + num_outliers);
  std::sort(priors.missing.begin(), priors.missing.end());
  std::sort(priors.outliers.begin(), priors.outliers.end());
  std::vector<char> is_missing(num_images, 0), is_outlier(num_images, 0);
  for (const uint32_t i : priors.missing) is_missing[i] = 1;
  for (const uint32_t i : priors.outliers) is_outlier[i] = 1;

  // Every image draws its noise and its displacement from its own stream,
  // whatever it is used for, so that the ratios and the noise level do not
  // change the draws of the other images.
  priors.positions.resize(num_images);
  for (size_t i = 0; i < num_images; ++i) {
    std::mt19937 rng = MakeRng(options.random_seed, kPriorNoiseStream, i);
    std::normal_distribution<double> normal(0, 1);
    Eigen::Vector3d noise;
    for (int k = 0; k < 3; ++k) noise(k) = normal(rng);
    Eigen::Vector3d direction;
    for (int k = 0; k < 3; ++k) direction(k) = normal(rng);
    const double length =
        Uniform(rng, options.prior_outlier_min_m, options.prior_outlier_max_m);
    const Eigen::Vector3d& center = layout.poses[i].center;
    if (is_missing[i]) {
      priors.positions[i] = Eigen::Vector3d::Constant(nan);
    } else if (is_outlier[i]) {
      const double norm = direction.norm();
      priors.positions[i] =
          center + length * (norm > 1e-12 ? Eigen::Vector3d(direction / norm)
                                          : Eigen::Vector3d::UnitX());
    } else {
      priors.positions[i] = center + options.prior_position_noise_m * noise;
    }
  }

  priors.stored = priors.positions;
  if (options.prior_as_gps) {
    // The scene frame is ENU around the origin (x east, y north, z up).
    std::vector<Eigen::Vector3d> enu;
    for (size_t i = 0; i < num_images; ++i) {
      if (!is_missing[i]) enu.push_back(priors.positions[i]);
    }
    const colmap::GPSTransform gps(colmap::GPSTransform::WGS84);
    const std::vector<Eigen::Vector3d> lla = gps.ENUToEll(
        enu, options.prior_gps_origin.x(), options.prior_gps_origin.y(),
        options.prior_gps_origin.z());
    size_t k = 0;
    for (size_t i = 0; i < num_images; ++i) {
      if (!is_missing[i]) priors.stored[i] = lla[k++];
    }
  }
  return priors;
}

std::string ImageName(size_t image_idx) {
  char name[32];
  std::snprintf(name, sizeof(name), "image%04zu.png", image_idx + 1);
  return name;
}

}  // namespace

bool SyntheticSceneOptions::Check() const {
  return OptionsError(*this).empty();
}

Status WriteSyntheticScene(const SyntheticSceneOptions& options,
                           const std::string& database_path,
                           colmap::Reconstruction* ground_truth,
                           SyntheticSceneShapes* shapes) {
  const std::string options_error = OptionsError(options);
  if (!options_error.empty()) {
    return Status::Error("Invalid synthetic scene options: " + options_error +
                         ".");
  }
  std::error_code error;
  if (std::filesystem::exists(database_path, error)) {
    return Status::Error("The database " + database_path +
                         " already exists; the synthetic scene needs a new "
                         "file.");
  }
  const std::filesystem::path parent =
      std::filesystem::path(database_path).parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent, error)) {
    return Status::Error("The folder " + parent.string() + " does not exist.");
  }
  if (ground_truth->NumCameras() > 0 || ground_truth->NumImages() > 0) {
    return Status::Error("WriteSyntheticScene needs an empty reconstruction.");
  }

  const size_t num_images = static_cast<size_t>(options.num_images);

  // Cameras and poses.
  const std::vector<colmap::Camera> true_cameras = MakeTrueCameras(options);
  const std::vector<colmap::Camera> database_cameras =
      MakeDatabaseCameras(options, true_cameras);
  std::vector<int> camera_of_image(num_images);
  for (size_t i = 0; i < num_images; ++i) {
    camera_of_image[i] = static_cast<int>(i % true_cameras.size());
  }
  std::mt19937 pose_rng = MakeRng(options.random_seed, kPoseStream);
  Layout layout;
  if (options.layout == "ring") {
    layout = MakeRingLayout(options.num_images, pose_rng);
  } else if (options.layout == "forward") {
    layout = MakeForwardLayout(options.num_images, pose_rng);
  } else {
    layout = MakeGridLayout(options.num_images, pose_rng);
  }
  const ShapeRoles roles = PickShapeRoles(options, &layout);

  // Points and what each image sees.
  const size_t num_points =
      options.num_points3D > 0
          ? static_cast<size_t>(options.num_points3D)
          : AutomaticNumPoints(options, layout, true_cameras, camera_of_image);
  std::vector<ScenePoint> points(num_points);  // the patch may add more
  std::mt19937 point_rng = MakeRng(options.random_seed, kPointStream);
  for (ScenePoint& point : points) point = layout.sample_point(point_rng);
  std::vector<std::vector<Observation>> observations = ComputeVisibility(
      layout, true_cameras, camera_of_image, points, options.num_threads);
  if (!roles.group.empty() && options.weak_group_num_patch_points > 0) {
    AddPrivatePatch(options, layout, true_cameras, camera_of_image, roles,
                    &points, &observations);
  }

  // Keypoints, each image with its own random stream.
  std::vector<SyntheticImage> images(num_images);
  std::vector<std::vector<Eigen::Vector2d>> normalized(num_images);
  ParallelFor(options.num_threads, num_images, [&](size_t i) {
    std::mt19937 rng = MakeRng(options.random_seed, kKeypointStream, i);
    const colmap::Camera& camera = true_cameras[camera_of_image[i]];
    images[i] = MakeKeypoints(options, camera, std::move(observations[i]), rng);
  });
  observations.clear();

  // Which pairs are matched.
  std::vector<std::pair<uint32_t, uint32_t>> pair_idxs =
      SelectPairs(layout, static_cast<size_t>(options.max_pairs_per_image),
                  options.num_threads);
  if (!roles.long_baseline.empty()) {
    RemoveShortBaselinePairs(layout, roles.long_baseline,
                             options.long_baseline_num_skipped_neighbors,
                             &pair_idxs);
  }
  std::vector<char> in_first_half;
  const int bridge_idx =
      options.weak_bridge
          ? KeepOneBridge(layout, images, &pair_idxs, &in_first_half)
          : -1;

  // How many true matches each pair keeps: pairs from the weak group to the
  // rest and the bridge are thinned.
  std::vector<size_t> max_true_matches(pair_idxs.size(),
                                       std::numeric_limits<size_t>::max());
  if (!roles.group.empty()) {
    for (size_t p = 0; p < pair_idxs.size(); ++p) {
      const auto [i, j] = pair_idxs[p];
      if (roles.in_group[i] != roles.in_group[j] && !roles.is_anchor[i] &&
          !roles.is_anchor[j]) {
        max_true_matches[p] =
            static_cast<size_t>(options.weak_group_max_matches_to_rest);
      }
    }
  }
  if (bridge_idx >= 0) {
    max_true_matches[bridge_idx] =
        std::min(max_true_matches[bridge_idx],
                 static_cast<size_t>(options.weak_bridge_max_matches));
  }

  // Wrong-rotation pairs, picked at random among the candidates (pairs whose
  // views overlap), and their symmetric keypoints (in pair order, as several
  // may add to one image).
  std::vector<WrongRotationPair> wrong_pairs;
  if (options.num_wrong_rotation_pairs > 0) {
    for (size_t p = 0; p < pair_idxs.size(); ++p) {
      const auto [i, j] = pair_idxs[p];
      if (NumCommonPoints(images[i], images[j]) <
          static_cast<size_t>(2 * kMinNumInliers)) {
        continue;
      }
      WrongRotationPair wrong;
      wrong.pair_idx = p;
      if (options.wrong_rotation_pairs == "any") {
        wrong_pairs.push_back(wrong);
        continue;
      }
      if (roles.in_group[i] == roles.in_group[j]) continue;
      wrong.turned_first = roles.in_group[j];
      const uint32_t other = wrong.turned_first ? i : j;
      const bool to_anchors =
          options.wrong_rotation_pairs == "group_to_anchors";
      if (static_cast<bool>(roles.is_anchor[other]) == to_anchors) {
        wrong_pairs.push_back(wrong);
      }
    }
    std::mt19937 rng = MakeRng(options.random_seed, kWrongRotationStream, 0);
    std::shuffle(wrong_pairs.begin(), wrong_pairs.end(), rng);
    wrong_pairs.resize(
        std::min(wrong_pairs.size(),
                 static_cast<size_t>(options.num_wrong_rotation_pairs)));
    std::sort(wrong_pairs.begin(), wrong_pairs.end(),
              [](const WrongRotationPair& a, const WrongRotationPair& b) {
                return a.pair_idx < b.pair_idx;
              });
    for (WrongRotationPair& wrong : wrong_pairs) {
      const auto [i, j] = pair_idxs[wrong.pair_idx];
      MakeSymmetricMatches(options, layout, true_cameras, camera_of_image,
                           points, num_points, wrong.turned_first ? j : i,
                           wrong.turned_first ? i : j, &images, &wrong);
    }
  }
  std::vector<const WrongRotationPair*> wrong_pair_of(pair_idxs.size(),
                                                      nullptr);
  for (const WrongRotationPair& wrong : wrong_pairs) {
    wrong_pair_of[wrong.pair_idx] = &wrong;
  }

  if (options.verification == "ground_truth") {
    ParallelFor(options.num_threads, num_images, [&](size_t i) {
      const colmap::Camera& camera = true_cameras[camera_of_image[i]];
      normalized[i].reserve(images[i].keypoints.size());
      for (const Eigen::Vector2d& keypoint : images[i].keypoints) {
        normalized[i].push_back(camera.ImageToWorld(keypoint));
      }
    });
  }

  // Matching and verification, each pair with its own random stream.
  const colmap::TwoViewGeometry::Options verification_options =
      MatcherVerificationOptions();
  std::vector<SyntheticPair> pairs(pair_idxs.size());
  ParallelFor(options.num_threads, pair_idxs.size(), [&](size_t p) {
    const auto [i, j] = pair_idxs[p];
    std::mt19937 rng = MakeRng(options.random_seed, kPairStream, p);
    SyntheticPair& pair = pairs[p];
    const WrongRotationPair* wrong = wrong_pair_of[p];
    pair.raw_matches = MakeRawMatches(
        wrong != nullptr ? wrong->matches : TrueMatches(images[i], images[j]),
        images[i], images[j],
        wrong != nullptr ? std::numeric_limits<size_t>::max()
                         : max_true_matches[p],
        options.wrong_match_ratio, rng);
    if (pair.raw_matches.size() < static_cast<size_t>(kMinNumInliers)) {
      return;  // COLMAP's verifier skips these (config UNDEFINED).
    }
    const colmap::Camera& camera1 = database_cameras[camera_of_image[i]];
    const colmap::Camera& camera2 = database_cameras[camera_of_image[j]];
    if (options.verification == "colmap") {
      // RANSAC draws from COLMAP's thread-local generator: reseed it per
      // pair so that the result does not depend on thread scheduling.
      colmap::SetPRNGSeed(static_cast<unsigned>(
          MakeRng(options.random_seed, kRansacStream, p)()));
      pair.geometry.Estimate(camera1, images[i].keypoints, camera2,
                             images[j].keypoints, pair.raw_matches,
                             verification_options);
    } else {
      // A wrong-rotation pair is verified against the turned pose, as the
      // matches are consistent with it.
      const Pose& pose1 = wrong != nullptr && wrong->turned_first
                              ? wrong->turned_pose
                              : layout.poses[i];
      const Pose& pose2 = wrong != nullptr && !wrong->turned_first
                              ? wrong->turned_pose
                              : layout.poses[j];
      pair.geometry = VerifyWithGroundTruth(
          pair.raw_matches, pose1, pose2, true_cameras[camera_of_image[i]],
          true_cameras[camera_of_image[j]], normalized[i], normalized[j],
          camera1.HasPriorFocalLength() && camera2.HasPriorFocalLength());
    }
  });

  SimulatedPriors priors;
  if (options.prior_position_noise_m >= 0) priors = MakePriors(options, layout);

  // The database, written as COLMAP's extractor and matcher would.
  {
    colmap::Database database(database_path);
    colmap::DatabaseTransaction transaction(&database);
    if (options.database_camera_per_image) {
      for (size_t i = 0; i < num_images; ++i) {
        colmap::Camera camera = database_cameras[camera_of_image[i]];
        camera.SetCameraId(static_cast<colmap::camera_t>(i + 1));
        database.WriteCamera(camera, /*use_camera_id=*/true);
      }
    } else {
      for (const colmap::Camera& camera : database_cameras) {
        database.WriteCamera(camera, /*use_camera_id=*/true);
      }
    }
    for (size_t i = 0; i < num_images; ++i) {
      colmap::Image image;
      image.SetImageId(static_cast<colmap::image_t>(i + 1));
      image.SetName(ImageName(i));
      image.SetCameraId(options.database_camera_per_image
                            ? static_cast<colmap::camera_t>(i + 1)
                            : database_cameras[camera_of_image[i]].CameraId());
      // NaN (no prior) is stored as NULL.
      if (!priors.stored.empty()) image.SetTvecPrior(priors.stored[i]);
      database.WriteImage(image, /*use_image_id=*/true);
      colmap::FeatureKeypoints keypoints;
      keypoints.reserve(images[i].keypoints.size());
      for (const Eigen::Vector2d& xy : images[i].keypoints) {
        keypoints.emplace_back(static_cast<float>(xy.x()),
                               static_cast<float>(xy.y()));
      }
      database.WriteKeypoints(image.ImageId(), keypoints);
    }
    for (size_t p = 0; p < pair_idxs.size(); ++p) {
      if (pairs[p].raw_matches.empty()) continue;
      const colmap::image_t image_id1 = pair_idxs[p].first + 1;
      const colmap::image_t image_id2 = pair_idxs[p].second + 1;
      database.WriteMatches(image_id1, image_id2, pairs[p].raw_matches);
      database.WriteTwoViewGeometry(image_id1, image_id2, pairs[p].geometry);
    }
  }

  // The ground truth.
  for (const colmap::Camera& camera : true_cameras) {
    ground_truth->AddCamera(camera);
  }
  for (size_t i = 0; i < num_images; ++i) {
    colmap::Image image;
    image.SetImageId(static_cast<colmap::image_t>(i + 1));
    image.SetName(ImageName(i));
    image.SetCameraId(true_cameras[camera_of_image[i]].CameraId());
    image.SetQvec(
        colmap::RotationMatrixToQuaternion(layout.poses[i].cam_from_world_R));
    image.SetTvec(layout.poses[i].cam_from_world_t);
    image.SetPoints2D(images[i].keypoints);
    ground_truth->AddImage(std::move(image));
    ground_truth->RegisterImage(static_cast<colmap::image_t>(i + 1));
  }
  std::vector<colmap::Track> tracks(points.size());
  for (size_t i = 0; i < num_images; ++i) {
    for (const auto& [point_idx, keypoint_idx] : images[i].point_to_keypoint) {
      tracks[point_idx].AddElement(static_cast<colmap::image_t>(i + 1),
                                   keypoint_idx);
    }
  }
  for (size_t p = 0; p < points.size(); ++p) {
    if (tracks[p].Length() < 2) continue;
    ground_truth->AddPoint3D(points[p].xyz, std::move(tracks[p]));
  }

  if (shapes != nullptr) {
    *shapes = SyntheticSceneShapes();
    const auto id = [](uint32_t idx) {
      return static_cast<colmap::image_t>(idx + 1);
    };
    for (const uint32_t i : roles.group) {
      shapes->weak_group_image_ids.push_back(id(i));
    }
    for (const uint32_t i : roles.anchors) {
      shapes->weak_group_anchor_image_ids.push_back(id(i));
    }
    for (const WrongRotationPair& wrong : wrong_pairs) {
      const auto [i, j] = pair_idxs[wrong.pair_idx];
      SyntheticSceneShapes::WrongRotationPair pair;
      pair.image_id1 = id(i);
      pair.image_id2 = id(j);
      pair.turned_image_id = id(wrong.turned_first ? i : j);
      pair.num_matches = wrong.matches.size();
      shapes->wrong_rotation_pairs.push_back(pair);
    }
    for (const auto& [moved, partner] : roles.pure_rotation) {
      shapes->pure_rotation_image_ids.emplace_back(id(moved), id(partner));
    }
    for (const uint32_t i : roles.long_baseline) {
      shapes->long_baseline_image_ids.push_back(id(i));
    }
    if (bridge_idx >= 0) {
      const auto [i, j] = pair_idxs[bridge_idx];
      shapes->weak_bridge_pair = {id(i), id(j)};
      for (size_t k = 0; k < num_images; ++k) {
        if (in_first_half[k] == in_first_half[i]) {
          shapes->weak_bridge_half_image_ids.push_back(id(k));
        }
      }
    }
    shapes->prior_positions = priors.positions;
    for (const uint32_t i : priors.outliers) {
      shapes->prior_outlier_image_ids.push_back(id(i));
    }
    for (const uint32_t i : priors.missing) {
      shapes->prior_missing_image_ids.push_back(id(i));
    }
  }
  return Status::Ok();
}

}  // namespace glomap
