#include "glomap/processors/focal_check.h"

#include <gtest/gtest.h>

#include <string>

namespace glomap {
namespace {

// A model of `num_images` images on camera `camera_id` (registered).
void AddCameraWithImages(colmap::camera_t camera_id, double focal_px,
                         bool prior, int num_images,
                         colmap::Reconstruction* reconstruction) {
  colmap::Camera camera;
  camera.SetCameraId(camera_id);
  camera.InitializeWithName("SIMPLE_RADIAL", focal_px, 1600, 1200);
  camera.SetPriorFocalLength(prior);
  reconstruction->AddCamera(camera);
  for (int i = 0; i < num_images; ++i) {
    colmap::Image image;
    image.SetImageId(static_cast<colmap::image_t>(100 * camera_id + i));
    image.SetName(std::to_string(image.ImageId()));
    image.SetCameraId(camera_id);
    reconstruction->AddImage(image);
    reconstruction->RegisterImage(image.ImageId());
  }
}

std::map<colmap::image_t, colmap::camera_t> CameraOfImage(
    const colmap::Reconstruction& reconstruction) {
  std::map<colmap::image_t, colmap::camera_t> camera_of_image;
  for (const auto& [image_id, image] : reconstruction.Images()) {
    camera_of_image.emplace(image_id, image.CameraId());
  }
  return camera_of_image;
}

// Camera 1: left by calibration and moved by BA (undetermined); camera 2:
// moved by calibration (determined); camera 3: left by calibration and by
// BA (a start value that was right); camera 4: a prior.
TEST(FocalCheck, FindsFocalsThatOnlyBundleAdjustmentMoved) {
  colmap::Reconstruction start;
  AddCameraWithImages(1, 1920, false, 3, &start);
  AddCameraWithImages(2, 1920, false, 3, &start);
  AddCameraWithImages(3, 1920, false, 3, &start);
  AddCameraWithImages(4, 1500, true, 3, &start);
  const auto start_focals = FocalsWithoutPrior(start);
  EXPECT_EQ(start_focals.size(), 3u);

  colmap::Reconstruction calibrated = start;
  calibrated.Camera(1).SetParams({1921, 800, 600, 0});
  calibrated.Camera(2).SetParams({1500, 800, 600, 0});
  const auto calibrated_focals = FocalsWithoutPrior(calibrated);

  colmap::Reconstruction adjusted = calibrated;
  adjusted.Camera(1).SetParams({1500, 800, 600, 0});
  adjusted.Camera(2).SetParams({1400, 800, 600, 0});
  adjusted.Camera(3).SetParams({1930, 800, 600, 0});
  adjusted.Camera(4).SetParams({1200, 800, 600, 0});
  const std::vector<UndeterminedFocal> undetermined = FindUndeterminedFocals(
      FocalCheckOptions(), start_focals, calibrated_focals,
      CameraOfImage(calibrated), adjusted);
  ASSERT_EQ(undetermined.size(), 1u);
  EXPECT_EQ(undetermined[0].camera_id, 1);
  EXPECT_EQ(undetermined[0].num_images, 3u);
  EXPECT_EQ(undetermined[0].width, 1600u);
  EXPECT_DOUBLE_EQ(undetermined[0].calibrated_px, 1921);
  EXPECT_DOUBLE_EQ(undetermined[0].adjusted_px, 1500);

  const std::string warning = UndeterminedFocalWarning(undetermined);
  EXPECT_NE(warning.find("camera 1 (1600x1200, 3 images"), std::string::npos)
      << warning;
  EXPECT_NE(warning.find("--ImageReader.camera_params"), std::string::npos);
  EXPECT_EQ(warning.find("single_camera"), std::string::npos);
  EXPECT_EQ(UndeterminedFocalWarning({}), "");
}

// A merged group split after calibration: its images' cameras are new ids,
// judged by the median over them against the group's calibrated focal; two
// undetermined cameras of one size also point to single_camera.
TEST(FocalCheck, SplitGroupsAndCamerasOfOneSize) {
  colmap::Reconstruction calibrated;
  AddCameraWithImages(1, 1920, false, 3, &calibrated);
  AddCameraWithImages(2, 1800, false, 2, &calibrated);
  const auto focals = FocalsWithoutPrior(calibrated);
  const auto camera_of_image = CameraOfImage(calibrated);

  colmap::Reconstruction adjusted = calibrated;
  // Group 1 split: its three images on cameras 11-13.
  const double split_focals[] = {1400, 1950, 1450};
  for (int i = 0; i < 3; ++i) {
    colmap::Camera camera = adjusted.Camera(1);
    camera.SetCameraId(static_cast<colmap::camera_t>(11 + i));
    camera.SetParams({split_focals[i], 800, 600, 0});
    adjusted.AddCamera(camera);
    adjusted.Image(100 + i).SetCameraId(camera.CameraId());
  }
  adjusted.Camera(2).SetParams({1500, 800, 600, 0});
  const std::vector<UndeterminedFocal> undetermined = FindUndeterminedFocals(
      FocalCheckOptions(), focals, focals, camera_of_image, adjusted);
  ASSERT_EQ(undetermined.size(), 2u);
  EXPECT_DOUBLE_EQ(undetermined[0].adjusted_px, 1450);  // the median
  EXPECT_NE(UndeterminedFocalWarning(undetermined).find("single_camera"),
            std::string::npos);
}

// Split groups without a prior (each image its own focal): a warning that
// names them and the spread when the viewing directions spread by less than
// min_view_spread_deg_for_split_focals, none where they spread more (an
// object ring fixes each image's focal) or where nothing was split.
TEST(FocalCheck, SplitGroupsWarnWhenTheViewsDoNotSpread) {
  SplitCameraGroup group;
  group.camera_id = 4;
  group.num_images = 40;
  group.width = 1024;
  group.height = 768;
  const FocalCheckOptions options;
  const std::string warning = SplitFocalWarning(options, {group}, 6.1);
  EXPECT_EQ(warning.rfind("Focal lengths not determined", 0), 0u);
  EXPECT_NE(warning.find("camera 4"), std::string::npos);
  EXPECT_NE(warning.find("1024x768, 40 images"), std::string::npos);
  EXPECT_NE(warning.find("6.1 deg"), std::string::npos);
  EXPECT_NE(warning.find("EXIF"), std::string::npos);
  EXPECT_EQ(SplitFocalWarning(options, {group}, 75.2), "");
  EXPECT_EQ(SplitFocalWarning(options, {}, 0.5), "");
}

}  // namespace
}  // namespace glomap
