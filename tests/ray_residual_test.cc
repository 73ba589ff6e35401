#include "glomap/estimators/cost_functions/ray_residual.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <random>

namespace glomap {
namespace {

using RowMajor3x3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

struct Evaluation {
  Eigen::Vector3d residual;
  RowMajor3x3 d_center;
  RowMajor3x3 d_point;
};

Evaluation Evaluate(const ceres::CostFunction& cost,
                    const Eigen::Vector3d& center,
                    const Eigen::Vector3d& point) {
  Evaluation e;
  const double* parameters[2] = {center.data(), point.data()};
  double* jacobians[2] = {e.d_center.data(), e.d_point.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, e.residual.data(), jacobians));
  return e;
}

Eigen::Vector3d ResidualOnly(const ceres::CostFunction& cost,
                             const Eigen::Vector3d& center,
                             const Eigen::Vector3d& point) {
  Eigen::Vector3d residual;
  const double* parameters[2] = {center.data(), point.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, residual.data(), nullptr));
  return residual;
}

Eigen::Vector3d RandomUnit(std::mt19937* rng) {
  std::normal_distribution<double> normal(0, 1);
  Eigen::Vector3d v(normal(*rng), normal(*rng), normal(*rng));
  return v.normalized();
}

// The projected residual is the joint one at the best scale: its value is
// RayResidual's with d = BestRayScale, and where that scale is not clamped
// its norm is the sine of the angle between the observed ray and X - c.
TEST(ProjectedRayResidual, IsTheRayResidualAtTheBestScale) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-5, 5);
  const double min_scale = 1e-3;
  int num_unclamped = 0;
  int num_clamped = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector3d ray = RandomUnit(&rng);
    const Eigen::Vector3d center(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector3d point(uniform(rng), uniform(rng), uniform(rng));
    const ProjectedRayResidual projected(ray, min_scale);
    const RayResidual joint(ray);
    double scale = BestRayScale(ray, point - center, min_scale);
    Eigen::Vector3d joint_residual;
    const double* joint_parameters[3] = {center.data(), point.data(), &scale};
    ASSERT_TRUE(
        joint.Evaluate(joint_parameters, joint_residual.data(), nullptr));
    const Eigen::Vector3d residual = ResidualOnly(projected, center, point);
    EXPECT_LT((residual - joint_residual).norm(), 1e-12);
    const Eigen::Vector3d diff = point - center;
    if (scale > min_scale) {
      ++num_unclamped;
      const double sine = ray.cross(diff.normalized()).norm();
      EXPECT_NEAR(residual.norm(), sine, 1e-12);
      EXPECT_NEAR(residual.dot(diff), 0, 1e-12);
    } else {
      ++num_clamped;
      EXPECT_LT(ray.dot(diff), min_scale * diff.squaredNorm() + 1e-15);
    }
  }
  EXPECT_GT(num_unclamped, 100);
  EXPECT_GT(num_clamped, 100);
}

// The analytic Jacobians, which carry the derivative of the projected scale,
// agree with central differences, on both sides of the clamp.
TEST(ProjectedRayResidual, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uniform(-5, 5);
  const double min_scale = 1e-3;
  const double step = 1e-6;
  int num_checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d ray = RandomUnit(&rng);
    const Eigen::Vector3d center(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector3d point(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector3d diff = point - center;
    // Central differences are not exact across the clamp's kink.
    if (std::abs(ray.dot(diff) - min_scale * diff.squaredNorm()) < 1e-3) {
      continue;
    }
    const ProjectedRayResidual cost(ray, min_scale);
    const Evaluation e = Evaluate(cost, center, point);
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d delta = step * Eigen::Vector3d::Unit(axis);
      const Eigen::Vector3d d_center =
          (ResidualOnly(cost, center + delta, point) -
           ResidualOnly(cost, center - delta, point)) /
          (2 * step);
      const Eigen::Vector3d d_point =
          (ResidualOnly(cost, center, point + delta) -
           ResidualOnly(cost, center, point - delta)) /
          (2 * step);
      EXPECT_LT((e.d_center.col(axis) - d_center).norm(), 1e-6)
          << "trial " << trial << " axis " << axis;
      EXPECT_LT((e.d_point.col(axis) - d_point).norm(), 1e-6)
          << "trial " << trial << " axis " << axis;
    }
    ++num_checked;
  }
  EXPECT_GT(num_checked, 250);
}

// Moving the point along the observed ray from the camera leaves a zero
// residual whatever the distance: the objective depends on directions only.
TEST(ProjectedRayResidual, ZeroAlongTheRayAtAnyDistance) {
  const Eigen::Vector3d ray = Eigen::Vector3d(1, 2, 2) / 3;
  const Eigen::Vector3d center(0.5, -1, 2);
  const ProjectedRayResidual cost(ray, 1e-5);
  for (const double distance : {0.01, 1.0, 100.0, 1e4}) {
    EXPECT_LT(ResidualOnly(cost, center, center + distance * ray).norm(),
              1e-12);
  }
  // Behind the camera the scale is clamped and the residual is about the
  // whole ray.
  EXPECT_GT(ResidualOnly(cost, center, center - ray).norm(), 0.99);
}

}  // namespace
}  // namespace glomap
