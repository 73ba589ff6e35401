// Relative poses of the view graph's pairs (paper Sec. 3, "Proposed
// Pipeline": "With the updated camera intrinsics, relative camera poses are
// estimated"). For every valid pair, an essential matrix in normalised image
// coordinates (current camera parameters, i.e. after view-graph calibration)
// is taken from the database's two-view geometry (E = K2^T F K1) or, where
// that cannot be used, estimated from the verified matches with COLMAP 3.8's
// LO-RANSAC + five-point solver; it is decomposed with cheirality and the
// pose refined on its inliers. The matches are then re-scored against the pose
// (or the pair's homography for planar/panoramic pairs) and pairs with too few
// inliers are invalidated.
#pragma once

#include <cstddef>
#include <string>

#include "base/reconstruction.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/status.h"

namespace glomap {

struct RelativePoseOptions {
  // Start each pair from the database's two-view geometry instead of a
  // RANSAC: E = K2^T F K1 with the current cameras, projected onto the
  // essential matrices, decomposed and refined on the matches that agree
  // with it within max_epipolar_error_px. The matches are the inliers of
  // that F already, so where F agrees with the calibrated cameras a RANSAC
  // on them finds it again. A RANSAC still runs for planar and panoramic
  // pairs, pairs without F, pairs where fewer matches agree than the
  // inlier checks below ask for (the projection moved the epipolar
  // geometry: F implies other focal lengths), and pairs whose refined pose
  // fails the re-scoring checks.
  bool use_stored_geometry = true;
  // RANSAC inlier threshold on the Sampson error, pixels; converted to
  // normalised units by 0.5 * (1/f1 + 1/f2).
  double max_epipolar_error_px = 1.0;
  // RANSAC trials at most. The database matches are already verified, so
  // the dynamic stopping criterion usually ends RANSAC after a few dozen.
  // Not a GlobalMapper.* option (a RANSAC internal, set in the code only).
  int max_num_trials = 10000;
  // RANSAC trials at least (guards against stopping on a lucky sample).
  // Not a GlobalMapper.* option (a RANSAC internal, set in the code only).
  int min_num_trials = 30;
  // RANSAC confidence that an all-inlier sample was drawn.
  // Not a GlobalMapper.* option (a RANSAC internal, set in the code only).
  double confidence = 0.9999;
  // Gauss-Newton/LM iterations of the pose refinement on RANSAC inliers.
  // Not a GlobalMapper.* option (an internal of the refinement, set in the code
  // only).
  int max_num_refinement_iterations = 20;
  // The refinement uses at most this many RANSAC inliers, evenly spread over
  // the matches: its cost is linear in them, its accuracy gain beyond a few
  // hundred is negligible next to the rotation averaging's tolerances.
  // Not a GlobalMapper.* option (an internal of the refinement, set in the code
  // only).
  int max_num_refinement_points = 500;

  // Re-scoring threshold on the Sampson error for CALIBRATED pairs, pixels.
  double max_epipolar_error_E_px = 1.0;
  // Re-scoring threshold for UNCALIBRATED pairs, pixels (looser: the focal
  // lengths behind the pose are estimated, see relative_pose.cc).
  double max_epipolar_error_F_px = 4.0;
  // Homography transfer threshold for PLANAR / PANORAMIC /
  // PLANAR_OR_PANORAMIC pairs, pixels.
  double max_epipolar_error_H_px = 4.0;
  // Rays within this cone around the epipole (either image) are not inliers:
  // there every epipolar line passes close by, so the epipolar constraint
  // does not verify the match.
  double min_epipole_angle_deg = 3.0;

  // Pairs with fewer inliers are invalidated.
  int min_num_inliers = 30;
  // Pairs with inliers / raw matches below this are invalidated
  // (ImagePair::num_raw_matches, or matches.size() when that is 0).
  double min_inlier_ratio = 0.25;

  // Worker threads over pairs; -1 uses all cores.
  int num_threads = -1;
  // Seed of every pair's RANSAC (combined with the pair id), so results do
  // not depend on thread scheduling.
  int random_seed = 0;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// What EstimateRelativePoses did with the valid pairs it was given.
struct RelativePoseStatistics {
  // Pairs it invalidated.
  size_t num_invalidated_pairs = 0;
  // Pairs whose pose came from the database's two-view geometry, and pairs
  // whose pose came from a RANSAC (use_stored_geometry off, no usable stored
  // geometry, or a failed start).
  size_t num_from_stored_geometry = 0;
  size_t num_from_ransac = 0;
};

// Estimates cam2_from_cam1 (unit translation) of every valid pair, writes
// qvec2_from_1 / tvec2_from_1 / has_relative_pose and inlier_idxs, and
// invalidates pairs whose estimation fails or whose re-scored inliers are too
// few (count or ratio); the counts go to `statistics` when not null.
// Invalidated pairs keep no inlier indices (no later stage reads them). Pairs
// whose images or cameras are missing from `reconstruction` are invalidated
// too. Returns Cancelled when `interrupt` fires; the view graph then holds some
// pairs' new poses and must not be used.
Status EstimateRelativePoses(const RelativePoseOptions& options,
                             const colmap::Reconstruction& reconstruction,
                             ViewGraph* view_graph,
                             RelativePoseStatistics* statistics = nullptr,
                             const Interrupt& interrupt = {});

}  // namespace glomap
