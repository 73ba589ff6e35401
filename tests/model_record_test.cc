// The recorded-model comparison must see a changed model, and only that.
#include "tests/support/model_record.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

colmap::Reconstruction MakeModel(const std::string& dir) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.random_seed = 3;
  colmap::Reconstruction truth;
  EXPECT_TRUE(WriteSyntheticScene(options, dir + "/database.db", &truth).ok());
  return truth;
}

TEST(ModelRecord, SameModelMatchesAndChangesAreNamed) {
  const std::string dir = testing::CreateTestDir("model_record");
  colmap::Reconstruction model = MakeModel(dir);
  const std::string path = dir + "/record.txt";
  ASSERT_TRUE(testing::WriteModelRecord(model, "test", path).ok());
  EXPECT_TRUE(testing::CompareWithModelRecord(model, path).empty());

  // A camera moved by 1e-3 of the scene, a focal length changed by 1e-3.
  colmap::Reconstruction moved = model;
  const colmap::image_t image_id = moved.RegImageIds().front();
  colmap::Image& image = moved.Image(image_id);
  double scene_size = 0;
  for (const colmap::image_t other : moved.RegImageIds()) {
    scene_size = std::max(scene_size, (moved.Image(other).ProjectionCenter() -
                                       image.ProjectionCenter())
                                          .norm());
  }
  image.SetTvec(image.Tvec() + Eigen::Vector3d(1e-3 * scene_size, 0, 0));
  std::vector<std::string> differences =
      testing::CompareWithModelRecord(moved, path);
  ASSERT_EQ(differences.size(), 1u);
  EXPECT_NE(differences[0].find(image.Name()), std::string::npos);

  colmap::Reconstruction refocused = model;
  colmap::Camera& camera = refocused.Camera(image.CameraId());
  camera.SetParams([&] {
    std::vector<double> params = camera.Params();
    params[0] *= 1.001;
    return params;
  }());
  differences = testing::CompareWithModelRecord(refocused, path);
  ASSERT_EQ(differences.size(), 1u);
  EXPECT_EQ(differences[0].rfind("camera", 0), 0u);

  // Below the tolerances: the same model.
  colmap::Reconstruction jittered = model;
  jittered.Image(image_id).SetTvec(jittered.Image(image_id).Tvec() +
                                   Eigen::Vector3d(1e-9 * scene_size, 0, 0));
  EXPECT_TRUE(testing::CompareWithModelRecord(jittered, path).empty());

  // One image fewer registered.
  colmap::Reconstruction fewer = model;
  fewer.DeRegisterImage(image_id);
  differences = testing::CompareWithModelRecord(fewer, path);
  EXPECT_TRUE(std::any_of(
      differences.begin(), differences.end(), [](const std::string& line) {
        return line.find("not registered") != std::string::npos;
      }));

  EXPECT_FALSE(
      testing::CompareWithModelRecord(model, dir + "/missing.txt").empty());
}

}  // namespace
}  // namespace glomap
