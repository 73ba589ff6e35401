// Each metric of the model evaluator on hand-made cases with known answers,
// and the `colmap model_evaluator` command end to end.
#include "colmap_ext/model_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>

#include "tests/support/camera_rotation.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDegToRad = M_PI / 180.0;

Eigen::Vector4d ToQvec(const Eigen::Matrix3d& rotation) {
  const Eigen::Quaterniond q(rotation);
  return Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
}

void AddPose(colmap::Reconstruction* model, colmap::image_t image_id,
             const Eigen::Matrix3d& cam_from_world_rotation,
             const Eigen::Vector3d& center) {
  if (!model->ExistsCamera(1)) {
    colmap::Camera camera;
    camera.SetCameraId(1);
    camera.InitializeWithName("PINHOLE", 500.0, 640, 480);
    model->AddCamera(camera);
  }
  colmap::Image image;
  image.SetImageId(image_id);
  image.SetCameraId(1);
  image.SetName("image" + std::to_string(image_id) + ".jpg");
  image.SetQvec(ToQvec(cam_from_world_rotation));
  image.SetTvec(-cam_from_world_rotation * center);
  model->AddImage(image);
  model->RegisterImage(image_id);
}

// n cameras on a ring of radius 5 with varying height, looking inwards.
colmap::Reconstruction MakeRing(int n) {
  colmap::Reconstruction model;
  for (int i = 0; i < n; ++i) {
    const double angle = 2.0 * M_PI * i / n;
    const Eigen::Vector3d center(5.0 * std::cos(angle), 5.0 * std::sin(angle),
                                 0.5 * std::sin(3.0 * angle));
    // Looking at the origin.
    AddPose(&model, i + 1, testing::CamFromWorldLookingAlong(-center), center);
  }
  return model;
}

// The same cameras seen in another frame: x' = scale * R x + t.
colmap::Reconstruction TransformModel(const colmap::Reconstruction& model,
                                      double scale,
                                      const Eigen::Matrix3d& rotation,
                                      const Eigen::Vector3d& translation) {
  colmap::Reconstruction moved;
  for (const colmap::image_t image_id : model.RegImageIds()) {
    const colmap::Image& image = model.Image(image_id);
    const Eigen::Matrix3d cam_from_world = image.RotationMatrix();
    const Eigen::Vector3d center = image.ProjectionCenter();
    AddPose(&moved, image_id, cam_from_world * rotation.transpose(),
            scale * rotation * center + translation);
  }
  return moved;
}

ModelEvaluation Evaluate(const colmap::Reconstruction& model,
                         const colmap::Reconstruction& ground_truth,
                         const ModelEvaluationOptions& options = {}) {
  ModelEvaluation evaluation;
  const Status status =
      EvaluateModel(model, ground_truth, options, &evaluation);
  EXPECT_TRUE(status.ok()) << status.message();
  return evaluation;
}

TEST(ComputeAuc, TrapezoidUnderRecallCurve) {
  // (0,0) -> (0.5,0.5), flat to 1: 0.125 + 0.25 = 0.375 of 1.
  EXPECT_NEAR(ComputeAuc({0.5, 2.0}, 1.0), 37.5, 1e-12);
  // A failure lowers the recall exactly like an error above the threshold.
  EXPECT_NEAR(ComputeAuc({kInf, 0.5}, 1.0), 37.5, 1e-12);
  // (0,0)->(0.5,0.5): 0.125; ->(1.5,1): 0.75; flat to 3: 1.5. Sum / 3.
  EXPECT_NEAR(ComputeAuc({1.5, 0.5}, 3.0), 100.0 * 2.375 / 3.0, 1e-12);
  EXPECT_NEAR(ComputeAuc({0.0, 0.0}, 1.0), 100.0, 1e-12);
  EXPECT_EQ(ComputeAuc({2.0, kInf}, 1.0), 0.0);
  EXPECT_EQ(ComputeAuc({}, 1.0), 0.0);
}

TEST(AngularErrors, RotationAndUnfoldedDirection) {
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())
          .toRotationMatrix();
  const Eigen::Matrix3d rotated =
      rotation *
      Eigen::AngleAxisd(0.7 * kDegToRad, Eigen::Vector3d(0, 1, 1).normalized())
          .toRotationMatrix();
  EXPECT_NEAR(RotationErrorDeg(rotation, rotated), 0.7, 1e-9);
  EXPECT_NEAR(RotationErrorDeg(rotation, rotation), 0.0, 1e-12);
  EXPECT_NEAR(DirectionErrorDeg({1, 0, 0}, {3, 3, 0}), 45.0, 1e-12);
  // No sign folding: the opposite direction is the largest error.
  EXPECT_NEAR(DirectionErrorDeg({1, 0, 0}, {-2, 0, 0}), 180.0, 1e-12);
}

TEST(EvaluateModel, SimilarityTransformedGroundTruthIsPerfect) {
  const colmap::Reconstruction ground_truth = MakeRing(8);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(1.0, Eigen::Vector3d(0.2, -1, 0.5).normalized())
          .toRotationMatrix();
  const colmap::Reconstruction model = TransformModel(
      ground_truth, 0.25, rotation, Eigen::Vector3d(3.0, -1.0, 7.0));
  ModelEvaluationOptions options;
  options.position_auc_thresholds = {0.01};
  const ModelEvaluation evaluation = Evaluate(model, ground_truth, options);
  EXPECT_EQ(evaluation.num_gt_images, 8);
  EXPECT_EQ(evaluation.num_registered, 8);
  EXPECT_EQ(evaluation.num_pairs, 28);
  ASSERT_EQ(evaluation.pose_aucs.size(), 4u);
  for (const double auc : evaluation.pose_aucs) EXPECT_NEAR(auc, 100.0, 1e-6);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_NEAR(evaluation.alignment_scale, 4.0, 1e-9);
  EXPECT_EQ(evaluation.num_alignment_inliers, 8);
  EXPECT_NEAR(evaluation.position_error_mean, 0.0, 1e-9);
  ASSERT_EQ(evaluation.position_aucs.size(), 1u);
  EXPECT_NEAR(evaluation.position_aucs[0], 100.0, 1e-5);
}

TEST(EvaluateModel, RotatedCameraGivesKnownPairErrors) {
  // Turning camera 3 by 2 degrees about its own centre gives exactly 2
  // degrees of relative-rotation error on its 4 pairs (of 10) and at most 2
  // degrees of direction error, and leaves the positions unchanged.
  const colmap::Reconstruction ground_truth = MakeRing(5);
  colmap::Reconstruction model;
  for (const colmap::image_t image_id : ground_truth.RegImageIds()) {
    const colmap::Image& image = ground_truth.Image(image_id);
    Eigen::Matrix3d rotation = image.RotationMatrix();
    if (image_id == 3) {
      rotation = Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitY()) *
                 rotation;
    }
    AddPose(&model, image_id, rotation, image.ProjectionCenter());
  }
  const ModelEvaluation evaluation = Evaluate(model, ground_truth);
  ASSERT_EQ(evaluation.pose_errors_deg.size(), 10u);
  int num_two_degrees = 0;
  for (const double error : evaluation.pose_errors_deg) {
    if (std::abs(error - 2.0) < 1e-9)
      ++num_two_degrees;
    else
      EXPECT_NEAR(error, 0.0, 1e-9);
  }
  EXPECT_EQ(num_two_degrees, 4);
  // Recall points (0, 0.6) and (2, 0.7) .. (2, 1.0): below 2 degrees the
  // curve is flat at 0.6 up to the threshold; above, the trapezoid from
  // (0, 0.6) to (2, 0.7) has area 1.3, then recall 1.0 up to the threshold.
  EXPECT_NEAR(evaluation.pose_aucs[0], 60.0, 1e-6);
  EXPECT_NEAR(evaluation.pose_aucs[1], 100.0 * (1.3 + 1.0) / 3.0, 1e-6);
  EXPECT_NEAR(evaluation.pose_aucs[2], 100.0 * (1.3 + 3.0) / 5.0, 1e-6);
  EXPECT_NEAR(evaluation.pose_aucs[3], 100.0 * (1.3 + 8.0) / 10.0, 1e-6);
  EXPECT_NEAR(evaluation.position_error_mean, 0.0, 1e-9);
}

TEST(EvaluateModel, TranslationDirectionIsNotSignFolded) {
  colmap::Reconstruction ground_truth;
  AddPose(&ground_truth, 1, Eigen::Matrix3d::Identity(), {0, 0, 0});
  AddPose(&ground_truth, 2, Eigen::Matrix3d::Identity(), {1, 0, 0});
  colmap::Reconstruction sideways;
  AddPose(&sideways, 1, Eigen::Matrix3d::Identity(), {0, 0, 0});
  AddPose(&sideways, 2, Eigen::Matrix3d::Identity(), {2, 2, 0});
  ModelEvaluation evaluation = Evaluate(sideways, ground_truth);
  ASSERT_EQ(evaluation.pose_errors_deg.size(), 1u);
  EXPECT_NEAR(evaluation.translation_errors_deg[0], 45.0, 1e-9);
  EXPECT_NEAR(evaluation.rotation_errors_deg[0], 0.0, 1e-9);
  // Two cameras cannot fix a similarity: no position figures.
  EXPECT_FALSE(evaluation.aligned);
  EXPECT_TRUE(std::isnan(evaluation.position_error_mean));

  colmap::Reconstruction flipped;
  AddPose(&flipped, 1, Eigen::Matrix3d::Identity(), {0, 0, 0});
  AddPose(&flipped, 2, Eigen::Matrix3d::Identity(), {-1, 0, 0});
  evaluation = Evaluate(flipped, ground_truth);
  EXPECT_NEAR(evaluation.pose_errors_deg[0], 180.0, 1e-9);
  EXPECT_EQ(evaluation.pose_aucs[3], 0.0);
}

TEST(EvaluateModel, UnregisteredImagesAreFailures) {
  // 4 ground-truth images, 3 registered perfectly: 3 of 6 pairs succeed.
  const colmap::Reconstruction ground_truth = MakeRing(4);
  colmap::Reconstruction model;
  for (const colmap::image_t image_id : {1, 2, 4}) {
    const colmap::Image& image = ground_truth.Image(image_id);
    AddPose(&model, image_id, image.RotationMatrix(), image.ProjectionCenter());
  }
  // An image the ground truth does not know is ignored.
  AddPose(&model, 9, Eigen::Matrix3d::Identity(), {9, 9, 9});
  ModelEvaluationOptions options;
  options.position_auc_thresholds = {0.1};
  const ModelEvaluation evaluation = Evaluate(model, ground_truth, options);
  EXPECT_EQ(evaluation.num_gt_images, 4);
  EXPECT_EQ(evaluation.num_registered, 3);
  EXPECT_EQ(evaluation.num_pairs, 6);
  EXPECT_EQ(evaluation.num_registered_pairs, 3);
  for (const double auc : evaluation.pose_aucs) EXPECT_NEAR(auc, 50.0, 1e-6);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_EQ(evaluation.position_errors.size(), 3u);
  EXPECT_NEAR(evaluation.position_aucs[0], 75.0, 1e-6);
}

TEST(EvaluateModel, RobustAlignmentIgnoresAnOutlierCamera) {
  const colmap::Reconstruction ground_truth = MakeRing(10);
  // Model in half the scale; camera 4 moved by 1 model unit = 2 GT units.
  colmap::Reconstruction model = TransformModel(
      ground_truth, 0.5, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  colmap::Image& moved = model.Image(4);
  const Eigen::Vector3d center =
      moved.ProjectionCenter() + Eigen::Vector3d(0.0, 0.0, 1.0);
  moved.SetTvec(-moved.RotationMatrix() * center);
  const ModelEvaluation evaluation = Evaluate(model, ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_EQ(evaluation.num_alignment_inliers, 9);
  EXPECT_NEAR(evaluation.alignment_scale, 2.0, 1e-9);
  EXPECT_NEAR(evaluation.position_error_median, 0.0, 1e-9);
  EXPECT_NEAR(evaluation.position_error_mean, 2.0 / 10.0, 1e-9);
  // A plain least-squares fit would spread the outlier over every camera.
  EXPECT_NEAR(*std::max_element(evaluation.position_errors.begin(),
                                evaluation.position_errors.end()),
              2.0, 1e-9);
}

// Ring of radius 5: scene size 10 (two opposite cameras). Camera 4 is 2 GT
// units off (20% of the scene), camera 7 0.3 units (3%).
TEST(EvaluateModel, CountsCamerasBeyondAFractionOfTheSceneSize) {
  const colmap::Reconstruction ground_truth = MakeRing(10);
  colmap::Reconstruction model = TransformModel(
      ground_truth, 0.5, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  for (const auto& [image_id, offset] :
       {std::make_pair(4, 1.0), std::make_pair(7, 0.15)}) {
    colmap::Image& moved = model.Image(image_id);
    const Eigen::Vector3d center =
        moved.ProjectionCenter() + Eigen::Vector3d(0.0, 0.0, offset);
    moved.SetTvec(-moved.RotationMatrix() * center);
  }
  ModelEvaluation evaluation = Evaluate(model, ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  // Opposite cameras are 10 apart in the plane, their heights differ a bit.
  EXPECT_NEAR(evaluation.scene_size, 10.0, 0.1);
  EXPECT_EQ(evaluation.num_cameras_beyond, 1);
  ASSERT_EQ(evaluation.cameras_beyond.size(), 1u);
  EXPECT_EQ(evaluation.cameras_beyond[0], "image4.jpg");
  const std::string text =
      EvaluationToText(evaluation, ModelEvaluationOptions());
  EXPECT_NE(text.find("Cameras beyond 5% of the scene size ("),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("): 1 (image4.jpg)"), std::string::npos) << text;

  ModelEvaluationOptions tight;
  tight.max_position_error_fraction_of_scene = 0.01;
  evaluation = Evaluate(model, ground_truth, tight);
  EXPECT_EQ(evaluation.num_cameras_beyond, 2);
  EXPECT_NE(EvaluationToJson(evaluation, tight).find("\"cameras_beyond\": 2"),
            std::string::npos);
}

TEST(EvaluateModel, SeededRansacIsDeterministic) {
  // 40 cameras: more triples than trials, so RANSAC samples at random.
  const colmap::Reconstruction ground_truth = MakeRing(40);
  colmap::Reconstruction model = ground_truth;
  for (const colmap::image_t image_id : {3, 17, 29}) {
    colmap::Image& image = model.Image(image_id);
    image.SetTvec(image.Tvec() + Eigen::Vector3d(0.4, -0.3, 0.2) * image_id);
  }
  const ModelEvaluation first = Evaluate(model, ground_truth);
  const ModelEvaluation second = Evaluate(model, ground_truth);
  ASSERT_TRUE(first.aligned);
  EXPECT_EQ(first.num_alignment_inliers, 37);
  EXPECT_EQ(first.position_errors, second.position_errors);
  EXPECT_EQ(first.pose_aucs, second.pose_aucs);
}

TEST(EvaluateModel, RejectsEmptyGroundTruthAndBadOptions) {
  ModelEvaluation evaluation;
  EXPECT_FALSE(
      EvaluateModel(MakeRing(3), colmap::Reconstruction(), {}, &evaluation)
          .ok());
  ModelEvaluationOptions options;
  options.pose_auc_thresholds_deg = {0.0};
  EXPECT_FALSE(options.Check());
  EXPECT_FALSE(
      EvaluateModel(MakeRing(3), MakeRing(3), options, &evaluation).ok());
}

TEST(ReadModel, ChecksTheFolderBeforeReading) {
  const std::string dir = testing::CreateTestDir("model_evaluation_read");
  colmap::Reconstruction model;
  EXPECT_FALSE(ReadModel(dir + "/missing", &model).ok());
  EXPECT_FALSE(ReadModel(dir, &model).ok());
  std::ofstream(dir + "/cameras.txt") << "# only cameras\n";
  EXPECT_FALSE(ReadModel(dir, &model).ok());

  MakeRing(6).WriteText(dir);
  const Status status = ReadModel(dir, &model);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(model.NumRegImages(), 6u);
}

double JsonNumber(const std::string& json, const std::string& key) {
  const std::regex pattern("\"" + key + "\": ([-0-9.eE+]+)");
  std::smatch match;
  if (!std::regex_search(json, match, pattern)) {
    ADD_FAILURE() << "No key " << key << " in " << json;
    return std::numeric_limits<double>::quiet_NaN();
  }
  return std::stod(match[1].str());
}

TEST(ModelEvaluatorCommand, WritesJsonWithTheMetrics) {
  const std::string dir = testing::CreateTestDir("model_evaluator_command");
  const std::string gt_dir = dir + "/gt";
  const std::string model_dir = dir + "/model";
  std::filesystem::create_directories(gt_dir);
  std::filesystem::create_directories(model_dir);
  // Ground truth as text; model as binary, scaled, with one of the 5 images
  // turned by 2 degrees and another one missing.
  const colmap::Reconstruction ground_truth = MakeRing(6);
  ground_truth.WriteText(gt_dir);
  colmap::Reconstruction model;
  for (const colmap::image_t image_id : ground_truth.RegImageIds()) {
    if (image_id == 6) continue;
    const colmap::Image& image = ground_truth.Image(image_id);
    Eigen::Matrix3d rotation = image.RotationMatrix();
    if (image_id == 3) {
      rotation = Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitY()) *
                 rotation;
    }
    AddPose(&model, image_id, rotation, 3.0 * image.ProjectionCenter());
  }
  model.WriteBinary(model_dir);

  const std::string json_path = dir + "/eval.json";
  const std::string command =
      testing::ColmapExecutable() + " model_evaluator --input_path " +
      model_dir + " --gt_path " + gt_dir + " --json_path " + json_path;
  // Runs the command with `flags`; its JSON, or "" when it failed.
  std::string output;
  auto evaluate = [&](const std::string& flags) -> std::string {
    if (testing::RunCommand(command + " " + flags, &output) != 0) return "";
    std::ifstream file(json_path);
    std::stringstream buffer;
    buffer << file.rdbuf();
    return buffer.str();
  };
  const std::string json = evaluate("--position_thresholds 0.01,0.5");
  ASSERT_FALSE(json.empty()) << output;
  EXPECT_EQ(JsonNumber(json, "images"), 6);
  EXPECT_EQ(JsonNumber(json, "registered"), 5);
  // 15 pairs: 5 fail (image 6), 4 at 2 degrees, 6 exact. Recall points
  // (0, 6/15) and (2, 7/15) .. (2, 10/15): the trapezoid between them has
  // area 13/15, then recall 10/15 up to the threshold.
  EXPECT_NEAR(JsonNumber(json, "auc@1"), 100.0 * 6.0 / 15.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json, "auc@3"),
              100.0 * (13.0 / 15.0 + (10.0 / 15.0) * 1.0) / 3.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json, "auc@5"),
              100.0 * (13.0 / 15.0 + (10.0 / 15.0) * 3.0) / 5.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json, "auc@10"),
              100.0 * (13.0 / 15.0 + (10.0 / 15.0) * 8.0) / 10.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json, "pos_err_mean"), 0.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json, "pos_err_median"), 0.0, 1e-6);
  // 5 of 6 images within any threshold.
  EXPECT_NEAR(JsonNumber(json, "pos_auc@0.5"), 100.0 * 5.0 / 6.0, 1e-4);
  EXPECT_NE(output.find("Registered images: 5"), std::string::npos) << output;

  // Other pose thresholds: at 0.5 degrees only the 6 exact pairs count.
  const std::string json_fine = evaluate("--pose_thresholds 0.5,1");
  ASSERT_FALSE(json_fine.empty()) << output;
  EXPECT_NEAR(JsonNumber(json_fine, "auc@0.5"), 100.0 * 6.0 / 15.0, 1e-6);
  EXPECT_NEAR(JsonNumber(json_fine, "auc@1"), 100.0 * 6.0 / 15.0, 1e-6);
  EXPECT_TRUE(evaluate("--pose_thresholds 0,x").empty()) << output;
}

TEST(ModelEvaluatorCommand, BadPathIsAOneLineError) {
  const std::string dir = testing::CreateTestDir("model_evaluator_bad_path");
  std::string output;
  EXPECT_NE(testing::RunCommand(testing::ColmapExecutable() +
                                    " model_evaluator --input_path " + dir +
                                    "/nothing --gt_path " + dir,
                                &output),
            0);
  EXPECT_NE(output.find("ERROR"), std::string::npos) << output;
  EXPECT_EQ(output.find("Check failed"), std::string::npos) << output;
}

TEST(ModelEvaluatorCommand, GroundTruthAgainstItselfOnSharedData) {
  const std::string datasets = testing::SharedDatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "No shared datasets.";
  const std::string gt_path = datasets + "/fountain-P11/gt";
  if (!std::filesystem::is_directory(gt_path)) {
    GTEST_SKIP() << gt_path << " is absent";
  }
  colmap::Reconstruction ground_truth;
  const Status status = ReadModel(gt_path, &ground_truth);
  ASSERT_TRUE(status.ok()) << status.message();
  const ModelEvaluation evaluation = Evaluate(ground_truth, ground_truth);
  EXPECT_EQ(evaluation.num_gt_images, 11);
  EXPECT_EQ(evaluation.num_registered, 11);
  EXPECT_NEAR(evaluation.pose_aucs[0], 100.0, 1e-6);
  EXPECT_NEAR(evaluation.position_error_mean, 0.0, 1e-9);
}

}  // namespace
}  // namespace glomap
