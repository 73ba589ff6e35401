// Global bundle adjustment rounds after global positioning (paper Sec. 3,
// "Global Bundle Adjustment"; glomap.md §2.7): each round first refines
// positions, points and intrinsics with the rotations held fixed (rotation
// averaging already gave good rotations, and freezing them keeps the first
// solve from falling into a bad minimum while positions are still coarse),
// then refines everything jointly, normalizes the scene and filters
// observations by reprojection error with a threshold that tightens from
// round to round.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/priors/prior_alignment.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/status.h"

namespace glomap {

struct GlobalBundleAdjustmentOptions {
  // Maximum number of rounds (rotation-fixed solve in the first round, joint
  // solve, filtering). The reference runs 3; after the second round the
  // final bundle adjustment that follows retriangulation does the remaining
  // work on many more points, so a third round only costs time (on
  // KITTI_sequence_1: 3 rounds 19.2 s, 1.80 cm; 2 rounds 17.8 s, 1.22 cm).
  int num_rounds = 2;

  // Scale of the robust loss on the reprojection residual, in pixels. The
  // loss is Ceres' soft-L1 (quadratic below the scale, linear above): the
  // reference uses Huber(1 px), which COLMAP 3.8's BundleAdjuster does not
  // offer, and soft-L1 is its smooth equivalent. Cauchy would be more
  // aggressive, but it down-weights correct observations whose error is
  // still large right after global positioning. 0: no robust loss (least
  // squares, as COLMAP's global bundle adjustment after its filtering).
  double loss_scale_px = 1.0;

  // Maximum Ceres iterations per solve (each round has up to two solves).
  // Forward motion with unknown focal length converges slowly (a long valley
  // between focal length, distortion and depth); capping each solve and
  // letting later solves continue is faster than running one to the end.
  int max_num_iterations = 40;

  // A solve of up to M = function_tolerance_num_images images stops once
  // the relative cost decrease of an iteration falls below this value
  // (Ceres' function_tolerance; the reference uses 1e-5). For N > M images
  // the tolerance is multiplied by (M / N)^2: a large block deforms smoothly
  // (a bend over the whole survey) at almost no reprojection cost, so that
  // mode converges with tiny relative decreases that a fixed tolerance
  // mistakes for convergence. On a 500-image synthetic survey, 1e-5 stopped
  // after 8 iterations at a median pairwise rotation error of 1.06 deg
  // (AUC@3 64%); 1e-7 reached 0.13 deg (AUC@3 95%). On the shared datasets
  // (<= 51 images) a smaller tolerance only adds iterations.
  double function_tolerance = 1e-5;
  // Not a GlobalMapper.* option (part of the solver tolerance, set in the code
  // only).
  int function_tolerance_num_images = 50;

  // Linear solver by the number of images: up to this, a dense Schur
  // complement; above, a sparse one (CHOLMOD), at every size.
  // The Schur complement of a global bundle adjustment is small and dense:
  // one block per image plus the shared intrinsics. Up to a few hundred
  // images a dense factorization of it is faster than COLMAP 3.8's choice
  // (sparse above 50 images): the sparse block matrix pays a hash lookup and
  // a lock per cell, and every point's chunk locks the shared intrinsics
  // block (measured on KITTI_sequence_1, 51 images: a fifth of the solve
  // time in GetCell and mutexes). Up to thousands of images the reduced
  // camera system stays sparse enough for CHOLMOD (a survey or a street
  // links each image to a bounded neighbourhood, so its factor grows about
  // linearly). There is no iterative fallback for large problems: the
  // iterative Schur solver that COLMAP uses above 1000 images stopped after
  // a few steps far from the optimum on a 2000-image survey (issue 14).
  // Not a GlobalMapper.* option (where the linear solver switches, set in the
  // code only).
  int max_num_images_dense_schur = 150;

  // Which groups of intrinsic parameters are refined (all cameras).
  bool refine_focal_length = true;
  bool refine_principal_point = false;
  bool refine_extra_params = true;

  // Soft prior on the intrinsics that few images cannot fix (0: none): the
  // difference of fx and fy, and every distortion parameter beyond the first
  // radial one (k2, tangential p1 p2, the higher orders of FULL_OPENCV and
  // OPENCV_FISHEYE), each pulled towards zero by one residual that is the
  // pixel shift it causes at the image corner divided by this many pixels
  // (IntrinsicsPriorMatrix). Against thousands of observations it weighs
  // like one: a lens that has the distortion keeps it, a narrow view that
  // cannot tell it from the poses does not invent it (templeRing with an
  // OPENCV camera: fx 1251 / fy 1535 px for a true 1520 / 1526, k2 1.94,
  // AUC@3 30 without it, 79 at 0.5 px, 89 at 0.1 px, as with SIMPLE_RADIAL;
  // OPENCV_FISHEYE: k4 = -1004). OPENCV_FISHEYE's higher orders get a
  // weaker prior (see IntrinsicsPriorMatrix).
  double intrinsics_prior_px = 0.1;

  // Bounds on the refined intrinsics (IntrinsicsBounds), so that parameters
  // the images cannot fix do not run away: the focal length within 0.1 to
  // 10 times the larger image side (COLMAP's mapper calls a camera outside
  // that bogus), the principal point inside the image, and each distortion
  // parameter alone moving the image corner by at most its distance from
  // the principal point (a lone k1 also no further inwards than where the
  // radial mapping would fold back inside the image). A parameter that a
  // solve moved beyond its bound is clamped onto it and held there, and the
  // solve runs again (logged); solves that stay within them are unchanged.
  // A start value outside a bound widens it to that value.
  bool bound_intrinsics = true;

  // Focal lengths known before the solve (cameras with prior_focal_length:
  // an EXIF focal or one the user gave), by camera id; the global mapper
  // fills it from the database. Each such camera's focal parameters get a
  // soft prior towards this value with a standard deviation of
  // prior_focal_length_std times it (0: none, the focal is free as in
  // COLMAP's mapper). Where the images fix the focal, it weighs nothing (a
  // 2% error costs 0.08 against thousands of observations); where they do
  // not (forward motion: focal length and depth along the track trade
  // against each other), it keeps the focal from drifting with the rest of
  // the model (a street of three cameras, one with an EXIF focal 2% off:
  // all three focals ended 21% off without it).
  std::map<colmap::camera_t, double> prior_focal_lengths_px;
  double prior_focal_length_std = 0.05;

  // The global mapper refines principal points (when refine_principal_point
  // is set, its default there) only when the registered cameras' viewing
  // directions spread enough to observe them: the median angle between an
  // optical axis and the mean axis is at least this, in degrees (0: refine
  // them whatever the spread). When all
  // cameras look the same way (forward motion, a nadir survey), a shift of
  // the principal point is the same as one small rotation of every camera
  // and cannot be told from it; with the directions spread, it can. True
  // principal points lie 15-40 px from the image centre on the shared
  // datasets, and this is then their largest error (measured AUC@3 with
  // refinement: castle-P19 77.8 -> 95.9, fountain-P11 88.6 -> 97.2,
  // templeRing 68.9 -> 89.8; KITTI_sequence_1, spread 0.5 deg, would
  // collapse to 11.9 and keeps the centre). The shared datasets spread by
  // 0.5 (KITTI), 16-35 (facades) and 63-82 deg (objects), the aerial
  // survey by 2 deg.
  double min_view_spread_deg_for_principal_point = 10.0;

  // Observations whose reprojection error on the normalized image plane
  // (pixels / focal length) exceeds this value times K, K - 1, ..., 1 in
  // successive filtering levels are removed, K =
  // initial_reproj_error_multiplier (glomap.md §2.7: 3, 2, 1; 0.01 is about
  // 10 px at f = 1000 px): loose while poses are still coarse. Normalized
  // units keep the threshold meaningful for any image size.
  double max_normalized_reproj_error = 0.01;
  int initial_reproj_error_multiplier = 3;

  // After the last round, points whose largest triangulation angle is below
  // this are deleted (their depth is poorly constrained).
  double min_tri_angle_deg = 1.0;

  // Rounds stop once the tracks that lost observations in a round are fewer
  // than this fraction of all tracks, even at the tightest threshold.
  double min_changed_tracks_ratio = 0.001;

  // Points of each solve (0: all). Above 0, a solve holds only the points
  // needed for every image to observe this many of them spread over the
  // image, longest tracks first (PointsLeftOutOfSolve); the points left
  // out are refined after each solve with the poses fixed
  // (RefinePointsWithFixedPoses, with the same loss), so that filtering
  // and normalization see every point at the new poses. A solve's memory
  // and time grow with its observations, and the noise of its poses about
  // with the inverse square root of their number: this is for models too
  // large to solve whole (RetriangulationOptions::
  // final_ba_max_num_observations).
  int solve_tracks_per_image = 0;
  // Observations a solve may hold (0: no limit). In a round whose model
  // has more, and solve_tracks_per_image is 0, the solves hold the points
  // of the largest number of tracks per image that fits
  // (SolveTracksPerImageWithin; a budget is never below
  // kMinSolveObservationsPerImage per image). The default leaves models of
  // up to about 3,000 images whole (the 2,000-image survey's rounds hold
  // 667,000 observations) and caps the memory of larger ones: at 5,000
  // images the survey's rounds held 1.65 million observations and peaked at
  // 1,939 MB, with this budget 1,624 MB (the peak then global
  // positioning's); at 10,000 images the budget is raised to 2 million.
  int max_num_solve_observations = 1000000;
  // After the rounds, when their solves left points out, this many sweeps
  // of block-coordinate descent over every observation: each pose refined
  // with the points held (a resection under the same loss, with its
  // position prior), then each point with the poses held. The solves fix
  // the model's shape from part of the points; the sweeps rest each pose on
  // all its observations, one image's or one point's problem at a time, so
  // at no memory cost. They recover what the part solve loses where the
  // shape is held (position priors), not along the dome of a survey without
  // priors, which such local steps barely move. Measured, AUC@3 without
  // sweeps / with 3 / all points in the solve: 600-image surveys (final
  // solve 194,000 of 359,000 observations) with 1 m priors 96.42 / 96.75 /
  // 96.76, without priors (OPENCV, a camera per image) 91.13 / 91.33 /
  // 96.33. 2,000-image survey with 1 m priors: 96.53 / 97.03 / 97.36.
  int left_out_sweeps = 3;

  // Skip the solve with fixed rotations (first round only; of the
  // intrinsics it refines the focal lengths alone), or the joint solve, in
  // every round.
  bool skip_fixed_rotation_stage = false;
  bool skip_joint_stage = false;

  // Ceres threads; -1 uses all cores.
  int num_threads = -1;
  // One more Ceres thread per this many residual blocks (see ceres_threads.h;
  // set from GlobalMapper.min_residuals_per_ceres_thread).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// The linear residuals of the intrinsics prior of `camera` (see
// GlobalBundleAdjustmentOptions::intrinsics_prior_px): residuals = A *
// params, one row per prior term, NumParams() columns; zero rows for models
// without such parameters (SIMPLE_PINHOLE, SIMPLE_RADIAL, ...). A row is the
// pixel shift at the image corner (normalized radius r = half diagonal /
// focal; the angle atan(r) for fisheye models) per unit of the parameter,
// divided by `sigma_px`.
Eigen::MatrixXd IntrinsicsPriorMatrix(const colmap::Camera& camera,
                                      double sigma_px);

// Per parameter of `camera` (NumParams() entries), the interval
// bound_intrinsics holds it in; -inf / +inf where it is not bounded (the
// distortion parameters of models other than the radial, OpenCV and fisheye
// ones).
std::vector<std::pair<double, double>> IntrinsicsBounds(
    const colmap::Camera& camera);

// Runs the BA rounds on the registered images and points of `reconstruction`
// (camera intrinsics are shared per camera). The gauge is fixed by holding
// one image's pose and one translation coordinate of a second image constant;
// the scene is normalized (Reconstruction::Normalize) after each round.
// `on_round_done` is called after each round (the GUI refreshes its viewer).
// Returns Cancelled if `interrupt` fires (the reconstruction then holds the
// state of the last finished Ceres iteration and is consistent), an error if
// there are fewer than two registered images with points or a solve fails.
//
// With position priors (`priors` not null nor empty, in the reconstruction's
// frame; issue 12) both solves of every round add the prior term (c - p) /
// std on the camera centre c = -R^T t of each image listed, under a Cauchy
// loss; the priors fix the gauge (no pose or scale held, except in a part of
// the model that shares no point with the rest and has too few priors of its
// own to fix a similarity), and the scene is never normalized, so the model
// stays in the prior frame, in metres. Before and after each solve the whole
// model takes the similarity that best fits it to its priors
// (FitSimilarityToPriors), which the solves themselves would take only
// slowly.
Status RunGlobalBundleAdjustment(
    const GlobalBundleAdjustmentOptions& options,
    colmap::Reconstruction* reconstruction, const Interrupt& interrupt = {},
    const std::function<void()>& on_round_done = {},
    const PositionPriorTerm* priors = nullptr);

// The points a solve leaves out when every image is to observe
// `tracks_per_image` of the points it holds, spread over the image
// (solve_tracks_per_image; none if 0). Each image is cut into a
// kSolveGridSize x kSolveGridSize grid, and each cell is to hold
// ceil(tracks_per_image / kSolveGridSize^2) observations: points are taken
// by decreasing track length (then by id), each while some observation of
// its track falls in a cell that holds fewer; the rest are left out. Every
// cell keeps at least min(its quota, its number of observations). Spread
// points fix a pose better than the same number bunched together.
constexpr int kSolveGridSize = 4;
std::unordered_set<colmap::point3D_t> PointsLeftOutOfSolve(
    const colmap::Reconstruction& reconstruction, int tracks_per_image);

// The fewest observations per image a budget leaves a solve (on average
// over the images with points): a smaller budget is raised to this. With
// fewer the poses lose accuracy fast. On an unseen 600-image survey
// (OPENCV, no focal prior, 30% wrong matches) the final bundle adjustment
// with 48, 64, 96 and 160 tracks per image spread over it (225 and 320
// observations per image at 96 and 160) gave AUC@3 77.0, 86.7, 93.6 and
// 93.8 (mean position error 0.27, 0.17, 0.10, 0.09), with all points 96.4
// (0.06); on the 5,000-image survey 100 observations per image gave 87.6,
// 186 gave 94.4 and 213 gave 90.4 (the dome: see the README).
constexpr int kMinSolveObservationsPerImage = 200;

// The largest solve_tracks_per_image whose solve holds at most
// `max_num_observations` observations of `reconstruction`, raised to
// kMinSolveObservationsPerImage times its images with points (bisection
// over PointsLeftOutOfSolve; at least 1); 0 if all of them fit.
int SolveTracksPerImageWithin(const colmap::Reconstruction& reconstruction,
                              size_t max_num_observations);

// Refines each image of `image_ids` on its own: its pose and its camera's
// intrinsics (the groups that `options` refines, with its intrinsics prior
// and robust loss), with every 3D point held; a resection with
// self-calibration, one small problem per image, `options.num_threads` of
// them at a time. Every image must have a camera of its own (the images
// write their cameras in parallel). Images without points stay as they are.
// Returns Cancelled if `interrupt` fires.
Status RefineImagesWithPointsFixed(
    const GlobalBundleAdjustmentOptions& options,
    const std::vector<colmap::image_t>& image_ids,
    colmap::Reconstruction* reconstruction, const Interrupt& interrupt = {});

}  // namespace glomap
