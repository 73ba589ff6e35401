#include "glomap/estimators/retriangulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "base/pose.h"
#include "base/projection.h"
#include "base/reconstruction.h"
#include "tests/support/camera_rotation.h"

namespace glomap {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

// A ring of cameras around a ball of points with known poses, noisy
// keypoints (plus keypoints that match nothing) and a view graph of verified
// matches between all image pairs that share points, with some wrong
// matches mixed in. Image `kUnregisteredId` is in the reconstruction and the
// view graph but not registered.
constexpr colmap::image_t kUnregisteredId = 100;

struct Scene {
  colmap::Reconstruction reconstruction;  // Poses, keypoints, no points.
  ViewGraph view_graph;
  std::vector<Eigen::Vector3d> true_points;
  // keypoint_point[image_id][point2D_idx]: index into true_points or -1.
  std::map<colmap::image_t, std::vector<int>> keypoint_point;
  size_t num_points_in_3_views = 0;  // Registered views.
};

Scene MakeScene(int num_images, int num_points, double wrong_match_ratio,
                int seed, double radial_distortion = 0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Scene scene;
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_RADIAL", 800, kWidth, kHeight);
  camera.Params(camera.ExtraParamsIdxs()[0]) = radial_distortion;
  scene.reconstruction.AddCamera(camera);

  std::vector<colmap::image_t> image_ids;
  std::vector<double> ring_angles;
  for (int i = 0; i <= num_images; ++i) {
    // The last image sits between the first two and stays unregistered.
    const double angle =
        i < num_images ? 2 * M_PI * i / num_images : M_PI / num_images;
    const colmap::image_t image_id = i < num_images ? i + 1 : kUnregisteredId;
    image_ids.push_back(image_id);
    ring_angles.push_back(angle);
    const Eigen::Vector3d center(6 * std::cos(angle), 6 * std::sin(angle),
                                 0.8 * std::sin(3 * angle));
    const Eigen::Matrix3d rotation = testing::CamFromWorldLookingAlong(-center);
    colmap::Image image;
    image.SetImageId(image_id);
    image.SetName("image" + std::to_string(image_id));
    image.SetCameraId(1);
    image.SetQvec(colmap::RotationMatrixToQuaternion(rotation));
    image.SetTvec(-rotation * center);
    scene.reconstruction.AddImage(image);
  }

  std::map<colmap::image_t, std::vector<Eigen::Vector2d>> keypoints;
  // point -> list of (image_id, point2D_idx)
  std::vector<std::vector<std::pair<colmap::image_t, int>>> observations;
  for (int p = 0; p < num_points; ++p) {
    Eigen::Vector3d xyz(normal(rng), normal(rng), normal(rng));
    xyz = xyz.normalized() * 2.0 * std::cbrt(uniform(rng));
    const double direction = 2 * M_PI * uniform(rng);
    std::vector<std::pair<colmap::image_t, int>> track;
    for (size_t i = 0; i < image_ids.size(); ++i) {
      double diff = std::abs(ring_angles[i] - direction);
      diff = std::min(diff, 2 * M_PI - diff);
      if (diff > 40 * M_PI / 180) continue;
      const colmap::Image& image = scene.reconstruction.Image(image_ids[i]);
      const Eigen::Vector3d in_cam =
          image.RotationMatrix() * xyz + image.Tvec();
      if (in_cam.z() <= 0) continue;
      const Eigen::Vector2d xy = camera.WorldToImage(in_cam.hnormalized());
      if (xy.x() < 0 || xy.y() < 0 || xy.x() > kWidth || xy.y() > kHeight) {
        continue;
      }
      auto& image_keypoints = keypoints[image_ids[i]];
      track.emplace_back(image_ids[i], image_keypoints.size());
      image_keypoints.push_back(
          xy + 0.5 * Eigen::Vector2d(normal(rng), normal(rng)));
      scene.keypoint_point[image_ids[i]].push_back(p);
    }
    int num_registered_views = 0;
    for (const auto& el : track)
      num_registered_views += el.first != kUnregisteredId;
    scene.num_points_in_3_views += num_registered_views >= 3;
    scene.true_points.push_back(xyz);
    observations.push_back(track);
  }
  // Keypoints that belong to no point.
  for (const colmap::image_t image_id : image_ids) {
    for (int k = 0; k < 100; ++k) {
      keypoints[image_id].emplace_back(kWidth * uniform(rng),
                                       kHeight * uniform(rng));
      scene.keypoint_point[image_id].push_back(-1);
    }
    scene.reconstruction.Image(image_id).SetPoints2D(keypoints[image_id]);
    if (image_id != kUnregisteredId) {
      scene.reconstruction.RegisterImage(image_id);
    }
  }

  // Verified matches of every pair sharing points, plus wrong ones.
  std::map<std::pair<colmap::image_t, colmap::image_t>, colmap::FeatureMatches>
      matches;
  for (const auto& track : observations) {
    for (size_t a = 0; a < track.size(); ++a) {
      for (size_t b = a + 1; b < track.size(); ++b) {
        auto el1 = track[a], el2 = track[b];
        if (el1.first > el2.first) std::swap(el1, el2);
        matches[{el1.first, el2.first}].emplace_back(el1.second, el2.second);
      }
    }
  }
  int pair_index = 0;
  for (auto& [image_pair, pair_matches] : matches) {
    const int num_wrong =
        static_cast<int>(wrong_match_ratio * pair_matches.size());
    const size_t num_points1 = keypoints[image_pair.first].size();
    const size_t num_points2 = keypoints[image_pair.second].size();
    for (int k = 0; k < num_wrong; ++k) {
      pair_matches.emplace_back(
          static_cast<colmap::point2D_t>(uniform(rng) * num_points1),
          static_cast<colmap::point2D_t>(uniform(rng) * num_points2));
    }
    ImagePair pair;
    pair.image_id1 = image_pair.first;
    pair.image_id2 = image_pair.second;
    pair.matches = pair_matches;
    // Invalid pairs are used too (their matches are still verified).
    pair.is_valid = (pair_index++ % 3) != 0;
    scene.view_graph.AddPair(pair);
  }
  return scene;
}

// Stale points that retriangulation must replace.
void AddStalePoints(colmap::Reconstruction* reconstruction) {
  for (colmap::point2D_t idx = 0; idx < 20; ++idx) {
    colmap::Track track;
    track.AddElement(1, idx);
    track.AddElement(2, idx);
    reconstruction->AddPoint3D(Eigen::Vector3d(100, 100, 100), track);
  }
}

struct PointStats {
  size_t num_points = 0;
  size_t num_observations = 0;
  size_t num_wrong_observations = 0;  // Not of the track's majority point.
  double median_position_error = 0;
};

PointStats Evaluate(const Scene& scene,
                    const colmap::Reconstruction& reconstruction) {
  PointStats stats;
  std::vector<double> errors;
  for (const auto& point3D : reconstruction.Points3D()) {
    std::map<int, int> votes;
    for (const colmap::TrackElement& el : point3D.second.Track().Elements()) {
      ++votes[scene.keypoint_point.at(el.image_id)[el.point2D_idx]];
      ++stats.num_observations;
    }
    const auto best = std::max_element(
        votes.begin(), votes.end(),
        [](const auto& a, const auto& b) { return a.second < b.second; });
    stats.num_wrong_observations +=
        point3D.second.Track().Length() - best->second;
    if (best->first >= 0) {
      errors.push_back(
          (point3D.second.XYZ() - scene.true_points[best->first]).norm());
    }
  }
  stats.num_points = reconstruction.NumPoints3D();
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2,
                     errors.end());
    stats.median_position_error = errors[errors.size() / 2];
  }
  return stats;
}

TEST(Retriangulation, RecoversPointsWithKnownPoses) {
  Scene scene = MakeScene(20, 2000, 0.05, 1);
  colmap::Reconstruction reconstruction = scene.reconstruction;
  AddStalePoints(&reconstruction);
  RetriangulationOptions options;
  options.run_bundle_adjustment = false;  // Keep the true coordinate frame.
  const Status status =
      Retriangulate(options, scene.view_graph, &reconstruction);
  ASSERT_TRUE(status.ok()) << status.message();

  const PointStats stats = Evaluate(scene, reconstruction);
  std::cout << stats.num_points << " points (" << scene.num_points_in_3_views
            << " true points in >= 3 views), " << stats.num_wrong_observations
            << " / " << stats.num_observations
            << " wrong observations, median error "
            << stats.median_position_error << std::endl;
  EXPECT_GT(stats.num_points, 0.9 * scene.num_points_in_3_views);
  EXPECT_LT(stats.num_points, 1.1 * scene.true_points.size());
  EXPECT_LT(stats.num_wrong_observations, 0.01 * stats.num_observations);
  EXPECT_LT(stats.median_position_error, 0.01);  // Scene radius ~6.
  for (const auto& point3D : reconstruction.Points3D()) {
    EXPECT_LT(point3D.second.XYZ().norm(), 50);  // Stale points are gone.
    EXPECT_GE(point3D.second.Error(), 0);        // Errors were updated.
  }

  // Poses are untouched, the unregistered image is kept as it was.
  for (const colmap::image_t image_id : scene.reconstruction.RegImageIds()) {
    EXPECT_EQ(reconstruction.Image(image_id).Qvec(),
              scene.reconstruction.Image(image_id).Qvec());
    EXPECT_EQ(reconstruction.Image(image_id).Tvec(),
              scene.reconstruction.Image(image_id).Tvec());
  }
  ASSERT_TRUE(reconstruction.ExistsImage(kUnregisteredId));
  EXPECT_FALSE(reconstruction.IsImageRegistered(kUnregisteredId));
  EXPECT_EQ(reconstruction.Image(kUnregisteredId).NumPoints2D(),
            scene.reconstruction.Image(kUnregisteredId).NumPoints2D());
  EXPECT_EQ(reconstruction.Image(kUnregisteredId).NumPoints3D(), 0u);
  EXPECT_EQ(reconstruction.NumRegImages(), 20u);
}

// The new points link to the model's own images: every observation names a
// keypoint of a registered image that links back to that point, no other
// keypoint links to a point, and the keypoints themselves are unchanged.
TEST(Retriangulation, ObservationsAndKeypointLinksAgree) {
  Scene scene = MakeScene(12, 800, 0.05, 7);
  colmap::Reconstruction reconstruction = scene.reconstruction;
  AddStalePoints(&reconstruction);
  RetriangulationOptions options;
  options.run_bundle_adjustment = false;
  ASSERT_TRUE(Retriangulate(options, scene.view_graph, &reconstruction).ok());
  ASSERT_GT(reconstruction.NumPoints3D(), 0u);
  size_t num_observations = 0;
  for (const auto& [point3D_id, point3D] : reconstruction.Points3D()) {
    for (const colmap::TrackElement& el : point3D.Track().Elements()) {
      ASSERT_TRUE(reconstruction.IsImageRegistered(el.image_id));
      EXPECT_EQ(
          reconstruction.Image(el.image_id).Point2D(el.point2D_idx).Point3DId(),
          point3D_id);
      ++num_observations;
    }
  }
  size_t num_linked = 0;
  for (const auto& [image_id, image] : reconstruction.Images()) {
    const colmap::Image& source = scene.reconstruction.Image(image_id);
    ASSERT_EQ(image.NumPoints2D(), source.NumPoints2D());
    for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
      EXPECT_EQ(image.Point2D(idx).XY(), source.Point2D(idx).XY());
    }
    num_linked += image.NumPoints3D();
  }
  EXPECT_EQ(num_linked, num_observations);
  EXPECT_EQ(reconstruction.NumImages(), scene.reconstruction.NumImages());
}

TEST(Retriangulation, WithBundleAdjustment) {
  Scene scene = MakeScene(20, 2000, 0.05, 2);
  colmap::Reconstruction reconstruction = scene.reconstruction;
  const Status status = Retriangulate(RetriangulationOptions(),
                                      scene.view_graph, &reconstruction);
  ASSERT_TRUE(status.ok()) << status.message();
  const PointStats stats = Evaluate(scene, reconstruction);
  EXPECT_GT(stats.num_points, 0.9 * scene.num_points_in_3_views);
  EXPECT_LT(stats.num_wrong_observations, 0.01 * stats.num_observations);
  double sum_error = 0;
  for (const auto& point3D : reconstruction.Points3D()) {
    sum_error += point3D.second.Error();
  }
  const double mean_error = sum_error / reconstruction.NumPoints3D();
  std::cout << "mean reprojection error " << mean_error << " px" << std::endl;
  EXPECT_LT(mean_error, 1.0);  // Keypoint noise sigma 0.5 px.
  EXPECT_TRUE(reconstruction.ExistsImage(kUnregisteredId));
}

// A final bundle adjustment over a budget holds a part of the points; the
// model keeps every point, and the points left out of the solve fit the
// final poses as well as the others.
TEST(Retriangulation, FinalBundleAdjustmentOverItsBudget) {
  Scene scene = MakeScene(20, 2000, 0.05, 2);
  colmap::Reconstruction whole = scene.reconstruction;
  ASSERT_TRUE(
      Retriangulate(RetriangulationOptions(), scene.view_graph, &whole).ok());
  colmap::Reconstruction budget = scene.reconstruction;
  RetriangulationOptions options;
  options.final_ba_max_num_observations =
      static_cast<int>(whole.ComputeNumObservations() / 4);
  ASSERT_TRUE(Retriangulate(options, scene.view_graph, &budget).ok());
  const PointStats whole_stats = Evaluate(scene, whole);
  const PointStats budget_stats = Evaluate(scene, budget);
  std::cout << "points " << whole_stats.num_points << " / "
            << budget_stats.num_points << ", wrong observations "
            << whole_stats.num_wrong_observations << " / "
            << budget_stats.num_wrong_observations << std::endl;
  EXPECT_GT(budget_stats.num_points, 0.98 * whole_stats.num_points);
  EXPECT_LT(budget_stats.num_wrong_observations,
            0.01 * budget_stats.num_observations);
  const auto mean_error = [](const colmap::Reconstruction& reconstruction) {
    double sum = 0;
    for (const auto& point3D : reconstruction.Points3D()) {
      sum += point3D.second.Error();
    }
    return sum / reconstruction.NumPoints3D();
  };
  std::cout << "mean reprojection error " << mean_error(whole) << " / "
            << mean_error(budget) << " px" << std::endl;
  EXPECT_LT(mean_error(budget), 1.05 * mean_error(whole));
}

// COLMAP's triangulator skips cameras whose parameters it deems bogus (an
// extra parameter above 1, or a focal outside [0.1, 10] x the image size);
// retriangulation uses the model's cameras as they are. Before, a camera
// with k1 = 1.5 left no point and the run failed (dino-363 after bundle
// adjustment of a model built with a 4x wrong focal).
TEST(Retriangulation, UsesCamerasThatColmapDeemsBogus) {
  Scene scene = MakeScene(20, 2000, 0.05, 6, /*radial_distortion=*/1.5);
  ASSERT_TRUE(scene.reconstruction.Camera(1).HasBogusParams(0.1, 10, 1));
  colmap::Reconstruction reconstruction = scene.reconstruction;
  RetriangulationOptions options;
  options.run_bundle_adjustment = false;
  const Status status =
      Retriangulate(options, scene.view_graph, &reconstruction);
  ASSERT_TRUE(status.ok()) << status.message();
  const PointStats stats = Evaluate(scene, reconstruction);
  EXPECT_GT(stats.num_points, 0.9 * scene.num_points_in_3_views);
  EXPECT_LT(stats.num_wrong_observations, 0.01 * stats.num_observations);
  EXPECT_LT(stats.median_position_error, 0.01);

  // With bundle adjustment (which needs points) the run succeeds too.
  reconstruction = scene.reconstruction;
  ASSERT_TRUE(
      Retriangulate(RetriangulationOptions(), scene.view_graph, &reconstruction)
          .ok());
  EXPECT_GT(reconstruction.NumPoints3D(), 0.9 * scene.num_points_in_3_views);
}

TEST(Retriangulation, MinNumMatchesDropsPairs) {
  Scene scene = MakeScene(12, 800, 0.0, 3);
  colmap::Reconstruction reconstruction = scene.reconstruction;
  RetriangulationOptions options;
  options.run_bundle_adjustment = false;
  options.min_num_matches = 1000000;  // No pair qualifies.
  EXPECT_FALSE(Retriangulate(options, scene.view_graph, &reconstruction).ok());
}

TEST(Retriangulation, InterruptAndBadInput) {
  Scene scene = MakeScene(12, 800, 0.0, 4);
  colmap::Reconstruction reconstruction = scene.reconstruction;
  Interrupt interrupt;
  interrupt.is_stopped = [] { return true; };
  const Status status = Retriangulate(
      RetriangulationOptions(), scene.view_graph, &reconstruction, interrupt);
  EXPECT_TRUE(status.cancelled());
  EXPECT_EQ(reconstruction.NumRegImages(), 12u);

  colmap::Reconstruction empty;
  EXPECT_FALSE(
      Retriangulate(RetriangulationOptions(), scene.view_graph, &empty).ok());
  RetriangulationOptions bad;
  bad.min_angle_deg = -1;
  EXPECT_EQ(bad.Check().message(), "min_angle_deg must be >= 0, is -1");
  EXPECT_EQ(bad.Check("GlobalMapper.tri_").message(),
            "GlobalMapper.tri_min_angle_deg must be >= 0, is -1");
  const Status refused =
      Retriangulate(bad, scene.view_graph, &reconstruction, Interrupt());
  EXPECT_EQ(refused.message(),
            "Invalid retriangulation options: min_angle_deg must be >= 0, is "
            "-1");
  // The final bundle adjustment's options, under their own prefix.
  RetriangulationOptions bad_ba;
  bad_ba.bundle_adjustment.loss_scale_px = -1;
  EXPECT_EQ(bad_ba.Check("GlobalMapper.tri_").message(),
            "GlobalMapper.tri_bundle_adjustment.loss_scale_px must be >= 0, "
            "is -1");
  // 0 is least squares, and accepted.
  RetriangulationOptions least_squares;
  least_squares.final_ba_loss_scale_px = 0;
  least_squares.bundle_adjustment.loss_scale_px = 0;
  EXPECT_TRUE(least_squares.Check().ok());
  least_squares.final_ba_loss_scale_px = -0.5;
  EXPECT_EQ(least_squares.Check().message(),
            "final_ba_loss_scale_px must be >= 0, is -0.5");
}

TEST(Retriangulation, Deterministic) {
  Scene scene = MakeScene(12, 800, 0.05, 5);
  colmap::Reconstruction first = scene.reconstruction;
  colmap::Reconstruction second = scene.reconstruction;
  RetriangulationOptions options;
  options.bundle_adjustment.num_threads = 1;
  ASSERT_TRUE(Retriangulate(options, scene.view_graph, &first).ok());
  ASSERT_TRUE(Retriangulate(options, scene.view_graph, &second).ok());
  ASSERT_EQ(first.NumPoints3D(), second.NumPoints3D());
  for (const auto& point3D : first.Points3D()) {
    ASSERT_TRUE(second.ExistsPoint3D(point3D.first));
    EXPECT_EQ(point3D.second.XYZ(), second.Point3D(point3D.first).XYZ());
  }
}

}  // namespace
}  // namespace glomap
