// See extraction_and_matching.h.
#include "colmap_ext/extraction_and_matching.h"

#include <iostream>
#include <utility>

#include "base/database.h"
#include "feature/extraction.h"
#include "feature/matching.h"
#include "util/misc.h"

namespace colmap {

std::string ApplyGlobalPresets(std::string data_type, std::string quality,
                               OptionManager* options) {
  StringToLower(&data_type);
  if (data_type == "video") {
    options->ModifyForVideoData();
  } else if (data_type == "individual") {
    options->ModifyForIndividualData();
  } else if (data_type == "internet") {
    options->ModifyForInternetData();
  } else {
    return "--data_type must be individual, video or internet, not " +
           data_type + ".";
  }
  StringToLower(&quality);
  if (quality == "low") {
    options->ModifyForLowQuality();
  } else if (quality == "medium") {
    options->ModifyForMediumQuality();
  } else if (quality == "high") {
    options->ModifyForHighQuality();
  } else if (quality == "extreme") {
    options->ModifyForExtremeQuality();
  } else {
    return "--quality must be low, medium, high or extreme, not " + quality +
           ".";
  }
  // Two settings of 3.8's high and extreme presets hurt the global mapper.
  // On templeRing's images (high quality): affine-shape features matched
  // fewer pairs (276 of 343 verified) and left 16 of 47 images outside the
  // view graph; guided matching (along the first fit's epipolar lines) added
  // matches on which bundle adjustment bent the radial distortion to -0.49
  // (AUC@3 39.9; without it 89.9, as on the dataset's own database).
  options->sift_extraction->estimate_affine_shape = false;
  options->sift_matching->guided_matching = false;
  return "";
}

ExtractionAndMatching::ExtractionAndMatching(const OptionManager& options,
                                             std::string data_type,
                                             std::string vocab_tree_path)
    : options_(options),
      data_type_(std::move(data_type)),
      vocab_tree_path_(std::move(vocab_tree_path)) {}

void ExtractionAndMatching::Stop() {
  {
    std::lock_guard<std::mutex> lock(active_mutex_);
    if (active_ != nullptr) active_->Stop();
  }
  Thread::Stop();
}

void ExtractionAndMatching::Run() {
  error_ = "Stopped.";
  if (!RunStep(std::make_unique<SiftFeatureExtractor>(
          *options_.image_reader, *options_.sift_extraction))) {
    return;
  }
  {
    // 3.8's matchers abort on a database without images.
    Database database(*options_.database_path);
    if (database.NumImages() < 2) {
      error_ = "Found " + std::to_string(database.NumImages()) +
               " image(s) with features in " + *options_.image_path +
               "; a reconstruction needs at least two.";
      return;
    }
  }
  if (!RunStep(NewMatcher())) return;
  error_.clear();
}

std::unique_ptr<Thread> ExtractionAndMatching::NewMatcher() {
  const std::string& database_path = *options_.database_path;
  std::string data_type = data_type_;
  StringToLower(&data_type);
  std::string which;
  std::unique_ptr<Thread> matcher;
  if (data_type == "video") {
    SequentialMatchingOptions sequential = *options_.sequential_matching;
    if (!vocab_tree_path_.empty()) {
      sequential.loop_detection = true;
      sequential.vocab_tree_path = vocab_tree_path_;
    }
    which = "sequential (overlap " + std::to_string(sequential.overlap) +
            (sequential.loop_detection
                 ? ", loop detection)"
                 : "; no loop detection without a vocabulary tree)");
    matcher = std::make_unique<SequentialFeatureMatcher>(
        sequential, *options_.sift_matching, database_path);
  } else {
    size_t num_images = 0;
    {
      Database database(database_path);
      num_images = database.NumImages();
    }
    if (vocab_tree_path_.empty() || num_images < 200) {
      which = "exhaustive (" + std::to_string(num_images) + " images)";
      matcher = std::make_unique<ExhaustiveFeatureMatcher>(
          *options_.exhaustive_matching, *options_.sift_matching,
          database_path);
    } else {
      VocabTreeMatchingOptions vocab_tree = *options_.vocab_tree_matching;
      vocab_tree.vocab_tree_path = vocab_tree_path_;
      which = "vocabulary tree (" + std::to_string(num_images) + " images)";
      matcher = std::make_unique<VocabTreeFeatureMatcher>(
          vocab_tree, *options_.sift_matching, database_path);
    }
  }
  // The global mapper needs nothing else from matching: its relative-pose
  // stage keeps the pairs with at least 30 inliers of its own check.
  std::cout << "Matching for the global mapper: " << which << "." << std::endl;
  return matcher;
}

bool ExtractionAndMatching::RunStep(std::unique_ptr<Thread> step) {
  {
    std::lock_guard<std::mutex> lock(active_mutex_);
    if (IsStopped()) return false;
    active_ = step.get();
  }
  step->Start();
  step->Wait();
  std::lock_guard<std::mutex> lock(active_mutex_);
  active_ = nullptr;
  return !IsStopped();
}

}  // namespace colmap
