// make_synthetic_scene: writes a synthetic COLMAP database and its ground
// truth for tests, benchmarks and demos.
//
//   make_synthetic_scene --output_path DIR [--num_images N ...]
//
// DIR/database.db is a new COLMAP 3.8 database (as after feature extraction
// and matching); DIR/gt/ is the ground truth as a COLMAP text model.

#include <boost/program_options.hpp>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "glomap/database_reader.h"
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
}

}  // namespace

int main(int argc, char** argv) {
  namespace po = boost::program_options;
  glomap::SyntheticSceneOptions options;
  std::string output_path;
  int prior_focal_length = options.prior_focal_length ? 1 : 0;
  int weak_bridge = options.weak_bridge ? 1 : 0;

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
  if (weak_bridge != 0 && weak_bridge != 1) {
    return Fail("--weak_bridge must be 0 or 1");
  }
  options.weak_bridge = weak_bridge == 1;

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
  PrintShapes(shapes);
  return EXIT_SUCCESS;
}
