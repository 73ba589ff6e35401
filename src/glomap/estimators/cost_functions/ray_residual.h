// The bounded ray residual of global positioning (paper Eq. 5, BATA-style),
// shared by the joint solve of cameras and points (global_positioning.cc)
// and by the camera-only solve that starts it (position_initialization.cc).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <algorithm>

namespace glomap {

// r = v - d (X - c) with a unit direction v in world coordinates: from the
// point c towards the point X (a camera centre and a 3D point, or two
// camera centres). Parameter blocks: c, X, the scale d. The residual is
// bilinear, so the analytic Jacobians are exact and cheap.
class RayResidual : public ceres::SizedCostFunction<3, 3, 3, 1> {
 public:
  explicit RayResidual(const Eigen::Vector3d& ray_in_world)
      : ray_in_world_(ray_in_world) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* center = parameters[0];
    const double* point = parameters[1];
    const double scale = parameters[2][0];
    const double diff[3] = {point[0] - center[0], point[1] - center[1],
                            point[2] - center[2]};
    for (int i = 0; i < 3; ++i) {
      residuals[i] = ray_in_world_[i] - scale * diff[i];
    }
    if (jacobians == nullptr) return true;
    for (int block = 0; block < 2; ++block) {
      if (jacobians[block] == nullptr) continue;
      // d r / d c = d I, d r / d X = -d I (row-major 3x3).
      const double value = block == 0 ? scale : -scale;
      double* jacobian = jacobians[block];
      for (int i = 0; i < 9; ++i) jacobian[i] = 0;
      jacobian[0] = jacobian[4] = jacobian[8] = value;
    }
    if (jacobians[2] != nullptr) {
      for (int i = 0; i < 3; ++i) jacobians[2][i] = -diff[i];
    }
    return true;
  }

 private:
  const Eigen::Vector3d ray_in_world_;
};

// The scale d >= min_scale that minimises |v - d w| for w = X - c: the
// projection <v, w> / |w|^2, which is negative when X lies behind c along v.
inline double BestRayScale(const Eigen::Vector3d& ray_in_world,
                           const Eigen::Vector3d& diff, double min_scale) {
  const double squared_norm = diff.squaredNorm();
  if (!(squared_norm > 0)) return min_scale;
  return std::max(min_scale, ray_in_world.dot(diff) / squared_norm);
}

}  // namespace glomap
