// make_synthetic_scene: writes a synthetic COLMAP database and its ground
// truth for tests, benchmarks and demos.
//
//   make_synthetic_scene --output_path DIR [--num_images N ...]
//
// DIR/database.db is a new COLMAP 3.8 database (as after feature extraction
// and matching); DIR/gt/ is the ground truth as a COLMAP text model (metres,
// x east, y north, z up). With --prior_position_noise_m >= 0 the database
// also holds simulated position priors, listed with their truth in
// DIR/priors.txt.

#include <algorithm>
#include <boost/program_options.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "glomap/io/database_reader.h"
#include "tests/support/synthetic_scene.h"

namespace {

int Fail(const std::string& message) {
  std::cerr << "make_synthetic_scene: " << message << std::endl;
  return EXIT_FAILURE;
}

std::string JoinIds(const std::vector<colmap::image_t>& image_ids) {
  std::string text;
  for (const colmap::image_t image_id : image_ids) {
    text += (text.empty() ? "" : " ") + std::to_string(image_id);
  }
  return text;
}

// One line per failure shape, with image ids, for scripts and tests.
void PrintShapes(const glomap::SyntheticSceneShapes& shapes) {
  if (!shapes.weak_group_image_ids.empty()) {
    std::cout << "Weak group: images " << JoinIds(shapes.weak_group_image_ids)
              << "; anchors " << JoinIds(shapes.weak_group_anchor_image_ids)
              << std::endl;
  }
  for (const auto& pair : shapes.wrong_rotation_pairs) {
    std::cout << "Wrong-rotation pair: images " << pair.image_id1 << " "
              << pair.image_id2 << ", turned image " << pair.turned_image_id
              << ", " << pair.num_matches << " symmetric matches" << std::endl;
  }
  for (const auto& [moved, partner] : shapes.pure_rotation_image_ids) {
    std::cout << "Pure-rotation image: " << moved << " at the centre of "
              << partner << std::endl;
  }
  if (!shapes.long_baseline_image_ids.empty()) {
    std::cout << "Long-baseline images: "
              << JoinIds(shapes.long_baseline_image_ids) << std::endl;
  }
  if (shapes.weak_bridge_pair.first != 0) {
    std::cout << "Weak bridge: images " << shapes.weak_bridge_pair.first << " "
              << shapes.weak_bridge_pair.second << "; half of "
              << shapes.weak_bridge_pair.first << ": "
              << JoinIds(shapes.weak_bridge_half_image_ids) << std::endl;
  }
  if (!shapes.prior_outlier_image_ids.empty()) {
    std::cout << "Prior outliers: images "
              << JoinIds(shapes.prior_outlier_image_ids) << std::endl;
  }
  if (!shapes.prior_missing_image_ids.empty()) {
    std::cout << "Images without prior: "
              << JoinIds(shapes.prior_missing_image_ids) << std::endl;
  }
}

// "lat,lon,alt" into a vector; false if it is not three numbers.
bool ParseGpsOrigin(const std::string& text, Eigen::Vector3d* origin) {
  std::stringstream stream(text);
  std::string field;
  int k = 0;
  while (std::getline(stream, field, ',')) {
    if (k == 3) return false;
    try {
      size_t end = 0;
      (*origin)(k) = std::stod(field, &end);
      if (field.find_first_not_of(" \t", end) != std::string::npos) {
        return false;
      }
    } catch (const std::exception&) {
      return false;
    }
    ++k;
  }
  return k == 3;
}

// DIR/priors.txt: per image, what kind of prior it got, its true centre and
// its metric prior (scene frame), so that tests can check what a mapper
// makes of them (e.g. that it names the outliers).
bool WritePriors(const glomap::SyntheticSceneOptions& options,
                 const glomap::SyntheticSceneShapes& shapes,
                 const colmap::Reconstruction& ground_truth,
                 const std::string& path) {
  std::ofstream file(path);
  if (!file) return false;
  file << "# Simulated camera position priors of a synthetic scene "
          "(make_synthetic_scene).\n"
       << "# Units: metres; frame: the ground truth's (x east, y north, z "
          "up).\n"
       << "# prior_position_noise_m " << options.prior_position_noise_m
       << " prior_outlier_ratio " << options.prior_outlier_ratio
       << " prior_outlier_min_m " << options.prior_outlier_min_m
       << " prior_outlier_max_m " << options.prior_outlier_max_m
       << " prior_missing_ratio " << options.prior_missing_ratio
       << " random_seed " << options.random_seed << "\n";
  if (options.prior_as_gps) {
    file << std::setprecision(10)
         << "# The database stores them as GPS (prior_tx, prior_ty, prior_tz "
            "= latitude deg, longitude deg, WGS84 altitude m) around the "
            "origin "
         << options.prior_gps_origin.x() << " " << options.prior_gps_origin.y()
         << " " << options.prior_gps_origin.z() << "\n";
  } else {
    file << "# The database stores them as they are here (prior_tx, "
            "prior_ty, prior_tz in metres).\n";
  }
  file << "# KIND: inlier (true centre + noise), outlier (displaced), "
          "missing (NULL in the database; prior and error nan).\n"
       << "# IMAGE_ID NAME KIND TRUE_X TRUE_Y TRUE_Z PRIOR_X PRIOR_Y "
          "PRIOR_Z ERROR_M\n";
  const auto contains = [](const std::vector<colmap::image_t>& ids,
                           colmap::image_t id) {
    return std::find(ids.begin(), ids.end(), id) != ids.end();
  };
  file << std::fixed << std::setprecision(6);
  for (size_t k = 0; k < shapes.prior_positions.size(); ++k) {
    const colmap::image_t image_id = static_cast<colmap::image_t>(k + 1);
    const colmap::Image& image = ground_truth.Image(image_id);
    const Eigen::Vector3d center = image.ProjectionCenter();
    const Eigen::Vector3d& prior = shapes.prior_positions[k];
    const char* kind =
        contains(shapes.prior_missing_image_ids, image_id)   ? "missing"
        : contains(shapes.prior_outlier_image_ids, image_id) ? "outlier"
                                                             : "inlier";
    file << image_id << " " << image.Name() << " " << kind << " " << center.x()
         << " " << center.y() << " " << center.z() << " " << prior.x() << " "
         << prior.y() << " " << prior.z() << " " << (prior - center).norm()
         << "\n";
  }
  return static_cast<bool>(file);
}

}  // namespace

int main(int argc, char** argv) {
  namespace po = boost::program_options;
  glomap::SyntheticSceneOptions options;
  std::string output_path;
  int prior_focal_length = options.prior_focal_length ? 1 : 0;
  int database_camera_per_image = options.database_camera_per_image ? 1 : 0;
  int weak_bridge = options.weak_bridge ? 1 : 0;
  int prior_as_gps = options.prior_as_gps ? 1 : 0;
  std::ostringstream default_gps_origin;
  default_gps_origin.precision(10);
  default_gps_origin << options.prior_gps_origin.x() << ","
                     << options.prior_gps_origin.y() << ","
                     << options.prior_gps_origin.z();
  std::string prior_gps_origin = default_gps_origin.str();

  po::options_description description("make_synthetic_scene options");
  description.add_options()("help,h", "Print this help.")(
      "output_path", po::value<std::string>(&output_path)->required(),
      "Folder for database.db and gt/ (created; database.db must not exist).")(
      "num_images",
      po::value<int>(&options.num_images)->default_value(options.num_images),
      "Number of images (10 to 10000).")(
      "num_cameras",
      po::value<int>(&options.num_cameras)->default_value(options.num_cameras),
      "Number of cameras, assigned to images round-robin.")(
      "camera_model",
      po::value<std::string>(&options.camera_model)
          ->default_value(options.camera_model),
      "COLMAP camera model, or a comma-separated list cycled per camera.")(
      "database_camera_per_image",
      po::value<int>(&database_camera_per_image)
          ->default_value(database_camera_per_image),
      "1: the database has one camera per image (copies of its true "
      "camera's entry), as feature_extractor writes by default.")(
      "prior_focal_length",
      po::value<int>(&prior_focal_length)->default_value(prior_focal_length),
      "1: store the true cameras with focal priors; 0: store the feature "
      "extractor's guess without priors.")(
      "image_width_px",
      po::value<int>(&options.image_width_px)
          ->default_value(options.image_width_px),
      "Image width in pixels.")("image_height_px",
                                po::value<int>(&options.image_height_px)
                                    ->default_value(options.image_height_px),
                                "Image height in pixels.")(
      "focal_length_px",
      po::value<double>(&options.focal_length_px)
          ->default_value(options.focal_length_px),
      "True focal length in pixels.")(
      "image_sizes",
      po::value<std::string>(&options.image_sizes)
          ->default_value(options.image_sizes),
      "Mixed cameras: WIDTHxHEIGHT sizes, comma-separated, cycled per camera "
      "(focal scaled with the width); empty: image_width_px x "
      "image_height_px.")(
      "principal_point_offset",
      po::value<double>(&options.principal_point_offset)
          ->default_value(options.principal_point_offset),
      "True principal points off the centre by up to this fraction of the "
      "image size (per camera and axis).")(
      "distortion_scale",
      po::value<double>(&options.distortion_scale)
          ->default_value(options.distortion_scale),
      "Scale of the true distortion (1: ordinary lenses, 10: strong).")(
      "num_cameras_with_prior",
      po::value<int>(&options.num_cameras_with_prior)
          ->default_value(options.num_cameras_with_prior),
      "With prior_focal_length 1, only the first this many cameras have a "
      "focal prior (-1: all).")(
      "prior_focal_length_error",
      po::value<double>(&options.prior_focal_length_error)
          ->default_value(options.prior_focal_length_error),
      "Stored focal priors off the truth by a factor in [1 - this, 1 + "
      "this], per camera.")(
      "num_points3D",
      po::value<int>(&options.num_points3D)
          ->default_value(options.num_points3D),
      "Number of 3D points (0: about 600 visible per image).")(
      "pixel_noise_px",
      po::value<double>(&options.pixel_noise_px)
          ->default_value(options.pixel_noise_px),
      "Standard deviation of the keypoint noise in pixels.")(
      "wrong_match_ratio",
      po::value<double>(&options.wrong_match_ratio)
          ->default_value(options.wrong_match_ratio),
      "Fraction of raw matches that are wrong, in [0, 0.9].")(
      "max_pairs_per_image",
      po::value<int>(&options.max_pairs_per_image)
          ->default_value(options.max_pairs_per_image),
      "Each image is matched to this many nearest images.")(
      "layout",
      po::value<std::string>(&options.layout)->default_value(options.layout),
      "ring, forward or grid.")(
      "verification",
      po::value<std::string>(&options.verification)
          ->default_value(options.verification),
      "colmap (COLMAP's two-view geometry estimation) or ground_truth "
      "(fast).")(
      "weak_group_size",
      po::value<int>(&options.weak_group_size)
          ->default_value(options.weak_group_size),
      "Failure shape: a group of this many neighbouring images (0: none) "
      "that also see a private patch, strongly matched among themselves and "
      "to their anchors, weakly to the rest.")(
      "weak_group_num_patch_points",
      po::value<int>(&options.weak_group_num_patch_points)
          ->default_value(options.weak_group_num_patch_points),
      "Points on the weak group's private patch.")(
      "weak_group_max_matches_to_rest",
      po::value<int>(&options.weak_group_max_matches_to_rest)
          ->default_value(options.weak_group_max_matches_to_rest),
      "True raw matches kept at most per pair of a group image and a "
      "non-anchor image.")(
      "weak_group_num_anchors",
      po::value<int>(&options.weak_group_num_anchors)
          ->default_value(options.weak_group_num_anchors),
      "Non-group images nearest to the group that see the patch and keep "
      "all matches with the group (0 to 5).")(
      "num_wrong_rotation_pairs",
      po::value<int>(&options.num_wrong_rotation_pairs)
          ->default_value(options.num_wrong_rotation_pairs),
      "Failure shape: pairs matched on symmetric structure, consistent but "
      "with a relative rotation wrong by --wrong_rotation_angle_deg (0: "
      "none).")(
      "wrong_rotation_angle_deg",
      po::value<double>(&options.wrong_rotation_angle_deg)
          ->default_value(options.wrong_rotation_angle_deg),
      "Error of the wrong-rotation pairs' relative rotation, degrees.")(
      "wrong_rotation_pairs",
      po::value<std::string>(&options.wrong_rotation_pairs)
          ->default_value(options.wrong_rotation_pairs),
      "Which pairs get a wrong rotation: group_to_rest, group_to_anchors or "
      "any.")(
      "num_pure_rotation_images",
      po::value<int>(&options.num_pure_rotation_images)
          ->default_value(options.num_pure_rotation_images),
      "Failure shape: images moved to the centre of their nearest image "
      "(pairs without baseline; 0: none).")(
      "num_long_baseline_images",
      po::value<int>(&options.num_long_baseline_images)
          ->default_value(options.num_long_baseline_images),
      "Failure shape: images not matched to their nearest images, linked "
      "only across wide baselines (0: none).")(
      "long_baseline_num_skipped_neighbors",
      po::value<int>(&options.long_baseline_num_skipped_neighbors)
          ->default_value(options.long_baseline_num_skipped_neighbors),
      "How many nearest images a long-baseline image is not matched to.")(
      "weak_bridge", po::value<int>(&weak_bridge)->default_value(weak_bridge),
      "Failure shape, 1: two halves of the scene joined by a single pair "
      "with at most --weak_bridge_max_matches matches; 0: off.")(
      "weak_bridge_max_matches",
      po::value<int>(&options.weak_bridge_max_matches)
          ->default_value(options.weak_bridge_max_matches),
      "True raw matches kept at most in the weak bridge's pair.")(
      "prior_position_noise_m",
      po::value<double>(&options.prior_position_noise_m)
          ->default_value(options.prior_position_noise_m),
      "Simulated position priors (GPS) in the database: true camera centre "
      "plus Gaussian noise of this standard deviation per axis, metres (the "
      "scene unit); < 0: no priors. Listed in <output_path>/priors.txt.")(
      "prior_outlier_ratio",
      po::value<double>(&options.prior_outlier_ratio)
          ->default_value(options.prior_outlier_ratio),
      "Fraction of the images whose prior is displaced by a random "
      "direction times a length in [prior_outlier_min_m, "
      "prior_outlier_max_m].")(
      "prior_outlier_min_m",
      po::value<double>(&options.prior_outlier_min_m)
          ->default_value(options.prior_outlier_min_m),
      "Shortest displacement of an outlier prior, metres.")(
      "prior_outlier_max_m",
      po::value<double>(&options.prior_outlier_max_m)
          ->default_value(options.prior_outlier_max_m),
      "Longest displacement of an outlier prior, metres.")(
      "prior_missing_ratio",
      po::value<double>(&options.prior_missing_ratio)
          ->default_value(options.prior_missing_ratio),
      "Fraction of the images without a prior (NULL).")(
      "prior_as_gps",
      po::value<int>(&prior_as_gps)->default_value(prior_as_gps),
      "1: store priors as latitude, longitude, altitude (WGS84), the scene "
      "being east-north-up around --prior_gps_origin; 0: metric positions "
      "in the scene frame.")(
      "prior_gps_origin",
      po::value<std::string>(&prior_gps_origin)
          ->default_value(prior_gps_origin),
      "Latitude (deg), longitude (deg), altitude (m) of the scene origin, "
      "comma-separated (write --prior_gps_origin=-33.9,18.4,10 for a "
      "negative latitude).")(
      "num_threads",
      po::value<int>(&options.num_threads)->default_value(options.num_threads),
      "Threads (-1: all cores).")(
      "random_seed",
      po::value<int>(&options.random_seed)->default_value(options.random_seed),
      "Seed of every random choice.");

  po::variables_map values;
  try {
    po::store(po::parse_command_line(argc, argv, description), values);
    if (values.count("help")) {
      std::cout << description << std::endl;
      return EXIT_SUCCESS;
    }
    po::notify(values);
  } catch (const std::exception& error) {
    return Fail(std::string(error.what()) + " (see --help)");
  }
  if (prior_focal_length != 0 && prior_focal_length != 1) {
    return Fail("--prior_focal_length must be 0 or 1");
  }
  options.prior_focal_length = prior_focal_length == 1;
  if (database_camera_per_image != 0 && database_camera_per_image != 1) {
    return Fail("--database_camera_per_image must be 0 or 1");
  }
  options.database_camera_per_image = database_camera_per_image == 1;
  if (weak_bridge != 0 && weak_bridge != 1) {
    return Fail("--weak_bridge must be 0 or 1");
  }
  options.weak_bridge = weak_bridge == 1;
  if (prior_as_gps != 0 && prior_as_gps != 1) {
    return Fail("--prior_as_gps must be 0 or 1");
  }
  options.prior_as_gps = prior_as_gps == 1;
  if (!ParseGpsOrigin(prior_gps_origin, &options.prior_gps_origin)) {
    return Fail(
        "--prior_gps_origin must be three comma-separated numbers "
        "(latitude, longitude, altitude), not '" +
        prior_gps_origin + "'");
  }

  if (!options.Check()) {
    // WriteSyntheticScene explains which option is wrong.
    colmap::Reconstruction unused;
    return Fail(glomap::WriteSyntheticScene(options, "", &unused).message());
  }

  const std::filesystem::path output_dir(output_path);
  const std::string database_path = (output_dir / "database.db").string();
  const std::string gt_path = (output_dir / "gt").string();
  std::error_code error;
  std::filesystem::create_directories(gt_path, error);
  if (error) {
    return Fail("cannot create " + gt_path + ": " + error.message());
  }

  colmap::Reconstruction ground_truth;
  glomap::SyntheticSceneShapes shapes;
  const glomap::Status status = glomap::WriteSyntheticScene(
      options, database_path, &ground_truth, &shapes);
  if (!status.ok()) return Fail(status.message());
  ground_truth.WriteText(gt_path);
  const std::string priors_path = (output_dir / "priors.txt").string();
  if (options.prior_position_noise_m >= 0) {
    if (!WritePriors(options, shapes, ground_truth, priors_path)) {
      return Fail("cannot write " + priors_path);
    }
  } else {
    std::filesystem::remove(priors_path, error);  // stale, of an earlier run
  }

  // Count what a mapper will see, through the same reader it uses.
  colmap::Reconstruction read_back;
  glomap::ViewGraph view_graph;
  const glomap::Status read_status = glomap::ReadDatabase(
      database_path, glomap::DatabaseReaderOptions(), &read_back, &view_graph);
  const size_t num_verified_pairs =
      read_status.ok() ? view_graph.NumPairs() : 0;

  std::cout << "Wrote " << ground_truth.NumImages() << " images, "
            << ground_truth.NumCameras() << " cameras, "
            << ground_truth.NumPoints3D() << " points, " << num_verified_pairs
            << " verified pairs (" << options.layout << ", "
            << options.verification << " verification) to " << database_path
            << "; ground truth in " << gt_path << std::endl;
  if (options.prior_position_noise_m >= 0) {
    std::cout << "Simulated position priors (noise "
              << options.prior_position_noise_m << " m per axis, "
              << shapes.prior_outlier_image_ids.size() << " outliers, "
              << shapes.prior_missing_image_ids.size() << " missing, stored "
              << (options.prior_as_gps ? "as GPS" : "in metres")
              << ") listed in " << priors_path << std::endl;
  }
  PrintShapes(shapes);
  return EXIT_SUCCESS;
}
