// Robust global rotation averaging (paper Sec. 3, "Rotation Averaging"):
// camera orientations from the relative rotations of the view graph, after
// Chatterjee & Govindu: a maximum-spanning-tree start, an L1 solve that is
// insensitive to gross outliers, then IRLS with Geman-McClure weights for
// accuracy. Pairs that disagree with the solution are rejected and the
// problem is solved again on the largest consistent component.
#pragma once

#include <cstddef>
#include <string>

#include "base/reconstruction.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/status.h"

namespace glomap {

struct RotationAveragingOptions {
  // Outer L1 iterations (each relinearizes around the current rotations).
  int max_num_l1_iterations = 5;
  // The L1 stage stops when the mean per-image update is below this (rad).
  // Not a GlobalMapper.* option (a convergence threshold, set in the code
  // only).
  double l1_step_convergence_threshold_rad = 1e-3;
  // ADMM iterations of each L1 solve: this many in the first, doubling in
  // each later one up to l1_max_num_admm_iterations. The inner solve need
  // not be exact: relinearizing matters more than inner accuracy (as in the
  // reference).
  // Neither is a GlobalMapper.* option (ADMM internals, set in the code only).
  int l1_initial_num_admm_iterations = 10;
  int l1_max_num_admm_iterations = 100;
  // ADMM stopping tolerances (Boyd et al., "Distributed optimization ...",
  // Sec. 3.3.1): absolute per residual coordinate (rad), and relative to the
  // size of the iterates.
  // Neither is a GlobalMapper.* option (ADMM stopping tolerances, set in the
  // code only).
  double admm_absolute_tolerance_rad = 1e-5;
  double admm_relative_tolerance = 1e-3;
  // Maximum number of iteratively reweighted least-squares iterations.
  int max_num_irls_iterations = 100;
  // IRLS stops when the mean per-image update is below this (rad).
  // Not a GlobalMapper.* option (a convergence threshold, set in the code
  // only).
  double irls_step_convergence_threshold_rad = 1e-3;
  // Scale of the Geman-McClure loss used to weight pairs in IRLS (deg).
  double irls_loss_parameter_sigma_deg = 5.0;
  // Pairs whose relative rotation disagrees with the averaged rotations by
  // more than this are invalidated, and the problem is solved again (deg).
  double max_rotation_error_deg = 10.0;
  // Number of solve-then-reject rounds (the reference runs two). Rounds after
  // the first start from the previous round's rotations.
  int num_rounds = 2;
  // Build the initial spanning tree preferring pairs that close rotation-
  // consistent triangles (loop error < max_rotation_error_deg), then pairs
  // with more inliers; false uses the inlier count only (as the reference).
  bool use_triangle_support_in_tree = true;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Estimates a world-to-camera rotation for every image of the largest
// connected component of the valid pairs that have a relative pose
// (qvec2_from_1: x2 = R21 x1 + t).
//
// Pairs whose relative rotation disagrees with the result by more than
// max_rotation_error_deg are invalidated, as are all pairs with an image
// outside the final component. Each round after the first, and the final
// component, stay within the images the round before solved, even when
// rejection leaves another component larger. Images of the final component
// get their Qvec (normalized, (w, x, y, z)), Tvec = 0 and are registered; all
// other images are deregistered. The gauge is fixed by giving the smallest
// image id of the component the identity rotation, so results are
// deterministic.
//
// Returns an error if a pair names an image that is not in the
// reconstruction, or if fewer than two images remain. num_rejected_pairs
// (optional) receives the number of pairs this call invalidated. Returns
// Cancelled when `interrupt` fires (the view graph may then be changed).
Status AverageRotations(const RotationAveragingOptions& options,
                        ViewGraph* view_graph,
                        colmap::Reconstruction* reconstruction,
                        size_t* num_rejected_pairs = nullptr,
                        const Interrupt& interrupt = {});

// Angle between the pair's measured relative rotation and the one implied by
// the two images' current Qvecs, R2 * R1^T (deg).
double RelativeRotationErrorDeg(const ImagePair& pair,
                                const colmap::Reconstruction& reconstruction);

}  // namespace glomap
