// The global mapper: the whole pipeline of "Global Structure-from-Motion
// Revisited" (Pan et al., ECCV 2024), stage by stage, on COLMAP 3.8's classes.
// It knows nothing of the command line, the GUI or the output folder: it takes
// a database path and options and returns models (one per camera cluster).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/estimators/bundle_adjustment.h"
#include "glomap/estimators/global_positioning.h"
#include "glomap/estimators/position_initialization.h"
#include "glomap/estimators/relative_pose.h"
#include "glomap/estimators/retriangulation.h"
#include "glomap/estimators/rotation_averaging.h"
#include "glomap/estimators/view_graph_calibration.h"
#include "glomap/io/database_reader.h"
#include "glomap/priors/mapper_priors.h"
#include "glomap/priors/position_priors.h"
#include "glomap/processors/camera_clustering.h"
#include "glomap/processors/focal_check.h"
#include "glomap/processors/pose_verification.h"
#include "glomap/processors/track_establishment.h"
#include "glomap/scene/camera_groups.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/status.h"

namespace glomap {

struct GlobalMapperOptions {
  // Which images and pairs are read from the database.
  DatabaseReaderOptions database;
  // Stage options, in pipeline order.
  ViewGraphCalibrationOptions view_graph_calibration;
  RelativePoseOptions relative_pose;
  RotationAveragingOptions rotation_averaging;
  TrackEstablishmentOptions tracks;
  // The start of global positioning from the pairs' translation directions
  // (with init_positions_from_pairs).
  PositionInitializationOptions position_initialization;
  GlobalPositioningOptions global_positioning;
  // Pose verification after global positioning (poses still coarse: a
  // looser inlier threshold) and again before the output.
  PoseVerificationOptions pose_verification;
  // The mapper refines principal points by default, but only where the
  // viewing directions make them observable (see
  // min_view_spread_deg_for_principal_point); refine_principal_point = false
  // keeps them as the database has them.
  GlobalBundleAdjustmentOptions bundle_adjustment = [] {
    GlobalBundleAdjustmentOptions ba_options;
    ba_options.refine_principal_point = true;
    return ba_options;
  }();
  RetriangulationOptions retriangulation;
  CameraClusteringOptions clustering;
  // Camera position priors (GPS or metric) in global positioning and bundle
  // adjustment; off by default.
  PositionPriorOptions position_priors;
  // When the mapper warns that focal lengths were not determined.
  FocalCheckOptions focal_check;

  // Stage switches (for experiments; every stage runs by default).
  bool skip_view_graph_calibration = false;
  bool skip_bundle_adjustment = false;
  bool skip_retriangulation = false;
  bool skip_clustering = false;
  bool skip_pose_verification = false;
  // Start global positioning from the camera centres of
  // position_initialization (the pairs' translation directions) instead of
  // the paper's random start; if that solve does not converge, or the
  // problem is small, the random start is solved too and the lower cost kept
  // (global_positioning.random_start_unless_converged,
  // random_start_max_num_images). It keeps 3,000- and
  // 5,000-image streets in one model where the random start alone splits
  // them (issue 14); on dino-363 the random start wins the comparison.
  bool init_positions_from_pairs = true;

  // Cameras that are identical in the database (focal prior flag, model,
  // size, every parameter: one camera per image, as feature_extractor writes
  // them by default) are one camera from the database to the output, where
  // every image gets its own camera back with the shared intrinsics (see
  // camera_groups.h). Off: every camera is calibrated and refined on its own.
  bool merge_identical_cameras = true;

  // Models (camera clusters) with fewer registered images are discarded.
  int min_model_size = 3;
  // Seed of every random choice (RANSAC, random initialisation): the same
  // input and seed give the same model.
  int random_seed = 0;
  // Threads for the parallel stages (-1: all cores).
  int num_threads = -1;
  // A Ceres solve gets one more thread (up to num_threads) per this many
  // residual blocks: on small problems a second thread brings nothing (see
  // ceres_threads.h).
  int min_residuals_per_ceres_thread = kMinResidualBlocksPerCeresThread;
  // Folder of the images, for point colours; empty: no colours.
  std::string image_path;

  // The first invalid option, named by its command-line key and with its
  // allowed range, e.g. "GlobalMapper.rp_max_epipolar_error_px must be > 0,
  // is -1" (every stage field that is an option is named as its key without
  // the stage's prefix, see global_mapper_options.cc).
  Status Check() const;
};

// Wall time and key counts of one stage, for logs and benchmarks.
struct StageSummary {
  std::string name;
  double seconds = 0;
  std::string counts;
};

struct GlobalMapperSummary {
  std::vector<StageSummary> stages;
  double total_seconds = 0;
  size_t num_images = 0;
  size_t num_registered_images = 0;
  // Images that pose verification re-placed or left unregistered (after
  // positioning and before the output together).
  size_t num_replaced_images = 0;
  size_t num_deregistered_images = 0;
  // What the user should know about the model (each also logged as a
  // warning): focal lengths the data did not fix (focal_check.h).
  std::vector<std::string> warnings;
};

// Hooks for a caller that shows progress (the GUI) or can cancel.
struct GlobalMapperCallbacks {
  // Called when a stage starts, with its name and index (0-based) of
  // `kNumStages`.
  std::function<void(const std::string& stage, int index)> on_stage_begin;
  // Called whenever the working model is consistent and worth showing:
  // after global positioning, after each bundle-adjustment round, at the end.
  std::function<void()> on_model_changed;
  Interrupt interrupt;
};

class GlobalMapper {
 public:
  static constexpr int kNumStages = 11;

  explicit GlobalMapper(GlobalMapperOptions options);

  // Runs the pipeline on the database at `database_path` (opened read-only).
  // `work` is the model being built (all database images; registered ones
  // have poses), so that a viewer can show it while the pipeline runs. On
  // success, `models` holds one model per camera cluster, largest first;
  // with a single cluster the model is moved out of `work`, which is then
  // empty (and on_model_changed is not called for it at the end).
  Status Run(const std::string& database_path, colmap::Reconstruction* work,
             std::vector<colmap::Reconstruction>* models,
             const GlobalMapperCallbacks& callbacks = {});

  const GlobalMapperSummary& Summary() const { return summary_; }
  // The frame of the models of the last Run: georegistered when position
  // priors were used (written beside each model as georegistration.txt).
  const Georegistration& GetGeoregistration() const {
    return priors_.GetGeoregistration();
  }

 private:
  GlobalMapperOptions options_;
  GlobalMapperSummary summary_;
  MapperPriors priors_;
};

}  // namespace glomap
