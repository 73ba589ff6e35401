// The global mapper as a COLMAP Thread, like IncrementalMapperController: the
// `global_mapper` command and the GUI's "Global reconstruction" both run it.
// Models go into a ReconstructionManager: the working model while the
// pipeline runs (so a viewer can show it), then one model per camera cluster.
#pragma once

#include <mutex>
#include <string>

#include "base/reconstruction_manager.h"
#include "glomap/controllers/global_mapper.h"
#include "util/threading.h"

namespace glomap {

class GlobalMapperController : public colmap::Thread {
 public:
  enum {
    // A stage started; StageName()/StageIndex() tell which.
    STAGE_CALLBACK,
    // The model in the manager changed and is consistent: render it. Runs on
    // the worker thread, which waits until the callback returns.
    MODEL_UPDATED_CALLBACK,
  };

  GlobalMapperController(const GlobalMapperOptions& options,
                         const std::string& database_path,
                         colmap::ReconstructionManager* reconstruction_manager);

  // Result of the last run: ok, an error with its one-line message, or
  // cancelled. Valid once the thread has finished. An exception in the
  // pipeline (e.g. std::bad_alloc) is an error too; it never leaves the
  // thread.
  Status RunStatus() const;
  const GlobalMapperSummary& Summary() const { return summary_; }
  // The frame of the models of the last run (see
  // GlobalMapper::GetGeoregistration). Valid once the thread has finished.
  const Georegistration& GetGeoregistration() const { return georegistration_; }

  std::string StageName() const;
  int StageIndex() const;

 private:
  void Run() override;
  // The pipeline with the working model in the manager; may throw.
  Status RunPipeline();

  const GlobalMapperOptions options_;
  const std::string database_path_;
  colmap::ReconstructionManager* reconstruction_manager_;
  GlobalMapperSummary summary_;
  Georegistration georegistration_;

  mutable std::mutex mutex_;
  Status status_;
  std::string stage_name_;
  int stage_index_ = -1;
};

}  // namespace glomap
