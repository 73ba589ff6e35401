// The start of global positioning: camera centres from the image pairs'
// relative translation directions under the fixed global rotations (a
// camera-only translation averaging), instead of the paper's random start.
//
// Why (issue 14): from the random start, a long forward-moving sequence is
// not untangled. On the synthetic street of 5,000 and 10,000 images the joint
// solve of cameras and points stopped at its iteration cap with 3.4-3.6% of
// the observations off by more than the angular threshold (1,000 images:
// 0.7%), pose verification re-placed 59 and 109 images, and camera
// clustering cut the street into pieces (10,000 images: 18 models). Along a
// forward motion, which of two cameras is ahead is fixed only by the small
// parallax of the points, so a section of the chain that starts reversed
// stays reversed at little cost; the pairs' translation directions say it
// directly (the essential matrix's cheirality), and a camera-only problem
// has a hundred times fewer unknowns than the joint one.
//
// The paper's argument for the random start (Sec. 3: the bilinear objective
// converges from it) still holds for the joint solve, which starts here from
// these centres and points triangulated from them: this only gives it a
// start whose large-scale layout is already right.
//
// On by default (GlobalMapper.init_positions_from_pairs). It kept the
// 5,000-image street (seed 0) and a 3,000-image street (seed 1) in one model
// (AUC@3 79.5 and 86.9; the random start: 1,992 of 5,000 images in the
// largest model, and two models with AUC@3 28.9). Where the pairs'
// directions are poor (dino-363: 363 views around an untextured object) the
// joint solve from this start stopped at its cap in a worse minimum (cost
// 0.193, AUC@3 38.7); such a solve is compared with one from the random
// start (0.064, AUC@3 78.7) and the lower cost kept (global_positioning.h).
#pragma once

#include <string>

#include "base/reconstruction.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/ceres_interrupt.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/status.h"

namespace glomap {

struct PositionInitializationOptions {
  // Huber scale on the norm of the direction residual v - d (c2 - c1)
  // (unit-vector units, as global positioning's loss_scale): a pair whose
  // translation direction is wrong pulls with a bounded force.
  double loss_scale = 0.1;
  // Maximum number of Levenberg-Marquardt iterations of the camera-only solve.
  int max_num_iterations = 100;
  // Relative cost change at which the solver stops.
  // Not a GlobalMapper.* option (a solver tolerance, set in the code only).
  double function_tolerance = 1e-6;
  // Lower bound of every pair's scale d (as global positioning's min_scale):
  // keeps the second camera ahead of the first along the pair's direction.
  // Not a GlobalMapper.* option (a numerical bound, set in the code only).
  double min_scale = 1e-5;
  // Ceres threads; -1 = all hardware threads.
  int num_threads = -1;
  // One more Ceres thread per this many residual blocks (ceres_threads.h).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Sets the centre of every registered image that takes part in a usable
// pair (valid, with a relative pose, both images registered) by writing its
// Tvec = -R c (the rotations, from rotation averaging, are kept). First the
// maximum spanning tree of those pairs (weight: the number of verified
// matches) is walked from its first image with one unit step along each
// tree pair's direction; then every usable pair's direction is fitted by the
// robust camera-only objective sum_ij rho(|v_ij - d_ij (c_j - c_i)|), each
// d_ij >= min_scale, from there. A registered image in no usable pair keeps
// its pose. The units are arbitrary (global positioning fixes its own
// scale). Returns the number of images placed in `num_placed_images`; an
// error if the solver fails, Status::Cancelled() when `interrupt` fires.
Status InitializeCameraCenters(const PositionInitializationOptions& options,
                               const ViewGraph& view_graph,
                               colmap::Reconstruction* reconstruction,
                               const Interrupt& interrupt = {},
                               size_t* num_placed_images = nullptr);

}  // namespace glomap
