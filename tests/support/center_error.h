// How far estimated camera centres are from the true ones, up to the
// similarity that global SfM leaves free. Header-only, like
// camera_rotation.h.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <vector>

#include "base/similarity_transform.h"

namespace glomap {
namespace testing {

// Mean distance between the estimated and true centres after the best
// similarity (estimated to true), relative to the diagonal of the true
// centres' bounding box. NaN if no similarity can be estimated.
inline double RelativeCenterError(const std::vector<Eigen::Vector3d>& estimated,
                                  const std::vector<Eigen::Vector3d>& truth) {
  colmap::SimilarityTransform3 transform;
  if (estimated.size() != truth.size() || estimated.empty() ||
      !transform.Estimate(estimated, truth)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  double sum_error = 0;
  Eigen::AlignedBox3d box;
  for (size_t i = 0; i < estimated.size(); ++i) {
    Eigen::Vector3d aligned = estimated[i];
    transform.TransformPoint(&aligned);
    sum_error += (aligned - truth[i]).norm();
    box.extend(truth[i]);
  }
  return sum_error / estimated.size() / box.diagonal().norm();
}

}  // namespace testing
}  // namespace glomap
