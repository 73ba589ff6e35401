// The whole pipeline, end to end: synthetic scenes with known answers, and
// real datasets of ../shared/datasets against the reference mappers' figures
// in each dataset's README.
#include "glomap/controllers/global_mapper.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <set>
#include <tuple>

#include "base/pose.h"
#include "colmap_ext/model_evaluation.h"
#include "tests/support/model_record.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  Status status;
  std::vector<colmap::Reconstruction> models;
};

RunResult RunMapper(const std::string& database_path,
                    GlobalMapperOptions options = GlobalMapperOptions()) {
  RunResult result;
  colmap::Reconstruction work;
  GlobalMapper mapper(options);
  result.status = mapper.Run(database_path, &work, &result.models);
  return result;
}

// Largest relative-rotation error over all pairs of registered images.
double MaxRelativeRotationErrorDeg(const colmap::Reconstruction& model,
                                   const colmap::Reconstruction& truth) {
  double max_error_deg = 0;
  std::vector<colmap::image_t> ids = model.RegImageIds();
  std::sort(ids.begin(), ids.end());
  for (size_t i = 0; i < ids.size(); ++i) {
    for (size_t j = i + 1; j < ids.size(); ++j) {
      const Eigen::Quaterniond qi = Eigen::Quaterniond(
          colmap::QuaternionToRotationMatrix(model.Image(ids[i]).Qvec()));
      const Eigen::Quaterniond qj = Eigen::Quaterniond(
          colmap::QuaternionToRotationMatrix(model.Image(ids[j]).Qvec()));
      const Eigen::Quaterniond ti = Eigen::Quaterniond(
          colmap::QuaternionToRotationMatrix(truth.Image(ids[i]).Qvec()));
      const Eigen::Quaterniond tj = Eigen::Quaterniond(
          colmap::QuaternionToRotationMatrix(truth.Image(ids[j]).Qvec()));
      const double error_rad =
          (qj * qi.inverse()).angularDistance(tj * ti.inverse());
      max_error_deg = std::max(max_error_deg, error_rad * 180 / M_PI);
    }
  }
  return max_error_deg;
}

struct SyntheticCase {
  bool prior_focal_length;
  int seed;
};

class GlobalMapperSynthetic : public ::testing::TestWithParam<SyntheticCase> {};

// The bar: 200 images, 1 px noise, 30% wrong matches; known
// intrinsics: rotation error below 0.1 deg and every image registered;
// unknown focal lengths: focal error below 1%.
TEST_P(GlobalMapperSynthetic, TwoHundredImagesNoiseAndOutliers) {
  const std::string dir = testing::CreateTestDir(
      std::string("global_mapper_synthetic_") +
      (GetParam().prior_focal_length ? "prior_" : "no_prior_") +
      std::to_string(GetParam().seed));
  SyntheticSceneOptions scene;
  scene.num_images = 200;
  scene.pixel_noise_px = 1.0;
  scene.wrong_match_ratio = 0.3;
  scene.prior_focal_length = GetParam().prior_focal_length;
  scene.random_seed = GetParam().seed;
  // Ten nearest neighbours per image keep the database small and its
  // verification (COLMAP's estimators) fast.
  scene.max_pairs_per_image = 10;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());

  const RunResult result = RunMapper(dir + "/database.db");
  ASSERT_TRUE(result.status.ok()) << result.status.message();
  ASSERT_EQ(result.models.size(), 1u);
  const colmap::Reconstruction& model = result.models[0];
  EXPECT_EQ(model.NumRegImages(), 200u);
  EXPECT_LT(MaxRelativeRotationErrorDeg(model, truth), 0.1);
  for (const auto& [camera_id, camera] : model.Cameras()) {
    const double true_focal = truth.Camera(camera_id).MeanFocalLength();
    EXPECT_LT(std::abs(camera.MeanFocalLength() - true_focal) / true_focal,
              0.01)
        << "camera " << camera_id;
  }
}

std::string SyntheticCaseName(
    const ::testing::TestParamInfo<SyntheticCase>& info) {
  return std::string(info.param.prior_focal_length ? "KnownFocal"
                                                   : "UnknownFocal") +
         "_seed" + std::to_string(info.param.seed);
}

// Two seeds in every test run; the bars hold for five (the other three are
// opt-in: --gtest_also_run_disabled_tests, about 4 minutes).
INSTANTIATE_TEST_SUITE_P(Synthetic, GlobalMapperSynthetic,
                         ::testing::Values(SyntheticCase{true, 7},
                                           SyntheticCase{false, 7},
                                           SyntheticCase{true, 8},
                                           SyntheticCase{false, 8}),
                         SyntheticCaseName);
INSTANTIATE_TEST_SUITE_P(
    DISABLED_MoreSeeds, GlobalMapperSynthetic,
    ::testing::Values(SyntheticCase{true, 9}, SyntheticCase{false, 9},
                      SyntheticCase{true, 10}, SyntheticCase{false, 10},
                      SyntheticCase{true, 11}, SyntheticCase{false, 11}),
    SyntheticCaseName);

// A nadir survey over hilly terrain, unknown focal length: the whole block
// can bend at almost no reprojection cost, and bundle adjustment that stops
// at a fixed relative cost decrease leaves that bend in (measured on this
// scene: median pairwise rotation error 0.85 deg with the tolerance of 1e-5
// for every size, 0.15 deg with the size-scaled one).
TEST(GlobalMapper, LargeSurveyDoesNotBend) {
  const std::string dir = testing::CreateTestDir("global_mapper_survey");
  SyntheticSceneOptions scene;
  scene.num_images = 300;
  scene.layout = "grid";
  scene.pixel_noise_px = 1.0;
  scene.wrong_match_ratio = 0.3;
  scene.prior_focal_length = false;
  scene.verification = "ground_truth";
  scene.random_seed = 7;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());

  const RunResult result = RunMapper(dir + "/database.db");
  ASSERT_TRUE(result.status.ok()) << result.status.message();
  ASSERT_EQ(result.models.size(), 1u);
  ModelEvaluation evaluation;
  ASSERT_TRUE(EvaluateModel(result.models[0], truth, ModelEvaluationOptions(),
                            &evaluation)
                  .ok());
  EXPECT_EQ(evaluation.num_registered, 300);
  std::vector<double> errors_deg = evaluation.rotation_errors_deg;
  ASSERT_FALSE(errors_deg.empty());
  std::nth_element(errors_deg.begin(),
                   errors_deg.begin() + errors_deg.size() / 2,
                   errors_deg.end());
  EXPECT_LT(errors_deg[errors_deg.size() / 2], 0.4);
}

// Issue 10's failure, reproduced: a group of two images strongly matched to
// each other, weakly (20 matches, below the relative-pose stage's 30
// inliers) to the rest, and linked to its anchor only through pairs whose
// matches are consistent with a relative rotation 30 deg off (symmetric
// structure). Without pose verification the two cameras end far from where
// they belong while the model reprojects well; with it every registered
// camera is within 1% of the scene size, and a camera that is not is left
// unregistered and counted.
class GlobalMapperWeakGroup : public ::testing::TestWithParam<int> {};

TEST_P(GlobalMapperWeakGroup, NoCameraIsSilentlyWrong) {
  const int seed = GetParam();
  const std::string dir = testing::CreateTestDir("global_mapper_weak_group_" +
                                                 std::to_string(seed));
  SyntheticSceneOptions scene;
  scene.num_images = 40;
  scene.max_pairs_per_image = 39;
  scene.verification = "ground_truth";
  scene.prior_focal_length = false;
  scene.weak_group_size = 2;
  scene.weak_group_max_matches_to_rest = 20;
  scene.num_wrong_rotation_pairs = 2;
  scene.wrong_rotation_pairs = "group_to_anchors";
  scene.random_seed = seed;
  colmap::Reconstruction truth;
  SyntheticSceneShapes shapes;
  ASSERT_TRUE(
      WriteSyntheticScene(scene, dir + "/database.db", &truth, &shapes).ok());
  ASSERT_EQ(shapes.weak_group_image_ids.size(), 2u);

  ModelEvaluationOptions one_percent;
  one_percent.max_position_error_fraction_of_scene = 0.01;
  auto evaluate = [&](bool verify, GlobalMapperSummary* summary) {
    GlobalMapperOptions options;
    options.skip_pose_verification = !verify;
    colmap::Reconstruction work;
    std::vector<colmap::Reconstruction> models;
    GlobalMapper mapper(options);
    const Status status = mapper.Run(dir + "/database.db", &work, &models);
    EXPECT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(models.size(), 1u);
    *summary = mapper.Summary();
    ModelEvaluation evaluation;
    if (!models.empty()) {
      EXPECT_TRUE(
          EvaluateModel(models[0], truth, one_percent, &evaluation).ok());
    }
    return evaluation;
  };

  GlobalMapperSummary before_summary;
  const ModelEvaluation before = evaluate(false, &before_summary);
  EXPECT_GE(before.num_cameras_beyond, 1)
      << "the scene no longer reproduces the failure";
  for (const std::string& name : before.cameras_beyond) {
    EXPECT_TRUE(name == truth.Image(shapes.weak_group_image_ids[0]).Name() ||
                name == truth.Image(shapes.weak_group_image_ids[1]).Name())
        << name;
  }

  GlobalMapperSummary after_summary;
  const ModelEvaluation after = evaluate(true, &after_summary);
  EXPECT_EQ(after.num_cameras_beyond, 0);
  // Every camera is either right or reported as left out.
  EXPECT_EQ(after.num_registered + after_summary.num_deregistered_images,
            after.num_gt_images);
  EXPECT_GE(
      after_summary.num_replaced_images + after_summary.num_deregistered_images,
      static_cast<size_t>(before.num_cameras_beyond));
}

INSTANTIATE_TEST_SUITE_P(Seeds, GlobalMapperWeakGroup,
                         ::testing::Values(0, 1, 2, 3, 4));

// The other shapes that can leave a camera unconstrained (issue 10): pure
// rotation pairs, cameras matched only across long baselines, two halves
// joined by one weak pair. None reproduced the failure, and this keeps it
// so: every registered camera within 1% of the scene size, every image
// either registered or counted as left out (by pose verification or, for a
// half that the bridge cannot hold, by the disconnected view graph).
struct ShapeCase {
  std::string name;
  std::function<void(SyntheticSceneOptions*)> apply;
  int seed;
};

class GlobalMapperFailureShapes : public ::testing::TestWithParam<ShapeCase> {};

TEST_P(GlobalMapperFailureShapes, NoCameraIsSilentlyWrong) {
  const ShapeCase& c = GetParam();
  const std::string dir = testing::CreateTestDir(
      "global_mapper_shape_" + c.name + "_" + std::to_string(c.seed));
  SyntheticSceneOptions scene;
  scene.num_images = 40;
  scene.max_pairs_per_image = 39;
  scene.verification = "ground_truth";
  scene.prior_focal_length = false;
  scene.wrong_match_ratio = 0.2;
  scene.random_seed = c.seed;
  c.apply(&scene);
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());

  colmap::Reconstruction work;
  std::vector<colmap::Reconstruction> models;
  GlobalMapper mapper{GlobalMapperOptions()};
  const Status status = mapper.Run(dir + "/database.db", &work, &models);
  ASSERT_TRUE(status.ok()) << status.message();
  ModelEvaluationOptions one_percent;
  one_percent.max_position_error_fraction_of_scene = 0.01;
  size_t num_registered = 0;
  for (const colmap::Reconstruction& model : models) {
    ModelEvaluation evaluation;
    ASSERT_TRUE(EvaluateModel(model, truth, one_percent, &evaluation).ok());
    num_registered += evaluation.num_registered;
    if (model.NumRegImages() >= 3) {
      EXPECT_EQ(evaluation.num_cameras_beyond, 0)
          << c.name << ": " << evaluation.cameras_beyond.front();
    }
  }
  std::cout << c.name << " (seed " << c.seed << "): " << models.size()
            << " model(s), " << num_registered << " of " << truth.NumRegImages()
            << " images registered, " << mapper.Summary().num_replaced_images
            << " re-placed, " << mapper.Summary().num_deregistered_images
            << " left out" << std::endl;
  EXPECT_GE(num_registered, truth.NumRegImages() / 2);
}

INSTANTIATE_TEST_SUITE_P(
    Shapes, GlobalMapperFailureShapes,
    ::testing::Values(
        ShapeCase{
            "pure_rotation",
            [](SyntheticSceneOptions* o) { o->num_pure_rotation_images = 2; },
            0},
        ShapeCase{
            "pure_rotation",
            [](SyntheticSceneOptions* o) { o->num_pure_rotation_images = 2; },
            1},
        ShapeCase{
            "long_baseline",
            [](SyntheticSceneOptions* o) { o->num_long_baseline_images = 1; },
            0},
        ShapeCase{
            "long_baseline",
            [](SyntheticSceneOptions* o) { o->num_long_baseline_images = 1; },
            1},
        ShapeCase{"weak_bridge",
                  [](SyntheticSceneOptions* o) { o->weak_bridge = true; }, 0},
        ShapeCase{"weak_bridge",
                  [](SyntheticSceneOptions* o) { o->weak_bridge = true; }, 1}),
    [](const auto& info) {
      return info.param.name + "_seed" + std::to_string(info.param.seed);
    });

// Position priors (issue 12) on a forward sequence: 3 m of noise per axis,
// 10% of the priors displaced by 20-100 m. With priors the model comes out
// in the priors' frame, in metres, and is compared with the truth without
// any alignment; without priors it is aligned to the same priors by a robust
// similarity (what a user would do with COLMAP's model_aligner). Every
// displaced prior is rejected and named, few good ones are.
//
// The bar on the position error: this synthetic sequence does not drift
// (the free model is right to about 1 cm after a similarity to the truth),
// so the error of both runs is that of the frame, which the priors' noise
// fixes no better than the floor sigma * sqrt(7 / N) (7 unknowns of a
// similarity, N good priors: 0.65 m RMS here); an absolute error of 2x less
// than the aligned free run is therefore impossible. The run with priors
// must stay within 30% of the aligned free run and within 1.5x of the
// floor, and its pairwise accuracy must not drop. The two runs are two
// estimates of the same frame from the same noisy priors: least squares on
// the inliers, and the Cauchy loss in bundle adjustment (97% as efficient
// for Gaussian noise at the default scale of 3 std); measured on seeds 0,
// 1, 2: 0.91 vs 0.77 m, 0.53 vs 0.53 m, 0.57 vs 0.55 m (with the loss scale
// at 100 std, seed 0 gives 0.77 m too).
class GlobalMapperPositionPriors : public ::testing::TestWithParam<int> {};

TEST_P(GlobalMapperPositionPriors, ForwardSequenceInPriorFrame) {
  const int seed = GetParam();
  const std::string dir = testing::CreateTestDir(
      "global_mapper_position_priors_" + std::to_string(seed));
  SyntheticSceneOptions scene;
  scene.num_images = 150;
  scene.layout = "forward";
  scene.verification = "ground_truth";
  scene.max_pairs_per_image = 15;
  constexpr double kPriorStdM = 3;
  constexpr double kMaxErrorStd = 5;
  scene.prior_position_noise_m = kPriorStdM;
  scene.prior_outlier_ratio = 0.1;
  scene.random_seed = seed;
  colmap::Reconstruction truth;
  SyntheticSceneShapes shapes;
  ASSERT_TRUE(
      WriteSyntheticScene(scene, dir + "/database.db", &truth, &shapes).ok());
  ASSERT_EQ(shapes.prior_outlier_image_ids.size(), 15u);

  GlobalMapperOptions prior_options;
  prior_options.position_priors.use_position_priors = true;
  prior_options.position_priors.prior_position_std_m = kPriorStdM;
  prior_options.position_priors.prior_max_error_std = kMaxErrorStd;
  GlobalMapper prior_mapper(prior_options);
  colmap::Reconstruction work;
  std::vector<colmap::Reconstruction> prior_models;
  const Status prior_status =
      prior_mapper.Run(dir + "/database.db", &work, &prior_models);
  ASSERT_TRUE(prior_status.ok()) << prior_status.message();
  ASSERT_EQ(prior_models.size(), 1u);
  GlobalMapper free_mapper{GlobalMapperOptions()};
  colmap::Reconstruction free_work;
  std::vector<colmap::Reconstruction> free_models;
  const Status free_status =
      free_mapper.Run(dir + "/database.db", &free_work, &free_models);
  ASSERT_TRUE(free_status.ok()) << free_status.message();
  ASSERT_EQ(free_models.size(), 1u);
  EXPECT_FALSE(free_mapper.GetGeoregistration().georegistered);
  const colmap::Reconstruction& prior_model = prior_models[0];
  const colmap::Reconstruction& free_model = free_models[0];

  const Georegistration& georegistration = prior_mapper.GetGeoregistration();
  EXPECT_TRUE(georegistration.georegistered);
  EXPECT_EQ(georegistration.frame, "metric");
  const std::set<std::string> rejected(
      georegistration.rejected_prior_image_names.begin(),
      georegistration.rejected_prior_image_names.end());
  for (const colmap::image_t image_id : shapes.prior_outlier_image_ids) {
    EXPECT_EQ(rejected.count(truth.Image(image_id).Name()), 1u)
        << truth.Image(image_id).Name();
  }
  const size_t num_good_rejected =
      rejected.size() - shapes.prior_outlier_image_ids.size();
  // A good prior is farther than 5 std from its camera with probability
  // 1.5e-5 (chi-square, 3 degrees of freedom): none is expected.
  EXPECT_LE(num_good_rejected, 2u);

  // Absolute errors in metres, by image id (ids are shared with the truth).
  std::vector<Eigen::Vector3d> free_centers;
  std::vector<Eigen::Vector3d> free_priors;
  for (const colmap::image_t image_id : free_model.RegImageIds()) {
    free_centers.push_back(free_model.Image(image_id).ProjectionCenter());
    free_priors.push_back(shapes.prior_positions[image_id - 1]);
  }
  SimilarityAlignment to_priors;
  ASSERT_TRUE(EstimateSimilarityRobust(free_centers, free_priors,
                                       kMaxErrorStd * kPriorStdM, 2000, 0,
                                       &to_priors)
                  .ok());
  auto mean_error = [&truth](const colmap::Reconstruction& model,
                             const SimilarityAlignment& alignment) {
    double sum = 0;
    for (const colmap::image_t image_id : model.RegImageIds()) {
      const Eigen::Vector3d center =
          alignment.scale * alignment.rotation *
              model.Image(image_id).ProjectionCenter() +
          alignment.translation;
      sum += (center - truth.Image(image_id).ProjectionCenter()).norm();
    }
    return sum / model.NumRegImages();
  };
  const double prior_error_m = mean_error(prior_model, SimilarityAlignment());
  const double free_aligned_error_m = mean_error(free_model, to_priors);
  const size_t num_good_priors =
      scene.num_images - shapes.prior_outlier_image_ids.size();
  const double floor_m = kPriorStdM * std::sqrt(7.0 / num_good_priors);

  ModelEvaluation prior_evaluation;
  ModelEvaluation free_evaluation;
  ASSERT_TRUE(EvaluateModel(prior_model, truth, ModelEvaluationOptions(),
                            &prior_evaluation)
                  .ok());
  ASSERT_TRUE(EvaluateModel(free_model, truth, ModelEvaluationOptions(),
                            &free_evaluation)
                  .ok());
  std::cout << "seed " << seed << ": absolute position error with priors "
            << prior_error_m << " m, without priors aligned to them "
            << free_aligned_error_m << " m (floor " << floor_m << " m); AUC@3 "
            << prior_evaluation.pose_aucs[1] << " vs "
            << free_evaluation.pose_aucs[1] << "; rejected " << rejected.size()
            << " priors (" << num_good_rejected << " good); "
            << prior_mapper.Summary().total_seconds << " s vs "
            << free_mapper.Summary().total_seconds << " s" << std::endl;
  EXPECT_EQ(prior_model.NumRegImages(), 150u);
  // The noise the model shows: 3 m, raised a little by the wrong priors.
  EXPECT_GT(georegistration.prior_noise_estimate_m, 0.8 * kPriorStdM);
  EXPECT_LT(georegistration.prior_noise_estimate_m, 1.3 * kPriorStdM);
  EXPECT_LT(prior_error_m, 1.3 * free_aligned_error_m);
  EXPECT_LT(prior_error_m, 1.5 * floor_m);
  EXPECT_GE(prior_evaluation.pose_aucs[1], free_evaluation.pose_aucs[1] - 0.5);
}

// Two seeds in every test run (about a minute each); a third is opt-in.
INSTANTIATE_TEST_SUITE_P(Seeds, GlobalMapperPositionPriors,
                         ::testing::Values(0, 1));
INSTANTIATE_TEST_SUITE_P(DISABLED_MoreSeeds, GlobalMapperPositionPriors,
                         ::testing::Values(2));

// Priors noisier than the user says (3 m of noise, prior_position_std_m at
// its default of 1 m): the model shows their real noise (georegistration.txt
// says it, and the log warns), instead of only rejecting good priors.
TEST(GlobalMapper, PriorsNoisierThanStatedAreSeen) {
  const std::string dir = testing::CreateTestDir("global_mapper_prior_noise");
  SyntheticSceneOptions scene;
  scene.num_images = 80;
  scene.layout = "forward";
  scene.verification = "ground_truth";
  scene.max_pairs_per_image = 15;
  scene.prior_position_noise_m = 3;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());
  GlobalMapperOptions options;
  options.position_priors.use_position_priors = true;
  ASSERT_EQ(options.position_priors.prior_position_std_m, 1);
  GlobalMapper mapper(options);
  colmap::Reconstruction work;
  std::vector<colmap::Reconstruction> models;
  ::testing::internal::CaptureStderr();
  const Status status = mapper.Run(dir + "/database.db", &work, &models);
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_TRUE(status.ok()) << status.message();
  const Georegistration& georegistration = mapper.GetGeoregistration();
  ASSERT_TRUE(georegistration.georegistered);
  EXPECT_GT(georegistration.prior_noise_estimate_m, 2.2);
  EXPECT_LT(georegistration.prior_noise_estimate_m, 4.0);
  EXPECT_NE(log.find("The position priors look noisier than "
                     "GlobalMapper.prior_position_std_m says"),
            std::string::npos);
}

TEST(GlobalMapper, SameSeedSameModel) {
  const std::string dir = testing::CreateTestDir("global_mapper_determinism");
  SyntheticSceneOptions scene;
  scene.num_images = 30;
  scene.wrong_match_ratio = 0.2;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());
  const RunResult a = RunMapper(dir + "/database.db");
  const RunResult b = RunMapper(dir + "/database.db");
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  ASSERT_EQ(a.models.size(), b.models.size());
  const auto& ma = a.models[0];
  const auto& mb = b.models[0];
  ASSERT_EQ(ma.NumRegImages(), mb.NumRegImages());
  ASSERT_EQ(ma.NumPoints3D(), mb.NumPoints3D());
  for (const colmap::image_t image_id : ma.RegImageIds()) {
    EXPECT_EQ(ma.Image(image_id).Qvec(), mb.Image(image_id).Qvec());
    EXPECT_EQ(ma.Image(image_id).Tvec(), mb.Image(image_id).Tvec());
  }
}

TEST(GlobalMapper, DatabaseWithoutPairsIsAnError) {
  const std::string dir = testing::CreateTestDir("global_mapper_no_pairs");
  const RunResult result = RunMapper(dir + "/missing.db");
  EXPECT_FALSE(result.status.ok());
  EXPECT_TRUE(result.models.empty());
}

// Real datasets: the reference figures of each dataset's README. The bars
// (issue 10): every image registered; pairwise AUC@3 at least the better of
// the two reference mappers' figures minus 0.5; no registered camera farther
// than 5% of the scene size from the ground truth after a robust similarity
// alignment; KITTI_sequence_1 also keeps its 2 cm mean position bar. Each
// dataset runs with two seeds, so that a bar is not met by one lucky seed
// (the benchmark runs five).
struct RealCase {
  std::string name;
  size_t num_images;
  double min_auc3;                // AUC@3 bar, percent
  double best_reference_pos_err;  // mean position error, GT units
  double absolute_max_pos_err;    // when > 0, an absolute bar instead
  // How far seed 0's model may be from its record.
  testing::ModelRecordTolerances record_tolerances = {};
};

// dino-363 (untextured, many wrong pairs) does not come out to the last
// digits on another CPU: a Release build on an AMD EPYC gave centres up to
// 1.5e-3 of the scene size and rotations up to 0.16 deg from the record made
// on the previous CI machine, k1 0.271 against 0.248 and 2,853 points
// against 2,856, with the same AUC@3 within 0.1. Its record therefore only
// catches changes well beyond that; the other datasets keep the tight
// default.
testing::ModelRecordTolerances AcrossCpusTolerances() {
  testing::ModelRecordTolerances tolerances;
  tolerances.max_center_difference_ratio = 5e-3;
  tolerances.max_rotation_difference_deg = 0.5;
  tolerances.max_camera_param_difference = 0.2;
  tolerances.max_count_difference_ratio = 1e-2;
  return tolerances;
}

class GlobalMapperRealData
    : public ::testing::TestWithParam<std::tuple<RealCase, int>> {};

TEST_P(GlobalMapperRealData, MatchesReferenceMappers) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets is absent";
  const RealCase& c = std::get<0>(GetParam());
  const int seed = std::get<1>(GetParam());
  const std::string dataset_dir = datasets + "/" + c.name;
  if (!std::filesystem::exists(dataset_dir + "/database.db") ||
      !std::filesystem::is_directory(dataset_dir + "/gt")) {
    GTEST_SKIP() << c.name << " (its database.db and gt/) is not in "
                 << datasets;
  }
  const std::string database_path = dataset_dir + "/database.db";
  const std::string digest_before = testing::FileDigest(database_path);

  GlobalMapperOptions options;
  options.random_seed = seed;
  const RunResult result = RunMapper(database_path, options);
  ASSERT_TRUE(result.status.ok()) << result.status.message();
  EXPECT_EQ(testing::FileDigest(database_path), digest_before);
  ASSERT_GE(result.models.size(), 1u);

  colmap::Reconstruction truth;
  ASSERT_TRUE(ReadModel(dataset_dir + "/gt", &truth).ok());
  ModelEvaluation evaluation;
  ASSERT_TRUE(EvaluateModel(result.models[0], truth, ModelEvaluationOptions(),
                            &evaluation)
                  .ok());
  std::cout << c.name << " (seed " << seed << "): registered "
            << evaluation.num_registered << "/" << evaluation.num_gt_images
            << ", AUC@1/3/5/10 " << evaluation.pose_aucs[0] << " "
            << evaluation.pose_aucs[1] << " " << evaluation.pose_aucs[2] << " "
            << evaluation.pose_aucs[3] << ", position error mean "
            << evaluation.position_error_mean << ", cameras beyond 5% "
            << evaluation.num_cameras_beyond << std::endl;
  EXPECT_EQ(evaluation.num_registered, static_cast<int>(c.num_images));
  EXPECT_EQ(evaluation.num_cameras_beyond, 0);

  // Seed 0 gives the model recorded when the pipeline last changed on
  // purpose, so a change meant to keep behaviour is checked on every
  // dataset (tests/data/recorded_models/README.md says when to record anew).
  if (seed == 0) {
    const std::string record_path = std::string(GLOMAP_SOURCE_DIR) +
                                    "/tests/data/recorded_models/" + c.name +
                                    "_seed0.txt";
    if (std::getenv("GLOMAP_RECORD_MODELS") != nullptr) {
      ASSERT_TRUE(testing::WriteModelRecord(
                      result.models[0],
                      "global_mapper on " + c.name + ", seed 0, defaults",
                      record_path)
                      .ok());
    } else {
      const std::vector<std::string> differences =
          testing::CompareWithModelRecord(result.models[0], record_path,
                                          c.record_tolerances);
      std::string report;
      for (const std::string& line : differences) report += line + "\n";
      EXPECT_TRUE(differences.empty())
          << "The model differs from " << record_path << ":\n"
          << report;
    }
  }
  EXPECT_GE(evaluation.pose_aucs[1], c.min_auc3);
  if (c.absolute_max_pos_err > 0) {
    EXPECT_LE(evaluation.position_error_mean, c.absolute_max_pos_err);
  } else {
    EXPECT_LE(evaluation.position_error_mean, 1.2 * c.best_reference_pos_err);
  }
}

INSTANTIATE_TEST_SUITE_P(
    SharedDatasets, GlobalMapperRealData,
    ::testing::Combine(
        // AUC@3 bars: the better reference figure minus 0.5; on dino-363
        // (no upstream figure) the stock mapper's minus 1.
        ::testing::Values(RealCase{"fountain-P11", 11, 88.7 - 0.5, 0.006072, 0},
                          RealCase{"Herz-Jesus-P8", 8, 90.0 - 0.5, 0.008546, 0},
                          RealCase{"entry-P10", 10, 88.4 - 0.5, 0.02241, 0},
                          RealCase{"castle-P19", 19, 78.3 - 0.5, 0.1283, 0},
                          RealCase{"templeRing", 47, 69.2 - 0.5, 0.001034, 0},
                          RealCase{"KITTI_sequence_1", 51, 66.2 - 0.5, 0, 0.02},
                          RealCase{"dino-363", 363, 70.2 - 1.0, 0.002523, 0,
                                   AcrossCpusTolerances()}),
        ::testing::Values(0, 1)),
    [](const auto& info) {
      std::string name = std::get<0>(info.param).name;
      for (char& ch : name) {
        if (!isalnum(ch)) ch = '_';
      }
      return name + "_seed" + std::to_string(std::get<1>(info.param));
    });

}  // namespace
}  // namespace glomap
