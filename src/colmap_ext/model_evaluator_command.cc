// colmap model_evaluator: accuracy of a model against a ground-truth model
// (pairwise pose AUC and camera position errors, see
// model_evaluation.h), as text and optionally as a JSON object.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "colmap_ext/commands.h"
#include "colmap_ext/model_evaluation.h"
#include "util/option_manager.h"

namespace colmap {
namespace {

// Parses "0.01,0.05,0.1" into positive numbers; false on anything else.
bool ParseThresholds(const std::string& text, std::vector<double>* values) {
  values->clear();
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (item.find_first_not_of(" \t") == std::string::npos) continue;
    try {
      size_t end = 0;
      const double value = std::stod(item, &end);
      if (item.find_first_not_of(" \t", end) != std::string::npos ||
          !(value > 0.0)) {
        return false;
      }
      values->push_back(value);
    } catch (const std::exception&) {
      return false;
    }
  }
  return true;
}

}  // namespace

int RunModelEvaluator(int argc, char** argv) {
  std::string input_path;
  std::string gt_path;
  std::string json_path;
  std::string position_thresholds;
  std::string pose_thresholds;
  glomap::ModelEvaluationOptions evaluation_options;
  double inlier_fraction =
      evaluation_options.alignment_inlier_fraction_of_scale;
  double beyond_fraction =
      evaluation_options.max_position_error_fraction_of_scene;

  OptionManager options;
  options.AddRequiredOption("input_path", &input_path,
                            "Model to evaluate (COLMAP binary or text).");
  options.AddRequiredOption("gt_path", &gt_path,
                            "Ground-truth model; images matched by name.");
  options.AddDefaultOption("json_path", &json_path,
                           "Also write the figures as a JSON object here.");
  options.AddDefaultOption(
      "position_thresholds", &position_thresholds,
      "Comma-separated distance thresholds, in ground-truth units, of the "
      "camera position AUC, e.g. 0.01,0.05,0.1.");
  options.AddDefaultOption(
      "pose_thresholds", &pose_thresholds,
      "Comma-separated angle thresholds in degrees of the pairwise pose AUC "
      "(default 1,3,5,10; upstream's benchmark reports 0.5,1,5,10).");
  options.AddDefaultOption(
      "alignment_inlier_fraction", &inlier_fraction,
      "RANSAC inlier threshold of the similarity alignment, as a fraction of "
      "the median distance of ground-truth cameras from their median.");
  options.AddDefaultOption(
      "max_position_error_fraction", &beyond_fraction,
      "Cameras whose position error after the alignment exceeds this "
      "fraction of the scene size (largest distance between two ground-truth "
      "camera centres) are reported as \"cameras beyond\".");
  options.Parse(argc, argv);

  if (!ParseThresholds(position_thresholds,
                       &evaluation_options.position_auc_thresholds)) {
    std::cerr << "ERROR: --position_thresholds must be positive numbers "
                 "separated by commas, got \""
              << position_thresholds << "\"." << std::endl;
    return EXIT_FAILURE;
  }
  if (!pose_thresholds.empty()) {
    std::vector<double> thresholds_deg;
    if (!ParseThresholds(pose_thresholds, &thresholds_deg) ||
        thresholds_deg.empty()) {
      std::cerr << "ERROR: --pose_thresholds must be positive angles in "
                   "degrees separated by commas, got \""
                << pose_thresholds << "\"." << std::endl;
      return EXIT_FAILURE;
    }
    evaluation_options.pose_auc_thresholds_deg = thresholds_deg;
  }
  evaluation_options.alignment_inlier_fraction_of_scale = inlier_fraction;
  evaluation_options.max_position_error_fraction_of_scene = beyond_fraction;
  if (!evaluation_options.Check()) {
    std::cerr << "ERROR: --alignment_inlier_fraction and "
                 "--max_position_error_fraction must be positive."
              << std::endl;
    return EXIT_FAILURE;
  }

  Reconstruction model;
  glomap::Status status = glomap::ReadModel(input_path, &model);
  Reconstruction ground_truth;
  if (status.ok()) status = glomap::ReadModel(gt_path, &ground_truth);
  glomap::ModelEvaluation evaluation;
  if (status.ok()) {
    status = glomap::EvaluateModel(model, ground_truth, evaluation_options,
                                   &evaluation);
  }
  if (!status.ok()) {
    std::cerr << "ERROR: " << status.message() << std::endl;
    return EXIT_FAILURE;
  }

  std::cout << glomap::EvaluationToText(evaluation, evaluation_options);
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << glomap::EvaluationToJson(evaluation, evaluation_options);
    file.close();
    if (!file) {
      std::cerr << "ERROR: Could not write " << json_path << "." << std::endl;
      return EXIT_FAILURE;
    }
  }
  return EXIT_SUCCESS;
}

}  // namespace colmap
