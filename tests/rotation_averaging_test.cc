#include "glomap/estimators/rotation_averaging.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "base/database.h"

namespace glomap {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Eigen::Quaterniond RandomRotation(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector4d v;
  for (int k = 0; k < 4; ++k) v(k) = normal(*rng);
  return Eigen::Quaterniond(v(0), v(1), v(2), v(3)).normalized();
}

// Isotropic noise rotation whose angle has root mean square sigma_deg (each
// rotation-vector component is N(0, sigma / sqrt(3))).
Eigen::Quaterniond NoiseRotation(double sigma_deg, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0,
                                          sigma_deg * kDegToRad / std::sqrt(3));
  const Eigen::Vector3d w(normal(*rng), normal(*rng), normal(*rng));
  if (w.norm() == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
}

double AngleDeg(const Eigen::Quaterniond& q) {
  return Eigen::AngleAxisd(q.normalized()).angle() / kDegToRad;
}

Eigen::Quaterniond ToQuaternion(const Eigen::Vector4d& qvec) {
  return Eigen::Quaterniond(qvec(0), qvec(1), qvec(2), qvec(3));
}

Eigen::Vector4d ToQvec(const Eigen::Quaterniond& q) {
  return Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
}

struct Scene {
  colmap::Reconstruction reconstruction;
  ViewGraph view_graph;
  // Ground-truth world-to-camera rotations by image id.
  std::map<colmap::image_t, Eigen::Quaterniond> rotations;
  // Pairs whose measurement was replaced by a gross outlier.
  std::set<colmap::image_pair_t> outlier_pairs;
};

void AddImages(int num_images, std::mt19937* rng, Scene* scene) {
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_PINHOLE", 500, 640, 480);
  scene->reconstruction.AddCamera(camera);
  for (int i = 0; i < num_images; ++i) {
    colmap::Image image;
    // Ids start at 3 so that nothing relies on id 1 being the gauge.
    image.SetImageId(i + 3);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(i + 3));
    scene->reconstruction.AddImage(image);
    scene->rotations[i + 3] = RandomRotation(rng);
  }
}

ImagePair& AddMeasuredPair(colmap::image_t id1, colmap::image_t id2,
                           const Eigen::Quaterniond& rotation2_from_1,
                           int num_inliers, Scene* scene) {
  ImagePair pair;
  pair.image_id1 = id1;
  pair.image_id2 = id2;
  pair.qvec2_from_1 = ToQvec(rotation2_from_1);
  pair.has_relative_pose = true;
  pair.inlier_idxs.resize(num_inliers);
  return scene->view_graph.AddPair(pair);
}

// Random pairs among the images with ids in [first_id, first_id + count);
// a chain keeps the graph connected.
void AddRandomPairs(colmap::image_t first_id, int count, int num_pairs,
                    double noise_deg, double outlier_ratio,
                    bool outliers_have_most_inliers, std::mt19937* rng,
                    Scene* scene) {
  std::uniform_int_distribution<int> image_dist(0, count - 1);
  std::uniform_int_distribution<int> inlier_dist(50, 500);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::set<std::pair<int, int>> used;
  for (int i = 0; i + 1 < count && static_cast<int>(used.size()) < num_pairs;
       ++i) {
    used.emplace(i, i + 1);
  }
  while (static_cast<int>(used.size()) < num_pairs) {
    int a = image_dist(*rng), b = image_dist(*rng);
    if (a == b) continue;
    used.emplace(std::min(a, b), std::max(a, b));
  }
  for (const auto& [a, b] : used) {
    const colmap::image_t id1 = first_id + a, id2 = first_id + b;
    const bool outlier = unit(*rng) < outlier_ratio;
    Eigen::Quaterniond measured;
    int num_inliers = inlier_dist(*rng);
    if (outlier) {
      measured = RandomRotation(rng);
      if (outliers_have_most_inliers) num_inliers += 1000;
      scene->outlier_pairs.insert(
          colmap::Database::ImagePairToPairId(id1, id2));
    } else {
      measured = NoiseRotation(noise_deg, rng) * scene->rotations.at(id2) *
                 scene->rotations.at(id1).conjugate();
    }
    AddMeasuredPair(id1, id2, measured, num_inliers, scene);
  }
}

Scene MakeScene(int num_images, int num_pairs, double noise_deg,
                double outlier_ratio, unsigned seed,
                bool outliers_have_most_inliers = false) {
  std::mt19937 rng(seed);
  Scene scene;
  AddImages(num_images, &rng, &scene);
  AddRandomPairs(3, num_images, num_pairs, noise_deg, outlier_ratio,
                 outliers_have_most_inliers, &rng, &scene);
  return scene;
}

// Runs rotation averaging on the scene's view graph and reconstruction.
Status AverageSceneRotations(
    Scene* scene, size_t* num_rejected = nullptr,
    const RotationAveragingOptions& options = RotationAveragingOptions()) {
  return AverageRotations(options, &scene->view_graph, &scene->reconstruction,
                          num_rejected);
}

// Gauge-free accuracy: the angle between estimated and true relative
// rotations over every pair of registered images.
struct ErrorStats {
  double mean_deg = 0;
  double max_deg = 0;
};

ErrorStats PairwiseErrors(const Scene& scene) {
  const std::vector<colmap::image_t>& ids = scene.reconstruction.RegImageIds();
  ErrorStats stats;
  size_t count = 0;
  for (size_t a = 0; a < ids.size(); ++a) {
    const Eigen::Quaterniond est_a =
        ToQuaternion(scene.reconstruction.Image(ids[a]).Qvec());
    for (size_t b = a + 1; b < ids.size(); ++b) {
      const Eigen::Quaterniond est_b =
          ToQuaternion(scene.reconstruction.Image(ids[b]).Qvec());
      const Eigen::Quaterniond true_relative =
          scene.rotations.at(ids[b]) * scene.rotations.at(ids[a]).conjugate();
      const double error =
          AngleDeg(est_b * est_a.conjugate() * true_relative.conjugate());
      stats.mean_deg += error;
      stats.max_deg = std::max(stats.max_deg, error);
      ++count;
    }
  }
  if (count > 0) stats.mean_deg /= count;
  return stats;
}

TEST(RotationAveraging, ExactDataIsRecovered) {
  Scene scene = MakeScene(50, 300, 0.0, 0.0, 1);
  size_t num_rejected = 123;
  const Status status = AverageSceneRotations(&scene, &num_rejected);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(num_rejected, 0);
  EXPECT_EQ(scene.reconstruction.NumRegImages(), 50);
  EXPECT_EQ(scene.view_graph.NumValidPairs(), 300);
  const ErrorStats errors = PairwiseErrors(scene);
  EXPECT_LT(errors.max_deg, 0.01);

  // Gauge: the smallest image id has the identity rotation; no translation.
  const colmap::Image& first = scene.reconstruction.Image(3);
  EXPECT_NEAR(std::abs(first.Qvec()(0)), 1.0, 1e-12);
  for (const auto& [image_id, image] : scene.reconstruction.Images()) {
    EXPECT_EQ(image.Tvec(), Eigen::Vector3d::Zero());
    EXPECT_NEAR(image.Qvec().norm(), 1.0, 1e-12);
  }
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    EXPECT_LT(RelativeRotationErrorDeg(pair, scene.reconstruction), 0.01);
  }
}

TEST(RotationAveraging, NoiseAndGrossOutliers) {
  Scene scene = MakeScene(200, 3000, 1.0, 0.2, 2);
  size_t num_rejected = 0;
  const Status status = AverageSceneRotations(&scene, &num_rejected);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(scene.reconstruction.NumRegImages(), 200);
  const ErrorStats errors = PairwiseErrors(scene);
  std::cout << "mean pairwise error " << errors.mean_deg << " deg, max "
            << errors.max_deg << " deg, rejected " << num_rejected << " of "
            << scene.view_graph.NumPairs() << " (" << scene.outlier_pairs.size()
            << " outliers)" << std::endl;
  EXPECT_LT(errors.mean_deg, 0.5);

  size_t num_outliers_kept = 0, num_inliers_rejected = 0, num_inliers = 0;
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (scene.outlier_pairs.count(pair_id)) {
      // A random rotation may by chance lie within the threshold.
      const Eigen::Quaterniond truth =
          scene.rotations.at(pair.image_id2) *
          scene.rotations.at(pair.image_id1).conjugate();
      const double true_error =
          AngleDeg(ToQuaternion(pair.qvec2_from_1) * truth.conjugate());
      if (true_error > 12.0) num_outliers_kept += pair.is_valid;
    } else {
      ++num_inliers;
      num_inliers_rejected += !pair.is_valid;
    }
  }
  EXPECT_EQ(num_outliers_kept, 0);
  EXPECT_LT(num_inliers_rejected, num_inliers / 100);
}

TEST(RotationAveraging, SpanningTreeOfOutliers) {
  // The outliers carry the most inliers. Without triangle support the
  // spanning-tree start is built almost entirely from wrong rotations and
  // the L1 stage must recover; with it, the tree should avoid them.
  for (const bool use_triangle_support : {false, true}) {
    Scene scene = MakeScene(100, 1500, 1.0, 0.2, 3,
                            /*outliers_have_most_inliers=*/true);
    RotationAveragingOptions options;
    options.use_triangle_support_in_tree = use_triangle_support;
    const Status status =
        AverageSceneRotations(&scene, /*num_rejected=*/nullptr, options);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(scene.reconstruction.NumRegImages(), 100);
    const ErrorStats errors = PairwiseErrors(scene);
    std::cout << "triangle support " << use_triangle_support
              << ": mean pairwise error " << errors.mean_deg << " deg"
              << std::endl;
    EXPECT_LT(errors.mean_deg, 0.5);
  }
}

TEST(RotationAveraging, ConsistentWrongRotations) {
  // Repeated structure: a third of the pairs between two halves of the scene
  // agree on the same wrong rotation of the second half (a 90 deg turn), so
  // the wrong measurements are consistent among themselves.
  std::mt19937 rng(4);
  Scene scene;
  AddImages(60, &rng, &scene);
  const Eigen::Quaterniond turn(
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int a = 0; a < 60; ++a) {
    for (int b = a + 1; b < 60; ++b) {
      if (unit(rng) > 0.3) continue;
      const colmap::image_t id1 = a + 3, id2 = b + 3;
      Eigen::Quaterniond rotation1 = scene.rotations.at(id1);
      Eigen::Quaterniond rotation2 = scene.rotations.at(id2);
      const bool crosses = (a < 30) != (b < 30);
      if (crosses && unit(rng) < 0.33) {
        // World-frame turn applied to the second half's cameras.
        if (b >= 30) rotation2 = rotation2 * turn;
        scene.outlier_pairs.insert(
            colmap::Database::ImagePairToPairId(id1, id2));
      }
      AddMeasuredPair(
          id1, id2,
          NoiseRotation(0.5, &rng) * rotation2 * rotation1.conjugate(), 100,
          &scene);
    }
  }
  const Status status = AverageSceneRotations(&scene);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(scene.reconstruction.NumRegImages(), 60);
  EXPECT_LT(PairwiseErrors(scene).mean_deg, 0.5);
  for (const colmap::image_pair_t pair_id : scene.outlier_pairs) {
    EXPECT_FALSE(scene.view_graph.Pairs().at(pair_id).is_valid);
  }
}

TEST(RotationAveraging, OnlyLargestComponentIsRegistered) {
  std::mt19937 rng(5);
  Scene scene;
  AddImages(53, &rng, &scene);                                // ids 3..55
  AddRandomPairs(3, 30, 120, 0.5, 0.0, false, &rng, &scene);  // ids 3..32
  AddRandomPairs(33, 20, 60, 0.5, 0.0, false, &rng, &scene);  // ids 33..52
  // Ids 53..55 have no pairs; 55 starts out registered and must be dropped.
  scene.reconstruction.RegisterImage(55);
  // A valid pair without a relative pose does not connect anything.
  ImagePair no_pose;
  no_pose.image_id1 = 10;
  no_pose.image_id2 = 40;
  scene.view_graph.AddPair(no_pose);

  size_t num_rejected = 0;
  const Status status = AverageSceneRotations(&scene, &num_rejected);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(scene.reconstruction.NumRegImages(), 30);
  for (colmap::image_t id = 3; id <= 55; ++id) {
    EXPECT_EQ(scene.reconstruction.IsImageRegistered(id), id <= 32) << id;
  }
  // Every pair touching the small component (and the bridging pair without
  // a pose) is invalidated; the large component's pairs stay valid.
  EXPECT_EQ(scene.view_graph.NumValidPairs(), 120);
  EXPECT_EQ(num_rejected, 61);
  EXPECT_LT(PairwiseErrors(scene).mean_deg, 0.5);
}

TEST(RotationAveraging, Deterministic) {
  Scene scene1 = MakeScene(80, 800, 1.0, 0.2, 6);
  Scene scene2 = MakeScene(80, 800, 1.0, 0.2, 6);
  ASSERT_TRUE(AverageSceneRotations(&scene1).ok());
  ASSERT_TRUE(AverageSceneRotations(&scene2).ok());
  for (const auto& [image_id, image] : scene1.reconstruction.Images()) {
    EXPECT_EQ(image.Qvec(), scene2.reconstruction.Image(image_id).Qvec());
  }
  for (const auto& [pair_id, pair] : scene1.view_graph.Pairs()) {
    EXPECT_EQ(pair.is_valid, scene2.view_graph.Pairs().at(pair_id).is_valid);
  }
}

TEST(RotationAveraging, ErrorsAreReportedAsStatus) {
  {
    Scene scene;  // No pairs at all.
    std::mt19937 rng(7);
    AddImages(3, &rng, &scene);
    EXPECT_FALSE(AverageSceneRotations(&scene).ok());
  }
  {
    Scene scene = MakeScene(5, 6, 0.0, 0.0, 8);
    AddMeasuredPair(3, 99, Eigen::Quaterniond::Identity(), 50, &scene);
    EXPECT_FALSE(AverageSceneRotations(&scene).ok());
  }
  {
    Scene scene = MakeScene(5, 6, 0.0, 0.0, 9);
    RotationAveragingOptions options;
    options.irls_loss_parameter_sigma_deg = 0;
    EXPECT_EQ(options.Check().message(),
              "irls_loss_parameter_sigma_deg must be > 0, is 0");
    EXPECT_FALSE(
        AverageSceneRotations(&scene, /*num_rejected=*/nullptr, options).ok());
  }
  {
    // Two images and one pair is the smallest solvable problem.
    Scene scene = MakeScene(2, 1, 0.0, 0.0, 10);
    ASSERT_TRUE(AverageSceneRotations(&scene).ok());
    EXPECT_LT(PairwiseErrors(scene).max_deg, 1e-6);
  }
}

// Rejection can shrink the solved component below a component that was
// never solved: the result must come from the solved images only (this threw
// std::out_of_range, looking up a rotation the last round never computed).
TEST(RotationAveraging, RejectionLeavesAnUnsolvedComponentLargest) {
  for (const int num_rounds : {1, 2}) {
    std::mt19937 rng(13);
    Scene scene;
    AddImages(11, &rng, &scene);  // ids 3..13
    const auto measure = [&scene](colmap::image_t id1, colmap::image_t id2,
                                  double noise_deg, std::mt19937* rng) {
      AddMeasuredPair(id1, id2,
                      NoiseRotation(noise_deg, rng) * scene.rotations.at(id2) *
                          scene.rotations.at(id1).conjugate(),
                      100, &scene);
    };
    // Solved component: a noisy clique 3..6, whose pairs all disagree with
    // the averaged rotations by more than the (tiny) threshold, and a chain
    // 6-7-8, which fits exactly.
    for (colmap::image_t id1 = 3; id1 <= 6; ++id1) {
      for (colmap::image_t id2 = id1 + 1; id2 <= 6; ++id2) {
        measure(id1, id2, 3.0, &rng);
      }
    }
    measure(6, 7, 0.0, &rng);
    measure(7, 8, 0.0, &rng);
    // A second component 9..13: smaller than 3..8, larger than 6..8.
    for (colmap::image_t id = 9; id < 13; ++id) measure(id, id + 1, 0.0, &rng);

    RotationAveragingOptions options;
    options.max_rotation_error_deg = 0.1;
    options.num_rounds = num_rounds;
    const Status status =
        AverageSceneRotations(&scene, /*num_rejected=*/nullptr, options);
    ASSERT_TRUE(status.ok()) << status.message();
    // What is left of 3..8 is smaller than 9..13 (the case of the crash) and
    // holds the chain; 9..13 was never solved and stays unregistered.
    EXPECT_LT(scene.reconstruction.NumRegImages(), 5);
    for (colmap::image_t id = 6; id <= 13; ++id) {
      EXPECT_EQ(scene.reconstruction.IsImageRegistered(id), id <= 8)
          << "image " << id << ", " << num_rounds << " rounds";
    }
    for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
      if (!pair.is_valid) continue;
      EXPECT_TRUE(scene.reconstruction.IsImageRegistered(pair.image_id1));
      EXPECT_TRUE(scene.reconstruction.IsImageRegistered(pair.image_id2));
      EXPECT_LT(RelativeRotationErrorDeg(pair, scene.reconstruction), 0.1);
    }
  }
}

// Scale check (not a correctness test): 2000 images, 60,000 pairs.
TEST(RotationAveraging, Timing2000Images60000Pairs) {
  Scene scene = MakeScene(2000, 60000, 1.0, 0.1, 11);
  const auto start = std::chrono::steady_clock::now();
  size_t num_rejected = 0;
  const Status status = AverageSceneRotations(&scene, &num_rejected);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  ASSERT_TRUE(status.ok()) << status.message();
  std::cout << "2000 images / 60000 pairs: " << seconds << " s, rejected "
            << num_rejected << ", mean pairwise error "
            << PairwiseErrors(scene).mean_deg << " deg" << std::endl;
  EXPECT_EQ(scene.reconstruction.NumRegImages(), 2000);
}

// Large-scale check, run by hand (--gtest_also_run_disabled_tests):
// 10,000 images, 300,000 pairs. GLOMAP_RA_LOCAL_GRAPH=1 matches each image
// with nearby ids only (a sequence-like graph, as in real captures) instead
// of uniformly random partners (the worst case for fill-in).
TEST(RotationAveraging, DISABLED_Timing10000Images300000Pairs) {
  const int kNumImages = 10000, kNumPairs = 300000;
  Scene scene;
  std::mt19937 rng(12);
  if (std::getenv("GLOMAP_RA_LOCAL_GRAPH") == nullptr) {
    scene = MakeScene(kNumImages, kNumPairs, 1.0, 0.1, 12);
  } else {
    AddImages(kNumImages, &rng, &scene);
    std::uniform_int_distribution<int> offset_dist(1, 100);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::set<std::pair<int, int>> used;
    for (int i = 0; i + 1 < kNumImages; ++i) used.emplace(i, i + 1);
    std::uniform_int_distribution<int> image_dist(0, kNumImages - 1);
    while (static_cast<int>(used.size()) < kNumPairs) {
      const int a = image_dist(rng), b = a + offset_dist(rng);
      if (b < kNumImages) used.emplace(a, b);
    }
    for (const auto& [a, b] : used) {
      const colmap::image_t id1 = a + 3, id2 = b + 3;
      const Eigen::Quaterniond measured =
          unit(rng) < 0.1 ? RandomRotation(&rng)
                          : NoiseRotation(1.0, &rng) * scene.rotations.at(id2) *
                                scene.rotations.at(id1).conjugate();
      AddMeasuredPair(id1, id2, measured, 100, &scene);
    }
  }
  const auto start = std::chrono::steady_clock::now();
  const Status status = AverageSceneRotations(&scene);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  ASSERT_TRUE(status.ok()) << status.message();
  // Accuracy over the registered images with the first 600 ids.
  Scene sample;
  for (const colmap::image_t image_id : scene.reconstruction.RegImageIds()) {
    if (image_id >= 603) continue;
    colmap::Image image = scene.reconstruction.Image(image_id);
    image.SetRegistered(false);
    sample.reconstruction.AddImage(image);
    sample.reconstruction.RegisterImage(image_id);
    sample.rotations[image_id] = scene.rotations.at(image_id);
  }
  std::cout << "10000 images / 300000 pairs: " << seconds << " s, "
            << scene.reconstruction.NumRegImages()
            << " registered, mean pairwise error (first 600 ids) "
            << PairwiseErrors(sample).mean_deg << " deg" << std::endl;
  EXPECT_GE(scene.reconstruction.NumRegImages(), kNumImages * 0.99);
  EXPECT_LT(PairwiseErrors(sample).mean_deg, 0.5);
}

}  // namespace
}  // namespace glomap
