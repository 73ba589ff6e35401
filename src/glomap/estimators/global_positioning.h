// Global positioning (paper Sec. 3, "Global positioning"; glomap.md §2.6 and
// §5): camera centres and 3D points estimated jointly from the fixed global
// rotations and the feature tracks, starting from a random initialization.
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/priors/prior_alignment.h"
#include "glomap/scene/tracks.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/status.h"

namespace glomap {

struct GlobalPositioningOptions {
  // Huber scale on the norm of the 3-vector residual (unit-ray units; the
  // reference's 0.1).
  double loss_scale = 0.1;
  // Maximum number of Levenberg-Marquardt iterations.
  int max_num_iterations = 100;
  // ... of the second solve, with position priors, which starts from the
  // first one's solution aligned to the priors (see RunGlobalPositioning).
  // It only has to bend that solution towards the priors, and bundle
  // adjustment goes on from there. On a 500-image forward sequence (3 m
  // priors) 20 iterations took 7.3 s of a 121 s run (the free solve: 101 in
  // 37 s) and left 10 good priors beyond the rejection threshold, which the
  // check after bundle adjustment re-admitted; the final model was as
  // accurate as after 42 iterations (to convergence, 17 s).
  int prior_max_num_iterations = 20;
  // Relative cost change at which the solver stops.
  // Not a GlobalMapper.* option (a solver tolerance, set in the code only).
  double function_tolerance = 1e-5;
  // Which unknowns are estimated. Fixed centres keep the images' current
  // poses (c = -R^T t), fixed points their random start, fixed scales 1.
  bool optimize_positions = true;
  bool optimize_points = true;
  bool optimize_scales = true;
  // Solve for centres and points only, each scale at its best value for them
  // (variable projection, ProjectedRayResidual in ray_residual.h): the same
  // minima without one unknown per observation, so the Schur complement
  // eliminates the points and leaves a system of the centres only. Used for
  // the solves from the image centres (start_from_image_centers) and with
  // priors; a solve from the random start keeps the scales as unknowns,
  // which gather the cameras out of the box far faster. 2,000-image street
  // from the centres: 14 s and 557 MB instead of 165 s and 1,031 MB;
  // survey 12 s and 695 MB instead of 40 s and 1,383 MB (a 500-image street
  // converged in 9 iterations to cost 1.646, where the joint solve stopped
  // at its cap, 101 iterations, at 1.649). False: every scale is an unknown
  // of every solve (the reference's formulation).
  bool project_out_scales = true;
  // Camera centres and points start uniformly in [-s, s]^3 with s this half
  // side length (the reference's [-100, 100]^3; the paper shows the random
  // start suffices).
  // Not a GlobalMapper.* option (the scale of the solution is arbitrary, set in
  // the code only).
  double init_box_size = 100;
  // Start from the registered images' current centres (c = -R^T t, set by
  // InitializeCameraCenters, position_initialization.h) with every point
  // triangulated from its rays, instead of the random start in the box.
  bool start_from_image_centers = false;
  // With start_from_image_centers: when that solve stops without converging
  // (at max_num_iterations), solve from the random start too and keep the
  // solution of lower cost.
  bool random_start_unless_converged = true;
  // ... and up to this many images also when it converges: a converged solve
  // can be in a worse minimum (dino-363, seed 0, many wrong pairs: 34
  // iterations to cost 1.52, AUC@3 58.0; the random start 13 iterations to
  // 0.064, 78.5). Above it the random solve costs more than it is likely to
  // give: on the 2,000-image survey the converged solve from the pairs took
  // 47 s, the random one 130 s more, to a higher cost.
  int random_start_max_num_images = 500;
  // ... but that random solve is stopped after this many iterations when its
  // cost is still above the final cost of the solve from the centres: the
  // random start spends its first iterations gathering the cameras out of
  // the box, and none still behind then was seen to end in a better
  // minimum (1,000-image street: 70.5 at iteration 25 against 2.72, 2.75
  // after the full 100; on KITTI 0.4-0.7% lower, in the same minimum; the
  // README's scale section has the 18 runs). 0: never stopped early.
  int random_start_check_iterations = 25;
  // Seed of the random initialization (same input + seed => same output).
  int random_seed = 1;
  // Loss weight of observations from cameras without a prior focal length
  // (their rays are less certain; the reference's 0.5).
  double uncalibrated_weight = 0.5;
  // Below this many images the solve uses Eigen's sparse Cholesky on the
  // full normal equations (faster on small problems); from it on, Ceres'
  // SPARSE_SCHUR with CHOLMOD and the elimination order scales, points,
  // centres (supernodal, for large camera blocks), or points, centres with
  // the scales projected out.
  // Not a GlobalMapper.* option (where the linear solver switches, set in the
  // code only).
  int max_num_images_eigen_sparse = 500;
  // Ceres threads; -1 = all hardware threads.
  int num_threads = -1;
  // One more Ceres thread per this many residual blocks (see ceres_threads.h;
  // set from GlobalMapper.min_residuals_per_ceres_thread).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;
  // Lower bound of every scale d (1 / scene units): keeps d > 0, i.e. the
  // point in front of the camera along the observed ray, and the trivial
  // solution d = 0 out of reach (the reference's 1e-5).
  // Not a GlobalMapper.* option (a numerical bound, set in the code only).
  double min_scale = 1e-5;
  // After the solve: observations whose ray is off by more than this angle
  // are removed ...
  double max_angular_error_deg = 1.0;
  // ... and by more than this multiple of it for cameras without a focal
  // prior, whose intrinsics are less certain (glomap.md §2.6: 1 and 2 deg).
  double uncalibrated_angular_error_factor = 2.0;
  // After the solve: points whose viewing rays span less than this are
  // removed.
  double min_tri_angle_deg = 1.0;
  // The result is rejected as degenerate (e.g. the "cuboid" failure where
  // cameras stay spread over the random-init box) when fewer than this
  // fraction of the observations survive the angular filter.
  double min_inlier_observation_ratio = 0.2;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// What global positioning did: which start its free solve kept, and what it
// did with position priors.
struct GlobalPositioningSummary {
  // The free solve (without priors) that was kept: started from the random
  // start (true) or from the images' centres, and its final cost.
  bool kept_random_start = true;
  double free_solve_cost = 0;
  // The final cost of the other start's solve when both were solved
  // (random_start_unless_converged, random_start_max_num_images), else -1.
  double other_start_cost = -1;
  // The random start's solve was stopped at random_start_check_iterations,
  // behind the solve from the centres.
  bool random_start_stopped_early = false;
  // The result is in the prior frame (metres), fixed by the priors; false:
  // no priors, or they could not fix a similarity (then the model is
  // normalised as without priors and the priors must not be used further).
  bool georegistered = false;
  // Priors of registered images within the rejection threshold of their
  // camera after the solve, and the registered images whose prior is farther
  // (sorted by id); bundle adjustment uses the first and leaves out the
  // second.
  size_t num_priors_used = 0;
  std::vector<colmap::image_t> rejected_image_ids;
};

// Rotations (the registered images' Qvec) are held fixed. Unknowns: the centre
// of every registered image observed by a track, one point per track with at
// least two observations in registered images, and one scale d >= 0 per
// observation (projected out of the solve from the image centres and of the
// one with priors: project_out_scales). Residual per observation (paper Eq. 5,
// BATA-style):
//   v - d (X - c),  v = R^T normalize(ImageToWorld(xy), 1)  (unit, world).
// On success: every image's Tvec = -R c, one Point3D per track (existing
// points are deleted first), structure filtered by angle and triangulation
// angle, and the reconstruction normalized (COLMAP's Normalize). Registered
// images that end up without any 3D point are deregistered, since their
// position is unconstrained. Returns an error if the problem is empty, the
// solver fails, produces non-finite values or a degenerate layout, and
// Status::Cancelled() when `interrupt` fires.
//
// With start_from_image_centers the free solve starts from the images'
// current centres (points triangulated from them); if it stops without
// converging and random_start_unless_converged is set, or it has at most
// random_start_max_num_images images, the random start is solved too (stopped
// at random_start_check_iterations if it is still behind then) and the solution
// of lower cost kept (`summary` says which).
//
// With position priors (`priors` not null nor empty; issue 12) the solve
// from the random start is followed by a robust similarity of its camera
// centres to the priors (AlignCentersToPriors, threshold
// priors->MaxErrorM()), which takes the whole solution into the prior frame
// (rotations included), and by a second solve from there with the prior term
// (c - p) / std under a Cauchy loss on every image with a prior (its cost
// weighted by the rays' noise squared, so that both terms count in units of
// their own noise), every scale free, for at most prior_max_num_iterations
// iterations. The result is then not normalised: it stays in the prior
// frame, in metres. Priors farther than the threshold from their camera
// afterwards are rejected (`summary`). If no similarity is found, a
// warning says so and the result is that of the free solve, normalised
// (`georegistered` false); if fewer than three non-collinear priors remain
// after the rejection, likewise, with the result of the second solve.
Status RunGlobalPositioning(const GlobalPositioningOptions& options,
                            const TrackStore& tracks,
                            colmap::Reconstruction* reconstruction,
                            const Interrupt& interrupt = {},
                            const PositionPriorTerm* priors = nullptr,
                            GlobalPositioningSummary* summary = nullptr);

}  // namespace glomap
