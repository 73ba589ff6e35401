#include "glomap/scene/camera_groups.h"

#include <gtest/gtest.h>

#include <string>

namespace glomap {
namespace {

// Groups: identical free cameras; a prior, another size, another model or
// another parameter makes a camera a group of its own (or another group).
TEST(CameraGroups, IdenticalCameraGroups) {
  colmap::Reconstruction reconstruction;
  auto add = [&](colmap::camera_t camera_id, const std::string& model,
                 size_t width, double focal, bool prior) {
    colmap::Camera camera;
    camera.SetCameraId(camera_id);
    camera.InitializeWithName(model, focal, width, 480);
    camera.SetPriorFocalLength(prior);
    reconstruction.AddCamera(camera);
  };
  add(7, "SIMPLE_RADIAL", 640, 768, false);
  add(3, "SIMPLE_RADIAL", 640, 768, false);
  add(5, "SIMPLE_RADIAL", 640, 768, true);   // EXIF focal: not with 3, 7
  add(10, "SIMPLE_RADIAL", 640, 768, true);  // same EXIF focal: with 5
  add(4, "SIMPLE_RADIAL", 800, 960, false);  // other size
  add(9, "SIMPLE_RADIAL", 800, 960, false);
  add(6, "OPENCV", 640, 768, false);         // other model
  add(8, "SIMPLE_RADIAL", 640, 700, false);  // other focal
  const CameraGroups groups = IdenticalCameraGroups(reconstruction);
  const CameraGroups expected = {{3, 3}, {4, 4}, {5, 5}, {6, 6},
                                 {7, 3}, {8, 8}, {9, 4}, {10, 5}};
  EXPECT_EQ(groups, expected);
}

// Merge points the images of a group at one camera; split gives every image
// its own camera back, with the group's (refined) intrinsics, also in a
// model that holds only some of the images and none of their cameras.
TEST(CameraGroups, MergeAndSplit) {
  colmap::Reconstruction reconstruction;
  for (colmap::camera_t camera_id = 1; camera_id <= 4; ++camera_id) {
    colmap::Camera camera;
    camera.SetCameraId(camera_id);
    camera.InitializeWithName("SIMPLE_RADIAL", 768, 640, 480);
    camera.SetPriorFocalLength(camera_id == 4);  // EXIF: not with 1-3
    reconstruction.AddCamera(camera);
    colmap::Image image;
    image.SetImageId(10 + camera_id);
    image.SetName("image" + std::to_string(camera_id));
    image.SetCameraId(camera_id);
    reconstruction.AddImage(image);
  }
  const MergedCameras merged = MergeIdenticalCameras(
      IdenticalCameraGroups(reconstruction), &reconstruction);
  EXPECT_EQ(merged.num_groups, 1);
  EXPECT_EQ(merged.num_cameras, 3);
  for (const colmap::image_t image_id : {11, 12, 13}) {
    EXPECT_EQ(reconstruction.Image(image_id).CameraId(), 1);
  }
  EXPECT_EQ(reconstruction.Image(14).CameraId(), 4);

  reconstruction.Camera(1).SetParams({1520, 310, 250, -0.1});
  colmap::Reconstruction part;  // image 13 only, on the group's camera
  part.AddCamera(reconstruction.Camera(1));
  part.AddImage(reconstruction.Image(13));
  SplitMergedCameras(merged, &part);
  EXPECT_EQ(part.Image(13).CameraId(), 3);
  ASSERT_TRUE(part.ExistsCamera(3));
  EXPECT_EQ(part.Camera(3).Params(), reconstruction.Camera(1).Params());

  SplitMergedCameras(merged, &reconstruction);
  for (colmap::camera_t camera_id = 1; camera_id <= 3; ++camera_id) {
    EXPECT_EQ(reconstruction.Image(10 + camera_id).CameraId(), camera_id);
    EXPECT_EQ(reconstruction.Camera(camera_id).Params(),
              std::vector<double>({1520, 310, 250, -0.1}));
  }
  EXPECT_EQ(reconstruction.Image(14).CameraId(), 4);
  EXPECT_EQ(reconstruction.Camera(4).MeanFocalLength(), 768);
}

}  // namespace
}  // namespace glomap
