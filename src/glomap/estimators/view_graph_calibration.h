// View-graph calibration (paper Sec. 3, "Proposed Pipeline"): before any pose
// is estimated, the focal lengths of cameras without a focal prior are
// estimated jointly from the fundamental matrices of all verified pairs, so
// that relative poses can be computed from essential matrices afterwards.
//
// Every pair gives the two Kruppa constraints of its fundamental matrix
// (Hartley's SVD form), written as Fetzer et al.'s relative focal residuals
// ("Stable Intrinsic Auto-Calibration from Fundamental Matrices of Devices
// with Uncorrelated Camera Parameters", WACV 2020), and a robust least
// squares problem over one focal per camera is solved with Ceres.
//
// The fundamental matrices often do not determine the focal length, though:
// the Kruppa equations are degenerate when all optical axes meet in one
// point (object-centred captures: orbits, turntables, gantries; Sturm, "On
// focal length calibration from two views", CVPR 2001) and nearly so when
// the cameras move along their optical axes or the field of view is narrow.
// The solve then returns a focal the data do not support (dino-363: 768 ->
// 767 px for a true 3310 px; castle-P19, entry-P10, templeRing and
// KITTI_sequence_1 likewise stay at COLMAP's guess). With a wrong focal the
// relative rotations are biased, the more so the narrower the field of view
// (dino-363, 11 degrees: off by 19 degrees in the median), and rotation
// averaging cannot see it, since biased rotations close loops about as well
// as true ones (median triangle error 4.3 vs 4.0 degrees on dino-363): it
// returns consistent but wrong orientations that no later stage repairs.
// Three or more views determine the focal where two do not, so the focal of
// a camera without a prior is then taken from a small incremental
// reconstruction (COLMAP 3.8's incremental mapper, whose bundle adjustments
// refine it) of the best-connected image and its most strongly matched
// neighbours; the fundamental matrices remain the fallback (e.g. forward
// motion, where the incremental mapper finds no initial pair).
#pragma once

#include <cstddef>
#include <string>

#include "base/reconstruction.h"
#include "glomap/scene/camera_groups.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/status.h"

namespace glomap {

struct ViewGraphCalibrationOptions {
  // Calibrate cameras without a focal prior whose database entries are
  // identical (model, image size, every parameter) as one camera: one focal
  // for all of them, in the fundamental-matrix solve and in the small
  // reconstruction (see IdenticalCameraGroups). COLMAP's feature extractor
  // writes one camera per image by default, with the same start values for
  // every image of one size without EXIF; a single image says almost nothing
  // about its own focal (templeRing, one camera per image: calibration left
  // all 47 focals at the 768 px guess, true 1520 px). Bundle adjustment
  // still refines every camera on its own, so images of different focals
  // (zoom, two phones of one resolution) end with their own.
  bool calibrate_identical_cameras_as_one = true;
  // A camera's new focal is rejected (old one kept) if new/old is below this.
  double min_focal_ratio = 0.1;
  // ... or above this.
  double max_focal_ratio = 10;
  // Pairs whose unrobustified residual norm (relative focal^2 errors) exceeds
  // this after the solve are invalidated.
  double max_two_view_error = 2.0;
  // Scale of the Cauchy loss on the relative focal^2 residuals (final solve;
  // a first solve uses max(coarse_loss_scale, this) to leave the loss' flat
  // tail).
  double loss_scale = 0.01;
  // Cauchy scale of that first, coarse solve (relative focal^2 error): from
  // the initial guess (often 20-50% off) every residual lies in the flat
  // tail of the narrow loss, where the steps stall.
  double coarse_loss_scale = 0.5;
  // Maximum number of Ceres iterations (per solve).
  int max_num_iterations = 100;
  // Relative cost change at which each solve stops (Ceres'
  // function_tolerance).
  // Not a GlobalMapper.* option (a solver tolerance, set in the code only).
  double function_tolerance = 1e-5;
  // From this many cameras without a focal prior on, the solve uses a sparse
  // Cholesky; below, dense QR, which is exact and robust on the small
  // problem of one scalar per camera (a sparse Cholesky on a near-singular
  // system failed upstream, glomap #147).
  // Not a GlobalMapper.* option (where the linear solver switches, set in the
  // code only).
  int min_num_free_cameras_sparse = 50;
  // Ceres threads; -1 uses all cores.
  int num_threads = -1;
  // One more Ceres thread per this many residual blocks (see ceres_threads.h;
  // set from GlobalMapper.min_residuals_per_ceres_thread).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;
  // Size of the small incremental reconstruction whose focal lengths replace
  // those from the fundamental matrices: the best-connected image and its
  // most strongly matched neighbours, this many images in all (0: the
  // fundamental matrices only). It takes 0.3-6 s on the shared datasets.
  int multi_view_num_images = 15;
  // ... where they matter: when the relative rotations that five-point
  // RANSAC estimates with the focals from the fundamental matrices differ
  // from the small reconstruction's by at least this much in the median
  // (deg). Forward motion, with its small rotations, is insensitive to the
  // focal (KITTI_sequence_1: 0.1 deg, synthetic streets 0.35-0.43), and so
  // are scenes whose fundamental matrices do determine it (fountain-P11:
  // 0.8, Herz-Jesus-P8: 0.2 deg); orbits are not (dino-363: 11, templeRing:
  // 15, castle-P19: 13, entry-P10: 8 deg). Rings of three cameras of
  // different sizes whose fundamental matrices left two focals 10-12% off
  // differ by 2.7 and 3.2 deg: at 5 deg they were kept, rotation averaging
  // rejected 72 of 460 pairs and pose verification left 1-2 images out; at
  // 2 deg every image is registered (AUC@3 87.3 -> 95.6). Synthetic nadir
  // surveys lie at 1.1-2.4 deg either way (the same models).
  double multi_view_min_rotation_bias_deg = 2;

  // The small reconstruction's own settings follow; everything else in it is
  // COLMAP 3.8's incremental mapper with its defaults.

  // Pairs with fewer matches are not used (the incremental mapper's default
  // minimum).
  // Not a GlobalMapper.* option (an internal of the small reconstruction, set
  // in the code only).
  int multi_view_min_num_matches = 15;
  // A camera's focal (a group's, see calibrate_identical_cameras_as_one) is
  // taken from the small reconstruction only if at least this many of its
  // images are registered in it (two views do not determine the focal);
  // fewer selected or connected images skip the reconstruction.
  int multi_view_min_num_images_per_camera = 3;
  // Keypoints per image that it uses at most (those matched in the most of
  // its pairs): a few hundred determine the focal, and the incremental
  // mapper's cost grows with them (fountain-P11, thousands of matched
  // keypoints per image: 21 s with all, 0.5 s with 500).
  // Not a GlobalMapper.* option (an internal of the small reconstruction, set
  // in the code only).
  int multi_view_max_num_keypoints_per_image = 500;
  // Initial-pair search: attempts per level, and levels (each after the
  // first halves the inlier count and triangulation angle required, as
  // COLMAP's mapper does when it finds no initial pair). The search stops
  // once a model holds multi_view_min_model_ratio of the selected images
  // (and at least multi_view_min_num_images_per_camera); the largest model
  // decides, and none when even it holds fewer.
  // None of these three is a GlobalMapper.* option (internals of the small
  // reconstruction, set in the code only).
  int multi_view_max_num_init_attempts = 10;
  int multi_view_num_init_relaxations = 3;
  double multi_view_min_model_ratio = 0.5;
  // Bundle adjustment and point filtering passes of each global refinement
  // of the small reconstruction (COLMAP's mapper runs up to 5, stopping once
  // few observations change).
  // Not a GlobalMapper.* option (an internal of the small reconstruction, set
  // in the code only).
  int multi_view_num_global_refinements = 2;
  // RANSAC threshold of the five-point estimates that the rotation bias is
  // measured on, pixels (the relative-pose stage's default
  // rp_max_epipolar_error_px).
  // Not a GlobalMapper.* option (an internal of the small reconstruction, set
  // in the code only).
  double multi_view_max_epipolar_error_px = 1.0;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Estimates one focal length per camera WITHOUT a focal prior (per group of
// identical cameras with calibrate_identical_cameras_as_one)
// (camera.HasPriorFocalLength() == false) from the fundamental matrices of
// valid pairs with config CALIBRATED or UNCALIBRATED; the principal point is
// kept at the camera's current one and cameras with a prior stay constant.
// Then, unless `multi_view_num_images` is 0, a small incremental
// reconstruction is built from the keypoints (the images' Points2D) and the
// valid pairs' matches (at least `multi_view_min_num_matches`) of the image
// with the most matches and its most strongly matched neighbours, all cameras
// starting from their focal on entry; a free camera with at least
// `multi_view_min_num_images_per_camera` images in it takes its focal from it.
// Accepted focals (new/old within [min_focal_ratio, max_focal_ratio]) are
// written into every focal parameter of the camera (so fx = fy afterwards).
// Pairs touching at least one free camera whose residual at the final focals
// exceeds `max_two_view_error` are invalidated; their number goes to
// `num_invalidated_pairs` when it is not null. Without any free camera the
// function returns Ok and changes nothing. Returns Cancelled when `interrupt`
// fires (focals may then be partly changed).
Status CalibrateViewGraph(const ViewGraphCalibrationOptions& options,
                          colmap::Reconstruction* reconstruction,
                          ViewGraph* view_graph,
                          size_t* num_invalidated_pairs = nullptr,
                          const Interrupt& interrupt = {});

// The two relative focal^2 residuals of one fundamental matrix F
// (x2^T F x1 = 0 in pixels) for focal lengths f1, f2 and principal points
// pp1, pp2. Returns false when F is degenerate (zero, rank < 2, not finite).
// Exposed for tests: at the true focals both residuals are ~0.
bool FundamentalMatrixFocalResiduals(const Eigen::Matrix3d& F,
                                     const Eigen::Vector2d& pp1,
                                     const Eigen::Vector2d& pp2, double f1,
                                     double f2, Eigen::Vector2d* residuals);

}  // namespace glomap
