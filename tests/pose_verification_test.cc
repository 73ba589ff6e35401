#include "glomap/processors/pose_verification.h"

#include <gtest/gtest.h>

#include <set>

#include "base/pose.h"
#include "base/similarity_transform.h"
#include "glomap/io/database_reader.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

// A synthetic ring scene: the true model (poses, keypoints, points with
// tracks) and the view graph of its database.
struct Scene {
  colmap::Reconstruction truth;
  colmap::Reconstruction model;  // Starts as a copy of the truth.
  ViewGraph view_graph;
  double scene_size = 0;  // Largest distance between two true centres.
};

Scene MakeScene(const std::string& name, int seed) {
  Scene scene;
  const std::string dir = testing::CreateTestDir(name);
  SyntheticSceneOptions options;
  options.num_images = 30;
  options.wrong_match_ratio = 0.2;
  options.verification = "ground_truth";
  options.random_seed = seed;
  EXPECT_TRUE(
      WriteSyntheticScene(options, dir + "/database.db", &scene.truth).ok());
  colmap::Reconstruction database_images;
  EXPECT_TRUE(ReadDatabase(dir + "/database.db", DatabaseReaderOptions(),
                           &database_images, &scene.view_graph)
                  .ok());
  scene.model = scene.truth;
  for (const colmap::image_t i : scene.truth.RegImageIds()) {
    for (const colmap::image_t j : scene.truth.RegImageIds()) {
      scene.scene_size =
          std::max(scene.scene_size, (scene.truth.Image(i).ProjectionCenter() -
                                      scene.truth.Image(j).ProjectionCenter())
                                         .norm());
    }
  }
  return scene;
}

double CenterError(const Scene& scene, colmap::image_t image_id) {
  return (scene.model.Image(image_id).ProjectionCenter() -
          scene.truth.Image(image_id).ProjectionCenter())
      .norm();
}

// Moves an image's camera by `offset` (world units) and turns it by
// `angle_deg` about its viewing axis, keeping its observations.
void Misplace(colmap::Image* image, const Eigen::Vector3d& offset,
              double angle_deg) {
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(colmap::DegToRad(angle_deg), Eigen::Vector3d::UnitZ())
          .toRotationMatrix() *
      image->RotationMatrix();
  const Eigen::Vector3d center = image->ProjectionCenter() + offset;
  image->SetQvec(colmap::RotationMatrixToQuaternion(rotation));
  image->SetTvec(-rotation * center);
}

TEST(PoseVerification, CorrectPosesAreAllKept) {
  Scene scene = MakeScene("pose_verification_correct", 1);
  PoseVerificationSummary summary;
  ASSERT_TRUE(VerifyPoses(PoseVerificationOptions(), scene.view_graph,
                          &scene.model, &summary)
                  .ok());
  EXPECT_EQ(summary.num_checked, scene.truth.NumRegImages());
  EXPECT_EQ(summary.num_kept, summary.num_checked);
  EXPECT_TRUE(summary.changed.empty());
  EXPECT_EQ(scene.model.NumRegImages(), scene.truth.NumRegImages());
}

// One camera far from where it belongs, observations unchanged: the other
// images' points give its true pose back.
TEST(PoseVerification, MisplacedCameraIsReplaced) {
  Scene scene = MakeScene("pose_verification_misplaced", 2);
  const colmap::image_t image_id = 7;
  Misplace(&scene.model.Image(image_id),
           Eigen::Vector3d(5, -3, 2) * scene.scene_size, 40);
  ASSERT_GT(CenterError(scene, image_id), scene.scene_size);

  PoseVerificationSummary summary;
  ASSERT_TRUE(VerifyPoses(PoseVerificationOptions(), scene.view_graph,
                          &scene.model, &summary)
                  .ok());
  ASSERT_EQ(summary.changed.size(), 1u);
  EXPECT_EQ(summary.changed[0].image_id, image_id);
  EXPECT_EQ(summary.changed[0].outcome,
            PoseVerificationResult::Outcome::kReplaced);
  EXPECT_EQ(summary.num_replaced, 1u);
  EXPECT_TRUE(scene.model.IsImageRegistered(image_id));
  EXPECT_LT(CenterError(scene, image_id), 0.01 * scene.scene_size);
}

// The failure that motivates the stage: two images moved together with the
// points only they observe, so that their own observations stay consistent,
// and their observations of everything else deleted (as bundle adjustment
// filters them); rotation averaging rejected their pairs with the rest.
// Each image's own points rest on the other one, so they are not evidence;
// the database matches to the main structure are.
const std::set<colmap::image_t> kGroup = {11, 12};

Scene MakeMisplacedGroupScene(const std::string& name) {
  Scene scene = MakeScene(name, 3);
  const colmap::SimilarityTransform3 move(
      3.0,
      colmap::RotationMatrixToQuaternion(
          Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())
              .toRotationMatrix()),
      Eigen::Vector3d(10, 4, -6) * scene.scene_size);
  std::set<colmap::point3D_t> group_points;
  for (const auto& [point3D_id, point3D] : scene.model.Points3D()) {
    size_t num_in_group = 0;
    for (const auto& element : point3D.Track().Elements()) {
      num_in_group += kGroup.count(element.image_id);
    }
    if (num_in_group >= 2) group_points.insert(point3D_id);
  }
  EXPECT_GT(group_points.size(), 20u);
  for (const colmap::point3D_t point3D_id : group_points) {
    const colmap::Track track = scene.model.Point3D(point3D_id).Track();
    for (const auto& element : track.Elements()) {
      if (!kGroup.count(element.image_id)) {
        scene.model.DeleteObservation(element.image_id, element.point2D_idx);
      }
    }
    move.TransformPoint(&scene.model.Point3D(point3D_id).XYZ());
  }
  for (const colmap::image_t image_id : kGroup) {
    colmap::Image& image = scene.model.Image(image_id);
    for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
      const colmap::Point2D& point2D = image.Point2D(idx);
      if (point2D.HasPoint3D() && !group_points.count(point2D.Point3DId())) {
        scene.model.DeleteObservation(image_id, idx);
      }
    }
    move.TransformPose(&image.Qvec(), &image.Tvec());
    EXPECT_GT(CenterError(scene, image_id), scene.scene_size);
  }
  for (auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (kGroup.count(pair.image_id1) != kGroup.count(pair.image_id2)) {
      pair.is_valid = false;
    }
  }
  return scene;
}

TEST(PoseVerification, MisplacedGroupIsReplacedNotTrusted) {
  Scene scene = MakeMisplacedGroupScene("pose_verification_group");
  PoseVerificationSummary summary;
  ASSERT_TRUE(VerifyPoses(PoseVerificationOptions(), scene.view_graph,
                          &scene.model, &summary)
                  .ok());
  EXPECT_EQ(summary.num_replaced, kGroup.size());
  for (const colmap::image_t image_id : kGroup) {
    ASSERT_TRUE(scene.model.IsImageRegistered(image_id));
    EXPECT_LT(CenterError(scene, image_id), 0.01 * scene.scene_size)
        << "image " << image_id;
  }
  for (const colmap::image_t image_id : scene.model.RegImageIds()) {
    if (!kGroup.count(image_id)) {
      EXPECT_LT(CenterError(scene, image_id), 1e-9) << "image " << image_id;
    }
  }
}

// Without the rejected pairs the group has no evidence left: its images are
// left out rather than trusted.
TEST(PoseVerification, MisplacedGroupWithoutRejectedPairsIsLeftOut) {
  Scene scene = MakeMisplacedGroupScene("pose_verification_group_valid_only");
  PoseVerificationOptions options;
  options.use_all_pairs = false;
  PoseVerificationSummary summary;
  ASSERT_TRUE(
      VerifyPoses(options, scene.view_graph, &scene.model, &summary).ok());
  EXPECT_EQ(summary.num_deregistered, kGroup.size());
  for (const colmap::image_t image_id : kGroup) {
    EXPECT_FALSE(scene.model.IsImageRegistered(image_id));
  }
}

// An image without matches in the database and with too few observations
// to check cannot be verified: it is left unregistered and named.
TEST(PoseVerification, UnverifiableImageIsLeftOut) {
  Scene scene = MakeScene("pose_verification_unverifiable", 4);
  const colmap::image_t image_id = 20;
  auto& pairs = scene.view_graph.Pairs();
  for (auto it = pairs.begin(); it != pairs.end();) {
    const bool involved =
        it->second.image_id1 == image_id || it->second.image_id2 == image_id;
    it = involved ? pairs.erase(it) : std::next(it);
  }
  colmap::Image& image = scene.model.Image(image_id);
  int num_kept = 0;
  for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
    if (image.Point2D(idx).HasPoint3D() && ++num_kept > 5) {
      scene.model.DeleteObservation(image_id, idx);
    }
  }
  Misplace(&image, Eigen::Vector3d(1, 1, 1) * scene.scene_size, 0);

  PoseVerificationSummary summary;
  ASSERT_TRUE(VerifyPoses(PoseVerificationOptions(), scene.view_graph,
                          &scene.model, &summary)
                  .ok());
  ASSERT_EQ(summary.changed.size(), 1u);
  EXPECT_EQ(summary.changed[0].outcome,
            PoseVerificationResult::Outcome::kDeregistered);
  EXPECT_FALSE(summary.changed[0].reason.empty());
  EXPECT_EQ(summary.num_deregistered, 1u);
  EXPECT_FALSE(scene.model.IsImageRegistered(image_id));
  EXPECT_EQ(scene.model.NumRegImages(), scene.truth.NumRegImages() - 1);
}

TEST(PoseVerification, SameSeedSameResult) {
  Scene a = MakeScene("pose_verification_seed", 5);
  Misplace(&a.model.Image(3), Eigen::Vector3d(2, 0, 0) * a.scene_size, 20);
  colmap::Reconstruction b = a.model;
  PoseVerificationSummary summary_a, summary_b;
  PoseVerificationOptions options;
  options.num_threads = 2;
  ASSERT_TRUE(VerifyPoses(options, a.view_graph, &a.model, &summary_a).ok());
  ASSERT_TRUE(VerifyPoses(options, a.view_graph, &b, &summary_b).ok());
  EXPECT_EQ(a.model.Image(3).Qvec(), b.Image(3).Qvec());
  EXPECT_EQ(a.model.Image(3).Tvec(), b.Image(3).Tvec());
}

TEST(PoseVerification, InvalidOptionsAreAnError) {
  Scene scene = MakeScene("pose_verification_options", 6);
  PoseVerificationOptions options;
  options.max_reproj_error_px = 0;
  PoseVerificationSummary summary;
  EXPECT_FALSE(
      VerifyPoses(options, scene.view_graph, &scene.model, &summary).ok());
}

}  // namespace
}  // namespace glomap
