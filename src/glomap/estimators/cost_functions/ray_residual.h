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

// The ray residual with the scale at its best value (BestRayScale) for the
// current c and X, i.e. d projected out (variable projection): with
// w = X - c and d = <v, w> / |w|^2 it is the part of v across w, of norm
// sin(angle(v, w)); where that d falls below min_scale (X behind c along v)
// d = min_scale. The minima in (c, X) are those of RayResidual minimised
// over d, without one scale unknown per observation. Parameter blocks: c, X.
// The Jacobians include the derivative of d, so they are exact.
class ProjectedRayResidual : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  ProjectedRayResidual(const Eigen::Vector3d& ray_in_world, double min_scale)
      : ray_in_world_(ray_in_world), min_scale_(min_scale) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> center(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
    const Eigen::Vector3d diff = point - center;
    const double scale = BestRayScale(ray_in_world_, diff, min_scale_);
    const bool clamped = !(scale > min_scale_);
    Eigen::Map<Eigen::Vector3d> residual(residuals);
    residual = ray_in_world_ - scale * diff;
    if (jacobians == nullptr) return true;
    // d (d w) / d w: d I when clamped, else
    // (w v^T + <v, w> I) / |w|^2 - 2 <v, w> w w^T / |w|^4.
    Eigen::Matrix3d d_scaled_diff = scale * Eigen::Matrix3d::Identity();
    if (!clamped) {
      d_scaled_diff += (diff * ray_in_world_.transpose() -
                        2 * scale * diff * diff.transpose()) /
                       diff.squaredNorm();
    }
    // r = v - d w: d r / d c = + d (d w) / d w, d r / d X = - that.
    using RowMajor = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    if (jacobians[0] != nullptr) {
      Eigen::Map<RowMajor> d_residual_d_center(jacobians[0]);
      d_residual_d_center = d_scaled_diff;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<RowMajor> d_residual_d_point(jacobians[1]);
      d_residual_d_point = -d_scaled_diff;
    }
    return true;
  }

 private:
  const Eigen::Vector3d ray_in_world_;
  const double min_scale_;
};

}  // namespace glomap
