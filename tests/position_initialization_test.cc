#include "glomap/estimators/position_initialization.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "base/pose.h"
#include "base/similarity_transform.h"
#include "tests/support/camera_rotation.h"
#include "tests/support/center_error.h"

namespace glomap {
namespace {

// Registered images with true rotations and zero translations (as rotation
// averaging leaves them), and a view graph whose pairs hold the true
// relative poses.
struct Scene {
  colmap::Reconstruction reconstruction;
  ViewGraph view_graph;
  std::vector<Eigen::Vector3d> true_centers;
};

// World-from-camera rotation looking along `forward`, image y roughly along
// world +y.
Eigen::Matrix3d Looking(const Eigen::Vector3d& forward) {
  return testing::CamFromWorldLookingAlong(forward, -Eigen::Vector3d::UnitY())
      .transpose();
}

void AddPair(Scene* scene, int i, int j, int num_matches,
             bool reversed = false) {
  const colmap::Image& image1 = scene->reconstruction.Image(i + 1);
  const colmap::Image& image2 = scene->reconstruction.Image(j + 1);
  ImagePair pair;
  pair.image_id1 = i + 1;
  pair.image_id2 = j + 1;
  const Eigen::Matrix3d rotation2_from_1 =
      image2.RotationMatrix() * image1.RotationMatrix().transpose();
  pair.qvec2_from_1 = colmap::RotationMatrixToQuaternion(rotation2_from_1);
  // The first centre seen from the second camera.
  pair.tvec2_from_1 = (image2.RotationMatrix() *
                       (scene->true_centers[i] - scene->true_centers[j]))
                          .normalized();
  if (reversed) pair.tvec2_from_1 *= -1;
  pair.has_relative_pose = true;
  pair.matches.resize(num_matches);
  scene->view_graph.AddPair(pair);
}

Scene MakeScene(const std::vector<Eigen::Vector3d>& centers,
                const std::vector<Eigen::Matrix3d>& world_from_cams) {
  Scene scene;
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_PINHOLE", 500, 640, 480);
  scene.reconstruction.AddCamera(camera);
  for (size_t i = 0; i < centers.size(); ++i) {
    colmap::Image image;
    image.SetImageId(i + 1);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(i + 1));
    image.SetQvec(
        colmap::RotationMatrixToQuaternion(world_from_cams[i].transpose()));
    image.SetTvec(Eigen::Vector3d::Zero());
    scene.reconstruction.AddImage(image);
    scene.reconstruction.RegisterImage(i + 1);
  }
  scene.true_centers = centers;
  return scene;
}

// A car on a winding road (1 m per frame, looking ahead), each image paired
// with its next `num_neighbors` images; nearer pairs have more matches.
Scene MakeStreet(int num_images, int num_neighbors) {
  std::vector<Eigen::Vector3d> centers;
  std::vector<Eigen::Matrix3d> rotations;
  for (int i = 0; i < num_images; ++i) {
    const double s = i;
    centers.emplace_back(20 * std::sin(s / 40), 0.2 * std::sin(s / 7), s);
    const Eigen::Vector3d ahead(std::cos(s / 40) / 2, 0, 1);
    rotations.push_back(Looking(ahead));
  }
  Scene scene = MakeScene(centers, rotations);
  for (int i = 0; i < num_images; ++i) {
    for (int j = i + 1; j <= i + num_neighbors && j < num_images; ++j) {
      AddPair(&scene, i, j, 1000 / (j - i));
    }
  }
  return scene;
}

// testing::RelativeCenterError over every image.
double RelativeCenterError(const Scene& scene) {
  std::vector<Eigen::Vector3d> estimated;
  for (size_t i = 0; i < scene.true_centers.size(); ++i) {
    estimated.push_back(scene.reconstruction.Image(i + 1).ProjectionCenter());
  }
  return testing::RelativeCenterError(estimated, scene.true_centers);
}

// Fraction of the images i whose estimated order along the street relative
// to image i + stride (the true direction of travel, after the similarity)
// is reversed.
double ReversedStepFraction(const Scene& scene, size_t stride) {
  std::vector<Eigen::Vector3d> estimated;
  for (size_t i = 0; i < scene.true_centers.size(); ++i) {
    estimated.push_back(scene.reconstruction.Image(i + 1).ProjectionCenter());
  }
  colmap::SimilarityTransform3 transform;
  EXPECT_TRUE(transform.Estimate(estimated, scene.true_centers));
  for (Eigen::Vector3d& center : estimated) transform.TransformPoint(&center);
  size_t num_reversed = 0;
  for (size_t i = 0; i + stride < estimated.size(); ++i) {
    const Eigen::Vector3d travel =
        scene.true_centers[i + stride] - scene.true_centers[i];
    num_reversed += travel.dot(estimated[i + stride] - estimated[i]) <= 0;
  }
  return static_cast<double>(num_reversed) / (estimated.size() - stride);
}

TEST(InitializeCameraCenters, WindingStreetFromExactDirections) {
  Scene scene = MakeStreet(300, 6);
  const Eigen::Vector4d qvec7 = scene.reconstruction.Image(7).Qvec();
  size_t num_placed = 0;
  ASSERT_TRUE(InitializeCameraCenters({}, scene.view_graph,
                                      &scene.reconstruction, {}, &num_placed)
                  .ok());
  EXPECT_EQ(num_placed, 300);
  // The road bends, so the directions fix the layout up to a similarity.
  EXPECT_LT(RelativeCenterError(scene), 1e-3);
  EXPECT_EQ(ReversedStepFraction(scene, 1), 0);
  // Rotations are kept.
  EXPECT_EQ(scene.reconstruction.Image(7).Qvec(), qvec7);
}

TEST(InitializeCameraCenters, WrongDirectionsOnTheSpanningTreeAreOutvoted) {
  // Every 25th image's pair to the next image has its direction reversed
  // and the most matches of all, so the spanning tree walks it and starts
  // the rest of the street backwards from there; the other pairs must turn
  // it around. (Whether the two images of such a pair are in the right
  // order, only that pair says on a nearly straight road: their other
  // pairs hold either order between their neighbours, and the points of
  // global positioning decide it. So the order is checked over 3 images.)
  Scene scene = MakeStreet(300, 6);
  for (auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (pair.image_id2 == pair.image_id1 + 1 && pair.image_id1 % 25 == 0) {
      pair.tvec2_from_1 *= -1;
      pair.matches.resize(5000);
    }
  }
  ASSERT_TRUE(
      InitializeCameraCenters({}, scene.view_graph, &scene.reconstruction)
          .ok());
  EXPECT_LT(RelativeCenterError(scene), 1e-2);
  EXPECT_EQ(ReversedStepFraction(scene, 3), 0);
}

TEST(InitializeCameraCenters, SurveyGridWithRandomWrongPairs) {
  // A 15 x 15 nadir grid, each image paired with its 8 neighbours; 10% of
  // the pairs get a random direction.
  std::vector<Eigen::Vector3d> centers;
  std::vector<Eigen::Matrix3d> rotations;
  for (int y = 0; y < 15; ++y) {
    for (int x = 0; x < 15; ++x) {
      centers.emplace_back(x, y, 0.05 * ((x * 7 + y * 3) % 5));
      rotations.push_back(Looking(Eigen::Vector3d(0.01 * x, 0.01 * y, 1)));
    }
  }
  Scene scene = MakeScene(centers, rotations);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  int num_wrong = 0;
  for (int i = 0; i < 225; ++i) {
    for (int j = i + 1; j < 225; ++j) {
      if (std::abs(i % 15 - j % 15) > 1 || std::abs(i / 15 - j / 15) > 1) {
        continue;
      }
      AddPair(&scene, i, j, 500);
    }
  }
  int pair_index = 0;
  for (auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (pair_index++ % 10 != 3) continue;
    pair.tvec2_from_1 =
        Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    ++num_wrong;
  }
  ASSERT_GT(num_wrong, 50);
  ASSERT_TRUE(
      InitializeCameraCenters({}, scene.view_graph, &scene.reconstruction)
          .ok());
  EXPECT_LT(RelativeCenterError(scene), 0.01);
}

TEST(InitializeCameraCenters, ImagesWithoutUsablePairsKeepTheirPose) {
  Scene scene = MakeStreet(30, 3);
  // Image 30: its pairs lose their relative pose or are invalid.
  for (auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (pair.image_id2 == 30) {
      if (pair.image_id1 % 2 == 0) {
        pair.has_relative_pose = false;
      } else {
        pair.is_valid = false;
      }
    }
  }
  // Image 29 is not registered.
  scene.reconstruction.DeRegisterImage(29);
  scene.reconstruction.Image(30).SetTvec(Eigen::Vector3d(1, 2, 3));
  size_t num_placed = 0;
  ASSERT_TRUE(InitializeCameraCenters({}, scene.view_graph,
                                      &scene.reconstruction, {}, &num_placed)
                  .ok());
  EXPECT_EQ(num_placed, 28);
  EXPECT_EQ(scene.reconstruction.Image(30).Tvec(), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(scene.reconstruction.Image(29).Tvec(), Eigen::Vector3d::Zero());
  EXPECT_NE(scene.reconstruction.Image(28).Tvec(), Eigen::Vector3d::Zero());
}

TEST(InitializeCameraCenters, ErrorsWithoutPairsOrWithBadOptions) {
  Scene scene = MakeStreet(10, 2);
  ViewGraph empty;
  const Status no_pairs =
      InitializeCameraCenters({}, empty, &scene.reconstruction);
  EXPECT_FALSE(no_pairs.ok());
  EXPECT_NE(no_pairs.message().find("no image pair"), std::string::npos);
  PositionInitializationOptions options;
  options.loss_scale = 0;
  const Status bad =
      InitializeCameraCenters(options, scene.view_graph, &scene.reconstruction);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("loss_scale"), std::string::npos);
}

TEST(InitializeCameraCenters, Deterministic) {
  Scene first = MakeStreet(120, 5);
  Scene second = MakeStreet(120, 5);
  ASSERT_TRUE(
      InitializeCameraCenters({}, first.view_graph, &first.reconstruction)
          .ok());
  ASSERT_TRUE(
      InitializeCameraCenters({}, second.view_graph, &second.reconstruction)
          .ok());
  for (colmap::image_t id = 1; id <= 120; ++id) {
    EXPECT_EQ(first.reconstruction.Image(id).Tvec(),
              second.reconstruction.Image(id).Tvec());
  }
}

}  // namespace
}  // namespace glomap
