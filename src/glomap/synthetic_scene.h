// Synthetic scenes with known ground truth for tests and benchmarks: a COLMAP
// 3.8 database that looks like the output of feature extraction and matching
// (cameras, images, keypoints, raw matches, verified two-view geometries),
// plus the true cameras, poses and points it was made from.
#pragma once

#include <string>

#include "base/reconstruction.h"
#include "glomap/status.h"

namespace glomap {

struct SyntheticSceneOptions {
  // Number of images (10 to 10000).
  int num_images = 20;

  // Number of distinct cameras; images are assigned to them round-robin.
  int num_cameras = 1;

  // COLMAP camera model name, or a comma-separated list that cycles per
  // camera (e.g. "PINHOLE,SIMPLE_RADIAL,OPENCV").
  std::string camera_model = "SIMPLE_RADIAL";

  // Whether the database stores the true camera parameters with the focal
  // prior flag set. If false it stores focal 1.2 * max(width, height), the
  // principal point at the centre and no distortion, with the flag unset, as
  // COLMAP's feature extractor does without EXIF data.
  bool prior_focal_length = true;

  // Image size in pixels (all cameras).
  int image_width_px = 1024;
  int image_height_px = 768;

  // True focal length in pixels; varied by up to +-10% per camera when
  // num_cameras > 1.
  double focal_length_px = 900;

  // Number of 3D points; 0 picks the density that makes each image see about
  // 600 points.
  int num_points3D = 0;

  // Keypoints per image at most (like a detector's limit); extra visible
  // points are dropped at random.
  int max_keypoints_per_image = 2000;

  // Keypoints that belong to no 3D point, as a fraction of the visible
  // points (features that the matcher finds nowhere else).
  double unmatched_keypoint_ratio = 0.3;

  // Standard deviation of the Gaussian noise on keypoint positions, pixels.
  double pixel_noise_px = 1.0;

  // Fraction of each pair's raw matches that are wrong (random keypoints
  // that see different points), in [0, 0.9].
  double wrong_match_ratio = 0.0;

  // Each image is matched to this many nearest images (by camera centre), so
  // the number of pairs grows linearly with the number of images.
  int max_pairs_per_image = 30;

  // Scene layout:
  //  "ring":    object-centred; cameras on a ring around an object (a dome
  //             of rings above 60 images), looking at its centre;
  //  "forward": a camera driving along a curved street lined with facades;
  //  "grid":    an aerial nadir survey over hilly terrain, row by row.
  std::string layout = "ring";

  // Geometric verification of the raw matches:
  //  "colmap":       colmap::TwoViewGeometry::Estimate on each pair with the
  //                  database's cameras and the matcher's default options,
  //                  exactly as COLMAP's matchers do (slower);
  //  "ground_truth": inliers are raw matches within 4 px (Sampson) of the
  //                  true epipolar geometry; F and E from the true poses
  //                  (E only when both cameras have priors). Fast, for large
  //                  benchmarks.
  std::string verification = "colmap";

  // Threads for the "colmap" verification; -1 = all cores.
  int num_threads = -1;

  // Seed of every random choice: the same options give the same database
  // content.
  int random_seed = 0;

  bool Check() const;
};

// Writes a new COLMAP 3.8 database at `database_path` (fails if the file
// exists) through colmap::Database: cameras, images named image0001.png...,
// keypoints (6 columns, as COLMAP writes them), raw matches and two-view
// geometries. Fills the empty `ground_truth` with the true cameras, the
// registered images with their true poses and the stored keypoints as
// Points2D, and the 3D points seen by at least two images with their tracks.
Status WriteSyntheticScene(const SyntheticSceneOptions& options,
                           const std::string& database_path,
                           colmap::Reconstruction* ground_truth);

}  // namespace glomap
