// The first half of `automatic_reconstructor --mapper global`, shared by the
// command and the GUI's Automatic reconstruction: COLMAP 3.8's presets for
// the data type and quality with the two settings the global mapper does not
// want turned off, then 3.8's feature extraction and its choice of matcher,
// unchanged, as one stoppable thread.
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "util/option_manager.h"
#include "util/threading.h"

namespace colmap {

// Applies COLMAP 3.8's presets for `data_type` (individual, video, internet)
// and `quality` (low, medium, high, extreme) to `options`, as its
// AutomaticReconstructionController does, then turns off what costs the
// global mapper accuracy (see the .cc). Call it before the user's values are
// set, so that they override it. "" if fine, else a one-line error.
std::string ApplyGlobalPresets(std::string data_type, std::string quality,
                               OptionManager* options);

// Feature extraction into `*options.database_path` with
// `*options.image_reader` and `*options.sift_extraction`, then matching with
// 3.8's choice of matcher (below). Features and matches already in the
// database are kept (3.8's extractor and matchers skip them). Stop() reaches
// the step that runs. `options` must outlive the thread.
class ExtractionAndMatching : public Thread {
 public:
  ExtractionAndMatching(const OptionManager& options, std::string data_type,
                        std::string vocab_tree_path);

  void Stop() override;

  // "" once both steps ran; otherwise why not (stopped, too few images).
  const std::string& Error() const { return error_; }

 private:
  void Run() override;
  // COLMAP 3.8's choice, unchanged: sequential for video (with loop
  // detection when a vocabulary tree is given), exhaustive below 200 images
  // or without a vocabulary tree, else vocabulary-tree matching.
  std::unique_ptr<Thread> NewMatcher();
  // Runs `step` to its end unless stopped; false if stopped.
  bool RunStep(std::unique_ptr<Thread> step);

  const OptionManager& options_;
  const std::string data_type_;
  const std::string vocab_tree_path_;
  std::mutex active_mutex_;
  Thread* active_ = nullptr;
  std::string error_ = "Not run.";
};

}  // namespace colmap
