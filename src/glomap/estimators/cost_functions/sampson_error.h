// The Sampson distance of one correspondence under a relative pose, the
// residual of the relative-pose refinement (relative_pose.cc).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>

#include "base/pose.h"

namespace glomap {

// r = x2^T E x1 / sqrt(|(E x1)_xy|^2 + |(E^T x2)_xy|^2) for E = [t]x R(q),
// with x1, x2 in normalised image coordinates (homogeneous, z = 1). Not
// squared, unlike COLMAP's RelativePoseCostFunction, whose squared residual
// would make the refinement minimise error^4. Parameter blocks: q (Ceres'
// [w, x, y, z], not necessarily unit: R(q) is the rotation of q / |q|, as
// ceres::QuaternionToRotation) and t (3). The Jacobians are analytic: this
// residual is evaluated for up to 500 matches of every pair over many
// iterations, and automatic differentiation made it most of the relative-pose
// stage's time.
class SampsonErrorCost : public ceres::SizedCostFunction<1, 4, 3> {
 public:
  SampsonErrorCost(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2)
      : x1_(x1(0), x1(1), 1.0), x2_(x2(0), x2(1), 1.0) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double w = parameters[0][0];
    const double x = parameters[0][1];
    const double y = parameters[0][2];
    const double z = parameters[0][3];
    const Eigen::Vector3d t(parameters[1][0], parameters[1][1],
                            parameters[1][2]);
    const double squared_norm = w * w + x * x + y * y + z * z;
    if (!(squared_norm > 0)) return false;
    // R = S(q) / |q|^2 with S quadratic in q.
    Eigen::Matrix3d S;
    S << w * w + x * x - y * y - z * z, 2 * (x * y - w * z),
        2 * (x * z + w * y),  //
        2 * (x * y + w * z), w * w - x * x + y * y - z * z,
        2 * (y * z - w * x),  //
        2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z;
    const Eigen::Matrix3d R = S / squared_norm;
    const Eigen::Matrix3d t_cross = colmap::CrossProductMatrix(t);
    const Eigen::Matrix3d E = t_cross * R;
    const Eigen::Vector3d Ex1 = E * x1_;
    const Eigen::Vector3d Etx2 = E.transpose() * x2_;
    const double numerator = x2_.dot(Ex1);
    // The tiny constant keeps the square root differentiable when a point
    // lies on the epipole (a numerical guard, far below any residual that
    // matters).
    const double squared_denominator = Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) +
                                       Etx2(0) * Etx2(0) + Etx2(1) * Etx2(1) +
                                       1e-20;
    const double denominator = std::sqrt(squared_denominator);
    residuals[0] = numerator / denominator;
    if (jacobians == nullptr) return true;

    // dr/dE = x2 x1^T / s - n / s^3 * ([Ex1_x, Ex1_y, 0] x1^T
    //                                  + x2 [Etx2_x, Etx2_y, 0]).
    const Eigen::Vector3d Ex1_xy(Ex1(0), Ex1(1), 0);
    const Eigen::Vector3d Etx2_xy(Etx2(0), Etx2(1), 0);
    const double factor = numerator / (squared_denominator * denominator);
    const Eigen::Matrix3d dr_dE =
        x2_ * x1_.transpose() / denominator -
        factor * (Ex1_xy * x1_.transpose() + x2_ * Etx2_xy.transpose());

    if (jacobians[0] != nullptr) {
      // dE = [t]x dR, so dr/dR = [t]x^T dr/dE; dR/dq_k = (dS/dq_k - 2 q_k R)
      // / |q|^2.
      const Eigen::Matrix3d dr_dR = t_cross.transpose() * dr_dE;
      const double dr_dR_dot_R = dr_dR.cwiseProduct(R).sum();
      Eigen::Matrix3d dS;
      const auto dr_dq = [&](double q_k) {
        return (2 * dr_dR.cwiseProduct(dS).sum() - 2 * q_k * dr_dR_dot_R) /
               squared_norm;
      };
      // dS/dq_k / 2 for q_k = w, x, y, z.
      dS << w, -z, y, z, w, -x, -y, x, w;
      jacobians[0][0] = dr_dq(w);
      dS << x, y, z, y, -x, -w, z, w, -x;
      jacobians[0][1] = dr_dq(x);
      dS << -y, x, w, x, y, z, -w, z, -y;
      jacobians[0][2] = dr_dq(y);
      dS << -z, -w, x, w, -z, y, x, y, z;
      jacobians[0][3] = dr_dq(z);
    }
    if (jacobians[1] != nullptr) {
      // dE = [dt]x R: dr/dt_k = <M, [e_k]x> with M = dr/dE R^T.
      const Eigen::Matrix3d M = dr_dE * R.transpose();
      jacobians[1][0] = M(2, 1) - M(1, 2);
      jacobians[1][1] = M(0, 2) - M(2, 0);
      jacobians[1][2] = M(1, 0) - M(0, 1);
    }
    return true;
  }

 private:
  const Eigen::Vector3d x1_;
  const Eigen::Vector3d x2_;
};

}  // namespace glomap
