#include "glomap/processors/track_filters.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "base/camera.h"
#include "base/image.h"
#include "base/pose.h"
#include "util/math.h"

namespace glomap {
namespace {

constexpr double kFocalPx = 500;
constexpr colmap::camera_t kPriorCameraId = 1;
constexpr colmap::camera_t kNoPriorCameraId = 2;

// Cameras look down +z with identity rotation; the tests place their centres
// and keypoints by hand so that every expected answer is known exactly.
class FilterScene {
 public:
  FilterScene() {
    for (const colmap::camera_t camera_id :
         {kPriorCameraId, kNoPriorCameraId}) {
      colmap::Camera camera;
      camera.SetCameraId(camera_id);
      camera.InitializeWithName("SIMPLE_PINHOLE", kFocalPx, 1000, 1000);
      camera.SetPriorFocalLength(camera_id == kPriorCameraId);
      reconstruction.AddCamera(camera);
    }
  }

  // Adds a registered image centred at `center` (unless `registered` is
  // false) with one keypoint per entry of `keypoints`.
  colmap::image_t AddImage(const Eigen::Vector3d& center,
                           const std::vector<Eigen::Vector2d>& keypoints,
                           colmap::camera_t camera_id = kPriorCameraId,
                           bool registered = true) {
    colmap::Image image;
    const colmap::image_t image_id = ++num_images_;
    image.SetImageId(image_id);
    image.SetCameraId(camera_id);
    image.SetName("image" + std::to_string(image_id));
    image.SetQvec(Eigen::Vector4d(1, 0, 0, 0));
    image.SetTvec(-center);
    image.SetPoints2D(keypoints);
    reconstruction.AddImage(image);
    if (registered) reconstruction.RegisterImage(image_id);
    return image_id;
  }

  // The pixel where `point` projects in a camera centred at `center`, moved
  // sideways by `offset_rad` radians of viewing angle.
  static Eigen::Vector2d Project(const Eigen::Vector3d& point,
                                 const Eigen::Vector3d& center,
                                 double offset_rad = 0) {
    const Eigen::Vector3d ray = point - center;
    const double angle = std::atan2(ray.x(), ray.z()) + offset_rad;
    return Eigen::Vector2d(kFocalPx * std::tan(angle) + 500,
                           kFocalPx * ray.y() / ray.z() + 500);
  }

  // Adds a registered image centred at `center` on camera `camera_id` whose
  // one keypoint is where `point` projects, moved by `offset_rad` (Project).
  colmap::image_t AddImageSeeing(const Eigen::Vector3d& point,
                                 const Eigen::Vector3d& center,
                                 double offset_rad = 0,
                                 colmap::camera_t camera_id = kPriorCameraId) {
    return AddImage(center, {Project(point, center, offset_rad)}, camera_id);
  }

  colmap::point3D_t AddPoint(const Eigen::Vector3d& xyz,
                             const std::vector<colmap::image_t>& image_ids) {
    colmap::Track track;
    for (const colmap::image_t image_id : image_ids) {
      track.AddElement(image_id, 0);
    }
    return reconstruction.AddPoint3D(xyz, track);
  }

  colmap::Reconstruction reconstruction;

 private:
  colmap::image_t num_images_ = 0;
};

TEST(TrackFilters, AngularErrorUsesPerCameraLimit) {
  // Ray off by 1.5°: out at a 1° limit (prior focal), in at a 2° limit
  // (no prior).
  const Eigen::Vector3d point(0, 0, 10);
  const std::vector<Eigen::Vector3d> centers = {
      {0, 0, 0}, {1, 0, 0}, {-1, 0, 0}, {2, 0, 0}};
  const double offset_rad = colmap::DegToRad(1.5);
  FilterScene scene;
  const colmap::image_t exact1 = scene.AddImageSeeing(point, centers[0]);
  const colmap::image_t exact2 = scene.AddImageSeeing(point, centers[1]);
  const colmap::image_t off_prior =
      scene.AddImageSeeing(point, centers[2], offset_rad);
  const colmap::image_t off_no_prior =
      scene.AddImageSeeing(point, centers[3], offset_rad, kNoPriorCameraId);
  const colmap::point3D_t point3D_id =
      scene.AddPoint(point, {exact1, exact2, off_prior, off_no_prior});

  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 2), 1);
  const colmap::Track& track = scene.reconstruction.Point3D(point3D_id).Track();
  ASSERT_EQ(track.Length(), 3);
  for (const auto& el : track.Elements()) EXPECT_NE(el.image_id, off_prior);
  // Tightening the no-prior limit removes the other one as well.
  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 1), 1);
  EXPECT_EQ(scene.reconstruction.Point3D(point3D_id).Track().Length(), 2);
  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 1), 0);
}

TEST(TrackFilters, AngularErrorRemovesPointsBehindCamera) {
  // The keypoint matches the ray exactly, but the point lies behind camera 3.
  const Eigen::Vector3d point(0, 0, 10);
  FilterScene scene;
  const colmap::image_t a = scene.AddImageSeeing(point, {0, 0, 0});
  const colmap::image_t b = scene.AddImageSeeing(point, {1, 0, 0});
  const colmap::image_t behind = scene.AddImage({0, 0, 20}, {{500, 500}});
  const colmap::point3D_t point3D_id = scene.AddPoint(point, {a, b, behind});
  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 2), 1);
  EXPECT_EQ(scene.reconstruction.Point3D(point3D_id).Track().Length(), 2);
  EXPECT_FALSE(scene.reconstruction.Image(behind).Point2D(0).HasPoint3D());
}

TEST(TrackFilters, PointLeftWithOneObservationIsDeleted) {
  const Eigen::Vector3d point(0, 0, 10);
  FilterScene scene;
  const colmap::image_t a = scene.AddImageSeeing(point, {0, 0, 0});
  const colmap::image_t b =
      scene.AddImageSeeing(point, {1, 0, 0}, colmap::DegToRad(5.0));
  scene.AddPoint(point, {a, b});
  // Both observations disappear with the point.
  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 1), 2);
  EXPECT_EQ(scene.reconstruction.NumPoints3D(), 0);
  EXPECT_FALSE(scene.reconstruction.Image(a).Point2D(0).HasPoint3D());
}

TEST(TrackFilters, UnregisteredImagesAreIgnored) {
  const Eigen::Vector3d point(0, 0, 10);
  FilterScene scene;
  const colmap::image_t a = scene.AddImageSeeing(point, {0, 0, 0});
  const colmap::image_t b = scene.AddImageSeeing(point, {1, 0, 0});
  // Far off, but not registered: not tested.
  const colmap::image_t c =
      scene.AddImage({2, 0, 0}, {{0, 0}}, kPriorCameraId, false);
  const colmap::point3D_t point3D_id = scene.AddPoint(point, {a, b, c});
  EXPECT_EQ(FilterObservationsByAngularError(&scene.reconstruction, 1, 1), 0);
  EXPECT_EQ(FilterObservationsByReprojectionErrorPx(&scene.reconstruction, 1),
            0);
  EXPECT_EQ(scene.reconstruction.Point3D(point3D_id).Track().Length(), 3);
}

TEST(TrackFilters, TriangulationAngle) {
  // Baseline 0.1 at depth 10: angle = 2 atan(0.05 / 10) = 0.573°.
  const Eigen::Vector3d point(0.05, 0, 10);
  FilterScene scene;
  const colmap::image_t a = scene.AddImageSeeing(point, {0, 0, 0});
  const colmap::image_t b = scene.AddImageSeeing(point, {0.1, 0, 0});
  // A second point that also has a wide pair (baseline 1 => 5.7°).
  const Eigen::Vector3d wide_point(0, 0, 10);
  const colmap::image_t c = scene.AddImageSeeing(wide_point, {0, 0, 0});
  const colmap::image_t d = scene.AddImageSeeing(wide_point, {1, 0, 0});
  const colmap::point3D_t narrow_id = scene.AddPoint(point, {a, b});
  const colmap::point3D_t wide_id = scene.AddPoint(wide_point, {c, d});

  EXPECT_EQ(FilterPointsByTriangulationAngle(&scene.reconstruction, 0.5), 0);
  EXPECT_EQ(FilterPointsByTriangulationAngle(&scene.reconstruction, 1.0), 1);
  EXPECT_FALSE(scene.reconstruction.ExistsPoint3D(narrow_id));
  EXPECT_TRUE(scene.reconstruction.ExistsPoint3D(wide_id));
  EXPECT_EQ(FilterPointsByTriangulationAngle(&scene.reconstruction, 6.0), 1);
  EXPECT_EQ(scene.reconstruction.NumPoints3D(), 0);
}

TEST(TrackFilters, NormalizedAndPixelReprojectionError) {
  const Eigen::Vector3d point(0, 0, 10);
  FilterScene scene;
  std::vector<colmap::image_t> image_ids;
  // Keypoint errors 0, 3, 6 and 12 px (0, 0.006, 0.012, 0.024 normalized).
  const std::vector<double> errors_px = {0, 3, 6, 12};
  for (size_t i = 0; i < errors_px.size(); ++i) {
    const Eigen::Vector3d center(0.5 * i, 0, 0);
    image_ids.push_back(
        scene.AddImage(center, {FilterScene::Project(point, center) +
                                Eigen::Vector2d(0, errors_px[i])}));
  }
  const colmap::point3D_t point3D_id = scene.AddPoint(point, image_ids);

  UpdatePointErrors(&scene.reconstruction);
  EXPECT_NEAR(scene.reconstruction.Point3D(point3D_id).Error(), 21.0 / 4, 1e-9);

  EXPECT_EQ(FilterObservationsByNormalizedReprojectionError(
                &scene.reconstruction, 0.02),
            1);
  EXPECT_EQ(scene.reconstruction.Point3D(point3D_id).Track().Length(), 3);
  EXPECT_EQ(FilterObservationsByReprojectionErrorPx(&scene.reconstruction, 4.0),
            1);
  EXPECT_EQ(scene.reconstruction.Point3D(point3D_id).Track().Length(), 2);
  UpdatePointErrors(&scene.reconstruction);
  EXPECT_NEAR(scene.reconstruction.Point3D(point3D_id).Error(), 1.5, 1e-9);
  // Error 3 px > 2 px: the point would keep one observation, so it goes.
  EXPECT_EQ(FilterObservationsByReprojectionErrorPx(&scene.reconstruction, 2.0),
            2);
  EXPECT_EQ(scene.reconstruction.NumPoints3D(), 0);
}

}  // namespace
}  // namespace glomap
