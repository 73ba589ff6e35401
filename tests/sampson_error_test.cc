#include "glomap/estimators/cost_functions/sampson_error.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>

namespace glomap {
namespace {

// The same residual written once more with automatic differentiation, as
// the relative-pose refinement had it: the reference for the analytic
// Jacobians.
struct AutoDiffSampson {
  template <typename T>
  bool operator()(const T* const qvec, const T* const tvec, T* residual) const {
    Eigen::Matrix<T, 3, 3, Eigen::RowMajor> R;
    ceres::QuaternionToRotation(qvec, R.data());
    Eigen::Matrix<T, 3, 3> t_cross;
    t_cross << T(0), -tvec[2], tvec[1], tvec[2], T(0), -tvec[0], -tvec[1],
        tvec[0], T(0);
    const Eigen::Matrix<T, 3, 3> E = t_cross * R;
    const Eigen::Matrix<T, 3, 1> x1_h(T(x1(0)), T(x1(1)), T(1));
    const Eigen::Matrix<T, 3, 1> x2_h(T(x2(0)), T(x2(1)), T(1));
    const Eigen::Matrix<T, 3, 1> Ex1 = E * x1_h;
    const Eigen::Matrix<T, 3, 1> Etx2 = E.transpose() * x2_h;
    residual[0] = x2_h.dot(Ex1) /
                  ceres::sqrt(Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) +
                              Etx2(0) * Etx2(0) + Etx2(1) * Etx2(1) + T(1e-20));
    return true;
  }
  Eigen::Vector2d x1;
  Eigen::Vector2d x2;
};

struct Evaluation {
  double residual = 0;
  Eigen::Matrix<double, 1, 4> d_q;
  Eigen::Matrix<double, 1, 3> d_t;
};

Evaluation Evaluate(const ceres::CostFunction& cost, const double* q,
                    const double* t) {
  Evaluation e;
  const double* parameters[2] = {q, t};
  double* jacobians[2] = {e.d_q.data(), e.d_t.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, &e.residual, jacobians));
  return e;
}

// Analytic and automatic derivatives agree for random poses (quaternions of
// any norm, as during a solve before the manifold renormalises), baselines
// and correspondences, near and far from the epipolar line.
TEST(SampsonErrorCost, MatchesAutomaticDifferentiation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int num_checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const double q[4] = {1.5 * uniform(rng), uniform(rng), uniform(rng),
                         uniform(rng)};
    const double t[3] = {uniform(rng), uniform(rng), uniform(rng)};
    AutoDiffSampson* functor = new AutoDiffSampson;
    functor->x1 = Eigen::Vector2d(uniform(rng), uniform(rng));
    functor->x2 = Eigen::Vector2d(uniform(rng), uniform(rng));
    const SampsonErrorCost analytic(functor->x1, functor->x2);
    const ceres::AutoDiffCostFunction<AutoDiffSampson, 1, 4, 3> automatic(
        functor);
    const Evaluation a = Evaluate(analytic, q, t);
    const Evaluation b = Evaluate(automatic, q, t);
    EXPECT_NEAR(a.residual, b.residual, 1e-12 * (1 + std::abs(b.residual)));
    const double scale = 1 + b.d_q.norm() + b.d_t.norm();
    EXPECT_LT((a.d_q - b.d_q).norm(), 1e-10 * scale)
        << "trial " << trial << ": " << a.d_q << " vs " << b.d_q;
    EXPECT_LT((a.d_t - b.d_t).norm(), 1e-10 * scale)
        << "trial " << trial << ": " << a.d_t << " vs " << b.d_t;
    ++num_checked;
  }
  EXPECT_EQ(num_checked, 200);
}

// A correspondence that fits the pose has zero residual; moving the second
// point off its epipolar line by d (normalised units) gives about d.
TEST(SampsonErrorCost, MeasuresTheDistanceToTheEpipolarLine) {
  const Eigen::Quaterniond rotation(
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1, -0.2).normalized()));
  const Eigen::Vector3d t(1, 0.1, -0.05);
  const Eigen::Vector3d point_in_cam1(0.3, -0.2, 4.0);
  const Eigen::Vector3d point_in_cam2 = rotation * point_in_cam1 + t;
  const Eigen::Vector2d x1 = point_in_cam1.hnormalized();
  const Eigen::Vector2d x2 = point_in_cam2.hnormalized();
  const double q[4] = {rotation.w(), rotation.x(), rotation.y(), rotation.z()};
  const double* parameters[2] = {q, t.data()};
  double residual = 1;
  ASSERT_TRUE(
      SampsonErrorCost(x1, x2).Evaluate(parameters, &residual, nullptr));
  EXPECT_NEAR(residual, 0, 1e-12);
  // The epipolar line of x1 in image 2 and its unit normal.
  const Eigen::Matrix3d E =
      colmap::CrossProductMatrix(t) * rotation.toRotationMatrix();
  const Eigen::Vector3d line = E * x1.homogeneous();
  const Eigen::Vector2d normal = line.head<2>().normalized();
  const double offset = 1e-3;
  ASSERT_TRUE(SampsonErrorCost(x1, x2 + offset * normal)
                  .Evaluate(parameters, &residual, nullptr));
  // Sampson's first-order distance splits the error between both images,
  // so it is below the one-image distance but of its size.
  EXPECT_GT(std::abs(residual), 0.5 * offset);
  EXPECT_LT(std::abs(residual), 1.01 * offset);
}

}  // namespace
}  // namespace glomap
