#include "glomap/estimators/relative_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "base/database.h"
#include "base/pose.h"
#include "estimators/two_view_geometry.h"

namespace glomap {
namespace {

using TwoViewGeometry = colmap::TwoViewGeometry;

constexpr size_t kWidth = 1200;
constexpr size_t kHeight = 900;

struct SceneSpec {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // cam2_from_cam1
  Eigen::Vector3d t = Eigen::Vector3d::UnitX();     // cam2_from_cam1
  int num_matches = 500;
  double outlier_ratio = 0.3;
  double noise_px = 0.3;
  int config = TwoViewGeometry::CALIBRATED;
  // Points on the plane n^T X = d (camera 1 frame) when set.
  bool planar = false;
  // Stores the pair's F (in pixels, from the camera's calibration matrix and
  // the motion below) as a database's two-view geometry gives it.
  bool store_fundamental = false;
  // The motion whose F is stored, when it is not the true one.
  std::optional<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> stored_motion;
};

struct TruePair {
  colmap::image_pair_t pair_id = 0;
  std::vector<bool> is_inlier;  // per match
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

Eigen::Vector3d RandomUnitVector(std::mt19937* rng) {
  std::normal_distribution<double> normal(0, 1);
  return Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
}

Eigen::Matrix3d RandomRotation(double max_angle_deg, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.3, 1);
  return Eigen::AngleAxisd(uniform(*rng) * max_angle_deg * M_PI / 180,
                           RandomUnitVector(rng))
      .toRotationMatrix();
}

// Adds two images observing a random scene through `camera_id` and the pair
// between them; returns the ground truth.
TruePair AddTwoViewScene(const SceneSpec& spec, colmap::camera_t camera_id,
                         std::mt19937* rng,
                         colmap::Reconstruction* reconstruction,
                         ViewGraph* view_graph) {
  const colmap::Camera& camera = reconstruction->Camera(camera_id);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, spec.noise_px);
  const Eigen::Vector3d plane_normal =
      Eigen::Vector3d(-0.3, 0.1, 1).normalized();
  const double plane_distance = 6;

  std::vector<Eigen::Vector2d> keypoints1, keypoints2;
  TruePair truth;
  truth.R = spec.R;
  truth.t = spec.t.norm() > 0 ? spec.t.normalized() : spec.t;
  while (static_cast<int>(keypoints1.size()) < spec.num_matches) {
    const Eigen::Vector2d pixel1(u(*rng) * kWidth, u(*rng) * kHeight);
    const Eigen::Vector3d ray1 = camera.ImageToWorld(pixel1).homogeneous();
    const double depth =
        spec.planar ? plane_distance / plane_normal.dot(ray1) : 4 + 6 * u(*rng);
    const Eigen::Vector3d X2 = spec.R * (depth * ray1) + spec.t;
    if (depth <= 0 || X2(2) <= 0.5) continue;
    const Eigen::Vector2d pixel2 = camera.WorldToImage(X2.hnormalized());
    if (pixel2(0) < 0 || pixel2(1) < 0 || pixel2(0) > kWidth ||
        pixel2(1) > kHeight) {
      continue;
    }
    const bool is_outlier = u(*rng) < spec.outlier_ratio;
    keypoints1.push_back(pixel1 + Eigen::Vector2d(noise(*rng), noise(*rng)));
    keypoints2.push_back(
        is_outlier ? Eigen::Vector2d(u(*rng) * kWidth, u(*rng) * kHeight)
                   : pixel2 + Eigen::Vector2d(noise(*rng), noise(*rng)));
    truth.is_inlier.push_back(!is_outlier);
  }

  const colmap::image_t image_id1 = reconstruction->NumImages() + 1;
  const colmap::image_t image_id2 = image_id1 + 1;
  for (const colmap::image_t image_id : {image_id1, image_id2}) {
    colmap::Image image;
    image.SetImageId(image_id);
    image.SetCameraId(camera_id);
    image.SetName("image" + std::to_string(image_id));
    image.SetPoints2D(image_id == image_id1 ? keypoints1 : keypoints2);
    reconstruction->AddImage(image);
  }

  ImagePair pair;
  pair.image_id1 = image_id1;
  pair.image_id2 = image_id2;
  pair.config = spec.config;
  const Eigen::Matrix3d K = camera.CalibrationMatrix();
  if (spec.planar) {
    pair.H = K * (spec.R + spec.t * plane_normal.transpose() / plane_distance) *
             K.inverse();
  } else if (spec.t.norm() == 0) {
    pair.H = K * spec.R * K.inverse();
  }
  if (spec.store_fundamental) {
    const auto& [R, t] =
        spec.stored_motion.value_or(std::make_pair(spec.R, spec.t));
    Eigen::Matrix3d t_cross;
    t_cross << 0, -t(2), t(1), t(2), 0, -t(0), -t(1), t(0), 0;
    pair.F = K.inverse().transpose() * t_cross * R * K.inverse();
  }
  for (size_t i = 0; i < keypoints1.size(); ++i) {
    pair.matches.emplace_back(i, i);
  }
  pair.num_raw_matches = static_cast<int>(keypoints1.size());
  truth.pair_id = colmap::Database::ImagePairToPairId(image_id1, image_id2);
  view_graph->AddPair(pair);
  return truth;
}

// Pairs of images on one camera (id 1) of `camera_model`, each pair seeing a
// scene of its own drawn from `rng`.
struct TwoViewScenes {
  TwoViewScenes(unsigned seed, const std::string& camera_model) : rng(seed) {
    colmap::Camera camera;
    camera.SetCameraId(1);
    camera.InitializeWithName(camera_model, 1000, kWidth, kHeight);
    if (camera_model == "SIMPLE_RADIAL") {
      camera.Params(3) = -0.08;
    }
    reconstruction.AddCamera(camera);
  }

  // Adds a pair seeing a scene as `spec` says; returns its ground truth.
  TruePair Add(const SceneSpec& spec) {
    return AddTwoViewScene(spec, 1, &rng, &reconstruction, &view_graph);
  }

  std::mt19937 rng;
  colmap::Reconstruction reconstruction;
  ViewGraph view_graph;
};

// Forward and sideways motion turning by up to `max_angle_deg`, but no
// camera behind the other.
SceneSpec RandomMotion(double max_angle_deg, std::mt19937* rng) {
  SceneSpec spec;
  spec.R = RandomRotation(max_angle_deg, rng);
  spec.t = RandomUnitVector(rng);
  spec.t(2) = std::abs(spec.t(2));
  return spec;
}

double RotationErrorDeg(const Eigen::Vector4d& qvec,
                        const Eigen::Matrix3d& R_true) {
  const Eigen::Matrix3d R = colmap::QuaternionToRotationMatrix(qvec);
  return Eigen::AngleAxisd(R * R_true.transpose()).angle() * 180 / M_PI;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double cos = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(cos, -1.0, 1.0)) * 180 / M_PI;
}

struct InlierScore {
  double recall = 0;            // true inliers found / true inliers
  double outlier_accepted = 0;  // outliers kept / outliers
};

InlierScore ScoreInliers(const ImagePair& pair, const TruePair& truth) {
  int num_true = 0, num_outliers = 0, found = 0, wrong = 0;
  for (const bool inlier : truth.is_inlier)
    (inlier ? num_true : num_outliers)++;
  for (const int idx : pair.inlier_idxs)
    (truth.is_inlier[idx] ? found : wrong)++;
  InlierScore score;
  score.recall = found / std::max(1.0, static_cast<double>(num_true));
  score.outlier_accepted =
      wrong / std::max(1.0, static_cast<double>(num_outliers));
  return score;
}

void ExpectAccuratePair(const ImagePair& pair, const TruePair& truth) {
  ASSERT_TRUE(pair.is_valid);
  ASSERT_TRUE(pair.has_relative_pose);
  EXPECT_NEAR(pair.tvec2_from_1.norm(), 1, 1e-9);
  EXPECT_LT(RotationErrorDeg(pair.qvec2_from_1, truth.R), 0.5);
  EXPECT_LT(AngleDeg(pair.tvec2_from_1, truth.t), 1.0);
  const InlierScore score = ScoreInliers(pair, truth);
  EXPECT_GT(score.recall, 0.95);
  EXPECT_LT(score.outlier_accepted, 0.05);
}

void ExpectAccuratePairs(const ViewGraph& view_graph,
                         const std::vector<TruePair>& truths) {
  for (const TruePair& truth : truths) {
    SCOPED_TRACE(truth.pair_id);
    ExpectAccuratePair(view_graph.Pairs().at(truth.pair_id), truth);
  }
}

TEST(RelativePose, CalibratedPairsWithOutliers) {
  TwoViewScenes scenes(/*seed=*/1, "PINHOLE");
  std::vector<TruePair> truths;
  for (int i = 0; i < 6; ++i) {
    truths.push_back(scenes.Add(RandomMotion(20, &scenes.rng)));
  }
  RelativePoseStatistics statistics;
  statistics.num_invalidated_pairs = 99;
  const Status status =
      EstimateRelativePoses(RelativePoseOptions(), scenes.reconstruction,
                            &scenes.view_graph, &statistics);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(statistics.num_invalidated_pairs, 0);
  // These pairs have no stored F: every pose came from a RANSAC.
  EXPECT_EQ(statistics.num_from_ransac, 6);
  EXPECT_EQ(statistics.num_from_stored_geometry, 0);
  ExpectAccuratePairs(scenes.view_graph, truths);
}

TEST(RelativePose, UncalibratedDistortedPairs) {
  TwoViewScenes scenes(/*seed=*/2, "SIMPLE_RADIAL");
  std::vector<TruePair> truths;
  for (int i = 0; i < 4; ++i) {
    SceneSpec spec;
    spec.R = RandomRotation(15, &scenes.rng);
    spec.t = Eigen::Vector3d(1, 0.2 * i - 0.3, 0.3);
    spec.config = TwoViewGeometry::UNCALIBRATED;
    spec.noise_px = 0.8;  // The UNCALIBRATED threshold is 4 px.
    truths.push_back(scenes.Add(spec));
  }
  ASSERT_TRUE(EstimateRelativePoses(RelativePoseOptions(),
                                    scenes.reconstruction, &scenes.view_graph)
                  .ok());
  ExpectAccuratePairs(scenes.view_graph, truths);
}

TEST(RelativePose, InvalidatesPairsWithTooFewInliers) {
  TwoViewScenes scenes(/*seed=*/3, "PINHOLE");
  SceneSpec few;
  few.num_matches = 20;
  few.outlier_ratio = 0;
  const TruePair too_few = scenes.Add(few);
  SceneSpec normal;
  normal.outlier_ratio = 0;
  const TruePair low_ratio = scenes.Add(normal);
  // Most of the raw matches did not survive verification.
  ViewGraph& view_graph = scenes.view_graph;
  view_graph.Pairs().at(low_ratio.pair_id).num_raw_matches = 5000;
  SceneSpec garbage;
  garbage.outlier_ratio = 1.0;
  const TruePair all_outliers = scenes.Add(garbage);
  const TruePair good = scenes.Add(normal);

  RelativePoseStatistics statistics;
  ASSERT_TRUE(EstimateRelativePoses(RelativePoseOptions(),
                                    scenes.reconstruction, &view_graph,
                                    &statistics)
                  .ok());
  EXPECT_FALSE(view_graph.Pairs().at(too_few.pair_id).is_valid);
  EXPECT_FALSE(view_graph.Pairs().at(low_ratio.pair_id).is_valid);
  EXPECT_FALSE(view_graph.Pairs().at(all_outliers.pair_id).is_valid);
  EXPECT_TRUE(view_graph.Pairs().at(good.pair_id).is_valid);
  EXPECT_EQ(statistics.num_invalidated_pairs, 3);
  // Invalid pairs keep no inlier indices (the low-ratio pair had plenty);
  // valid ones hold theirs without spare capacity.
  for (const colmap::image_pair_t pair_id :
       {too_few.pair_id, low_ratio.pair_id, all_outliers.pair_id}) {
    EXPECT_EQ(view_graph.Pairs().at(pair_id).inlier_idxs.capacity(), 0u);
  }
  const std::vector<int>& good_inliers =
      view_graph.Pairs().at(good.pair_id).inlier_idxs;
  EXPECT_GE(good_inliers.size(), 30u);
  EXPECT_EQ(good_inliers.capacity(), good_inliers.size());

  RelativePoseOptions bad_options;
  bad_options.min_inlier_ratio = 2;
  EXPECT_FALSE(
      EstimateRelativePoses(bad_options, scenes.reconstruction, &view_graph)
          .ok());
}

TEST(RelativePose, DeterministicAcrossRunsAndThreads) {
  TwoViewScenes scenes(/*seed=*/4, "PINHOLE");
  for (int i = 0; i < 12; ++i) {
    SceneSpec spec = RandomMotion(20, &scenes.rng);
    spec.outlier_ratio = 0.5;
    scenes.Add(spec);
  }
  auto run = [&](int num_threads) {
    ViewGraph copy = scenes.view_graph;
    RelativePoseOptions options;
    options.num_threads = num_threads;
    EXPECT_TRUE(
        EstimateRelativePoses(options, scenes.reconstruction, &copy).ok());
    return copy;
  };
  const ViewGraph first = run(2);
  for (const int num_threads : {2, 1, 3}) {
    const ViewGraph other = run(num_threads);
    for (const auto& [pair_id, pair] : first.Pairs()) {
      const ImagePair& other_pair = other.Pairs().at(pair_id);
      EXPECT_EQ(pair.is_valid, other_pair.is_valid);
      EXPECT_EQ(pair.qvec2_from_1, other_pair.qvec2_from_1);
      EXPECT_EQ(pair.tvec2_from_1, other_pair.tvec2_from_1);
      EXPECT_EQ(pair.inlier_idxs, other_pair.inlier_idxs);
    }
  }
}

TEST(RelativePose, PureRotationAndPlanarPairsDoNotCrash) {
  TwoViewScenes scenes(/*seed=*/5, "PINHOLE");
  SceneSpec rotation;
  rotation.R = RandomRotation(15, &scenes.rng);
  rotation.t = Eigen::Vector3d::Zero();
  rotation.config = TwoViewGeometry::PANORAMIC;
  const TruePair panoramic = scenes.Add(rotation);
  // The same pure rotation labelled CALIBRATED (a matcher may do that).
  rotation.config = TwoViewGeometry::CALIBRATED;
  const TruePair rotation_as_calibrated = scenes.Add(rotation);
  SceneSpec plane;
  plane.R = RandomRotation(15, &scenes.rng);
  plane.t = Eigen::Vector3d(1, 0.1, 0.2);
  plane.planar = true;
  plane.config = TwoViewGeometry::PLANAR;
  const TruePair planar = scenes.Add(plane);

  const ViewGraph& view_graph = scenes.view_graph;
  ASSERT_TRUE(EstimateRelativePoses(RelativePoseOptions(),
                                    scenes.reconstruction, &scenes.view_graph)
                  .ok());
  for (const TruePair* truth : {&panoramic, &rotation_as_calibrated, &planar}) {
    const ImagePair& pair = view_graph.Pairs().at(truth->pair_id);
    if (pair.has_relative_pose) {
      EXPECT_TRUE(pair.qvec2_from_1.allFinite());
      EXPECT_TRUE(pair.tvec2_from_1.allFinite());
    }
    const InlierScore score = ScoreInliers(pair, *truth);
    std::cout << "pair " << truth->pair_id << " valid " << pair.is_valid
              << " rotation error "
              << RotationErrorDeg(pair.qvec2_from_1, truth->R)
              << " deg, inlier recall " << score.recall
              << ", outliers accepted " << score.outlier_accepted << std::endl;
  }
  // The homography test verifies panoramic and planar pairs by the
  // database H, independent of the (ill-defined) translation.
  const InlierScore panoramic_score =
      ScoreInliers(view_graph.Pairs().at(panoramic.pair_id), panoramic);
  EXPECT_GT(panoramic_score.recall, 0.95);
  EXPECT_LT(panoramic_score.outlier_accepted, 0.05);
  const ImagePair& planar_pair = view_graph.Pairs().at(planar.pair_id);
  EXPECT_TRUE(planar_pair.is_valid);
  EXPECT_LT(RotationErrorDeg(planar_pair.qvec2_from_1, planar.R), 0.5);
  EXPECT_LT(AngleDeg(planar_pair.tvec2_from_1, planar.t), 1.0);
  EXPECT_GT(ScoreInliers(planar_pair, planar).recall, 0.95);
}

// With the database's F stored, the poses come from it (no RANSAC), as
// accurate as the RANSAC's: calibrated pinhole pairs, and distorted pairs
// whose F (as 3.8's matcher fits it in distorted pixels) ignores the
// distortion; the refinement on normalised coordinates removes that bias.
TEST(RelativePose, StoredGeometryGivesThePosesWithoutRansac) {
  for (const std::string camera_model : {"PINHOLE", "SIMPLE_RADIAL"}) {
    SCOPED_TRACE(camera_model);
    TwoViewScenes scenes(/*seed=*/7, camera_model);
    std::vector<TruePair> truths;
    for (int i = 0; i < 8; ++i) {
      SceneSpec spec = RandomMotion(20, &scenes.rng);
      spec.store_fundamental = true;
      if (camera_model == "SIMPLE_RADIAL") {
        spec.config = TwoViewGeometry::UNCALIBRATED;
        spec.noise_px = 0.8;
      }
      truths.push_back(scenes.Add(spec));
    }
    for (const bool use_stored_geometry : {true, false}) {
      SCOPED_TRACE(use_stored_geometry);
      ViewGraph view_graph = scenes.view_graph;
      RelativePoseOptions options;
      options.use_stored_geometry = use_stored_geometry;
      RelativePoseStatistics statistics;
      ASSERT_TRUE(EstimateRelativePoses(options, scenes.reconstruction,
                                        &view_graph, &statistics)
                      .ok());
      EXPECT_EQ(statistics.num_invalidated_pairs, 0);
      EXPECT_EQ(statistics.num_from_stored_geometry,
                use_stored_geometry ? truths.size() : 0);
      EXPECT_EQ(statistics.num_from_ransac,
                use_stored_geometry ? 0 : truths.size());
      ExpectAccuratePairs(view_graph, truths);
    }
  }
}

// A stored F that fits the matches only coarsely (as 3.8's matcher fits it,
// at 4 px on raw matches): a part of the true inliers agrees with it at this
// stage's 1 px; the pose still reaches all of them (the inliers are selected
// again while the refinement gains them, as LO-RANSAC does) and the
// RANSAC's accuracy.
TEST(RelativePose, CoarseStoredGeometryReachesAllInliers) {
  TwoViewScenes scenes(/*seed=*/9, "PINHOLE");
  std::vector<TruePair> truths;
  for (int i = 0; i < 8; ++i) {
    SceneSpec spec = RandomMotion(20, &scenes.rng);
    spec.noise_px = 0.5;
    spec.store_fundamental = true;
    const Eigen::Matrix3d R_off =
        Eigen::AngleAxisd(0.06 * M_PI / 180, RandomUnitVector(&scenes.rng))
            .toRotationMatrix();
    spec.stored_motion = std::make_pair(R_off * spec.R, spec.t);
    truths.push_back(scenes.Add(spec));
  }
  std::array<ViewGraph, 2> results = {scenes.view_graph, scenes.view_graph};
  for (const bool use_stored_geometry : {true, false}) {
    RelativePoseOptions options;
    options.use_stored_geometry = use_stored_geometry;
    RelativePoseStatistics statistics;
    ASSERT_TRUE(EstimateRelativePoses(options, scenes.reconstruction,
                                      &results[use_stored_geometry],
                                      &statistics)
                    .ok());
    EXPECT_EQ(statistics.num_from_stored_geometry,
              use_stored_geometry ? truths.size() : 0);
  }
  for (const TruePair& truth : truths) {
    SCOPED_TRACE(truth.pair_id);
    const ImagePair& stored = results[1].Pairs().at(truth.pair_id);
    const ImagePair& ransac = results[0].Pairs().at(truth.pair_id);
    ASSERT_TRUE(stored.is_valid);
    EXPECT_LT(RotationErrorDeg(stored.qvec2_from_1, truth.R), 0.5);
    EXPECT_LT(AngleDeg(stored.tvec2_from_1, truth.t), 1.0);
    // 0.5 px noise puts a few true inliers beyond the 1 px threshold with
    // any pose: the bar is the RANSAC's recall on the same matches.
    EXPECT_GE(ScoreInliers(stored, truth).recall,
              ScoreInliers(ransac, truth).recall - 0.01);
    EXPECT_LT(ScoreInliers(stored, truth).outlier_accepted, 0.05);
  }
}

// A stored F that does not fit the matches (another motion: a database
// edited by hand, or a pair verified with another camera) is not trusted:
// that pair's pose comes from a RANSAC and is right; a stored F of a planar
// pair is never used.
TEST(RelativePose, StoredGeometryThatDoesNotFitFallsBackToRansac) {
  TwoViewScenes scenes(/*seed=*/8, "PINHOLE");
  std::vector<TruePair> truths;
  SceneSpec wrong = RandomMotion(20, &scenes.rng);
  wrong.store_fundamental = true;
  wrong.stored_motion = std::make_pair(RandomRotation(30, &scenes.rng),
                                       RandomUnitVector(&scenes.rng));
  truths.push_back(scenes.Add(wrong));
  SceneSpec right = RandomMotion(20, &scenes.rng);
  right.store_fundamental = true;
  truths.push_back(scenes.Add(right));
  SceneSpec plane;
  plane.R = RandomRotation(15, &scenes.rng);
  plane.t = Eigen::Vector3d(1, 0.1, 0.2);
  plane.planar = true;
  plane.config = TwoViewGeometry::PLANAR;
  plane.store_fundamental = true;
  truths.push_back(scenes.Add(plane));
  RelativePoseStatistics statistics;
  ASSERT_TRUE(EstimateRelativePoses(RelativePoseOptions(),
                                    scenes.reconstruction, &scenes.view_graph,
                                    &statistics)
                  .ok());
  EXPECT_EQ(statistics.num_from_stored_geometry, 1);
  EXPECT_EQ(statistics.num_from_ransac, 2);
  ExpectAccuratePairs(scenes.view_graph, truths);
}

// Throughput on verified matches (10% outliers), as in a real database:
// prints pairs per second, asserts only a generous bound.
TEST(RelativePose, Throughput) {
  TwoViewScenes scenes(/*seed=*/6, "SIMPLE_RADIAL");
  const int kNumPairs = 100;
  for (int i = 0; i < kNumPairs; ++i) {
    SceneSpec spec = RandomMotion(20, &scenes.rng);
    spec.num_matches = 1000;
    spec.outlier_ratio = 0.1;
    spec.store_fundamental = true;
    scenes.Add(spec);
  }
  for (const bool use_stored_geometry : {true, false}) {
    ViewGraph view_graph = scenes.view_graph;
    RelativePoseOptions options;
    options.use_stored_geometry = use_stored_geometry;
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(
        EstimateRelativePoses(options, scenes.reconstruction, &view_graph)
            .ok());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    std::cout << kNumPairs << " pairs x 1000 matches in " << seconds << " s ("
              << kNumPairs / seconds << " pairs/s), "
              << (use_stored_geometry ? "from the stored F" : "RANSAC")
              << std::endl;
    EXPECT_EQ(view_graph.NumValidPairs(), kNumPairs);
    EXPECT_LT(seconds, 60);
  }
}

}  // namespace
}  // namespace glomap
