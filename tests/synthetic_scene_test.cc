#include "tests/support/synthetic_scene.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "base/database.h"
#include "base/essential_matrix.h"
#include "base/gps.h"
#include "base/pose.h"
#include "estimators/two_view_geometry.h"
#include "glomap/io/database_reader.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

using colmap::TwoViewGeometry;

struct Scene {
  colmap::Reconstruction ground_truth;
  SyntheticSceneShapes shapes;
  colmap::Reconstruction reconstruction;  // read back from the database
  ViewGraph view_graph;
  std::string database_path;
};

void MakeScene(const SyntheticSceneOptions& options, const std::string& name,
               Scene* scene) {
  const std::string dir = testing::CreateTestDir("synthetic_scene_" + name);
  scene->database_path = dir + "/database.db";
  const Status status = WriteSyntheticScene(
      options, scene->database_path, &scene->ground_truth, &scene->shapes);
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
    // Symmetric-structure keypoints come on top of the detector's limit.
    if (options.num_wrong_rotation_pairs == 0) {
      EXPECT_LE(image.NumPoints2D(), options.max_keypoints_per_image);
    }
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

// One database camera per image (COLMAP's extractor default) over two
// physical cameras: every image gets a camera of its own, a copy of its
// physical camera's database entry; keypoints, matches and the ground truth
// are those of the same scene with one database camera per physical camera.
TEST(SyntheticScene, DatabaseCameraPerImage) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.num_cameras = 2;
  options.camera_model = "SIMPLE_RADIAL,OPENCV";
  options.prior_focal_length = false;
  options.max_pairs_per_image = 4;
  Scene shared;
  MakeScene(options, "per_physical_camera", &shared);
  options.database_camera_per_image = true;
  Scene per_image;
  MakeScene(options, "per_image", &per_image);
  ASSERT_EQ(per_image.reconstruction.NumCameras(), 12);
  EXPECT_EQ(per_image.ground_truth.NumCameras(), 2);
  for (const auto& [image_id, image] : per_image.reconstruction.Images()) {
    EXPECT_EQ(image.CameraId(), image_id);
    const colmap::Camera& camera = per_image.reconstruction.Camera(image_id);
    const colmap::Camera& physical = shared.reconstruction.Camera(
        shared.reconstruction.Image(image_id).CameraId());
    EXPECT_EQ(camera.ModelId(), physical.ModelId());
    EXPECT_EQ(camera.Params(), physical.Params());
    EXPECT_FALSE(camera.HasPriorFocalLength());
    EXPECT_EQ(per_image.ground_truth.Image(image_id).CameraId(),
              shared.ground_truth.Image(image_id).CameraId());
  }
  EXPECT_EQ(per_image.view_graph.Pairs().size(),
            shared.view_graph.Pairs().size());
  for (const auto& [pair_id, pair] : per_image.view_graph.Pairs()) {
    const ImagePair& same = shared.view_graph.Pairs().at(pair_id);
    ASSERT_EQ(pair.matches.size(), same.matches.size());
    for (size_t m = 0; m < pair.matches.size(); ++m) {
      EXPECT_EQ(pair.matches[m].point2D_idx1, same.matches[m].point2D_idx1);
      EXPECT_EQ(pair.matches[m].point2D_idx2, same.matches[m].point2D_idx2);
    }
    EXPECT_EQ(pair.F, same.F);
  }
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

// Makes the scene of `options` with one thread (`first`), with two
// (`second`) and with two and random seed 1 (`other_seed`), in the folders
// `name`_a, _b and _c: the first two must hold the same, the third not.
void ExpectSameAcrossThreadsNotSeeds(SyntheticSceneOptions options,
                                     const std::string& name, Scene* first,
                                     Scene* second, Scene* other_seed) {
  options.num_threads = 1;
  MakeScene(options, name + "_a", first);
  options.num_threads = 2;
  MakeScene(options, name + "_b", second);
  options.random_seed = 1;
  MakeScene(options, name + "_c", other_seed);
  EXPECT_EQ(ContentDigest(*first), ContentDigest(*second));
  EXPECT_NE(ContentDigest(*first), ContentDigest(*other_seed));
}

TEST(SyntheticScene, Deterministic) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.wrong_match_ratio = 0.2;
  options.max_pairs_per_image = 4;
  Scene first, second, other_seed;
  ExpectSameAcrossThreadsNotSeeds(options, "seed", &first, &second,
                                  &other_seed);
  EXPECT_EQ(first.ground_truth.NumPoints3D(),
            second.ground_truth.NumPoints3D());
}

// The stored pair of two images, or null if the database has none.
const ImagePair* FindPair(const ViewGraph& view_graph,
                          colmap::image_t image_id1,
                          colmap::image_t image_id2) {
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if ((pair.image_id1 == image_id1 && pair.image_id2 == image_id2) ||
        (pair.image_id1 == image_id2 && pair.image_id2 == image_id1)) {
      return &pair;
    }
  }
  return nullptr;
}

// True cam2_from_cam1 rotation of two ground-truth images.
Eigen::Matrix3d TrueRelativeRotation(const colmap::Reconstruction& gt,
                                     colmap::image_t image_id1,
                                     colmap::image_t image_id2) {
  return gt.Image(image_id2).RotationMatrix() *
         gt.Image(image_id1).RotationMatrix().transpose();
}

double RotationAngleDeg(const Eigen::Matrix3d& rotation) {
  return Eigen::AngleAxisd(rotation).angle() * 180 / M_PI;
}

// The relative rotation that a pair's stored E and inliers give (the
// decomposition that puts the inliers in front of both cameras).
Eigen::Matrix3d RotationFromStoredE(const colmap::Reconstruction& gt,
                                    const ImagePair& pair) {
  const colmap::Image& image1 = gt.Image(pair.image_id1);
  const colmap::Image& image2 = gt.Image(pair.image_id2);
  const colmap::Camera& camera1 = gt.Camera(image1.CameraId());
  const colmap::Camera& camera2 = gt.Camera(image2.CameraId());
  std::vector<Eigen::Vector2d> points1, points2;
  for (const auto& match : pair.matches) {
    points1.push_back(
        camera1.ImageToWorld(image1.Point2D(match.point2D_idx1).XY()));
    points2.push_back(
        camera2.ImageToWorld(image2.Point2D(match.point2D_idx2).XY()));
  }
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  std::vector<Eigen::Vector3d> points3D;
  colmap::PoseFromEssentialMatrix(pair.E, points1, points2, &R, &t, &points3D);
  return R;
}

bool Contains(const std::vector<colmap::image_t>& image_ids,
              colmap::image_t image_id) {
  return std::find(image_ids.begin(), image_ids.end(), image_id) !=
         image_ids.end();
}

TEST(SyntheticScene, DefaultOptionsMakeNoFailureShapes) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.verification = "ground_truth";
  Scene scene;
  scene.shapes.weak_group_image_ids = {1};  // must be cleared
  MakeScene(options, "no_shapes", &scene);
  EXPECT_TRUE(scene.shapes.weak_group_image_ids.empty());
  EXPECT_TRUE(scene.shapes.weak_group_anchor_image_ids.empty());
  EXPECT_TRUE(scene.shapes.wrong_rotation_pairs.empty());
  EXPECT_TRUE(scene.shapes.pure_rotation_image_ids.empty());
  EXPECT_TRUE(scene.shapes.long_baseline_image_ids.empty());
  EXPECT_EQ(scene.shapes.weak_bridge_pair.first, 0);
  EXPECT_TRUE(scene.shapes.prior_positions.empty());
  EXPECT_TRUE(scene.shapes.prior_outlier_image_ids.empty());
  EXPECT_TRUE(scene.shapes.prior_missing_image_ids.empty());
}

TEST(SyntheticScene, WeakGroup) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.weak_group_size = 2;
  options.weak_group_num_anchors = 1;
  options.weak_group_max_matches_to_rest = 30;
  Scene scene;
  MakeScene(options, "weak_group", &scene);
  CheckGroundTruth(options, scene);
  ASSERT_EQ(scene.shapes.weak_group_image_ids.size(), 2u);
  ASSERT_EQ(scene.shapes.weak_group_anchor_image_ids.size(), 1u);
  const colmap::image_t group1 = scene.shapes.weak_group_image_ids[0];
  const colmap::image_t group2 = scene.shapes.weak_group_image_ids[1];
  const colmap::image_t anchor = scene.shapes.weak_group_anchor_image_ids[0];
  const colmap::Reconstruction& gt = scene.ground_truth;
  // Neighbours on the ring (40 images: 9 deg apart), the anchor next to them.
  const double ring_step =
      (gt.Image(1).ProjectionCenter() - gt.Image(2).ProjectionCenter()).norm();
  EXPECT_LT((gt.Image(group1).ProjectionCenter() -
             gt.Image(group2).ProjectionCenter())
                .norm(),
            1.5 * ring_step);
  EXPECT_LT((gt.Image(anchor).ProjectionCenter() -
             gt.Image(group1).ProjectionCenter())
                .norm(),
            2.5 * ring_step);

  // Strong inside the group and to the anchor, weak to the rest.
  const ImagePair* inside = FindPair(scene.view_graph, group1, group2);
  ASSERT_NE(inside, nullptr);
  EXPECT_GT(inside->matches.size(), 800);
  for (const colmap::image_t image_id : {group1, group2}) {
    const ImagePair* to_anchor = FindPair(scene.view_graph, image_id, anchor);
    ASSERT_NE(to_anchor, nullptr);
    EXPECT_GT(to_anchor->matches.size(), 600);
  }
  size_t num_weak_pairs = 0;
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    const bool in1 = pair.image_id1 == group1 || pair.image_id1 == group2;
    const bool in2 = pair.image_id2 == group1 || pair.image_id2 == group2;
    if (in1 == in2 || pair.image_id1 == anchor || pair.image_id2 == anchor) {
      continue;
    }
    EXPECT_LE(pair.num_raw_matches, 30);
    EXPECT_GT(TrueMatchFraction(gt, pair), 0.99);
    ++num_weak_pairs;
  }
  EXPECT_GT(num_weak_pairs, 20);

  // Only the group and the anchor see the patch: their points are the only
  // ones seen by no other image while shared by three.
  size_t num_patch_points = 0;
  for (const auto& [point3D_id, point3D] : gt.Points3D()) {
    std::set<colmap::image_t> viewers;
    for (const auto& element : point3D.Track().Elements()) {
      viewers.insert(element.image_id);
    }
    if (viewers == std::set<colmap::image_t>{group1, group2, anchor}) {
      ++num_patch_points;
    }
  }
  EXPECT_GT(num_patch_points, 500);
}

TEST(SyntheticScene, WrongRotationPairsWithGroundTruthVerification) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.weak_group_size = 2;
  options.num_wrong_rotation_pairs = 4;
  options.wrong_rotation_angle_deg = 30;
  options.wrong_match_ratio = 0.2;
  Scene scene;
  MakeScene(options, "wrong_rotation_gt", &scene);
  CheckGroundTruth(options, scene);
  ASSERT_EQ(scene.shapes.wrong_rotation_pairs.size(), 4u);
  size_t num_stored = 0;
  for (const auto& wrong : scene.shapes.wrong_rotation_pairs) {
    SCOPED_TRACE(std::to_string(wrong.image_id1) + "-" +
                 std::to_string(wrong.image_id2));
    // Between the group and the rest; the turned image is not in the group.
    EXPECT_NE(Contains(scene.shapes.weak_group_image_ids, wrong.image_id1),
              Contains(scene.shapes.weak_group_image_ids, wrong.image_id2));
    EXPECT_FALSE(
        Contains(scene.shapes.weak_group_image_ids, wrong.turned_image_id));
    EXPECT_FALSE(
        Contains(scene.shapes.weak_group_anchor_image_ids, wrong.image_id1));
    EXPECT_FALSE(
        Contains(scene.shapes.weak_group_anchor_image_ids, wrong.image_id2));
    const ImagePair* pair =
        FindPair(scene.view_graph, wrong.image_id1, wrong.image_id2);
    if (wrong.num_matches < 30) continue;  // too little overlap to matter
    ASSERT_NE(pair, nullptr);
    ++num_stored;
    EXPECT_EQ(pair->config, TwoViewGeometry::CALIBRATED);
    // No match sees the same point in both images, yet the inliers are
    // nearly all the symmetric matches, consistent with the stored E.
    EXPECT_LT(TrueMatchFraction(scene.ground_truth, *pair), 0.01);
    EXPECT_GT(pair->matches.size(), 0.95 * wrong.num_matches);
    // The stored geometry's rotation is off by the set angle.
    const Eigen::Matrix3d true_rotation = TrueRelativeRotation(
        scene.ground_truth, pair->image_id1, pair->image_id2);
    const Eigen::Matrix3d stored_rotation =
        RotationFromStoredE(scene.ground_truth, *pair);
    EXPECT_NEAR(RotationAngleDeg(stored_rotation * true_rotation.transpose()),
                30, 1e-6);
  }
  EXPECT_GE(num_stored, 3);
}

TEST(SyntheticScene, WrongRotationPairsWithColmapVerification) {
  SyntheticSceneOptions options;
  options.num_images = 20;
  options.max_pairs_per_image = 4;  // COLMAP's RANSAC takes ~50 ms a pair
  options.verification = "colmap";
  options.weak_group_size = 2;
  options.num_wrong_rotation_pairs = 2;
  options.wrong_rotation_pairs = "group_to_anchors";
  options.weak_group_num_anchors = 2;
  options.wrong_rotation_angle_deg = 20;
  Scene scene;
  MakeScene(options, "wrong_rotation_colmap", &scene);
  ASSERT_EQ(scene.shapes.wrong_rotation_pairs.size(), 2u);
  for (const auto& wrong : scene.shapes.wrong_rotation_pairs) {
    SCOPED_TRACE(std::to_string(wrong.image_id1) + "-" +
                 std::to_string(wrong.image_id2));
    EXPECT_TRUE(Contains(scene.shapes.weak_group_anchor_image_ids,
                         wrong.turned_image_id));
    const ImagePair* pair =
        FindPair(scene.view_graph, wrong.image_id1, wrong.image_id2);
    ASSERT_NE(pair, nullptr);
    // COLMAP's verifier finds the symmetric matches convincing.
    EXPECT_EQ(pair->config, TwoViewGeometry::CALIBRATED);
    EXPECT_GT(pair->matches.size(), 0.9 * wrong.num_matches);
    EXPECT_GT(pair->matches.size(), 300);
    const Eigen::Matrix3d true_rotation = TrueRelativeRotation(
        scene.ground_truth, pair->image_id1, pair->image_id2);
    const Eigen::Matrix3d stored_rotation =
        RotationFromStoredE(scene.ground_truth, *pair);
    EXPECT_NEAR(RotationAngleDeg(stored_rotation * true_rotation.transpose()),
                20, 1);
  }
}

TEST(SyntheticScene, PureRotationImages) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.num_pure_rotation_images = 2;
  Scene scene;
  MakeScene(options, "pure_rotation", &scene);
  CheckGroundTruth(options, scene);
  ASSERT_EQ(scene.shapes.pure_rotation_image_ids.size(), 2u);
  const colmap::Reconstruction& gt = scene.ground_truth;
  for (const auto& [moved, partner] : scene.shapes.pure_rotation_image_ids) {
    EXPECT_NE(moved, partner);
    EXPECT_LT((gt.Image(moved).ProjectionCenter() -
               gt.Image(partner).ProjectionCenter())
                  .norm(),
              1e-9);
    // Turned by about one ring step (9 deg) around the shared centre.
    const double angle_deg =
        RotationAngleDeg(TrueRelativeRotation(gt, moved, partner));
    EXPECT_GT(angle_deg, 3);
    EXPECT_LT(angle_deg, 20);
    // Stored as COLMAP stores a panorama pair: a homography, no E.
    const ImagePair* pair = FindPair(scene.view_graph, moved, partner);
    ASSERT_NE(pair, nullptr);
    EXPECT_EQ(pair->config, TwoViewGeometry::PLANAR_OR_PANORAMIC);
    EXPECT_GT(pair->matches.size(), 200);
    EXPECT_EQ(pair->E, Eigen::Matrix3d::Zero());
    const colmap::Image& image1 = gt.Image(pair->image_id1);
    const colmap::Image& image2 = gt.Image(pair->image_id2);
    for (const auto& match : pair->matches) {
      const Eigen::Vector3d x1 =
          image1.Point2D(match.point2D_idx1).XY().homogeneous();
      const Eigen::Vector2d& x2 = image2.Point2D(match.point2D_idx2).XY();
      // Lens distortion is small: within a few pixels of the homography.
      EXPECT_LT(((pair->H * x1).hnormalized() - x2).norm(), 12);
    }
  }
}

TEST(SyntheticScene, LongBaselineImages) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.num_long_baseline_images = 1;
  options.long_baseline_num_skipped_neighbors = 8;
  Scene scene;
  MakeScene(options, "long_baseline", &scene);
  CheckGroundTruth(options, scene);
  ASSERT_EQ(scene.shapes.long_baseline_image_ids.size(), 1u);
  const colmap::image_t image_id = scene.shapes.long_baseline_image_ids[0];
  const colmap::Reconstruction& gt = scene.ground_truth;
  const Eigen::Vector3d center = gt.Image(image_id).ProjectionCenter();
  std::vector<std::pair<double, colmap::image_t>> by_distance;
  for (const auto& [other_id, image] : gt.Images()) {
    if (other_id == image_id) continue;
    by_distance.emplace_back((image.ProjectionCenter() - center).norm(),
                             other_id);
  }
  std::sort(by_distance.begin(), by_distance.end());
  for (size_t k = 0; k < by_distance.size(); ++k) {
    const bool matched =
        FindPair(scene.view_graph, image_id, by_distance[k].second) != nullptr;
    if (k < 8) {
      EXPECT_FALSE(matched) << k;
    }
  }
  size_t num_pairs = 0;
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    num_pairs += pair.image_id1 == image_id || pair.image_id2 == image_id;
  }
  EXPECT_GT(num_pairs, 5);
}

TEST(SyntheticScene, WeakBridge) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.weak_bridge = true;
  options.weak_bridge_max_matches = 40;
  Scene scene;
  MakeScene(options, "weak_bridge", &scene);
  CheckGroundTruth(options, scene);
  ASSERT_NE(scene.shapes.weak_bridge_pair.first, 0);
  EXPECT_EQ(scene.shapes.weak_bridge_half_image_ids.size(), 20u);
  EXPECT_TRUE(Contains(scene.shapes.weak_bridge_half_image_ids,
                       scene.shapes.weak_bridge_pair.first));
  EXPECT_FALSE(Contains(scene.shapes.weak_bridge_half_image_ids,
                        scene.shapes.weak_bridge_pair.second));
  size_t num_crossing = 0;
  for (const auto& [pair_id, pair] : scene.view_graph.Pairs()) {
    if (Contains(scene.shapes.weak_bridge_half_image_ids, pair.image_id1) ==
        Contains(scene.shapes.weak_bridge_half_image_ids, pair.image_id2)) {
      continue;
    }
    ++num_crossing;
    EXPECT_LE(pair.num_raw_matches, 40);
    EXPECT_GE(pair.matches.size(), 30);
  }
  EXPECT_EQ(num_crossing, 1);
}

TEST(SyntheticScene, FailureShapesAreDeterministic) {
  SyntheticSceneOptions options;
  options.num_images = 30;
  options.verification = "ground_truth";
  options.wrong_match_ratio = 0.2;
  options.weak_group_size = 3;
  options.weak_group_num_anchors = 2;
  options.num_wrong_rotation_pairs = 4;
  options.num_pure_rotation_images = 1;
  options.num_long_baseline_images = 1;
  options.weak_bridge = true;
  Scene first, second, other_seed;
  ExpectSameAcrossThreadsNotSeeds(options, "shapes", &first, &second,
                                  &other_seed);
  EXPECT_EQ(first.shapes.weak_group_image_ids,
            second.shapes.weak_group_image_ids);
  EXPECT_EQ(first.shapes.wrong_rotation_pairs.size(), 4u);
  EXPECT_EQ(first.shapes.pure_rotation_image_ids,
            second.shapes.pure_rotation_image_ids);
  EXPECT_EQ(first.shapes.weak_bridge_pair, second.shapes.weak_bridge_pair);
  // No image plays two parts.
  std::set<colmap::image_t> special;
  size_t num_special = 0;
  for (const auto* ids : {&first.shapes.weak_group_image_ids,
                          &first.shapes.weak_group_anchor_image_ids,
                          &first.shapes.long_baseline_image_ids}) {
    special.insert(ids->begin(), ids->end());
    num_special += ids->size();
  }
  for (const auto& [moved, partner] : first.shapes.pure_rotation_image_ids) {
    special.insert({moved, partner});
    num_special += 2;
  }
  EXPECT_EQ(special.size(), num_special);
  EXPECT_EQ(num_special, 3u + 2u + 1u + 2u);
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
  options = SyntheticSceneOptions();
  options.num_wrong_rotation_pairs = 1;  // group_to_rest without a group
  EXPECT_FALSE(options.Check());
  options.wrong_rotation_pairs = "any";
  EXPECT_TRUE(options.Check());
  options.wrong_rotation_angle_deg = 0;
  EXPECT_FALSE(options.Check());
  options = SyntheticSceneOptions();
  options.weak_group_size = 8;  // with its anchor, more than half the images
  options.num_images = 16;
  EXPECT_FALSE(options.Check());
  options.weak_group_size = 7;
  EXPECT_TRUE(options.Check());
  options.wrong_rotation_pairs = "all";
  EXPECT_FALSE(options.Check());
  EXPECT_TRUE(SyntheticSceneOptions().Check());
  status = WriteSyntheticScene(SyntheticSceneOptions(),
                               dir + "/no/such/folder/db.db", &gt2);
  EXPECT_FALSE(status.ok());
}

// The images of a database as COLMAP 3.8 reads them, by id.
std::map<colmap::image_t, colmap::Image> ReadDatabaseImages(
    const std::string& database_path) {
  colmap::Database database(database_path);
  std::map<colmap::image_t, colmap::Image> images;
  for (colmap::Image& image : database.ReadAllImages()) {
    images.emplace(image.ImageId(), std::move(image));
  }
  return images;
}

// Every row of a query, with each value's type and bytes.
std::string DumpQuery(const std::string& database_path,
                      const std::string& query) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(database_path.c_str(), &db, SQLITE_OPEN_READONLY,
                            nullptr),
            SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, query.c_str(), -1, &stmt, nullptr),
            SQLITE_OK)
      << query;
  std::string dump;
  size_t num_rows = 0;
  while (stmt != nullptr && sqlite3_step(stmt) == SQLITE_ROW) {
    ++num_rows;
    for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
      const int type = sqlite3_column_type(stmt, c);
      const void* bytes = type == SQLITE_BLOB ? sqlite3_column_blob(stmt, c)
                                              : sqlite3_column_text(stmt, c);
      dump += std::to_string(type) + ":";
      if (bytes != nullptr) {
        dump.append(static_cast<const char*>(bytes),
                    sqlite3_column_bytes(stmt, c));
      }
      dump += '|';
    }
    dump += '\n';
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return std::to_string(num_rows) + " rows\n" + dump;
}

// Everything in a database but the position priors.
std::string DumpAllButPositionPriors(const std::string& database_path) {
  std::string dump;
  for (const std::string query :
       {"SELECT * FROM cameras ORDER BY camera_id",
        "SELECT image_id, name, camera_id, prior_qw, prior_qx, prior_qy, "
        "prior_qz FROM images ORDER BY image_id",
        "SELECT * FROM keypoints ORDER BY image_id",
        "SELECT * FROM descriptors ORDER BY image_id",
        "SELECT * FROM matches ORDER BY pair_id",
        "SELECT * FROM two_view_geometries ORDER BY pair_id"}) {
    dump += query + "\n" + DumpQuery(database_path, query);
  }
  return dump;
}

// Whether two lists of priors are equal, NaN (no prior) matching NaN.
bool SamePriors(const std::vector<Eigen::Vector3d>& priors1,
                const std::vector<Eigen::Vector3d>& priors2) {
  if (priors1.size() != priors2.size()) return false;
  for (size_t k = 0; k < priors1.size(); ++k) {
    for (int i = 0; i < 3; ++i) {
      const double a = priors1[k](i), b = priors2[k](i);
      if (!(a == b || (std::isnan(a) && std::isnan(b)))) return false;
    }
  }
  return true;
}

// Metric positions of priors stored as GPS around `origin` (lat, lon, alt).
std::vector<Eigen::Vector3d> GpsToEnu(const std::vector<Eigen::Vector3d>& lla,
                                      const Eigen::Vector3d& origin) {
  // COLMAP 3.8's EllToENU measures from its first point: put the origin
  // there.
  std::vector<Eigen::Vector3d> ell = {origin};
  ell.insert(ell.end(), lla.begin(), lla.end());
  std::vector<Eigen::Vector3d> enu =
      colmap::GPSTransform(colmap::GPSTransform::WGS84)
          .EllToENU(ell, origin.x(), origin.y());
  EXPECT_LT(enu[0].norm(), 1e-9);
  enu.erase(enu.begin());
  return enu;
}

TEST(SyntheticScene, NoPositionPriorsByDefault) {
  SyntheticSceneOptions options;
  EXPECT_LT(options.prior_position_noise_m, 0);
  options.num_images = 12;
  options.verification = "ground_truth";
  Scene scene;
  MakeScene(options, "no_priors", &scene);
  for (const auto& [image_id, image] :
       ReadDatabaseImages(scene.database_path)) {
    EXPECT_FALSE(image.HasTvecPrior()) << image_id;
    EXPECT_TRUE(image.TvecPrior().array().isNaN().all()) << image_id;
    EXPECT_FALSE(scene.reconstruction.Image(image_id).HasTvecPrior());
  }
  EXPECT_EQ(DumpQuery(scene.database_path,
                      "SELECT image_id FROM images WHERE prior_tx IS NOT NULL "
                      "OR prior_ty IS NOT NULL OR prior_tz IS NOT NULL"),
            "0 rows\n");
  EXPECT_TRUE(scene.shapes.prior_positions.empty());
}

TEST(SyntheticScene, PositionPriors) {
  SyntheticSceneOptions options;
  options.num_images = 200;
  options.verification = "ground_truth";
  options.max_pairs_per_image = 4;
  options.prior_position_noise_m = 0.5;
  options.prior_outlier_ratio = 0.1;
  options.prior_outlier_min_m = 20;
  options.prior_outlier_max_m = 100;
  options.prior_missing_ratio = 0.05;
  Scene scene;
  MakeScene(options, "priors", &scene);
  ASSERT_EQ(scene.shapes.prior_positions.size(), 200u);
  ASSERT_EQ(scene.shapes.prior_outlier_image_ids.size(), 20u);
  ASSERT_EQ(scene.shapes.prior_missing_image_ids.size(), 10u);
  for (const colmap::image_t image_id : scene.shapes.prior_missing_image_ids) {
    EXPECT_FALSE(Contains(scene.shapes.prior_outlier_image_ids, image_id));
  }

  const std::map<colmap::image_t, colmap::Image> images =
      ReadDatabaseImages(scene.database_path);
  ASSERT_EQ(images.size(), 200u);
  Eigen::Vector3d sum_error = Eigen::Vector3d::Zero();
  double sum_squared_error = 0;
  double max_axis_error = 0;
  size_t num_inliers = 0;
  for (const auto& [image_id, image] : images) {
    SCOPED_TRACE(image.Name());
    const Eigen::Vector3d center =
        scene.ground_truth.Image(image_id).ProjectionCenter();
    // The project's reader reads the same priors as COLMAP's.
    const colmap::Image& read = scene.reconstruction.Image(image_id);
    if (Contains(scene.shapes.prior_missing_image_ids, image_id)) {
      EXPECT_FALSE(image.HasTvecPrior());
      EXPECT_TRUE(image.TvecPrior().array().isNaN().all());
      EXPECT_FALSE(read.HasTvecPrior());
      EXPECT_TRUE(
          scene.shapes.prior_positions[image_id - 1].array().isNaN().all());
      continue;
    }
    ASSERT_TRUE(image.HasTvecPrior());
    EXPECT_EQ(image.TvecPrior(), scene.shapes.prior_positions[image_id - 1]);
    EXPECT_EQ(read.TvecPrior(), image.TvecPrior());
    const Eigen::Vector3d error = image.TvecPrior() - center;
    if (Contains(scene.shapes.prior_outlier_image_ids, image_id)) {
      EXPECT_GE(error.norm(), 20 - 1e-9);
      EXPECT_LE(error.norm(), 100 + 1e-9);
      continue;
    }
    ++num_inliers;
    sum_error += error;
    sum_squared_error += error.squaredNorm();
    max_axis_error = std::max(max_axis_error, error.cwiseAbs().maxCoeff());
  }
  ASSERT_EQ(num_inliers, 170u);
  // Zero-mean noise of 0.5 m per axis: the RMS 3D error is 0.5 * sqrt(3) m
  // (510 draws: the estimate's standard deviation is ~3%).
  const double rms_error = std::sqrt(sum_squared_error / num_inliers);
  EXPECT_NEAR(rms_error, 0.5 * std::sqrt(3.0), 0.1 * 0.5 * std::sqrt(3.0));
  EXPECT_LT((sum_error / num_inliers).cwiseAbs().maxCoeff(), 0.15);
  EXPECT_LT(max_axis_error, 5 * 0.5);
}

TEST(SyntheticScene, PositionPriorsChangeNothingElse) {
  for (const std::string layout : {"ring", "forward", "grid"}) {
    SCOPED_TRACE(layout);
    SyntheticSceneOptions options;
    // COLMAP's verification on the ring (its RANSAC takes ~50 ms a pair).
    options.num_images = layout == "ring" ? 16 : 30;
    options.layout = layout;
    options.verification = layout == "ring" ? "colmap" : "ground_truth";
    options.max_pairs_per_image = 4;
    options.wrong_match_ratio = 0.2;
    options.num_threads = 2;
    Scene plain, with_priors, as_gps;
    MakeScene(options, "priors_off_" + layout, &plain);
    options.prior_position_noise_m = 3;
    options.prior_outlier_ratio = 0.2;
    options.prior_missing_ratio = 0.1;
    MakeScene(options, "priors_on_" + layout, &with_priors);
    options.prior_as_gps = true;
    MakeScene(options, "priors_gps_" + layout, &as_gps);

    const std::string plain_dump =
        DumpAllButPositionPriors(plain.database_path);
    EXPECT_EQ(plain_dump, DumpAllButPositionPriors(with_priors.database_path));
    EXPECT_EQ(plain_dump, DumpAllButPositionPriors(as_gps.database_path));
    EXPECT_NE(DumpQuery(plain.database_path, "SELECT * FROM images"),
              DumpQuery(with_priors.database_path, "SELECT * FROM images"));
    EXPECT_EQ(ContentDigest(plain), ContentDigest(with_priors));
    EXPECT_EQ(ContentDigest(plain), ContentDigest(as_gps));
    // The same ground truth.
    ASSERT_EQ(plain.ground_truth.NumPoints3D(),
              with_priors.ground_truth.NumPoints3D());
    for (const auto& [image_id, image] : plain.ground_truth.Images()) {
      const colmap::Image& other = with_priors.ground_truth.Image(image_id);
      EXPECT_EQ(image.Qvec(), other.Qvec());
      EXPECT_EQ(image.Tvec(), other.Tvec());
    }
  }
}

TEST(SyntheticScene, PositionPriorsAreDeterministic) {
  SyntheticSceneOptions options;
  options.num_images = 40;
  options.verification = "ground_truth";
  options.max_pairs_per_image = 4;
  options.prior_position_noise_m = 1;
  options.prior_outlier_ratio = 0.1;
  options.prior_missing_ratio = 0.1;
  Scene first, second, other_seed, more_noise, no_outliers;
  MakeScene(options, "priors_seed_a", &first);
  MakeScene(options, "priors_seed_b", &second);
  options.prior_position_noise_m = 2;
  MakeScene(options, "priors_noise_2", &more_noise);
  options.prior_position_noise_m = 1;
  options.prior_outlier_ratio = 0;
  MakeScene(options, "priors_no_outliers", &no_outliers);
  options.prior_outlier_ratio = 0.1;
  options.random_seed = 1;
  MakeScene(options, "priors_seed_c", &other_seed);

  EXPECT_EQ(DumpQuery(first.database_path, "SELECT * FROM images"),
            DumpQuery(second.database_path, "SELECT * FROM images"));
  EXPECT_EQ(first.shapes.prior_outlier_image_ids,
            second.shapes.prior_outlier_image_ids);
  EXPECT_EQ(first.shapes.prior_missing_image_ids,
            second.shapes.prior_missing_image_ids);
  EXPECT_TRUE(
      SamePriors(first.shapes.prior_positions, second.shapes.prior_positions));
  EXPECT_FALSE(SamePriors(first.shapes.prior_positions,
                          other_seed.shapes.prior_positions));
  // Every image has its own noise: the noise level scales it, and the
  // outlier ratio changes only the outliers' priors.
  EXPECT_EQ(first.shapes.prior_outlier_image_ids,
            more_noise.shapes.prior_outlier_image_ids);
  for (colmap::image_t image_id = 1; image_id <= 40; ++image_id) {
    SCOPED_TRACE(image_id);
    if (Contains(first.shapes.prior_missing_image_ids, image_id)) continue;
    const Eigen::Vector3d center =
        first.ground_truth.Image(image_id).ProjectionCenter();
    const Eigen::Vector3d& prior = first.shapes.prior_positions[image_id - 1];
    if (Contains(first.shapes.prior_outlier_image_ids, image_id)) continue;
    EXPECT_LT(((more_noise.shapes.prior_positions[image_id - 1] - center) -
               2 * (prior - center))
                  .norm(),
              1e-9);
    EXPECT_EQ(no_outliers.shapes.prior_positions[image_id - 1], prior);
  }
}

TEST(SyntheticScene, PositionPriorsAsGps) {
  // Zurich (the default) and a south-western origin; the ring is centred on
  // its object, the grid flies 40 m above ground.
  const std::vector<std::pair<std::string, Eigen::Vector3d>> cases = {
      {"ring", Eigen::Vector3d(47.3769, 8.5417, 400)},
      {"grid", Eigen::Vector3d(-33.9249, -70.6693, 520)}};
  for (const auto& [layout, origin] : cases) {
    SCOPED_TRACE(layout);
    SyntheticSceneOptions options;
    options.num_images = 60;
    options.layout = layout;
    options.verification = "ground_truth";
    options.max_pairs_per_image = 4;
    options.prior_position_noise_m = 2;
    options.prior_outlier_ratio = 0.1;
    options.prior_missing_ratio = 0.1;
    options.prior_gps_origin = origin;
    Scene metric, gps;
    MakeScene(options, "metric_" + layout, &metric);
    options.prior_as_gps = true;
    MakeScene(options, "gps_" + layout, &gps);
    // The same simulated positions, only stored differently.
    ASSERT_TRUE(
        SamePriors(metric.shapes.prior_positions, gps.shapes.prior_positions));
    EXPECT_EQ(metric.shapes.prior_outlier_image_ids,
              gps.shapes.prior_outlier_image_ids);

    const std::map<colmap::image_t, colmap::Image> metric_images =
        ReadDatabaseImages(metric.database_path);
    const std::map<colmap::image_t, colmap::Image> gps_images =
        ReadDatabaseImages(gps.database_path);
    std::vector<Eigen::Vector3d> lla, expected;
    for (const auto& [image_id, image] : gps_images) {
      if (Contains(gps.shapes.prior_missing_image_ids, image_id)) {
        EXPECT_FALSE(image.HasTvecPrior());
        continue;
      }
      ASSERT_TRUE(image.HasTvecPrior());
      lla.push_back(image.TvecPrior());
      expected.push_back(metric_images.at(image_id).TvecPrior());
      // Latitude, longitude and altitude, near the origin.
      EXPECT_LT(std::abs(image.TvecPrior(0) - origin.x()), 0.01);
      EXPECT_LT(std::abs(image.TvecPrior(1) - origin.y()), 0.01);
      if (!Contains(gps.shapes.prior_outlier_image_ids, image_id)) {
        EXPECT_NEAR(image.TvecPrior(2), origin.z() + expected.back().z(), 0.01);
      }
    }
    ASSERT_EQ(lla.size(), 54u);
    const std::vector<Eigen::Vector3d> enu = GpsToEnu(lla, origin);
    double max_error_m = 0;
    for (size_t k = 0; k < enu.size(); ++k) {
      max_error_m = std::max(max_error_m, (enu[k] - expected[k]).norm());
    }
    EXPECT_LT(max_error_m, 1e-3);
    // In fact it is far below a millimetre.
    EXPECT_LT(max_error_m, 1e-6);
  }
}

TEST(SyntheticScene, PositionPriorOptions) {
  SyntheticSceneOptions options;
  options.prior_position_noise_m = 0;  // exact priors
  EXPECT_TRUE(options.Check());
  options.prior_position_noise_m = std::nan("");
  EXPECT_FALSE(options.Check());
  // The prior options need priors.
  for (int k = 0; k < 3; ++k) {
    options = SyntheticSceneOptions();
    if (k == 0) options.prior_outlier_ratio = 0.1;
    if (k == 1) options.prior_missing_ratio = 0.1;
    if (k == 2) options.prior_as_gps = true;
    EXPECT_FALSE(options.Check()) << k;
    options.prior_position_noise_m = 1;
    EXPECT_TRUE(options.Check()) << k;
  }
  options = SyntheticSceneOptions();
  options.prior_position_noise_m = 1;
  options.prior_outlier_ratio = 1.5;
  EXPECT_FALSE(options.Check());
  options.prior_outlier_ratio = 0.6;
  options.prior_missing_ratio = 0.5;
  EXPECT_FALSE(options.Check());
  options.prior_missing_ratio = 0.4;
  EXPECT_TRUE(options.Check());
  options.prior_outlier_min_m = 200;  // above the maximum
  EXPECT_FALSE(options.Check());
  options.prior_outlier_min_m = -1;
  EXPECT_FALSE(options.Check());
  options.prior_outlier_min_m = 20;
  options.prior_gps_origin = Eigen::Vector3d(95, 8, 400);
  EXPECT_FALSE(options.Check());
  options.prior_gps_origin = Eigen::Vector3d(47, 200, 400);
  EXPECT_FALSE(options.Check());
  options.prior_gps_origin = Eigen::Vector3d(-47, -179, -20);
  EXPECT_TRUE(options.Check());

  // All images displaced, or none with a prior.
  const std::string dir = testing::CreateTestDir("synthetic_scene_priors_all");
  options = SyntheticSceneOptions();
  options.num_images = 10;
  options.verification = "ground_truth";
  options.prior_position_noise_m = 0;
  options.prior_missing_ratio = 1;
  colmap::Reconstruction gt;
  SyntheticSceneShapes shapes;
  ASSERT_TRUE(
      WriteSyntheticScene(options, dir + "/none.db", &gt, &shapes).ok());
  EXPECT_EQ(shapes.prior_missing_image_ids.size(), 10u);
  for (const auto& [image_id, image] : ReadDatabaseImages(dir + "/none.db")) {
    EXPECT_FALSE(image.HasTvecPrior());
  }
  options.prior_missing_ratio = 0;
  options.prior_outlier_ratio = 1;
  colmap::Reconstruction gt2;
  ASSERT_TRUE(
      WriteSyntheticScene(options, dir + "/all.db", &gt2, &shapes).ok());
  EXPECT_EQ(shapes.prior_outlier_image_ids.size(), 10u);
  EXPECT_TRUE(shapes.prior_missing_image_ids.empty());
  options.prior_outlier_ratio = 0;
  colmap::Reconstruction gt3;
  ASSERT_TRUE(
      WriteSyntheticScene(options, dir + "/exact.db", &gt3, &shapes).ok());
  for (const auto& [image_id, image] : ReadDatabaseImages(dir + "/exact.db")) {
    EXPECT_LT(
        (image.TvecPrior() - gt3.Image(image_id).ProjectionCenter()).norm(),
        1e-12);
  }
}

}  // namespace
}  // namespace glomap
