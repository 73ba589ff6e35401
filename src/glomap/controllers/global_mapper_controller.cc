#include "glomap/controllers/global_mapper_controller.h"

namespace glomap {

GlobalMapperController::GlobalMapperController(
    const GlobalMapperOptions& options, const std::string& database_path,
    colmap::ReconstructionManager* reconstruction_manager)
    : options_(options),
      database_path_(database_path),
      reconstruction_manager_(reconstruction_manager) {
  RegisterCallback(STAGE_CALLBACK);
  RegisterCallback(MODEL_UPDATED_CALLBACK);
}

Status GlobalMapperController::RunStatus() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}

std::string GlobalMapperController::StageName() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stage_name_;
}

int GlobalMapperController::StageIndex() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stage_index_;
}

void GlobalMapperController::Run() {
  // No exception may leave a thread (std::terminate): whatever the pipeline
  // throws (std::bad_alloc above all) ends the run as an error, without a
  // partial model in the manager.
  const size_t num_models_before = reconstruction_manager_->Size();
  Status status;
  try {
    status = RunPipeline();
  } catch (...) {
    status = StatusFromCurrentException();
    while (reconstruction_manager_->Size() > num_models_before) {
      reconstruction_manager_->Delete(reconstruction_manager_->Size() - 1);
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = status;
    stage_name_ = status.ok() ? "Done" : "";
  }
  if (status.ok()) Callback(MODEL_UPDATED_CALLBACK);
}

Status GlobalMapperController::RunPipeline() {
  // The working model lives in the manager from the start, so that the
  // viewer can render it after global positioning and each BA round.
  const size_t work_idx = reconstruction_manager_->Add();
  colmap::Reconstruction* work = &reconstruction_manager_->Get(work_idx);

  GlobalMapperCallbacks callbacks;
  callbacks.on_stage_begin = [this](const std::string& name, int index) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage_name_ = name;
      stage_index_ = index;
    }
    Callback(STAGE_CALLBACK);
  };
  callbacks.on_model_changed = [this]() {
    BlockIfPaused();
    if (!IsStopped()) Callback(MODEL_UPDATED_CALLBACK);
  };
  callbacks.interrupt.is_stopped = [this]() {
    BlockIfPaused();
    return IsStopped();
  };

  GlobalMapper mapper(options_);
  std::vector<colmap::Reconstruction> models;
  Status status = mapper.Run(database_path_, work, &models, callbacks);
  summary_ = mapper.Summary();
  georegistration_ = mapper.GetGeoregistration();

  // Replace the working model by the final models, largest first; on
  // failure or cancel, leave no partial model behind.
  reconstruction_manager_->Delete(work_idx);
  if (status.ok()) {
    for (auto& model : models) {
      const size_t idx = reconstruction_manager_->Add();
      reconstruction_manager_->Get(idx) = std::move(model);
    }
  }
  return status;
}

}  // namespace glomap
