// The model shape measures (issue 14): view spread, and the nadir block
// whose dome can hide, on blocks built by hand.
#include "glomap/processors/model_shape.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "base/pose.h"
#include "base/reconstruction.h"
#include "support/camera_rotation.h"

namespace glomap {
namespace {

// Cameras at `centers`, camera i looking along `view_directions[i]` (or
// all along the one given), each observing one point `depth` ahead of it
// (at the same keypoint).
colmap::Reconstruction MakeBlock(
    const std::vector<Eigen::Vector3d>& centers,
    const std::vector<Eigen::Vector3d>& view_directions, double depth) {
  colmap::Reconstruction model;
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_RADIAL", 500, 640, 480);
  model.AddCamera(camera);
  for (size_t i = 0; i < centers.size(); ++i) {
    const Eigen::Vector3d view_direction =
        view_directions[view_directions.size() == 1 ? 0 : i].normalized();
    // "Up" in the images: north for nadir views, else the sky.
    const Eigen::Vector3d world_up = std::abs(view_direction.z()) > 0.9
                                         ? Eigen::Vector3d::UnitY()
                                         : Eigen::Vector3d::UnitZ();
    const Eigen::Matrix3d cam_from_world =
        testing::CamFromWorldLookingAlong(view_direction, world_up);
    colmap::Image image;
    image.SetImageId(i + 1);
    image.SetName("image" + std::to_string(i + 1));
    image.SetCameraId(1);
    image.SetQvec(colmap::RotationMatrixToQuaternion(cam_from_world));
    image.SetTvec(-cam_from_world * centers[i]);
    image.SetPoints2D({Eigen::Vector2d(320, 240)});
    model.AddImage(image);
    model.RegisterImage(i + 1);
    colmap::Track track;
    track.AddElement(i + 1, 0);
    model.AddPoint3D(centers[i] + depth * view_direction, track);
  }
  return model;
}

// An aerial survey: 10 x 10 cameras over 400 m x 300 m, 40 m above the
// ground, looking straight down.
TEST(MeasureNadirBlock, AerialSurveyIsAWideNadirBlock) {
  std::vector<Eigen::Vector3d> centers;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) {
      centers.emplace_back(400.0 * i / 9, 300.0 * j / 9, 40);
    }
  }
  const NadirBlockShape shape =
      MeasureNadirBlock(MakeBlock(centers, {Eigen::Vector3d(0, 0, -1)}, 40));
  EXPECT_NEAR(shape.view_spread_deg, 0, 1e-6);
  EXPECT_NEAR(shape.view_to_plane_normal_deg, 0, 1e-6);
  EXPECT_NEAR(shape.height, 40, 1e-9);
  // Twice the standard deviation of 10 equally spaced values over 300 m
  // (of 0, 1, ..., 9: (10^2 - 1) / 12).
  EXPECT_NEAR(shape.width, 2 * 300 * std::sqrt(99.0 / 12) / 9, 1e-6);
  EXPECT_NEAR(shape.WidthOverHeight(), shape.width / 40, 1e-12);
  EXPECT_GT(shape.WidthOverHeight(), 4);
}

// A street: cameras along a line, looking along it. Not a block at all.
TEST(MeasureNadirBlock, ForwardStreetIsNotANadirBlock) {
  std::vector<Eigen::Vector3d> centers;
  for (int i = 0; i < 100; ++i) {
    centers.emplace_back(5.0 * i, 0.3 * std::sin(0.1 * i), 1.5);
  }
  const NadirBlockShape shape =
      MeasureNadirBlock(MakeBlock(centers, {Eigen::Vector3d(1, 0, 0)}, 20));
  EXPECT_NEAR(shape.view_spread_deg, 0, 1e-6);
  EXPECT_GT(shape.view_to_plane_normal_deg, 80);
  EXPECT_LT(shape.WidthOverHeight(), 0.1);
}

// Cameras around an object look in every direction.
TEST(ViewDirectionSpreadDeg, RingLooksEveryWay) {
  std::vector<Eigen::Vector3d> centers;
  std::vector<Eigen::Vector3d> view_directions;
  for (int i = 0; i < 36; ++i) {
    const double angle = 2 * M_PI * i / 36;
    centers.emplace_back(std::cos(angle), std::sin(angle), 0);
    view_directions.push_back(-centers.back());
  }
  const colmap::Reconstruction model = MakeBlock(centers, view_directions, 1);
  // Every axis is about 90 deg from any mean direction.
  EXPECT_GT(ViewDirectionSpreadDeg(model), 80);
  EXPECT_GT(MeasureNadirBlock(model).view_spread_deg, 80);
  EXPECT_EQ(ViewDirectionSpreadDeg(colmap::Reconstruction()), 180);
}

TEST(MeasureNadirBlock, TooFewImagesAreNoBlock) {
  const NadirBlockShape shape = MeasureNadirBlock(
      MakeBlock({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(100, 0, 0)},
                {Eigen::Vector3d(0, 0, -1)}, 10));
  EXPECT_EQ(shape.view_spread_deg, 180);
  EXPECT_EQ(shape.WidthOverHeight(), 0);
}

}  // namespace
}  // namespace glomap
