// Structure-only refinement: every 3D point moved to minimise its own
// reprojection errors while all poses and intrinsics stay fixed (the step
// of COLMAP's point_triangulator that its BundleAdjuster does with every
// pose held). With the poses fixed the points do not interact, so each
// point is a problem of three unknowns and is solved alone, by
// Levenberg-Marquardt on its own observations, on several threads, without
// one Ceres problem of all observations (on a 2,000-image street that
// problem was the mapper's peak: 1.16 million cost functions, residual
// blocks and Jacobian rows, 0.4 GB).
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {

struct PointRefinementOptions {
  // Levenberg-Marquardt iterations per point, accepted or rejected.
  int max_num_iterations = 10;
  // A point stops once an accepted step lowers its cost by less than this
  // fraction (Ceres' function_tolerance, same default).
  double function_tolerance = 1e-6;
  // ... or once a step is shorter than this fraction of the point's
  // distance from the origin (Ceres' parameter_tolerance, same default).
  double parameter_tolerance = 1e-8;
  // Scale of a soft-L1 loss on each observation's reprojection error, in
  // pixels (Ceres' SoftLOneLoss, as bundle adjustment uses); 0: least
  // squares, as COLMAP's structure-only bundle adjustment.
  double loss_scale_px = 0;
  // Threads; -1 uses all cores. Each point is solved alone, so the result
  // does not depend on the number of threads.
  int num_threads = -1;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

struct PointRefinementSummary {
  size_t num_points = 0;
  size_t num_observations = 0;
  // Half the sum of squared reprojection errors over all observations of
  // the refined points [px^2] (under the loss, if any), before and after.
  double initial_cost = 0;
  double final_cost = 0;
};

// Refines the points `point3D_ids` of `reconstruction` (every point when
// empty) by (robust) least squares on their reprojection errors, with poses and
// intrinsics held fixed; tracks are not changed. A step that would put a
// point behind (or onto the centre plane of) any camera of its track is
// rejected like a step that raises the cost; a point already behind a
// camera of its track is left where it is (COLMAP's
// FilterObservationsWithNegativeDepth removes such observations first).
// Returns Cancelled if `interrupt` fires (points refined so far keep their
// new positions, the others their old ones).
Status RefinePointsWithFixedPoses(
    const PointRefinementOptions& options,
    const std::vector<colmap::point3D_t>& point3D_ids,
    colmap::Reconstruction* reconstruction, const Interrupt& interrupt = {},
    PointRefinementSummary* summary = nullptr);

}  // namespace glomap
