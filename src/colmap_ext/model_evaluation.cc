#include "colmap_ext/model_evaluation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>
#include <unordered_map>

namespace glomap {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

double Median(std::vector<double> values) {
  if (values.empty()) return kNaN;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  const double upper = values[mid];
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

double Mean(const std::vector<double>& values) {
  if (values.empty()) return kNaN;
  double sum = 0.0;
  for (const double value : values) sum += value;
  return sum / static_cast<double>(values.size());
}

// Threshold as it appears in keys and text: 1, 3, 0.05 (shortest form).
std::string FormatThreshold(double threshold) {
  std::ostringstream out;
  out << std::setprecision(6) << threshold;
  return out.str();
}

std::string FormatJsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  std::ostringstream out;
  out << std::setprecision(10) << value;
  return out.str();
}

// Closed-form least-squares similarity (Umeyama) of the selected points.
bool FitSimilarity(const std::vector<Eigen::Vector3d>& src,
                   const std::vector<Eigen::Vector3d>& dst,
                   const std::vector<int>& indices,
                   SimilarityAlignment* alignment) {
  Eigen::Matrix3Xd src_matrix(3, indices.size());
  Eigen::Matrix3Xd dst_matrix(3, indices.size());
  for (size_t k = 0; k < indices.size(); ++k) {
    src_matrix.col(k) = src[indices[k]];
    dst_matrix.col(k) = dst[indices[k]];
  }
  const Eigen::Matrix4d transform =
      Eigen::umeyama(src_matrix, dst_matrix, /*with_scaling=*/true);
  if (!transform.allFinite()) return false;
  const Eigen::Matrix3d scaled_rotation = transform.topLeftCorner<3, 3>();
  const double scale = std::cbrt(scaled_rotation.determinant());
  if (!(scale > 0.0) || !std::isfinite(scale)) return false;
  alignment->scale = scale;
  alignment->rotation = scaled_rotation / scale;
  alignment->translation = transform.topRightCorner<3, 1>();
  return true;
}

double AlignmentResidual(const SimilarityAlignment& alignment,
                         const Eigen::Vector3d& src,
                         const Eigen::Vector3d& dst) {
  return (alignment.scale * alignment.rotation * src + alignment.translation -
          dst)
      .norm();
}

// Inliers of `alignment` and its MSAC cost (sum of squared residuals
// truncated at the threshold; lower is better).
std::vector<int> FindInliers(const std::vector<Eigen::Vector3d>& src,
                             const std::vector<Eigen::Vector3d>& dst,
                             const SimilarityAlignment& alignment,
                             double inlier_threshold, double* cost) {
  std::vector<int> inliers;
  const double max_squared = inlier_threshold * inlier_threshold;
  *cost = 0.0;
  for (size_t i = 0; i < src.size(); ++i) {
    const double residual = AlignmentResidual(alignment, src[i], dst[i]);
    const double squared = residual * residual;
    if (squared <= max_squared) {
      inliers.push_back(static_cast<int>(i));
      *cost += squared;
    } else {
      *cost += max_squared;
    }
  }
  return inliers;
}

// A triangle whose points are (nearly) coincident or collinear does not fix a
// rotation.
bool IsDegenerateSample(const std::vector<Eigen::Vector3d>& points,
                        const std::vector<int>& sample) {
  const Eigen::Vector3d edge1 = points[sample[1]] - points[sample[0]];
  const Eigen::Vector3d edge2 = points[sample[2]] - points[sample[0]];
  const double lengths = edge1.norm() * edge2.norm();
  return !(lengths > 0.0) || edge1.cross(edge2).norm() <= 1e-9 * lengths;
}

// Every distinct triple of n points when there are at most max_num_samples
// of them (exhaustive, hence optimal), else max_num_samples random ones.
std::vector<std::vector<int>> MakeSamples(int n, int max_num_samples,
                                          uint64_t random_seed) {
  std::vector<std::vector<int>> samples;
  const double num_triples = static_cast<double>(n) * (n - 1) * (n - 2) / 6.0;
  if (num_triples <= max_num_samples) {
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        for (int k = j + 1; k < n; ++k) samples.push_back({i, j, k});
      }
    }
    return samples;
  }
  std::mt19937_64 rng(random_seed);
  std::uniform_int_distribution<int> distribution(0, n - 1);
  samples.reserve(max_num_samples);
  while (static_cast<int>(samples.size()) < max_num_samples) {
    std::vector<int> sample(3);
    sample[0] = distribution(rng);
    do {
      sample[1] = distribution(rng);
    } while (sample[1] == sample[0]);
    do {
      sample[2] = distribution(rng);
    } while (sample[2] == sample[0] || sample[2] == sample[1]);
    samples.push_back(std::move(sample));
  }
  return samples;
}

Eigen::Matrix3d RotationMatrix(const colmap::Image& image) {
  return Eigen::Quaterniond(image.Qvec(0), image.Qvec(1), image.Qvec(2),
                            image.Qvec(3))
      .normalized()
      .toRotationMatrix();
}

Eigen::Vector3d ProjectionCenter(const colmap::Image& image) {
  return -RotationMatrix(image).transpose() * image.Tvec();
}

// The ground-truth images (registered ones, in id order) and their matches
// in the model by name (nullptr where the model does not register one).
struct MatchedImages {
  std::vector<const colmap::Image*> gt_images;
  std::vector<const colmap::Image*> matched_images;
};

// Pairwise relative-pose errors of every ground-truth pair (a pair with an
// unregistered image counts as infinitely wrong) and their AUCs.
void EvaluatePairs(const MatchedImages& images,
                   const ModelEvaluationOptions& options,
                   ModelEvaluation* evaluation) {
  const std::vector<const colmap::Image*>& gt_images = images.gt_images;
  const std::vector<const colmap::Image*>& matched_images =
      images.matched_images;
  const int num_images = static_cast<int>(gt_images.size());
  // The relative pose of j from i is
  // R_ij = R_j R_i^T, t_ij = t_j - R_ij t_i (world-to-camera poses).
  std::vector<Eigen::Matrix3d> gt_rotations(num_images);
  std::vector<Eigen::Matrix3d> rotations(num_images);
  for (int i = 0; i < num_images; ++i) {
    gt_rotations[i] = RotationMatrix(*gt_images[i]);
    if (matched_images[i] != nullptr) {
      rotations[i] = RotationMatrix(*matched_images[i]);
    }
  }
  std::vector<double> pair_errors_deg;
  for (int i = 0; i < num_images; ++i) {
    for (int j = i + 1; j < num_images; ++j) {
      ++evaluation->num_pairs;
      if (matched_images[i] == nullptr || matched_images[j] == nullptr) {
        pair_errors_deg.push_back(kInf);
        continue;
      }
      ++evaluation->num_registered_pairs;
      const Eigen::Matrix3d gt_relative_rotation =
          gt_rotations[j] * gt_rotations[i].transpose();
      const Eigen::Vector3d gt_relative_translation =
          gt_images[j]->Tvec() - gt_relative_rotation * gt_images[i]->Tvec();
      const Eigen::Matrix3d relative_rotation =
          rotations[j] * rotations[i].transpose();
      const Eigen::Vector3d relative_translation =
          matched_images[j]->Tvec() -
          relative_rotation * matched_images[i]->Tvec();
      const double rotation_error =
          RotationErrorDeg(gt_relative_rotation, relative_rotation);
      // Two ground-truth cameras at one place have no translation direction:
      // only the rotation is scored. An estimate that puts two distinct
      // cameras at one place gets the largest direction error.
      double translation_error = 0.0;
      if (gt_relative_translation.squaredNorm() > 0.0) {
        translation_error = relative_translation.squaredNorm() > 0.0
                                ? DirectionErrorDeg(gt_relative_translation,
                                                    relative_translation)
                                : 180.0;
      }
      evaluation->rotation_errors_deg.push_back(rotation_error);
      evaluation->translation_errors_deg.push_back(translation_error);
      evaluation->pose_errors_deg.push_back(
          std::max(rotation_error, translation_error));
      pair_errors_deg.push_back(evaluation->pose_errors_deg.back());
    }
  }
  for (const double threshold : options.pose_auc_thresholds_deg) {
    evaluation->pose_aucs.push_back(ComputeAuc(pair_errors_deg, threshold));
  }
}

// Camera positions after a robust similarity alignment, their errors,
// the cameras beyond max_position_error_fraction_of_scene and the AUCs.
void EvaluatePositions(const MatchedImages& images,
                       const ModelEvaluationOptions& options,
                       ModelEvaluation* evaluation) {
  const std::vector<const colmap::Image*>& gt_images = images.gt_images;
  const std::vector<const colmap::Image*>& matched_images =
      images.matched_images;
  const int num_images = static_cast<int>(gt_images.size());
  // The inlier threshold scales with the scene: a fraction of the median
  // distance of the ground-truth centres from their coordinate-wise median.
  std::vector<Eigen::Vector3d> gt_centers;
  for (const colmap::Image* image : gt_images) {
    gt_centers.push_back(ProjectionCenter(*image));
  }
  Eigen::Vector3d median_center;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> coordinates;
    for (const Eigen::Vector3d& center : gt_centers) {
      coordinates.push_back(center(axis));
    }
    median_center(axis) = Median(coordinates);
  }
  std::vector<double> distances_to_median;
  for (const Eigen::Vector3d& center : gt_centers) {
    distances_to_median.push_back((center - median_center).norm());
  }
  const double scene_scale = Median(distances_to_median);
  for (size_t i = 0; i < gt_centers.size(); ++i) {
    for (size_t j = i + 1; j < gt_centers.size(); ++j) {
      evaluation->scene_size = std::max(evaluation->scene_size,
                                        (gt_centers[i] - gt_centers[j]).norm());
    }
  }
  const double max_position_error =
      options.max_position_error_fraction_of_scene * evaluation->scene_size;
  evaluation->alignment_inlier_threshold =
      options.alignment_inlier_fraction_of_scale * scene_scale;

  std::vector<Eigen::Vector3d> model_centers;
  std::vector<Eigen::Vector3d> matched_gt_centers;
  std::vector<std::string> matched_names;
  for (int i = 0; i < num_images; ++i) {
    if (matched_images[i] == nullptr) continue;
    model_centers.push_back(ProjectionCenter(*matched_images[i]));
    matched_gt_centers.push_back(gt_centers[i]);
    matched_names.push_back(gt_images[i]->Name());
  }
  SimilarityAlignment alignment;
  evaluation->aligned =
      evaluation->alignment_inlier_threshold > 0.0 &&
      EstimateSimilarityRobust(model_centers, matched_gt_centers,
                               evaluation->alignment_inlier_threshold,
                               options.alignment_max_num_trials,
                               options.random_seed, &alignment)
          .ok();
  std::vector<double> position_errors_with_failures(
      num_images - static_cast<int>(model_centers.size()), kInf);
  if (evaluation->aligned) {
    evaluation->alignment_scale = alignment.scale;
    evaluation->alignment_rotation = alignment.rotation;
    evaluation->alignment_translation = alignment.translation;
    evaluation->num_alignment_inliers = alignment.num_inliers;
    for (size_t k = 0; k < model_centers.size(); ++k) {
      evaluation->position_errors.push_back(AlignmentResidual(
          alignment, model_centers[k], matched_gt_centers[k]));
      position_errors_with_failures.push_back(
          evaluation->position_errors.back());
      if (!(evaluation->position_errors.back() <= max_position_error)) {
        evaluation->cameras_beyond.push_back(matched_names[k]);
      }
    }
    evaluation->position_error_mean = Mean(evaluation->position_errors);
    evaluation->position_error_median = Median(evaluation->position_errors);
  } else {
    position_errors_with_failures.assign(num_images, kInf);
    evaluation->cameras_beyond = matched_names;
    evaluation->position_error_mean = kNaN;
    evaluation->position_error_median = kNaN;
  }
  evaluation->num_cameras_beyond =
      static_cast<int>(evaluation->cameras_beyond.size());
  for (const double threshold : options.position_auc_thresholds) {
    evaluation->position_aucs.push_back(
        ComputeAuc(position_errors_with_failures, threshold));
  }
}

}  // namespace

bool ModelEvaluationOptions::Check() const {
  for (const double threshold : pose_auc_thresholds_deg) {
    if (!(threshold > 0.0) || !std::isfinite(threshold)) return false;
  }
  for (const double threshold : position_auc_thresholds) {
    if (!(threshold > 0.0) || !std::isfinite(threshold)) return false;
  }
  return alignment_inlier_fraction_of_scale > 0.0 &&
         std::isfinite(alignment_inlier_fraction_of_scale) &&
         alignment_max_num_trials > 0 &&
         max_position_error_fraction_of_scene > 0.0 &&
         std::isfinite(max_position_error_fraction_of_scene);
}

double ComputeAuc(std::vector<double> errors, double threshold) {
  if (errors.empty() || !(threshold > 0.0)) return 0.0;
  std::sort(errors.begin(), errors.end());
  const double n = static_cast<double>(errors.size());
  double area = 0.0;
  double previous_error = 0.0;
  double previous_recall = 0.0;
  for (size_t i = 0; i < errors.size() && errors[i] < threshold; ++i) {
    const double recall = static_cast<double>(i + 1) / n;
    area += 0.5 * (recall + previous_recall) * (errors[i] - previous_error);
    previous_error = errors[i];
    previous_recall = recall;
  }
  // The recall stays flat from the last error below the threshold to it.
  area += previous_recall * (threshold - previous_error);
  return 100.0 * area / threshold;
}

double RotationErrorDeg(const Eigen::Matrix3d& rotation1,
                        const Eigen::Matrix3d& rotation2) {
  // Via the quaternion of the difference: acos of the trace loses precision
  // for the sub-degree errors that AUC@1 depends on.
  const Eigen::Quaterniond difference(rotation1.transpose() * rotation2);
  return 2.0 * std::atan2(difference.vec().norm(), std::abs(difference.w())) *
         kRadToDeg;
}

double DirectionErrorDeg(const Eigen::Vector3d& direction1,
                         const Eigen::Vector3d& direction2) {
  return std::atan2(direction1.cross(direction2).norm(),
                    direction1.dot(direction2)) *
         kRadToDeg;
}

Status EstimateSimilarityRobust(const std::vector<Eigen::Vector3d>& src,
                                const std::vector<Eigen::Vector3d>& dst,
                                double inlier_threshold, int max_num_trials,
                                uint64_t random_seed,
                                SimilarityAlignment* alignment) {
  if (src.size() != dst.size()) {
    return Status::Error("Similarity alignment: point counts differ.");
  }
  if (src.size() < 3) {
    return Status::Error("Similarity alignment needs at least 3 points.");
  }
  if (!(inlier_threshold > 0.0) || max_num_trials <= 0) {
    return Status::Error("Similarity alignment: invalid RANSAC options.");
  }

  // RANSAC over minimal samples, scored by MSAC cost.
  bool found = false;
  SimilarityAlignment best;
  std::vector<int> best_inliers;
  double best_cost = kInf;
  for (const std::vector<int>& sample :
       MakeSamples(static_cast<int>(src.size()), max_num_trials, random_seed)) {
    if (IsDegenerateSample(src, sample) || IsDegenerateSample(dst, sample)) {
      continue;
    }
    SimilarityAlignment candidate;
    if (!FitSimilarity(src, dst, sample, &candidate)) continue;
    double cost = 0.0;
    std::vector<int> inliers =
        FindInliers(src, dst, candidate, inlier_threshold, &cost);
    if (cost < best_cost) {
      best_cost = cost;
      best = candidate;
      best_inliers = std::move(inliers);
      found = true;
    }
  }
  if (!found) {
    return Status::Error(
        "Similarity alignment: all camera centres are (nearly) collinear.");
  }

  // Least squares on the inliers, until the inlier set no longer changes.
  constexpr int kMaxNumRefinements = 10;
  for (int iteration = 0; iteration < kMaxNumRefinements; ++iteration) {
    if (best_inliers.size() < 3) break;
    SimilarityAlignment refined;
    if (!FitSimilarity(src, dst, best_inliers, &refined)) break;
    double cost = 0.0;
    std::vector<int> inliers =
        FindInliers(src, dst, refined, inlier_threshold, &cost);
    const bool stable = inliers == best_inliers;
    best = refined;
    best_inliers = std::move(inliers);
    if (stable) break;
  }

  *alignment = best;
  alignment->num_inliers = static_cast<int>(best_inliers.size());
  return Status::Ok();
}

Status EvaluateModel(const colmap::Reconstruction& model,
                     const colmap::Reconstruction& ground_truth,
                     const ModelEvaluationOptions& options,
                     ModelEvaluation* evaluation) {
  if (!options.Check()) {
    return Status::Error("Invalid model evaluation options.");
  }
  *evaluation = ModelEvaluation();

  // Ground-truth images (registered ones, in id order) and their matches in
  // the model by name; nullptr where the model does not register the image.
  std::vector<colmap::image_t> gt_image_ids = ground_truth.RegImageIds();
  std::sort(gt_image_ids.begin(), gt_image_ids.end());
  if (gt_image_ids.empty()) {
    return Status::Error("The ground-truth model has no images.");
  }
  std::unordered_map<std::string, const colmap::Image*> model_images;
  for (const colmap::image_t image_id : model.RegImageIds()) {
    const colmap::Image& image = model.Image(image_id);
    model_images.emplace(image.Name(), &image);
  }
  MatchedImages images;
  std::vector<const colmap::Image*>& gt_images = images.gt_images;
  std::vector<const colmap::Image*>& matched_images = images.matched_images;
  for (const colmap::image_t image_id : gt_image_ids) {
    const colmap::Image& gt_image = ground_truth.Image(image_id);
    gt_images.push_back(&gt_image);
    const auto match = model_images.find(gt_image.Name());
    matched_images.push_back(match == model_images.end() ? nullptr
                                                         : match->second);
  }
  const int num_images = static_cast<int>(gt_images.size());
  evaluation->num_gt_images = num_images;
  for (const colmap::Image* image : matched_images) {
    if (image != nullptr) ++evaluation->num_registered;
  }

  EvaluatePairs(images, options, evaluation);
  EvaluatePositions(images, options, evaluation);
  return Status::Ok();
}

Status ReadModel(const std::string& path, colmap::Reconstruction* model) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(path, error)) {
    return Status::Error("Model folder " + path + " does not exist.");
  }
  const auto has_all = [&path](const std::string& extension) {
    std::error_code file_error;
    for (const char* name : {"cameras", "images", "points3D"}) {
      if (!fs::is_regular_file(fs::path(path) / (name + extension),
                               file_error)) {
        return false;
      }
    }
    return true;
  };
  if (!has_all(".bin") && !has_all(".txt")) {
    return Status::Error("Folder " + path +
                         " is not a COLMAP model: it needs cameras, images "
                         "and points3D, all .bin or all .txt.");
  }
  try {
    colmap::Reconstruction read_model;
    read_model.Read(path);
    *model = std::move(read_model);
  } catch (const std::exception& exception) {
    return Status::Error("Could not read the model in " + path +
                         ": malformed file (" + exception.what() + ").");
  }
  return Status::Ok();
}

std::string EvaluationToJson(const ModelEvaluation& evaluation,
                             const ModelEvaluationOptions& options) {
  std::ostringstream json;
  json << "{\n";
  json << "  \"images\": " << evaluation.num_gt_images << ",\n";
  json << "  \"registered\": " << evaluation.num_registered << ",\n";
  json << "  \"pairs\": " << evaluation.num_pairs << ",\n";
  json << "  \"registered_pairs\": " << evaluation.num_registered_pairs
       << ",\n";
  for (size_t k = 0; k < evaluation.pose_aucs.size(); ++k) {
    json << "  \"auc@" << FormatThreshold(options.pose_auc_thresholds_deg[k])
         << "\": " << FormatJsonNumber(evaluation.pose_aucs[k]) << ",\n";
  }
  json << "  \"rot_err_median_deg\": "
       << FormatJsonNumber(Median(evaluation.rotation_errors_deg)) << ",\n";
  json << "  \"trans_err_median_deg\": "
       << FormatJsonNumber(Median(evaluation.translation_errors_deg)) << ",\n";
  json << "  \"alignment_inliers\": " << evaluation.num_alignment_inliers
       << ",\n";
  json << "  \"alignment_threshold\": "
       << FormatJsonNumber(evaluation.alignment_inlier_threshold) << ",\n";
  for (size_t k = 0; k < evaluation.position_aucs.size(); ++k) {
    json << "  \"pos_auc@"
         << FormatThreshold(options.position_auc_thresholds[k])
         << "\": " << FormatJsonNumber(evaluation.position_aucs[k]) << ",\n";
  }
  json << "  \"scene_size\": " << FormatJsonNumber(evaluation.scene_size)
       << ",\n";
  json << "  \"cameras_beyond\": " << evaluation.num_cameras_beyond << ",\n";
  json << "  \"cameras_beyond_fraction\": "
       << FormatJsonNumber(options.max_position_error_fraction_of_scene)
       << ",\n";
  json << "  \"pos_err_mean\": "
       << FormatJsonNumber(evaluation.position_error_mean) << ",\n";
  json << "  \"pos_err_median\": "
       << FormatJsonNumber(evaluation.position_error_median) << "\n";
  json << "}\n";
  return json.str();
}

std::string EvaluationToText(const ModelEvaluation& evaluation,
                             const ModelEvaluationOptions& options) {
  std::ostringstream text;
  text << std::fixed;
  text << "Images in ground truth: " << evaluation.num_gt_images << "\n";
  text << "Registered images: " << evaluation.num_registered << "\n";
  text << "Image pairs: " << evaluation.num_pairs << " ("
       << evaluation.num_registered_pairs << " with both images registered)\n";
  for (size_t k = 0; k < evaluation.pose_aucs.size(); ++k) {
    text << "Pose AUC @ " << FormatThreshold(options.pose_auc_thresholds_deg[k])
         << " deg: " << std::setprecision(2) << evaluation.pose_aucs[k]
         << " %\n";
  }
  text << std::setprecision(4) << "Median relative rotation error: "
       << Median(evaluation.rotation_errors_deg) << " deg\n"
       << "Median translation direction error: "
       << Median(evaluation.translation_errors_deg) << " deg\n";
  if (!evaluation.aligned) {
    text << "Position error: no similarity alignment (fewer than 3 "
            "registered, non-collinear cameras)\n";
  } else {
    text << std::setprecision(6) << "Similarity alignment: scale "
         << evaluation.alignment_scale << ", "
         << evaluation.num_alignment_inliers << " of "
         << evaluation.position_errors.size() << " cameras within "
         << evaluation.alignment_inlier_threshold << "\n";
    text << "Position error: mean " << evaluation.position_error_mean
         << ", median " << evaluation.position_error_median << "\n";
  }
  text << std::setprecision(6) << "Cameras beyond "
       << FormatThreshold(100 * options.max_position_error_fraction_of_scene)
       << "% of the scene size (" << evaluation.scene_size
       << "): " << evaluation.num_cameras_beyond;
  constexpr size_t kMaxNamesListed = 20;
  for (size_t k = 0;
       k < std::min(kMaxNamesListed, evaluation.cameras_beyond.size()); ++k) {
    text << (k == 0 ? " (" : ", ") << evaluation.cameras_beyond[k];
  }
  if (!evaluation.cameras_beyond.empty()) {
    text << (evaluation.cameras_beyond.size() > kMaxNamesListed ? ", ...)"
                                                                : ")");
  }
  text << "\n";
  for (size_t k = 0; k < evaluation.position_aucs.size(); ++k) {
    text << "Position AUC @ "
         << FormatThreshold(options.position_auc_thresholds[k]) << ": "
         << std::setprecision(2) << evaluation.position_aucs[k] << " %\n";
  }
  return text.str();
}

}  // namespace glomap
