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
#pragma once

#include <cstddef>

#include "base/reconstruction.h"
#include "glomap/status.h"
#include "glomap/view_graph.h"

namespace glomap {

struct ViewGraphCalibrationOptions {
  // A camera's new focal is rejected (old one kept) if new/old is below this.
  double min_focal_ratio = 0.1;
  // ... or above this.
  double max_focal_ratio = 10;
  // Pairs whose unrobustified residual norm (relative focal^2 errors) exceeds
  // this after the solve are invalidated.
  double max_two_view_error = 2.0;
  // Scale of the Cauchy loss on the relative focal^2 residuals (final solve;
  // a first solve uses max(0.5, this) to leave the loss' flat tail).
  double loss_scale = 0.01;
  // Maximum number of Ceres iterations.
  int max_num_iterations = 100;
  // Ceres threads; -1 uses all cores.
  int num_threads = -1;

  bool Check() const;
};

// Estimates one focal length per camera WITHOUT a focal prior
// (camera.HasPriorFocalLength() == false) from the fundamental matrices of
// valid pairs with config CALIBRATED or UNCALIBRATED; the principal point is
// kept at the camera's current one and cameras with a prior stay constant.
// Accepted focals are written into every focal parameter of the camera (so
// fx = fy afterwards). Pairs touching at least one free camera whose
// residual exceeds `max_two_view_error` are invalidated; their number goes to
// `num_invalidated_pairs` when it is not null. Without any free camera the
// function returns Ok and changes nothing.
Status CalibrateViewGraph(const ViewGraphCalibrationOptions& options,
                          colmap::Reconstruction* reconstruction,
                          ViewGraph* view_graph,
                          size_t* num_invalidated_pairs = nullptr);

// The two relative focal^2 residuals of one fundamental matrix F
// (x2^T F x1 = 0 in pixels) for focal lengths f1, f2 and principal points
// pp1, pp2. Returns false when F is degenerate (zero, rank < 2, not finite).
// Exposed for tests: at the true focals both residuals are ~0.
bool FundamentalMatrixFocalResiduals(const Eigen::Matrix3d& F,
                                     const Eigen::Vector2d& pp1,
                                     const Eigen::Vector2d& pp2, double f1,
                                     double f2, Eigen::Vector2d* residuals);

}  // namespace glomap
