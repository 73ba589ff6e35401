#include "glomap/estimators/cost_functions/pose_manifold.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <random>

namespace glomap {
namespace {

using Pose = std::array<double, 7>;
using Delta = std::array<double, 6>;

// A world-to-camera pose [qw, qx, qy, qz, tx, ty, tz] with its camera centre
// at `center`, far from the origin as in a large block.
Pose MakePose(const Eigen::Quaterniond& rotation,
              const Eigen::Vector3d& center) {
  const Eigen::Quaterniond q = rotation.normalized();
  const Eigen::Vector3d t = -(q * center);
  return {q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()};
}

Eigen::Quaterniond Rotation(const Pose& pose) {
  return Eigen::Quaterniond(pose[0], pose[1], pose[2], pose[3]);
}

Eigen::Vector3d Center(const Pose& pose) {
  return -(Rotation(pose).conjugate() *
           Eigen::Vector3d(pose[4], pose[5], pose[6]));
}

Pose Plus(const Pose& x, const Delta& delta) {
  Pose result;
  EXPECT_TRUE(
      PoseAboutCenterManifold().Plus(x.data(), delta.data(), result.data()));
  return result;
}

const Eigen::Vector3d kFarCenter(420, -310, 40);

TEST(PoseAboutCenterManifold, RotationStepKeepsTheCameraCentre) {
  const Pose x = MakePose(Eigen::Quaterniond(Eigen::AngleAxisd(
                              0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                          kFarCenter);
  const Delta delta = {0.01, -0.02, 0.005, 0, 0, 0};
  const Pose y = Plus(x, delta);
  EXPECT_LT((Center(y) - kFarCenter).norm(), 1e-9);
  // The rotation changed by |delta|, about delta, in camera coordinates.
  const Eigen::Vector3d axis_angle(delta[0], delta[1], delta[2]);
  const Eigen::Quaterniond expected =
      Eigen::Quaterniond(
          Eigen::AngleAxisd(axis_angle.norm(), axis_angle.normalized())) *
      Rotation(x);
  EXPECT_LT(Rotation(y).angularDistance(expected), 1e-12);
}

TEST(PoseAboutCenterManifold, CentreStepMovesOnlyTheCentre) {
  const Pose x = MakePose(Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2), kFarCenter);
  const Pose y = Plus(x, {0, 0, 0, 0.5, -1.5, 2});
  EXPECT_LT((Center(y) - (kFarCenter + Eigen::Vector3d(0.5, -1.5, 2))).norm(),
            1e-9);
  EXPECT_LT(Rotation(y).angularDistance(Rotation(x)), 1e-12);
}

TEST(PoseAboutCenterManifold, PlusAndMinusAreInverse) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const PoseAboutCenterManifold manifold;
  for (int trial = 0; trial < 50; ++trial) {
    const Pose x = MakePose(
        Eigen::Quaterniond(uniform(rng), uniform(rng), uniform(rng),
                           uniform(rng)),
        100 * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)));
    Delta delta;
    for (int i = 0; i < 3; ++i) delta[i] = 0.5 * uniform(rng);
    for (int i = 3; i < 6; ++i) delta[i] = 10 * uniform(rng);
    const Pose y = Plus(x, delta);
    Delta back;
    ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back.data()));
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(back[i], delta[i], 1e-9) << i;
    Delta zero;
    ASSERT_TRUE(manifold.Minus(x.data(), x.data(), zero.data()));
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(zero[i], 0, 1e-12) << i;
  }
}

// The Jacobians Ceres takes from the manifold: Plus's at delta = 0 against
// central differences, and Minus's as its left inverse.
TEST(PoseAboutCenterManifold, JacobiansMatchFiniteDifferences) {
  const std::unique_ptr<ceres::Manifold> manifold(NewPoseAboutCenterManifold());
  ASSERT_EQ(manifold->AmbientSize(), 7);
  ASSERT_EQ(manifold->TangentSize(), 6);
  const Pose x = MakePose(Eigen::Quaterniond(0.7, -0.2, 0.4, 0.1), kFarCenter);
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_jacobian;
  ASSERT_TRUE(manifold->PlusJacobian(x.data(), plus_jacobian.data()));
  const double step = 1e-6;
  for (int j = 0; j < 6; ++j) {
    Delta forward{}, backward{};
    forward[j] = step;
    backward[j] = -step;
    const Pose a = Plus(x, forward);
    const Pose b = Plus(x, backward);
    for (int i = 0; i < 7; ++i) {
      EXPECT_NEAR(plus_jacobian(i, j), (a[i] - b[i]) / (2 * step),
                  1e-6 * (1 + std::abs(plus_jacobian(i, j))))
          << i << ", " << j;
    }
  }
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> minus_jacobian;
  ASSERT_TRUE(manifold->MinusJacobian(x.data(), minus_jacobian.data()));
  const Eigen::Matrix<double, 6, 6> product = minus_jacobian * plus_jacobian;
  EXPECT_LT((product - Eigen::Matrix<double, 6, 6>::Identity()).norm(), 1e-9);
}

}  // namespace
}  // namespace glomap
