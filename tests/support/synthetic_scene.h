// Synthetic scenes with known ground truth for tests and benchmarks: a COLMAP
// 3.8 database that looks like the output of feature extraction and matching
// (cameras, images, keypoints, raw matches, verified two-view geometries),
// plus the true cameras, poses and points it was made from.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {

struct SyntheticSceneOptions {
  // Number of images (10 to 10000).
  int num_images = 20;

  // Number of distinct cameras; images are assigned to them round-robin.
  int num_cameras = 1;

  // COLMAP camera model name, or a comma-separated list that cycles per
  // camera (e.g. "PINHOLE,SIMPLE_RADIAL,OPENCV").
  std::string camera_model = "SIMPLE_RADIAL";

  // Whether the database stores one camera per image (ids equal to the image
  // ids), each a copy of its true camera's database entry, as COLMAP's
  // feature extractor does by default: several database cameras then share
  // one physical camera. The true cameras (num_cameras) and the ground truth
  // are the same either way.
  bool database_camera_per_image = false;

  // Whether the database stores the true camera parameters with the focal
  // prior flag set. If false it stores focal 1.2 * max(width, height), the
  // principal point at the centre and no distortion, with the flag unset, as
  // COLMAP's feature extractor does without EXIF data.
  bool prior_focal_length = true;

  // Image size in pixels (all cameras, unless image_sizes is set).
  int image_width_px = 1024;
  int image_height_px = 768;

  // Mixed cameras: image sizes as "WIDTHxHEIGHT", comma-separated, cycled
  // per camera like camera_model (e.g. "1024x768,1600x1200,640x480"); each
  // camera's focal length scales with its width (so that every camera sees
  // about the same field of view). Empty: image_width_px x image_height_px.
  std::string image_sizes;

  // True focal length in pixels (for a camera image_width_px wide); varied
  // by up to +-10% per camera when num_cameras > 1.
  double focal_length_px = 900;

  // True principal points lie off the image centre by up to this fraction
  // of the image width and height (uniform per camera and axis; 0: at the
  // centre). Real cameras have them 1-3% off.
  double principal_point_offset = 0;

  // Scale of the true distortion coefficients: 1 draws the small distortion
  // of ordinary lenses (k1 in [-0.02, 0.01], k2 in +-0.005, tangential and
  // higher orders in +-0.0005); 10 a strong wide-angle or fisheye lens.
  double distortion_scale = 1;

  // With prior_focal_length, only the first this many true cameras (-1:
  // all) are stored with their focal prior; the others as the feature
  // extractor stores a camera without EXIF (mixed cameras, some with EXIF).
  int num_cameras_with_prior = -1;

  // Stored focal priors are off the truth by a factor in [1 - this, 1 +
  // this], drawn per true camera (EXIF focal lengths are rarely exact; 0:
  // exact). The principal point and distortion are stored as the truth.
  double prior_focal_length_error = 0;

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

  // Scene layout, in metres, z up (see the position priors below):
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

  // Failure shapes of global mappers (issue 10): scenes in which a camera
  // that global positioning cannot constrain may end far from where it
  // belongs while the model still reprojects well. All are off by default.
  // A weak group of 2 whose pairs to the rest keep 20 matches (below the
  // mapper's 30 inliers) and whose 2 pairs to its anchor have a wrong
  // rotation ("group_to_anchors") reproduces the failure seen on real data.

  // Weak group: this many neighbouring images (one picked by the seed and its
  // nearest images by camera centre; 0 = none) that also see a private
  // textured patch, as close-ups of a detail do: they are strongly matched
  // among themselves and to their anchors, weakly to the rest.
  int weak_group_size = 0;
  // Points on the private patch, which only the group and its anchors see
  // (on a ring, all of them: 1000 points add ~1000 matches to each of their
  // pairs).
  int weak_group_num_patch_points = 1000;
  // Pairs of a group image and a non-anchor image keep at most this many of
  // their true raw matches (picked at random); wrong matches are added on
  // top in proportion, as everywhere.
  int weak_group_max_matches_to_rest = 30;
  // Number of anchors (0 to 5): the non-group images nearest to the group,
  // which also see the patch and keep all their matches with the group.
  int weak_group_num_anchors = 1;

  // Wrong-rotation pairs (0 = none): pairs matched on repeated or symmetric
  // structure. Their matches are geometrically consistent, but image B of
  // the pair is seen as if turned by wrong_rotation_angle_deg towards image A
  // about the vertical axis through the point it looks at (a rotationally
  // symmetric object does that), so their relative rotation is wrong by that
  // angle. The pair's true matches are replaced by symmetric ones: every
  // point of the scene (not of a private patch) that A sees and the turned B
  // would see, with keypoints appended to B's (beyond
  // max_keypoints_per_image).
  int num_wrong_rotation_pairs = 0;
  // Angle by which the wrong-rotation pairs' relative rotation is wrong, deg.
  double wrong_rotation_angle_deg = 30;
  // Which pairs are made wrong, picked at random among the matched pairs
  // whose images share at least 30 points (fewer if there are fewer):
  //  "group_to_rest":    a weak-group image and a non-anchor image (B);
  //  "group_to_anchors": a weak-group image and an anchor (B);
  //  "any":              any matched pair (B is the second image).
  std::string wrong_rotation_pairs = "group_to_rest";

  // Pure-rotation images (0 = none): images moved to the camera centre of
  // their nearest image, keeping their orientation, so that the two form a
  // pair without baseline (panoramic; the translation direction of the pair
  // is undefined).
  int num_pure_rotation_images = 0;

  // Long-baseline images (0 = none): images not matched to their nearest
  // images, so that they are linked to the scene only across wide baselines.
  int num_long_baseline_images = 0;
  // How many of its nearest images a long-baseline image is not matched to.
  int long_baseline_num_skipped_neighbors = 8;

  // Weak bridge: the images are split into two halves (at the median of the
  // camera centres along the direction in which they spread most); of the
  // pairs across the split only the one with the most true matches is kept.
  bool weak_bridge = false;
  // True raw matches the bridge pair keeps at most (picked at random).
  int weak_bridge_max_matches = 40;

  // Simulated camera position priors (GPS, or positions known from another
  // source), written to the images table's prior_tx, prior_ty, prior_tz as
  // COLMAP 3.8 stores them. The scene unit is the metre in every layout
  // (ring: an object of radius 2 m seen from 8 m in a room of radius 16 m;
  // forward: a street with one image per metre; grid: a survey 40 m above
  // the ground, 10 m between images), and the world frame of every layout is
  // east-north-up (x east, y north, z up: z is the vertical in all three),
  // so the ground truth, the priors and SyntheticSceneShapes are all in
  // metres in that frame. Each prior is drawn from its own random streams:
  // enabling priors, or changing any prior option, changes nothing else in
  // the database (keypoints, matches, geometries) nor the ground truth.

  // Standard deviation of the Gaussian noise added to the true camera centre
  // on each axis, metres; < 0: no priors (NULL, as without EXIF GPS).
  double prior_position_noise_m = -1;
  // Fraction of the images (rounded to a count) whose prior is displaced
  // instead: true centre plus a displacement in a uniformly random direction
  // whose length is uniform in [prior_outlier_min_m, prior_outlier_max_m]
  // (no noise on top, so the error is exactly that length).
  double prior_outlier_ratio = 0;
  double prior_outlier_min_m = 20;
  double prior_outlier_max_m = 100;
  // Fraction of the images (rounded to a count; disjoint from the outliers)
  // that get no prior (NULL), as images without GPS in a mixed collection.
  double prior_missing_ratio = 0;
  // If true, priors are stored as COLMAP's feature extractor stores EXIF
  // GPS: prior_tx = latitude (deg), prior_ty = longitude (deg), prior_tz =
  // altitude (m, above the WGS84 ellipsoid), the scene's ENU position around
  // prior_gps_origin converted with colmap::GPSTransform(WGS84)::ENUToEll.
  // Read back with GPSTransform(WGS84).EllToENU({origin, lla, ...}, lat0,
  // lon0): in COLMAP 3.8 EllToENU measures from its first point, not from
  // (lat0, lon0), so the origin must come first. If false, priors are the
  // metric positions in the scene frame.
  bool prior_as_gps = false;
  // Latitude (deg), longitude (deg) and altitude (m) of the scene's origin.
  Eigen::Vector3d prior_gps_origin = Eigen::Vector3d(47.3769, 8.5417, 400);

  // Threads for the "colmap" verification; -1 = all cores.
  int num_threads = -1;

  // Seed of every random choice: the same options give the same database
  // content.
  int random_seed = 0;

  bool Check() const;
};

// The images and pairs that the failure-shape options picked, by image id
// (image0001.png has id 1).
struct SyntheticSceneShapes {
  std::vector<colmap::image_t> weak_group_image_ids;
  std::vector<colmap::image_t> weak_group_anchor_image_ids;
  struct WrongRotationPair {
    colmap::image_t image_id1 = 0;  // smaller id
    colmap::image_t image_id2 = 0;
    // The image seen as if turned (image B, either of the two).
    colmap::image_t turned_image_id = 0;
    // Symmetric matches stored for the pair (fewer than 15: not verified).
    size_t num_matches = 0;
  };
  std::vector<WrongRotationPair> wrong_rotation_pairs;
  // (moved image id, id of the image whose centre it shares).
  std::vector<std::pair<colmap::image_t, colmap::image_t>>
      pure_rotation_image_ids;
  std::vector<colmap::image_t> long_baseline_image_ids;
  // The pair that joins the two halves ((0, 0) without weak bridge), and the
  // images of the half that holds the pair's first image.
  std::pair<colmap::image_t, colmap::image_t> weak_bridge_pair = {0, 0};
  std::vector<colmap::image_t> weak_bridge_half_image_ids;

  // Simulated position priors (all empty when prior_position_noise_m < 0).
  // The metric prior of each image (index: image id - 1) in the scene frame,
  // metres, before any conversion to GPS; NaN for images without a prior.
  std::vector<Eigen::Vector3d> prior_positions;
  // Images whose prior is displaced (outliers), and images without a prior.
  std::vector<colmap::image_t> prior_outlier_image_ids;
  std::vector<colmap::image_t> prior_missing_image_ids;
};

// Writes a new COLMAP 3.8 database at `database_path` (fails if the file
// exists) through colmap::Database: cameras, images named image0001.png...,
// keypoints (6 columns, as COLMAP writes them), raw matches and two-view
// geometries. Fills the empty `ground_truth` with the true cameras, the
// registered images with their true poses and the stored keypoints as
// Points2D, and the 3D points seen by at least two images with their tracks.
// `shapes` (optional) receives what the failure-shape options picked and the
// simulated position priors.
Status WriteSyntheticScene(const SyntheticSceneOptions& options,
                           const std::string& database_path,
                           colmap::Reconstruction* ground_truth,
                           SyntheticSceneShapes* shapes = nullptr);

}  // namespace glomap
