#include "glomap/synthetic_scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "base/database.h"
#include "base/pose.h"
#include "estimators/two_view_geometry.h"
#include "glomap/database_reader.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

using colmap::TwoViewGeometry;

struct Scene {
  colmap::Reconstruction ground_truth;
  colmap::Reconstruction reconstruction;  // read back from the database
  ViewGraph view_graph;
  std::string database_path;
};

void MakeScene(const SyntheticSceneOptions& options, const std::string& name,
               Scene* scene) {
  const std::string dir = testing::CreateTestDir("synthetic_scene_" + name);
  scene->database_path = dir + "/database.db";
  const Status status =
      WriteSyntheticScene(options, scene->database_path, &scene->ground_truth);
  ASSERT_TRUE(status.ok()) << status.message();
  DatabaseReaderOptions reader_options;
  const Status read_status =
      ReadDatabase(scene->database_path, reader_options, &scene->reconstruction,
                   &scene->view_graph);
  ASSERT_TRUE(read_status.ok()) << read_status.message();
}

// Digest of everything the pipeline reads from the database.
std::string ContentDigest(const Scene& scene) {
  std::ostringstream out;
  out.precision(17);
  std::vector<colmap::image_t> image_ids;
  for (const auto& [image_id, image] : scene.reconstruction.Images()) {
    image_ids.push_back(image_id);
  }
  std::sort(image_ids.begin(), image_ids.end());
  for (const colmap::image_t image_id : image_ids) {
    const colmap::Image& image = scene.reconstruction.Image(image_id);
    out << image.Name() << image.CameraId();
    for (const auto& point2D : image.Points2D())
      out << point2D.XY().transpose();
  }
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    out << pair_id << ' ' << pair.config << ' ' << pair.num_raw_matches << ' '
        << pair.F << pair.E;
    for (const auto& match : pair.matches) {
      out << match.point2D_idx1 << ',' << match.point2D_idx2 << ';';
    }
  }
  std::ostringstream digest;
  digest << std::hash<std::string>()(out.str()) << ':' << out.str().size();
  return digest.str();
}

// The fraction of a pair's matches whose keypoints see the same true point.
double TrueMatchFraction(const colmap::Reconstruction& ground_truth,
                         const ImagePair& pair) {
  const colmap::Image& image1 = ground_truth.Image(pair.image_id1);
  const colmap::Image& image2 = ground_truth.Image(pair.image_id2);
  size_t num_true = 0;
  for (const auto& match : pair.matches) {
    const auto& point1 = image1.Point2D(match.point2D_idx1);
    const auto& point2 = image2.Point2D(match.point2D_idx2);
    num_true += point1.HasPoint3D() && point1.Point3DId() == point2.Point3DId();
  }
  return pair.matches.empty()
             ? 0
             : static_cast<double>(num_true) / pair.matches.size();
}

double TotalTrueMatchFraction(const colmap::Reconstruction& ground_truth,
                              const ViewGraph& view_graph) {
  double num_true = 0;
  size_t num_matches = 0;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    num_true += TrueMatchFraction(ground_truth, pair) * pair.matches.size();
    num_matches += pair.matches.size();
  }
  return num_matches == 0 ? 0 : num_true / num_matches;
}

size_t TotalRawMatches(const ViewGraph& view_graph) {
  size_t total = 0;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    total += pair.num_raw_matches;
  }
  return total;
}

// Checks the ground truth against itself and the database content.
void CheckGroundTruth(const SyntheticSceneOptions& options,
                      const Scene& scene) {
  const colmap::Reconstruction& gt = scene.ground_truth;
  ASSERT_EQ(gt.NumImages(), options.num_images);
  ASSERT_EQ(gt.NumRegImages(), options.num_images);
  ASSERT_EQ(gt.NumCameras(), options.num_cameras);
  ASSERT_EQ(scene.reconstruction.NumImages(), options.num_images);
  ASSERT_EQ(scene.reconstruction.NumCameras(), options.num_cameras);
  EXPECT_GT(gt.NumPoints3D(), 0);

  // The stored keypoints are the ground truth's Points2D, in the same order.
  for (const auto& [image_id, gt_image] : gt.Images()) {
    const colmap::Image& image = scene.reconstruction.Image(image_id);
    EXPECT_EQ(image.Name(), gt_image.Name());
    EXPECT_EQ(image.CameraId(), gt_image.CameraId());
    ASSERT_EQ(image.NumPoints2D(), gt_image.NumPoints2D());
    for (colmap::point2D_t k = 0; k < image.NumPoints2D(); ++k) {
      ASSERT_EQ(image.Point2D(k).XY(), gt_image.Point2D(k).XY());
    }
    EXPECT_LE(image.NumPoints2D(), options.max_keypoints_per_image);
  }
  EXPECT_EQ(gt.Image(1).Name(), "image0001.png");

  // True poses project true points onto their keypoints within the noise.
  double sum_error = 0;
  size_t num_observations = 0;
  for (const auto& [point3D_id, point3D] : gt.Points3D()) {
    EXPECT_GE(point3D.Track().Length(), 2);
    for (const auto& element : point3D.Track().Elements()) {
      const colmap::Image& image = gt.Image(element.image_id);
      const colmap::Camera& camera = gt.Camera(image.CameraId());
      const Eigen::Vector3d in_camera =
          colmap::QuaternionRotatePoint(image.Qvec(), point3D.XYZ()) +
          image.Tvec();
      ASSERT_GT(in_camera.z(), 0);
      const Eigen::Vector2d projection =
          camera.WorldToImage(in_camera.hnormalized());
      const double error =
          (projection - image.Point2D(element.point2D_idx).XY()).norm();
      EXPECT_LT(error, 6 * options.pixel_noise_px + 1e-3);
      sum_error += error;
      ++num_observations;
    }
  }
  ASSERT_GT(num_observations, 0);
  // The mean of a 2D Gaussian's norm is sigma * sqrt(pi / 2).
  const double mean_error = sum_error / num_observations;
  EXPECT_NEAR(mean_error, options.pixel_noise_px * 1.2533,
              0.15 * options.pixel_noise_px + 1e-3);
  // About 600 visible points per image.
  const double observations_per_image =
      static_cast<double>(num_observations) / options.num_images;
  EXPECT_GT(observations_per_image, 350);
  EXPECT_LT(observations_per_image, 900);

  // Every image takes part in verified pairs, and every pair is canonical.
  EXPECT_EQ(scene.view_graph.ImagesWithValidPairs().size(),
            static_cast<size_t>(options.num_images));
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    EXPECT_LT(pair.image_id1, pair.image_id2);
    EXPECT_GE(pair.num_raw_matches, static_cast<int>(pair.matches.size()));
  }
}

TEST(SyntheticScene, RingWithColmapVerification) {
  SyntheticSceneOptions options;
  options.num_images = 15;
  Scene scene;
  MakeScene(options, "ring_colmap", &scene);
  CheckGroundTruth(options, scene);
  EXPECT_TRUE(scene.reconstruction.Camera(1).HasPriorFocalLength());
  EXPECT_EQ(scene.reconstruction.Camera(1).Params(),
            scene.ground_truth.Camera(1).Params());
  size_t num_calibrated = 0;
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    num_calibrated += pair.config == TwoViewGeometry::CALIBRATED;
    EXPECT_GT(TrueMatchFraction(scene.ground_truth, pair), 0.99);
    // Without wrong matches, RANSAC keeps nearly all raw matches.
    EXPECT_GT(pair.matches.size(), 0.9 * pair.num_raw_matches);
  }
  EXPECT_EQ(num_calibrated, scene.view_graph.NumPairs());
}

TEST(SyntheticScene, WrongMatchesAreAddedAndRejected) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.max_pairs_per_image = 4;  // COLMAP's RANSAC takes ~50 ms a pair
  options.verification = "colmap";
  Scene clean, noisy;
  MakeScene(options, "wrong_0", &clean);
  options.wrong_match_ratio = 0.4;
  MakeScene(options, "wrong_40", &noisy);
  CheckGroundTruth(options, noisy);

  // Keypoints do not depend on the wrong-match ratio.
  for (const auto& [image_id, image] : clean.ground_truth.Images()) {
    ASSERT_EQ(image.NumPoints2D(),
              noisy.ground_truth.Image(image_id).NumPoints2D());
  }
  // A ratio r turns n true matches into n / (1 - r) raw matches.
  const double expected = TotalRawMatches(clean.view_graph) / (1 - 0.4);
  EXPECT_NEAR(TotalRawMatches(noisy.view_graph), expected, 0.02 * expected);
  // Verification removes them again, except the few that happen to lie
  // near an epipolar line (a 4 px band covers ~1% of an image); in weak
  // pairs RANSAC may also fit those, as it does on real data.
  EXPECT_GT(TotalTrueMatchFraction(noisy.ground_truth, noisy.view_graph), 0.97);
  for (const auto& [pair_id, pair] : noisy.view_graph.Pairs()) {
    if (pair.matches.size() < 100) continue;
    EXPECT_GT(TrueMatchFraction(noisy.ground_truth, pair), 0.95);
    EXPECT_LT(pair.matches.size(), 0.65 * pair.num_raw_matches);
  }
}

TEST(SyntheticScene, GroundTruthVerification) {
  SyntheticSceneOptions options;
  options.num_images = 20;
  options.verification = "ground_truth";
  options.wrong_match_ratio = 0.3;
  Scene scene;
  MakeScene(options, "ring_gt", &scene);
  CheckGroundTruth(options, scene);
  EXPECT_GT(TotalTrueMatchFraction(scene.ground_truth, scene.view_graph), 0.97);
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    EXPECT_EQ(pair.config, TwoViewGeometry::CALIBRATED);
    if (pair.matches.size() >= 100) {
      EXPECT_GT(TrueMatchFraction(scene.ground_truth, pair), 0.95);
    }
    // F and E are those of the true relative pose.
    const colmap::Image& image1 = scene.ground_truth.Image(pair.image_id1);
    const colmap::Image& image2 = scene.ground_truth.Image(pair.image_id2);
    Eigen::Vector4d qvec;
    Eigen::Vector3d tvec;
    colmap::ComputeRelativePose(image1.Qvec(), image1.Tvec(), image2.Qvec(),
                                image2.Tvec(), &qvec, &tvec);
    const Eigen::Matrix3d R = colmap::QuaternionToRotationMatrix(qvec);
    const Eigen::Vector3d t = tvec.normalized();
    Eigen::Matrix3d t_cross;
    t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    EXPECT_LT((pair.E - t_cross * R).norm(), 1e-9);
    // Inliers satisfy the epipolar constraint of F in pixels.
    int num_close = 0;
    for (const auto& match : pair.matches) {
      const Eigen::Vector3d x1 =
          image1.Point2D(match.point2D_idx1).XY().homogeneous();
      const Eigen::Vector3d x2 =
          image2.Point2D(match.point2D_idx2).XY().homogeneous();
      const Eigen::Vector3d Fx1 = pair.F * x1;
      const double distance = std::abs(x2.dot(Fx1)) / Fx1.head<2>().norm();
      num_close += distance < 8;
    }
    EXPECT_GT(num_close, 0.95 * pair.matches.size());
  }
}

TEST(SyntheticScene, CameraModelsAndPriors) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.num_cameras = 3;
  options.camera_model = "PINHOLE, SIMPLE_RADIAL,OPENCV";
  options.prior_focal_length = false;
  options.max_pairs_per_image = 4;
  Scene scene;
  MakeScene(options, "models", &scene);
  CheckGroundTruth(options, scene);
  const char* models[3] = {"PINHOLE", "SIMPLE_RADIAL", "OPENCV"};
  std::set<double> focals;
  for (colmap::camera_t camera_id = 1; camera_id <= 3; ++camera_id) {
    const colmap::Camera& camera = scene.reconstruction.Camera(camera_id);
    const colmap::Camera& true_camera = scene.ground_truth.Camera(camera_id);
    EXPECT_EQ(camera.ModelName(), models[camera_id - 1]);
    EXPECT_EQ(true_camera.ModelName(), models[camera_id - 1]);
    EXPECT_FALSE(camera.HasPriorFocalLength());
    EXPECT_DOUBLE_EQ(camera.MeanFocalLength(), 1.2 * 1024);
    EXPECT_NEAR(true_camera.MeanFocalLength(), 900, 90);
    focals.insert(true_camera.MeanFocalLength());
    for (const size_t idx : camera.ExtraParamsIdxs()) {
      EXPECT_EQ(camera.Params(idx), 0);
    }
  }
  EXPECT_EQ(focals.size(), 3);
  EXPECT_EQ(scene.reconstruction.Image(5).CameraId(), 2);
  // Without priors COLMAP fits F only.
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    EXPECT_NE(pair.config, TwoViewGeometry::CALIBRATED);
    EXPECT_EQ(pair.E, Eigen::Matrix3d::Zero());
  }

  // Every COLMAP 3.8 model yields a valid scene.
  options.camera_model =
      "SIMPLE_PINHOLE,RADIAL,OPENCV_FISHEYE,FULL_OPENCV,FOV,"
      "SIMPLE_RADIAL_FISHEYE,RADIAL_FISHEYE,THIN_PRISM_FISHEYE";
  options.num_cameras = 8;
  options.num_images = 16;
  options.prior_focal_length = true;
  options.verification = "ground_truth";
  Scene all_models;
  MakeScene(options, "all_models", &all_models);
  CheckGroundTruth(options, all_models);
}

TEST(SyntheticScene, OtherLayouts) {
  for (const std::string layout : {"forward", "grid"}) {
    SCOPED_TRACE(layout);
    SyntheticSceneOptions options;
    options.num_images = 40;
    options.layout = layout;
    options.verification = "ground_truth";
    Scene scene;
    MakeScene(options, "layout_" + layout, &scene);
    CheckGroundTruth(options, scene);
    // Each image is matched to its neighbours only.
    EXPECT_LE(
        scene.view_graph.NumPairs(),
        static_cast<size_t>(options.num_images * options.max_pairs_per_image));
    // Tracks are short compared with the sequence.
    size_t max_track_length = 0;
    for (const auto& [id, point3D] : scene.ground_truth.Points3D()) {
      max_track_length = std::max(max_track_length, point3D.Track().Length());
    }
    EXPECT_LT(max_track_length, 40);
  }
}

TEST(SyntheticScene, Deterministic) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.wrong_match_ratio = 0.2;
  options.max_pairs_per_image = 4;
  options.num_threads = 1;
  Scene first, second, other_seed;
  MakeScene(options, "seed_a", &first);
  options.num_threads = 2;
  MakeScene(options, "seed_b", &second);
  options.random_seed = 1;
  MakeScene(options, "seed_c", &other_seed);
  EXPECT_EQ(ContentDigest(first), ContentDigest(second));
  EXPECT_NE(ContentDigest(first), ContentDigest(other_seed));
  EXPECT_EQ(first.ground_truth.NumPoints3D(),
            second.ground_truth.NumPoints3D());
}

TEST(SyntheticScene, Errors) {
  const std::string dir = testing::CreateTestDir("synthetic_scene_errors");
  SyntheticSceneOptions options;
  options.num_images = 10;
  options.verification = "ground_truth";
  colmap::Reconstruction gt;
  ASSERT_TRUE(WriteSyntheticScene(options, dir + "/db.db", &gt).ok());
  colmap::Reconstruction gt2;
  Status status = WriteSyntheticScene(options, dir + "/db.db", &gt2);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("already exists"), std::string::npos);

  options.camera_model = "NOT_A_MODEL";
  EXPECT_FALSE(options.Check());
  status = WriteSyntheticScene(options, dir + "/db2.db", &gt2);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("NOT_A_MODEL"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir + "/db2.db"));

  options = SyntheticSceneOptions();
  options.num_images = 5;
  EXPECT_FALSE(options.Check());
  options = SyntheticSceneOptions();
  options.layout = "spiral";
  EXPECT_FALSE(options.Check());
  options = SyntheticSceneOptions();
  options.verification = "magic";
  EXPECT_FALSE(options.Check());
  EXPECT_TRUE(SyntheticSceneOptions().Check());
  status = WriteSyntheticScene(SyntheticSceneOptions(),
                               dir + "/no/such/folder/db.db", &gt2);
  EXPECT_FALSE(status.ok());
}

}  // namespace
}  // namespace glomap
