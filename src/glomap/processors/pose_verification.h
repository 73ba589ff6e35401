// Pose verification: every registered image is checked against the structure
// that the other images establish, so that a camera that global positioning
// could not constrain (left near its random start, "cameras in the
// initialization cube", glomap #166) never reaches the output unnoticed.
//
// Why a separate check is needed: such a camera usually keeps a low
// reprojection error, because the points it observes were triangulated from
// it and from the few images of its own small group, and bundle adjustment
// deletes its observations of the main structure as outliers. Nothing in the
// model's own residuals shows the error.
//
// The check is the one COLMAP's incremental mapper uses to register an image,
// applied to an image that is already placed: 2D-3D correspondences, absolute
// pose RANSAC (COLMAP's P3P solver), inlier count and ratio. The
// correspondences of image i link its keypoints to 3D points through its
// verified matches (the database's pairs) and its own observations; a 3D point
// only counts if at least `min_point_support` other registered images observe
// it, i.e. its position does not rest on image i. The current pose passes when
// it explains nearly as many correspondences as the best pose RANSAC finds, or
// agrees with it. Images that fail become suspects and the check repeats with
// points counted only through unsuspected images, so that a wrongly placed
// group cannot vouch for itself or pull its neighbours into its frame. A
// failing image is re-placed from the RANSAC estimate when that estimate is
// well supported, and deregistered when it is not.
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/status.h"

namespace glomap {

struct PoseVerificationOptions {
  // A 2D-3D correspondence is an inlier of a pose when its reprojection
  // error is below this, in pixels (COLMAP's abs_pose_max_error is 12 px).
  double max_reproj_error_px = 12.0;
  // The same threshold for the check right after global positioning, where
  // intrinsics are not refined yet and positioning keeps rays up to 1-2 deg
  // off (the global mapper uses it in place of max_reproj_error_px there).
  double positioning_max_reproj_error_px = 24.0;

  // A 3D point is used to check image i only if at least this many
  // registered images other than i observe it.
  int min_point_support = 2;

  // Link keypoints to points through every pair of the view graph, also
  // those an earlier stage rejected. A camera whose rotation was wrong has
  // its correct pairs rejected by rotation averaging, and those matches are
  // exactly the evidence that re-places it; RANSAC keeps the one pose that
  // the matches of many pairs agree on. Off: only the pairs every stage kept.
  bool use_all_pairs = true;

  // A pose is "well supported" with at least this many inliers and at least
  // this inlier ratio (COLMAP's incremental mapper: 30 and 0.25; 15 here
  // because the check also runs on images that the mapper already placed,
  // including the weakly textured ones).
  int min_num_inliers = 15;
  double min_inlier_ratio = 0.25;

  // Poses are compared by a score that counts at most this many inliers
  // through each other image (the image of the matched pair, or the images
  // observing the point): evidence is what many images agree on, so one
  // strongly matched image (a symmetric structure, a wrong pair that
  // survived) cannot outvote the others.
  int max_inliers_per_image = 10;

  // The current pose passes when its score is at least this fraction of the
  // RANSAC estimate's score: a pose from the global solve need not be the
  // best pose for this image alone, but it must explain most of what the
  // best pose explains.
  double min_inlier_fraction_of_estimate = 0.6;

  // ... or when it agrees with the estimate within these limits (rotation
  // angle; camera-centre distance as a fraction of the scene size, the
  // median distance of the camera centres from their median). A pose from
  // the global solve is a compromise over all images, so at a tight inlier
  // threshold it may explain fewer points than a pose fitted to this image
  // alone while being close to it.
  double max_rotation_difference_deg = 2.0;
  double max_center_distance_ratio = 0.02;

  // Images that fail are suspects, and points count as evidence only
  // through unsuspected images; the check repeats until the suspects do not
  // change, at most this many times.
  int max_num_rounds = 4;

  // RANSAC over P3P samples, scored as above (COLMAP's confidence for
  // absolute pose); the trials needed follow the best pose's inlier ratio.
  // None of these three is a GlobalMapper.* option (RANSAC internals, set in
  // the code only).
  double ransac_confidence = 0.9999;
  int ransac_min_num_trials = 100;
  int ransac_max_num_trials = 10000;
  // The RANSAC estimate is refined on its inliers (COLMAP's absolute pose
  // refinement, intrinsics fixed) while its score improves, at most this
  // many times.
  // Not a GlobalMapper.* option (an internal of the refinement, set in the code
  // only).
  int max_num_refinements = 3;

  // Seed of the RANSAC samples (same input and seed, same result).
  int random_seed = 0;
  // Threads; -1: all cores.
  int num_threads = -1;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// What the check decided for one image.
struct PoseVerificationResult {
  enum class Outcome { kKept, kReplaced, kDeregistered };

  colmap::image_t image_id = colmap::kInvalidImageId;
  Outcome outcome = Outcome::kKept;
  // 2D-3D correspondences used, inliers of the current pose and of the
  // RANSAC estimate (0 if RANSAC found none).
  size_t num_correspondences = 0;
  size_t num_current_inliers = 0;
  size_t num_estimate_inliers = 0;
  // Other images the correspondences come through, and the scores (inliers
  // counted at most max_inliers_per_image times per image).
  size_t num_source_images = 0;
  size_t current_score = 0;
  size_t estimate_score = 0;
  // Difference between the current pose and the estimate (when there is
  // one): rotation angle in degrees, camera-centre distance as a fraction of
  // the scene size (median distance of the registered camera centres from
  // their coordinate-wise median).
  double rotation_difference_deg = 0;
  double center_distance_ratio = 0;
  // One line for the log, e.g. "only 3 of 40 correspondences agree...".
  std::string reason;
};

struct PoseVerificationSummary {
  size_t num_checked = 0;
  size_t num_kept = 0;
  size_t num_replaced = 0;
  size_t num_deregistered = 0;
  // Only the images that were re-placed or deregistered, by image id.
  std::vector<PoseVerificationResult> changed;
};

// Checks every registered image of `reconstruction` (see the file comment).
// A re-placed image gets the refined RANSAC pose, loses its observations
// that disagree with it, and observes the inlier points it did not observe
// yet; a deregistered image loses all its observations (COLMAP deletes
// points left with fewer than two). Logs one line per changed image, by
// name. Returns Cancelled if `interrupt` fires before any change is applied.
Status VerifyPoses(const PoseVerificationOptions& options,
                   const ViewGraph& view_graph,
                   colmap::Reconstruction* reconstruction,
                   PoseVerificationSummary* summary,
                   const Interrupt& interrupt = {});

}  // namespace glomap
