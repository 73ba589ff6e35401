#include "glomap/estimators/point_refinement.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "base/camera_models.h"
#include "base/cost_functions.h"
#include "base/pose.h"
#include "base/projection.h"
#include "base/reconstruction.h"

namespace glomap {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

// Cameras on an arc looking at a cloud of points around the origin; one
// camera per model in `models` (cycled), each with some distortion; every
// point seen by every camera, its keypoints its projections plus Gaussian
// noise of `noise_px`.
struct Scene {
  colmap::Reconstruction reconstruction;
  std::vector<colmap::point3D_t> point3D_ids;
  std::vector<Eigen::Vector3d> true_points;
};

Scene MakeScene(const std::vector<std::string>& models, int num_images,
                int num_points, double noise_px, int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Scene scene;
  for (int i = 0; i < num_images; ++i) {
    colmap::Camera camera;
    camera.SetCameraId(i + 1);
    camera.InitializeWithName(models[i % models.size()], 700 + 20 * i, kWidth,
                              kHeight);
    const std::vector<size_t> extra = camera.ExtraParamsIdxs();
    for (size_t k = 0; k < extra.size(); ++k) {
      camera.Params(extra[k]) = (k == 0 ? 0.05 : 0.01) * (i % 2 ? 1 : -1);
    }
    scene.reconstruction.AddCamera(camera);

    const double angle = -0.6 + 1.2 * i / std::max(1, num_images - 1);
    const Eigen::Vector3d center(8 * std::sin(angle), 0.5 * (i % 3),
                                 -8 * std::cos(angle));
    // Looks at the origin: z axis along -center.
    const Eigen::Vector3d z = -center.normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d rotation;
    rotation << x.transpose(), y.transpose(), z.transpose();
    colmap::Image image;
    image.SetImageId(i + 1);
    image.SetCameraId(i + 1);
    image.SetName("image" + std::to_string(i));
    image.SetQvec(colmap::RotationMatrixToQuaternion(rotation));
    image.SetTvec(-rotation * center);
    image.SetPoints2D(
        std::vector<Eigen::Vector2d>(num_points, Eigen::Vector2d::Zero()));
    scene.reconstruction.AddImage(image);
    scene.reconstruction.RegisterImage(i + 1);
  }
  for (int p = 0; p < num_points; ++p) {
    const Eigen::Vector3d xyz(normal(rng), normal(rng), normal(rng));
    colmap::Track track;
    for (int i = 0; i < num_images; ++i) {
      colmap::Image& image = scene.reconstruction.Image(i + 1);
      const colmap::Camera& camera = scene.reconstruction.Camera(i + 1);
      const Eigen::Vector2d projection =
          colmap::ProjectPointToImage(xyz, image.ProjectionMatrix(), camera);
      image.Point2D(p).SetXY(
          projection + noise_px * Eigen::Vector2d(normal(rng), normal(rng)));
      track.AddElement(i + 1, p);
    }
    scene.point3D_ids.push_back(scene.reconstruction.AddPoint3D(xyz, track));
    scene.true_points.push_back(xyz);
  }
  return scene;
}

void Perturb(double sigma, int seed, Scene* scene) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  for (const colmap::point3D_t id : scene->point3D_ids) {
    colmap::Point3D& point3D = scene->reconstruction.Point3D(id);
    point3D.SetXYZ(point3D.XYZ() +
                   Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
  }
}

const std::vector<std::string> kModels = {
    "SIMPLE_RADIAL", "OPENCV", "OPENCV_FISHEYE", "PINHOLE", "FULL_OPENCV"};

TEST(PointRefinement, NoiselessKeypointsBringEveryPointBack) {
  Scene scene = MakeScene(kModels, 5, 200, /*noise_px=*/0, /*seed=*/1);
  Perturb(0.05, 2, &scene);
  PointRefinementOptions options;
  options.max_num_iterations = 50;
  options.function_tolerance = 0;
  options.parameter_tolerance = 0;
  PointRefinementSummary summary;
  ASSERT_TRUE(RefinePointsWithFixedPoses(options, {}, &scene.reconstruction, {},
                                         &summary)
                  .ok());
  EXPECT_EQ(summary.num_points, 200u);
  EXPECT_EQ(summary.num_observations, 1000u);
  EXPECT_GT(summary.initial_cost, 100.0);
  EXPECT_LT(summary.final_cost, 1e-12);
  for (size_t p = 0; p < scene.point3D_ids.size(); ++p) {
    EXPECT_LT((scene.reconstruction.Point3D(scene.point3D_ids[p]).XYZ() -
               scene.true_points[p])
                  .norm(),
              1e-8)
        << p;
  }
}

// With noisy keypoints the optimum is not the true point: each refined
// point must be the one Ceres finds for the same least-squares problem
// with COLMAP's structure-only cost function.
TEST(PointRefinement, ReachesTheOptimumCeresFindsWithColmapsCostFunction) {
  Scene scene =
      MakeScene({"SIMPLE_RADIAL", "OPENCV"}, 4, 100, /*noise_px=*/1, 3);
  Perturb(0.02, 4, &scene);
  colmap::Reconstruction expected = scene.reconstruction;
  for (const colmap::point3D_t id : scene.point3D_ids) {
    colmap::Point3D& point3D = expected.Point3D(id);
    ceres::Problem problem;
    for (const colmap::TrackElement& element : point3D.Track().Elements()) {
      const colmap::Image& image = expected.Image(element.image_id);
      colmap::Camera& camera = expected.Camera(image.CameraId());
      const Eigen::Vector2d xy = image.Point2D(element.point2D_idx).XY();
      ceres::CostFunction* cost_function = nullptr;
      if (camera.ModelName() == "SIMPLE_RADIAL") {
        cost_function = colmap::BundleAdjustmentConstantPoseCostFunction<
            colmap::SimpleRadialCameraModel>::Create(image.Qvec(), image.Tvec(),
                                                     xy);
      } else {
        cost_function = colmap::BundleAdjustmentConstantPoseCostFunction<
            colmap::OpenCVCameraModel>::Create(image.Qvec(), image.Tvec(), xy);
      }
      problem.AddResidualBlock(cost_function, nullptr, point3D.XYZ().data(),
                               camera.ParamsData());
      problem.SetParameterBlockConstant(camera.ParamsData());
    }
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.function_tolerance = 1e-14;
    solver_options.gradient_tolerance = 1e-14;
    solver_options.parameter_tolerance = 1e-14;
    solver_options.max_num_iterations = 100;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
  }
  PointRefinementOptions options;
  options.num_threads = 1;
  ASSERT_TRUE(
      RefinePointsWithFixedPoses(options, {}, &scene.reconstruction).ok());
  for (const colmap::point3D_t id : scene.point3D_ids) {
    EXPECT_LT(
        (scene.reconstruction.Point3D(id).XYZ() - expected.Point3D(id).XYZ())
            .norm(),
        1e-5)
        << id;
  }
}

TEST(PointRefinement, OnlyTheGivenPointsMoveAndNothingElseChanges) {
  Scene scene = MakeScene(kModels, 5, 50, /*noise_px=*/0.5, 5);
  Perturb(0.05, 6, &scene);
  const colmap::Reconstruction before = scene.reconstruction;
  const std::vector<colmap::point3D_t> subset = {scene.point3D_ids[3],
                                                 scene.point3D_ids[17]};
  PointRefinementSummary summary;
  ASSERT_TRUE(RefinePointsWithFixedPoses({}, subset, &scene.reconstruction, {},
                                         &summary)
                  .ok());
  EXPECT_EQ(summary.num_points, 2u);
  EXPECT_LT(summary.final_cost, summary.initial_cost);
  for (const colmap::point3D_t id : scene.point3D_ids) {
    const bool in_subset = id == subset[0] || id == subset[1];
    const double moved =
        (scene.reconstruction.Point3D(id).XYZ() - before.Point3D(id).XYZ())
            .norm();
    if (in_subset) {
      EXPECT_GT(moved, 1e-3) << id;
    } else {
      EXPECT_EQ(moved, 0) << id;
    }
    EXPECT_EQ(scene.reconstruction.Point3D(id).Track().Length(),
              before.Point3D(id).Track().Length());
  }
  for (const auto& [image_id, image] : before.Images()) {
    EXPECT_EQ(scene.reconstruction.Image(image_id).Qvec(), image.Qvec());
    EXPECT_EQ(scene.reconstruction.Image(image_id).Tvec(), image.Tvec());
  }
  for (const auto& [camera_id, camera] : before.Cameras()) {
    EXPECT_EQ(scene.reconstruction.Camera(camera_id).Params(), camera.Params());
  }
}

// No step may carry a point behind a camera, and a point that starts
// behind one stays where it is.
TEST(PointRefinement, PointsStayInFrontOfTheirCameras) {
  Scene scene = MakeScene({"SIMPLE_RADIAL"}, 3, 20, /*noise_px=*/0, 7);
  // Every keypoint of point 0 is far off the image: its optimum lies
  // beyond the cameras' centre planes, which the solve must not cross.
  for (int i = 0; i < 3; ++i) {
    scene.reconstruction.Image(i + 1).Point2D(0).SetXY(
        Eigen::Vector2d(1e6, -1e6));
  }
  const colmap::point3D_t behind = scene.point3D_ids[1];
  const colmap::Image& image1 = scene.reconstruction.Image(1);
  const Eigen::Vector3d center1 = image1.ProjectionCenter();
  // Point 1 moved behind camera 1.
  const Eigen::Vector3d behind_xyz = center1 - 2 * image1.ViewingDirection();
  scene.reconstruction.Point3D(behind).SetXYZ(behind_xyz);
  ASSERT_TRUE(RefinePointsWithFixedPoses({}, {}, &scene.reconstruction).ok());
  EXPECT_EQ(scene.reconstruction.Point3D(behind).XYZ(), behind_xyz);
  const Eigen::Vector3d xyz0 =
      scene.reconstruction.Point3D(scene.point3D_ids[0]).XYZ();
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(colmap::HasPointPositiveDepth(
        scene.reconstruction.Image(i + 1).ProjectionMatrix(), xyz0))
        << i;
  }
}

// With a soft-L1 loss a wrong keypoint pulls its point far less than under
// least squares.
TEST(PointRefinement, RobustLossDiscountsAWrongObservation) {
  Scene least_squares = MakeScene(kModels, 6, 100, /*noise_px=*/0.3, 12);
  for (size_t p = 0; p < least_squares.point3D_ids.size(); ++p) {
    colmap::Point2D& wrong = least_squares.reconstruction.Image(1).Point2D(p);
    wrong.SetXY(wrong.XY() + Eigen::Vector2d(40, -30));
  }
  Perturb(0.02, 13, &least_squares);
  Scene robust = least_squares;
  PointRefinementOptions options;
  options.max_num_iterations = 50;
  ASSERT_TRUE(
      RefinePointsWithFixedPoses(options, {}, &least_squares.reconstruction)
          .ok());
  options.loss_scale_px = 1;
  ASSERT_TRUE(
      RefinePointsWithFixedPoses(options, {}, &robust.reconstruction).ok());
  double least_squares_error = 0;
  double robust_error = 0;
  for (size_t p = 0; p < robust.point3D_ids.size(); ++p) {
    const Eigen::Vector3d& truth = robust.true_points[p];
    least_squares_error +=
        (least_squares.reconstruction.Point3D(robust.point3D_ids[p]).XYZ() -
         truth)
            .norm();
    robust_error +=
        (robust.reconstruction.Point3D(robust.point3D_ids[p]).XYZ() - truth)
            .norm();
  }
  std::cout << "mean point error: least squares "
            << least_squares_error / robust.point3D_ids.size() << ", soft-L1 "
            << robust_error / robust.point3D_ids.size() << std::endl;
  EXPECT_LT(robust_error, 0.3 * least_squares_error);
}

TEST(PointRefinement, SameModelWithAnyNumberOfThreads) {
  Scene one = MakeScene(kModels, 5, 3000, /*noise_px=*/1, 8);
  Perturb(0.05, 9, &one);
  Scene two = one;
  PointRefinementOptions options;
  options.num_threads = 1;
  ASSERT_TRUE(
      RefinePointsWithFixedPoses(options, {}, &one.reconstruction).ok());
  options.num_threads = 2;
  ASSERT_TRUE(
      RefinePointsWithFixedPoses(options, {}, &two.reconstruction).ok());
  for (const colmap::point3D_t id : one.point3D_ids) {
    EXPECT_EQ(one.reconstruction.Point3D(id).XYZ(),
              two.reconstruction.Point3D(id).XYZ());
  }
}

TEST(PointRefinement, BadInputAndCancel) {
  Scene scene = MakeScene({"SIMPLE_RADIAL"}, 3, 2000, /*noise_px=*/1, 10);
  Perturb(0.05, 11, &scene);
  EXPECT_FALSE(RefinePointsWithFixedPoses({}, {}, nullptr).ok());
  PointRefinementOptions bad;
  bad.max_num_iterations = 0;
  const Status status =
      RefinePointsWithFixedPoses(bad, {}, &scene.reconstruction);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("max_num_iterations"), std::string::npos);

  const colmap::Reconstruction before = scene.reconstruction;
  Interrupt stopped;
  stopped.is_stopped = []() { return true; };
  EXPECT_TRUE(RefinePointsWithFixedPoses({}, {}, &scene.reconstruction, stopped)
                  .cancelled());
  for (const colmap::point3D_t id : scene.point3D_ids) {
    EXPECT_EQ(scene.reconstruction.Point3D(id).XYZ(), before.Point3D(id).XYZ());
  }
}

}  // namespace
}  // namespace glomap
