// Accuracy of a reconstruction against a ground-truth model, with the two
// metrics of the paper's evaluation (Section 4, "Metrics"):
//  - pairwise AUC: for every pair of ground-truth images, the larger of the
//    relative-rotation error and the angle between the relative translation
//    directions, summarised as the area under the recall curve;
//  - camera position errors after a robust similarity alignment of the model
//    to the ground truth (used for sequences, where relative errors hide
//    scale drift).
// Images are matched by name; images of the model that the ground truth does
// not know are ignored.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {

struct ModelEvaluationOptions {
  // Thresholds of the pairwise pose AUC, in degrees.
  std::vector<double> pose_auc_thresholds_deg = {1.0, 3.0, 5.0, 10.0};
  // Thresholds of the camera position AUC, in ground-truth units (metres for
  // the shared datasets); empty for none.
  std::vector<double> position_auc_thresholds = {};
  // Inlier threshold of the similarity RANSAC as a fraction of the scene
  // scale, the median distance of the ground-truth camera centres from their
  // coordinate-wise median (robust to a few far-away cameras).
  double alignment_inlier_fraction_of_scale = 0.05;
  // Upper bound on random 3-point samples of the alignment RANSAC; when there
  // are fewer distinct triples, all of them are tried instead.
  int alignment_max_num_trials = 2000;
  // Seed of the alignment RANSAC, so that the same input gives the same
  // output.
  uint64_t random_seed = 0;
  // A registered camera is "placed wrongly" when its position error after
  // the alignment exceeds this fraction of the scene size (the largest
  // distance between two ground-truth camera centres).
  double max_position_error_fraction_of_scene = 0.05;

  bool Check() const;
};

struct ModelEvaluation {
  // Images in the ground truth.
  int num_gt_images = 0;
  // Ground-truth images that the model registers (matched by name).
  int num_registered = 0;
  // Image pairs of the ground truth, and those with both images registered.
  int64_t num_pairs = 0;
  int64_t num_registered_pairs = 0;

  // Per pair of registered images (failures are not listed): the error in
  // degrees of the relative rotation, of the relative translation direction,
  // and their maximum.
  std::vector<double> rotation_errors_deg;
  std::vector<double> translation_errors_deg;
  std::vector<double> pose_errors_deg;
  // Pose AUC in percent, one per options.pose_auc_thresholds_deg; pairs with
  // an unregistered image count as failures.
  std::vector<double> pose_aucs;

  // Whether the similarity alignment could be fitted (needs 3 registered,
  // non-degenerate camera centres); the position fields below are NaN
  // otherwise.
  bool aligned = false;
  // Model-to-ground-truth similarity: x_gt = scale * rotation * x +
  // translation.
  double alignment_scale = 1.0;
  Eigen::Matrix3d alignment_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d alignment_translation = Eigen::Vector3d::Zero();
  // RANSAC inlier threshold used, in ground-truth units, and inlier count.
  double alignment_inlier_threshold = 0.0;
  int num_alignment_inliers = 0;
  // Camera position error of every registered ground-truth image after the
  // alignment, in ground-truth units, in ground-truth image-id order.
  std::vector<double> position_errors;
  double position_error_mean = 0.0;
  double position_error_median = 0.0;
  // Position AUC in percent, one per options.position_auc_thresholds;
  // unregistered images count as failures.
  std::vector<double> position_aucs;

  // Scene size: the largest distance between two ground-truth camera
  // centres, in ground-truth units.
  double scene_size = 0.0;
  // Registered cameras farther from the ground truth than
  // options.max_position_error_fraction_of_scene * scene_size after the
  // alignment (all registered cameras when no alignment could be fitted),
  // with their names in ground-truth image-id order.
  int num_cameras_beyond = 0;
  std::vector<std::string> cameras_beyond;
};

// Area under the recall curve of `errors` up to `threshold`, divided by the
// threshold, in percent: the trapezoid rule over the points (0, 0) and
// (error_i, i / n) of the sorted errors, closed at the threshold. n counts
// every entry, so that +infinity (a failure) lowers the recall without ever
// being recalled. Returns 0 for no errors.
double ComputeAuc(std::vector<double> errors, double threshold);

// Angle in degrees between two rotations, between two directions
// (unsigned, not folded: a reconstruction fixes the sign).
double RotationErrorDeg(const Eigen::Matrix3d& rotation1,
                        const Eigen::Matrix3d& rotation2);
double DirectionErrorDeg(const Eigen::Vector3d& direction1,
                         const Eigen::Vector3d& direction2);

// Similarity x_dst = scale * rotation * x_src + translation fitted robustly:
// RANSAC over 3-point subsets (closed-form Umeyama), then least squares on the
// inliers of the best sample, repeated until the inlier set is stable.
struct SimilarityAlignment {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  int num_inliers = 0;
};
Status EstimateSimilarityRobust(const std::vector<Eigen::Vector3d>& src,
                                const std::vector<Eigen::Vector3d>& dst,
                                double inlier_threshold, int max_num_trials,
                                uint64_t random_seed,
                                SimilarityAlignment* alignment);

// Compares `model` with `ground_truth`. Fails only on invalid options or an
// empty ground truth; a model that registers nothing gives zero AUCs.
Status EvaluateModel(const colmap::Reconstruction& model,
                     const colmap::Reconstruction& ground_truth,
                     const ModelEvaluationOptions& options,
                     ModelEvaluation* evaluation);

// Reads a COLMAP model folder (binary preferred, else text) after checking
// that it holds cameras, images and points3D, so that a bad path is an error
// message instead of an abort inside COLMAP.
Status ReadModel(const std::string& path, colmap::Reconstruction* model);

// The evaluation as one JSON object: images, registered, auc@<t> per pose
// threshold, pos_err_mean, pos_err_median, pos_auc@<t> per position
// threshold, plus pairs, registered_pairs, alignment_inliers and the median
// rotation and translation errors. NaN values are written as null.
std::string EvaluationToJson(const ModelEvaluation& evaluation,
                             const ModelEvaluationOptions& options);

// The evaluation as human-readable lines.
std::string EvaluationToText(const ModelEvaluation& evaluation,
                             const ModelEvaluationOptions& options);

}  // namespace glomap
