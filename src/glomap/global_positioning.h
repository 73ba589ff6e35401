// Global positioning (paper Sec. 3, "Global positioning"; glomap.md §2.6 and
// §5): camera centres and 3D points estimated jointly from the fixed global
// rotations and the feature tracks, starting from a random initialization.
#pragma once

#include <string>

#include "base/reconstruction.h"
#include "glomap/ceres_threads.h"
#include "glomap/status.h"
#include "glomap/tracks.h"

namespace glomap {

struct GlobalPositioningOptions {
  // Huber scale on the norm of the 3-vector residual (unit-ray units; the
  // reference's 0.1).
  double loss_scale = 0.1;
  // Maximum number of Levenberg-Marquardt iterations.
  int max_num_iterations = 100;
  // Relative cost change at which the solver stops.
  double function_tolerance = 1e-5;
  // Which unknowns are estimated. Fixed centres keep the images' current
  // poses (c = -R^T t), fixed points their random start, fixed scales 1.
  bool optimize_positions = true;
  bool optimize_points = true;
  bool optimize_scales = true;
  // Camera centres and points start uniformly in [-s, s]^3 with s this half
  // side length (the reference's [-100, 100]^3; the paper shows the random
  // start suffices).
  double init_box_size = 100;
  // Seed of the random initialization (same input + seed => same output).
  int random_seed = 1;
  // Loss weight of observations from cameras without a prior focal length
  // (their rays are less certain; the reference's 0.5).
  double uncalibrated_weight = 0.5;
  // Below this many images the solve uses Eigen's sparse Cholesky on the
  // full normal equations (faster on small problems); from it on, Ceres'
  // SPARSE_SCHUR with CHOLMOD and the elimination order scales, points,
  // centres (supernodal, for large camera blocks).
  int max_num_images_eigen_sparse = 500;
  // Ceres threads; -1 = all hardware threads.
  int num_threads = -1;
  // One more Ceres thread per this many residual blocks (see ceres_threads.h;
  // set from GlobalMapper.min_residuals_per_ceres_thread).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;
  // Lower bound of every scale d (1 / scene units): keeps d > 0, i.e. the
  // point in front of the camera along the observed ray, and the trivial
  // solution d = 0 out of reach (the reference's 1e-5).
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

// Rotations (the registered images' Qvec) are held fixed. Unknowns: the centre
// of every registered image observed by a track, one point per track with at
// least two observations in registered images, and one scale d >= 0 per
// observation. Residual per observation (paper Eq. 5, BATA-style):
//   v - d (X - c),  v = R^T normalize(ImageToWorld(xy), 1)  (unit, world).
// On success: every image's Tvec = -R c, one Point3D per track (existing
// points are deleted first), structure filtered by angle and triangulation
// angle, and the reconstruction normalized (COLMAP's Normalize). Registered
// images that end up without any 3D point are deregistered, since their
// position is unconstrained. Returns an error if the problem is empty, the
// solver fails, produces non-finite values or a degenerate layout, and
// Status::Cancelled() when `interrupt` fires.
Status RunGlobalPositioning(const GlobalPositioningOptions& options,
                            const TrackStore& tracks,
                            colmap::Reconstruction* reconstruction,
                            const Interrupt& interrupt = {});

}  // namespace glomap
