// Camera setups a COLMAP project can have (issue 27), on the shared datasets
// rewritten as a user's feature_extractor run would have written them: one
// camera per image (the extractor's default) without a focal prior, or one
// shared camera, with each camera model. Keypoints, matches and two-view
// geometries stay those of the dataset; only the cameras change, in a copy.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "base/database.h"
#include "colmap_ext/model_evaluation.h"
#include "glomap/controllers/global_mapper.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

// Copies `source` to `target` and replaces its cameras by cameras of
// `model_name` (one per image, ids equal to the image ids, or one per camera
// of the source: the shared datasets have one) with the start values COLMAP's
// feature extractor writes without EXIF: focal 1.2 x the larger image side,
// principal point at the centre, no distortion, no focal prior. (Existing
// camera rows are updated, not deleted: images refer to them.)
void RewriteCameras(const std::string& source, const std::string& target,
                    const std::string& model_name, bool per_image) {
  std::filesystem::copy_file(source, target);
  colmap::Database database(target);
  std::map<colmap::camera_t, colmap::Camera> old_cameras;
  for (const colmap::Camera& camera : database.ReadAllCameras()) {
    old_cameras.emplace(camera.CameraId(), camera);
  }
  auto new_camera = [&](const colmap::Camera& old, colmap::camera_t id) {
    colmap::Camera camera;
    camera.SetCameraId(id);
    camera.InitializeWithName(model_name,
                              1.2 * std::max(old.Width(), old.Height()),
                              old.Width(), old.Height());
    camera.SetPriorFocalLength(false);
    if (old_cameras.count(id) > 0) {
      database.UpdateCamera(camera);
    } else {
      database.WriteCamera(camera, /*use_camera_id=*/true);
    }
  };
  colmap::DatabaseTransaction transaction(&database);
  if (!per_image) {
    for (const auto& [camera_id, old] : old_cameras) new_camera(old, camera_id);
    return;
  }
  for (colmap::Image& image : database.ReadAllImages()) {
    new_camera(old_cameras.at(image.CameraId()), image.ImageId());
    image.SetCameraId(image.ImageId());
    database.UpdateImage(image);
  }
}

struct CameraSetupCase {
  std::string dataset;
  std::string model;
  bool per_image;
  // Bar of AUC@3: item 1, the better reference mapper's figure on the same
  // rewritten database minus 1; item 2, the dataset's SIMPLE_RADIAL figure
  // (seeds 0 and 1, the lower) minus 1, or minus 3 for FULL_OPENCV and
  // OPENCV_FISHEYE.
  double min_auc3;
};

class CameraSetups
    : public ::testing::TestWithParam<std::tuple<CameraSetupCase, int>> {};

TEST_P(CameraSetups, EveryImageRegisteredAndAccurate) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const CameraSetupCase& c = std::get<0>(GetParam());
  const int seed = std::get<1>(GetParam());
  const std::string dataset_dir = datasets + "/" + c.dataset;
  if (!std::filesystem::exists(dataset_dir + "/database.db") ||
      !std::filesystem::is_directory(dataset_dir + "/gt")) {
    GTEST_SKIP() << c.dataset << " (its database.db and gt/) is not in "
                 << datasets;
  }
  const std::string dir = testing::CreateTestDir(
      "camera_setups_" + c.dataset + "_" + c.model +
      (c.per_image ? "_per_image_" : "_shared_") + std::to_string(seed));
  const std::string database_path = dir + "/database.db";
  RewriteCameras(dataset_dir + "/database.db", database_path, c.model,
                 c.per_image);

  GlobalMapperOptions options;
  options.random_seed = seed;
  colmap::Reconstruction work;
  std::vector<colmap::Reconstruction> models;
  GlobalMapper mapper(options);
  const Status status = mapper.Run(database_path, &work, &models);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_GE(models.size(), 1u);
  const colmap::Reconstruction& model = models[0];

  // The written model keeps the database's cameras: one per image, of the
  // model the database names.
  colmap::Database database(database_path);
  for (const colmap::Image& db_image : database.ReadAllImages()) {
    if (!model.ExistsImage(db_image.ImageId())) continue;
    const colmap::Image& image = model.Image(db_image.ImageId());
    EXPECT_EQ(image.CameraId(), db_image.CameraId());
    ASSERT_TRUE(model.ExistsCamera(image.CameraId()));
    EXPECT_EQ(model.Camera(image.CameraId()).ModelName(), c.model);
  }

  colmap::Reconstruction truth;
  ASSERT_TRUE(ReadModel(dataset_dir + "/gt", &truth).ok());
  ModelEvaluation evaluation;
  ASSERT_TRUE(
      EvaluateModel(model, truth, ModelEvaluationOptions(), &evaluation).ok());
  std::cout << c.dataset << " " << c.model
            << (c.per_image ? " per image" : " shared") << " (seed " << seed
            << "): registered " << evaluation.num_registered << "/"
            << evaluation.num_gt_images << ", AUC@3 " << evaluation.pose_aucs[1]
            << " (bar " << c.min_auc3 << "), cameras beyond 5% "
            << evaluation.num_cameras_beyond << std::endl;
  EXPECT_EQ(evaluation.num_registered, evaluation.num_gt_images);
  EXPECT_EQ(evaluation.num_cameras_beyond, 0);
  EXPECT_GE(evaluation.pose_aucs[1], c.min_auc3);
  // Item 5: a model this wrong says that its focal lengths were not
  // determined, and a good one does not cry wolf.
  const std::vector<std::string>& warnings = mapper.Summary().warnings;
  for (const std::string& warning : warnings) std::cout << warning << "\n";
  if (evaluation.pose_aucs[1] < 50) EXPECT_FALSE(warnings.empty());
  if (evaluation.pose_aucs[1] > 90) EXPECT_TRUE(warnings.empty());
}

INSTANTIATE_TEST_SUITE_P(
    SharedDatasets, CameraSetups,
    ::testing::Combine(
        ::testing::Values(
            // Item 1: one SIMPLE_RADIAL camera per image, no focal prior.
            // Reference mappers on the same databases (issue 27): templeRing
            // 62.8 (COLMAP 4.1.1 global_mapper) and 57.9 (COLMAP 3.8
            // mapper); castle-P19 69.2 and 66.9.
            CameraSetupCase{"templeRing", "SIMPLE_RADIAL", true, 62.8 - 1},
            CameraSetupCase{"castle-P19", "SIMPLE_RADIAL", true, 69.2 - 1},
            // Item 2, one dataset per model family. SIMPLE_RADIAL one per
            // image, seeds 0 / 1: templeRing 89.6 / 90.0, castle-P19 95.9 /
            // 96.4, fountain-P11 97.2 / 97.2.
            CameraSetupCase{"castle-P19", "PINHOLE", true, 95.9 - 1},
            CameraSetupCase{"templeRing", "OPENCV", true, 89.6 - 1},
            CameraSetupCase{"templeRing", "OPENCV", false, 89.6 - 1},
            CameraSetupCase{"castle-P19", "FULL_OPENCV", true, 95.9 - 3},
            CameraSetupCase{"fountain-P11", "OPENCV_FISHEYE", true, 97.2 - 3}),
        ::testing::Values(0, 1)),
    [](const auto& info) {
      const CameraSetupCase& c = std::get<0>(info.param);
      std::string name = c.dataset + "_" + c.model +
                         (c.per_image ? "_per_image" : "_shared") + "_seed" +
                         std::to_string(std::get<1>(info.param));
      for (char& ch : name) {
        if (!isalnum(ch)) ch = '_';
      }
      return name;
    });

// Synthetic scenes (tests/support/synthetic_scene.h): the two cases a
// project with one camera per image and identical start values can be.

struct SyntheticRun {
  std::string database_path;
  colmap::Reconstruction truth;
  colmap::Reconstruction model;
  ModelEvaluation evaluation;
  std::vector<std::string> warnings;  // GlobalMapperSummary::warnings
};

// Writes `scene`, lets `edit_database` change the database (if set), runs
// the mapper with `options` and evaluates its first model.
void RunSynthetic(
    const SyntheticSceneOptions& scene, const std::string& name,
    SyntheticRun* run,
    const GlobalMapperOptions& options = GlobalMapperOptions(),
    const std::function<void(const std::string&)>& edit_database = {}) {
  const std::string dir = testing::CreateTestDir("camera_setups_" + name);
  run->database_path = dir + "/database.db";
  ASSERT_TRUE(WriteSyntheticScene(scene, run->database_path, &run->truth).ok());
  if (edit_database) edit_database(run->database_path);
  colmap::Reconstruction work;
  std::vector<colmap::Reconstruction> models;
  GlobalMapper mapper(options);
  const Status status = mapper.Run(run->database_path, &work, &models);
  ASSERT_TRUE(status.ok()) << status.message();
  run->warnings = mapper.Summary().warnings;
  ASSERT_GE(models.size(), 1u);
  run->model = std::move(models[0]);
  ASSERT_TRUE(EvaluateModel(run->model, run->truth, ModelEvaluationOptions(),
                            &run->evaluation)
                  .ok());
}

// Largest relative focal error of the registered images' cameras against
// the true camera of each image.
double MaxRelativeFocalError(const SyntheticRun& run) {
  double max_error = 0;
  for (const colmap::image_t image_id : run.model.RegImageIds()) {
    const double focal = run.model.Camera(run.model.Image(image_id).CameraId())
                             .MeanFocalLength();
    const double truth = run.truth.Camera(run.truth.Image(image_id).CameraId())
                             .MeanFocalLength();
    max_error = std::max(max_error, std::abs(focal / truth - 1));
  }
  return max_error;
}

// How many of `warnings` contain `text`.
int CountContaining(const std::vector<std::string>& warnings,
                    const std::string& text) {
  return static_cast<int>(std::count_if(
      warnings.begin(), warnings.end(), [&text](const std::string& warning) {
        return warning.find(text) != std::string::npos;
      }));
}

class CameraSetupsSynthetic : public ::testing::TestWithParam<int> {};

// One physical camera written as one camera per image (feature_extractor's
// default without EXIF): the model is that of the same scene written with
// one shared camera, and every image's camera has the one true focal.
TEST_P(CameraSetupsSynthetic, OnePhysicalCameraWrittenPerImage) {
  SyntheticSceneOptions scene;
  scene.num_images = 40;
  scene.prior_focal_length = false;
  scene.random_seed = GetParam();
  SyntheticRun shared;
  RunSynthetic(scene, "one_shared_" + std::to_string(GetParam()), &shared);
  scene.database_camera_per_image = true;
  SyntheticRun per_image;
  RunSynthetic(scene, "one_per_image_" + std::to_string(GetParam()),
               &per_image);
  std::cout << "one physical camera: AUC@3 shared "
            << shared.evaluation.pose_aucs[1] << ", per image "
            << per_image.evaluation.pose_aucs[1] << ", largest focal error "
            << MaxRelativeFocalError(per_image) << std::endl;
  EXPECT_EQ(per_image.evaluation.num_registered, scene.num_images);
  EXPECT_EQ(per_image.evaluation.num_cameras_beyond, 0);
  EXPECT_GE(per_image.evaluation.pose_aucs[1],
            shared.evaluation.pose_aucs[1] - 1);
  EXPECT_LT(MaxRelativeFocalError(per_image), 0.01);
  EXPECT_EQ(per_image.model.NumCameras(), per_image.model.NumImages());
  for (const auto& [camera_id, camera] : per_image.model.Cameras()) {
    EXPECT_EQ(camera.Params(), per_image.model.Camera(1).Params());
  }
}

// Every image its own focal (a zoom lens: +-10%), all written with the same
// start values: the images are first calibrated as one camera, and bundle
// adjustment finds that they fit clearly better apart and gives each its
// own focal. (Kept merged, a 60-image ring broke apart: AUC@3 0.5, 30 of
// 60 cameras beyond 5% of the scene; with the split 76.4, none.)
TEST_P(CameraSetupsSynthetic, EveryImageItsOwnFocal) {
  SyntheticSceneOptions scene;
  scene.num_images = 40;
  scene.num_cameras = 40;
  scene.prior_focal_length = false;
  scene.random_seed = GetParam();
  SyntheticRun zoom;
  RunSynthetic(scene, "zoom_" + std::to_string(GetParam()), &zoom);
  std::cout << "each image its own focal: AUC@3 "
            << zoom.evaluation.pose_aucs[1] << ", largest focal error "
            << MaxRelativeFocalError(zoom) << std::endl;
  // Seed 1 registers 39 of 40: pose verification after global positioning,
  // still with one focal for all, leaves one image out, and nothing
  // registers it again after the split (not solved yet). Without merging
  // the same scenes give AUC@3 12.0 (seed 1) and 10.1 (seed 2) with 12 and
  // 18 cameras beyond 5%; with the split 72.7 and 76.8, none beyond.
  EXPECT_GE(zoom.evaluation.num_registered, scene.num_images - 1);
  EXPECT_EQ(zoom.evaluation.num_cameras_beyond, 0);
  EXPECT_LT(MaxRelativeFocalError(zoom), 0.03);
  EXPECT_GE(zoom.evaluation.pose_aucs[1], 50);
  // The ring's views spread: each image's focal is fixed, no warning.
  EXPECT_EQ(CountContaining(zoom.warnings, "fit different intrinsics"), 0);
}

// The same on a nadir grid, fisheye lenses with strong distortion: the
// views do not spread (6 deg), each image's focal rests on its own views
// and comes out 2-7% off (AUC@3 7 and 25 on seeds 1 and 0); the mapper says
// so (before: no warning at all).
TEST_P(CameraSetupsSynthetic, EveryImageItsOwnFocalOnAGridWarns) {
  SyntheticSceneOptions scene;
  scene.layout = "grid";
  scene.num_images = 40;
  scene.num_cameras = 40;
  scene.camera_model = "OPENCV_FISHEYE";
  scene.principal_point_offset = 0.02;
  scene.distortion_scale = 3;
  scene.database_camera_per_image = true;
  scene.prior_focal_length = false;
  scene.random_seed = GetParam();
  SyntheticRun zoom;
  RunSynthetic(scene, "zoom_grid_" + std::to_string(GetParam()), &zoom);
  std::cout << "each image its own focal, grid: AUC@3 "
            << zoom.evaluation.pose_aucs[1] << ", largest focal error "
            << MaxRelativeFocalError(zoom) << std::endl;
  for (const std::string& warning : zoom.warnings) std::cout << warning << "\n";
  EXPECT_EQ(CountContaining(zoom.warnings, "fit different intrinsics"), 1);
  EXPECT_EQ(CountContaining(zoom.warnings, "40 images"), 1);
}

// Every image its own focal (+-10%) over a larger nadir survey, OPENCV, all
// written with the feature extractor's start values. A focal error there
// is mostly a change of height, so the merged rounds absorb much of it by
// bending the block: apart, the images fit only 6 % better (0.94 of the
// merged error). Split only below 0.9, the 150-image survey stayed one
// camera and broke without a word (seed 3: AUC@3 1.5, median rotation
// error 5.0 deg; 600 and 3,500 images: 1.0 and 0.9); split, 90.1.
TEST_P(CameraSetupsSynthetic, EveryImageItsOwnFocalOnASurvey) {
  SyntheticSceneOptions scene;
  scene.layout = "grid";
  scene.num_images = 150;
  scene.num_cameras = 150;
  scene.camera_model = "OPENCV";
  scene.database_camera_per_image = true;
  scene.prior_focal_length = false;
  scene.wrong_match_ratio = 0.3;
  scene.verification = "ground_truth";
  scene.random_seed = GetParam();
  SyntheticRun zoom;
  RunSynthetic(scene, "zoom_survey_" + std::to_string(GetParam()), &zoom);
  std::vector<double> rotation_errors_deg = zoom.evaluation.rotation_errors_deg;
  ASSERT_FALSE(rotation_errors_deg.empty());
  std::nth_element(rotation_errors_deg.begin(),
                   rotation_errors_deg.begin() + rotation_errors_deg.size() / 2,
                   rotation_errors_deg.end());
  std::cout << "each image its own focal, survey: AUC@3 "
            << zoom.evaluation.pose_aucs[1] << ", median rotation error "
            << rotation_errors_deg[rotation_errors_deg.size() / 2]
            << " deg, largest focal error " << MaxRelativeFocalError(zoom)
            << std::endl;
  EXPECT_EQ(zoom.evaluation.num_registered, scene.num_images);
  EXPECT_EQ(zoom.evaluation.num_cameras_beyond, 0);
  EXPECT_GE(zoom.evaluation.pose_aucs[1], 70);
  // Split: every image on its own camera, and the mapper says that the
  // grid's views cannot fix each focal well.
  EXPECT_EQ(zoom.model.NumCameras(), zoom.model.NumImages());
  EXPECT_EQ(CountContaining(zoom.warnings, "fit different intrinsics"), 1);
}

// Known intrinsics (item 3): with focal lengths, principal points and
// distortion all held, the written cameras are the database's, bit for bit,
// whatever the mapper merged, calibrated or split on the way. The cameras
// have EXIF focal lengths that are not the truth (so that a stage that
// "corrects" them would show).
TEST_P(CameraSetupsSynthetic, KnownIntrinsicsKeptBitForBit) {
  SyntheticSceneOptions scene;
  scene.num_images = 30;
  scene.num_cameras = 2;
  scene.camera_model = "OPENCV";
  scene.database_camera_per_image = true;
  scene.prior_focal_length = true;
  scene.random_seed = GetParam();
  GlobalMapperOptions options;
  options.random_seed = GetParam();
  options.bundle_adjustment.refine_focal_length = false;
  options.bundle_adjustment.refine_principal_point = false;
  options.bundle_adjustment.refine_extra_params = false;
  // The EXIF focals 2% off the truth, as a camera's metadata gives them.
  auto exif_two_percent_off = [](const std::string& database_path) {
    colmap::Database database(database_path);
    for (colmap::Camera& camera : database.ReadAllCameras()) {
      for (const size_t idx : camera.FocalLengthIdxs()) {
        camera.Params(idx) *= 1.02;
      }
      database.UpdateCamera(camera);
    }
  };
  SyntheticRun known;
  RunSynthetic(scene, "known_" + std::to_string(GetParam()), &known, options,
               exif_two_percent_off);
  colmap::Database database(known.database_path);
  int num_compared = 0;
  for (const colmap::Camera& db_camera : database.ReadAllCameras()) {
    if (!known.model.ExistsCamera(db_camera.CameraId())) continue;
    const colmap::Camera& camera = known.model.Camera(db_camera.CameraId());
    EXPECT_EQ(camera.ModelId(), db_camera.ModelId());
    EXPECT_EQ(camera.Params(), db_camera.Params())
        << "camera " << db_camera.CameraId();
    ++num_compared;
  }
  EXPECT_GE(num_compared, scene.num_images - 1);
}

// Mixed cameras (item 4): three physical cameras of different sizes,
// models, focal lengths, off-centre principal points and distortion, one
// with an EXIF focal 2% off and two without, written one camera per image:
// one model with every image registered and each image's camera within 1%
// of its true focal length and principal point.
TEST_P(CameraSetupsSynthetic, MixedCamerasOneModel) {
  SyntheticSceneOptions scene;
  scene.num_images = 45;
  scene.num_cameras = 3;
  scene.camera_model = "SIMPLE_RADIAL,OPENCV,RADIAL";
  scene.image_sizes = "1024x768,1600x1200,640x480";
  scene.principal_point_offset = 0.02;
  scene.distortion_scale = 3;
  scene.database_camera_per_image = true;
  scene.prior_focal_length = true;
  scene.num_cameras_with_prior = 1;
  scene.prior_focal_length_error = 0.02;
  scene.random_seed = GetParam();
  SyntheticRun mixed;
  RunSynthetic(scene, "mixed_" + std::to_string(GetParam()), &mixed);
  double max_principal_point_error = 0;
  for (const colmap::image_t image_id : mixed.model.RegImageIds()) {
    const colmap::Camera& camera =
        mixed.model.Camera(mixed.model.Image(image_id).CameraId());
    const colmap::Camera& truth =
        mixed.truth.Camera(mixed.truth.Image(image_id).CameraId());
    EXPECT_EQ(camera.Width(), truth.Width());
    max_principal_point_error =
        std::max({max_principal_point_error,
                  std::abs(camera.PrincipalPointX() - truth.PrincipalPointX()) /
                      truth.Width(),
                  std::abs(camera.PrincipalPointY() - truth.PrincipalPointY()) /
                      truth.Height()});
  }
  std::cout << "three mixed cameras: registered "
            << mixed.evaluation.num_registered << "/" << scene.num_images
            << ", AUC@3 " << mixed.evaluation.pose_aucs[1]
            << ", largest focal error " << MaxRelativeFocalError(mixed)
            << ", largest principal point error " << max_principal_point_error
            << " of the image size" << std::endl;
  EXPECT_EQ(mixed.evaluation.num_registered, scene.num_images);
  EXPECT_EQ(mixed.evaluation.num_cameras_beyond, 0);
  EXPECT_LT(MaxRelativeFocalError(mixed), 0.01);
  EXPECT_LT(max_principal_point_error, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Seeds, CameraSetupsSynthetic, ::testing::Values(0, 1));

}  // namespace
}  // namespace glomap
