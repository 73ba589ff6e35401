#include "glomap/controllers/global_mapper.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_set>
#include <utility>

#include "base/pose.h"
#include "base/projection.h"
#include "base/similarity_transform.h"
#include "glomap/processors/model_shape.h"
#include "glomap/processors/track_filters.h"
#include "glomap/util/options_check.h"
#include "glomap/util/return_freed_memory.h"
#include "util/logging.h"
#include "util/misc.h"
#include "util/timer.h"

namespace glomap {
namespace {

// Times one stage and logs "Stage <name>: <seconds> s (<counts>)", the line
// the benchmark script parses.
class StageTimer {
 public:
  StageTimer(const std::string& name, int index, GlobalMapperSummary* summary,
             const GlobalMapperCallbacks& callbacks)
      : name_(name), summary_(summary) {
    LOG(INFO) << "Stage " << name_ << " ...";
    if (callbacks.on_stage_begin) callbacks.on_stage_begin(name, index);
    timer_.Start();
  }

  void Finish(const std::string& counts) {
    StageSummary stage;
    stage.name = name_;
    stage.seconds = timer_.ElapsedSeconds();
    stage.counts = counts;
    LOG(INFO) << "Stage " << name_ << ": " << std::fixed << std::setprecision(3)
              << stage.seconds << " s (" << counts << ")";
    summary_->stages.push_back(stage);
  }

 private:
  std::string name_;
  GlobalMapperSummary* summary_;
  colmap::Timer timer_;
};

std::string Counts(std::initializer_list<std::pair<const char*, size_t>> kv) {
  std::ostringstream out;
  bool first = true;
  for (const auto& [key, value] : kv) {
    if (!first) out << ", ";
    out << key << "=" << value;
    first = false;
  }
  return out.str();
}

// Point colours from the images that exist: the database is all the mapper
// needs, and projects often come without (some of) their images, for which
// COLMAP would print one warning per image.
void ExtractColors(const std::string& image_path,
                   colmap::Reconstruction* model) {
  size_t num_read = 0;
  std::vector<colmap::image_t> image_ids = model->RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  for (const colmap::image_t image_id : image_ids) {
    const std::string path =
        colmap::JoinPaths(image_path, model->Image(image_id).Name());
    if (colmap::ExistsFile(path) &&
        model->ExtractColorsForImage(image_id, image_path)) {
      ++num_read;
    }
  }
  if (num_read < image_ids.size()) {
    LOG(WARNING) << "Point colours from " << num_read << " of "
                 << image_ids.size() << " images (the others are not in "
                 << image_path << ").";
  }
}

// Pose verification with its counts added to the run's summary.
Status VerifyPosesAndCount(const PoseVerificationOptions& options,
                           const ViewGraph& view_graph,
                           colmap::Reconstruction* work,
                           const Interrupt& interrupt,
                           GlobalMapperSummary* summary, std::string* counts) {
  if (work->NumRegImages() <= static_cast<size_t>(options.min_point_support)) {
    // Each pose is checked against points that min_point_support other
    // images observe: with fewer images nothing can be checked, and every
    // image would be left out.
    LOG(INFO) << "Pose verification skipped: it needs more than "
              << options.min_point_support << " registered images, and "
              << work->NumRegImages() << " are registered.";
    *counts = Counts(
        {{"images_checked", 0}, {"images_registered", work->NumRegImages()}});
    return Status::Ok();
  }
  PoseVerificationSummary verification;
  const Status status =
      VerifyPoses(options, view_graph, work, &verification, interrupt);
  if (!status.ok()) return status;
  summary->num_replaced_images += verification.num_replaced;
  summary->num_deregistered_images += verification.num_deregistered;
  *counts = Counts({{"images_checked", verification.num_checked},
                    {"replaced", verification.num_replaced},
                    {"left_unregistered", verification.num_deregistered},
                    {"images_registered", work->NumRegImages()}});
  if (work->NumRegImages() < 2) {
    return Status::Error(
        "Pose verification left fewer than two registered images: no image "
        "pose is supported by the structure that the others observe.");
  }
  return Status::Ok();
}

// A block counts as nadir when its cameras look within this angle of their
// mean direction (median) ...
constexpr double kNadirMaxViewSpreadDeg = 15;
// ... and that direction is within this angle of the normal of the plane of
// the camera centres ...
constexpr double kNadirMaxViewToNormalDeg = 20;
// ... and its dome can hide when the block is at least this many times
// wider than the cameras' height above the ground. Measured on the synthetic
// surveys (unknown focal length, 40 m of height, no priors): 1,000 images,
// 4.4 times, AUC@3 97.6 (no warning); 2,000 images, 6.3 times, AUC@3 82.7
// where the same run with GPS priors has 97.4.
constexpr double kDomeRiskWidthOverHeight = 5;

// Warns when `model` is a wide nadir block whose cameras have radial
// distortion parameters (refined in bundle adjustment); logs its shape
// either way.
void WarnIfDomeCanHide(const colmap::Reconstruction& model) {
  bool refines_distortion = false;
  for (const auto& [camera_id, camera] : model.Cameras()) {
    if (!camera.ExtraParamsIdxs().empty()) refines_distortion = true;
  }
  if (!refines_distortion) return;
  const NadirBlockShape shape = MeasureNadirBlock(model);
  const bool nadir = shape.view_spread_deg <= kNadirMaxViewSpreadDeg &&
                     shape.view_to_plane_normal_deg <= kNadirMaxViewToNormalDeg;
  VLOG(3) << "Block shape: viewing directions spread by " << std::fixed
          << std::setprecision(1) << shape.view_spread_deg << " deg, "
          << shape.view_to_plane_normal_deg
          << " deg from the normal of the camera plane, width "
          << shape.WidthOverHeight() << " x the height.";
  if (!nadir || shape.WidthOverHeight() < kDomeRiskWidthOverHeight) return;
  LOG(WARNING) << "The cameras look down on a block " << std::fixed
               << std::setprecision(1) << shape.WidthOverHeight()
               << " times wider than their height above it, and radial "
                  "distortion is refined without position priors: such a "
                  "block can bend into a shallow dome that the reprojection "
                  "error does not show (the bend looks like radial "
                  "distortion). To prevent it, use position priors "
                  "(--GlobalMapper.use_position_priors 1), a calibrated "
                  "camera with --GlobalMapper.ba_refine_extra_params 0, or "
                  "add oblique images.";
}

// How the registered images of a merged group fit: their mean reprojection
// error and how many observations and images it is over.
struct GroupFit {
  double mean_error_px = 0;
  size_t num_observations = 0;
  size_t num_images = 0;
};

// GroupFit of each merged group, by group id, in one pass over the model:
// an image belongs to the group of its original camera
// (`original_camera_of_image`) or of its current one.
std::map<colmap::camera_t, GroupFit> GroupFits(
    const colmap::Reconstruction& model, const MergedCameras& merged,
    const std::set<colmap::camera_t>& groups) {
  std::map<colmap::camera_t, GroupFit> fits;
  for (const colmap::camera_t group : groups) fits[group];
  for (const colmap::image_t image_id : model.RegImageIds()) {
    const colmap::Image& image = model.Image(image_id);
    const auto original = merged.original_camera_of_image.find(image_id);
    const colmap::camera_t camera_id =
        original != merged.original_camera_of_image.end() ? original->second
                                                          : image.CameraId();
    const auto group = merged.group_of.find(camera_id);
    if (group == merged.group_of.end() || groups.count(group->second) == 0) {
      continue;
    }
    const colmap::Camera& camera = model.Camera(image.CameraId());
    GroupFit& fit = fits[group->second];
    ++fit.num_images;
    for (const colmap::Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D()) continue;
      fit.mean_error_px += std::sqrt(colmap::CalculateSquaredReprojectionError(
          point2D.XY(), model.Point3D(point2D.Point3DId()).XYZ(), image.Qvec(),
          image.Tvec(), camera));
      ++fit.num_observations;
    }
  }
  for (auto& [group, fit] : fits) {
    if (fit.num_observations > 0) fit.mean_error_px /= fit.num_observations;
  }
  return fits;
}

// A group of merged cameras whose images, each on its own camera, fit with
// a mean reprojection error below a fraction of the merged one is not one
// physical camera. That fraction is kSplitMaxErrorRatio, or lower where
// the images have few observations each: refitting q more parameters per
// image to m observations of one camera lowers the mean error by itself,
// to about sqrt(1 - q / 2m) of it, and the fraction stays
// kSplitMarginBelowRefitGain below that.
// Measured (each image refitted alone, points held, against the merged
// rounds): one physical camera per image gave 0.995 to 0.997 on the shared
// datasets and 0.99 to 1.01 on synthetic rings, streets and surveys
// (three cameras of different sizes; OPENCV with 300 to 600 images);
// every image its own focal (+-10%) gave 0.75 and 0.77 on rings, 0.66 on
// a 300-image street, but 0.93 on nadir surveys of 600 and 3,500 images
// (OPENCV, no focal prior): a focal error there is mostly a change of
// height. At the earlier fraction 0.9 those surveys stayed merged and broke
// (AUC@3 1.0 and 0.9, median rotation error 7.1 and 10.0 deg); split, the
// 600-image one gives 90.4, as with a camera per image from the start.
constexpr double kSplitMaxErrorRatio = 0.97;
constexpr double kSplitMarginBelowRefitGain = 0.02;

// The split fraction (see kSplitMaxErrorRatio) for a group whose images
// have `fit`'s observations and refit `num_refit_params` intrinsic
// parameters each.
double SplitMaxErrorRatio(const GroupFit& fit, int num_refit_params) {
  if (fit.num_images == 0 || fit.num_observations == 0) {
    return kSplitMaxErrorRatio;
  }
  const double residuals_per_image =
      2.0 * fit.num_observations / fit.num_images;
  const double refit_gain =
      std::sqrt(std::max(0.0, 1 - num_refit_params / residuals_per_image));
  return std::min(kSplitMaxErrorRatio, refit_gain - kSplitMarginBelowRefitGain);
}

// Intrinsic parameters of `camera` that RefineImagesWithPointsFixed refits
// under `options`.
int NumRefitParams(const GlobalBundleAdjustmentOptions& options,
                   const colmap::Camera& camera) {
  int num_params = 0;
  if (options.refine_focal_length) {
    num_params += static_cast<int>(camera.FocalLengthIdxs().size());
  }
  if (options.refine_principal_point) {
    num_params += static_cast<int>(camera.PrincipalPointIdxs().size());
  }
  if (options.refine_extra_params) {
    num_params += static_cast<int>(camera.ExtraParamsIdxs().size());
  }
  return num_params;
}

// The trial of MergeIdenticalCameras' assumption: after the bundle
// adjustment rounds, every image of a merged group is refitted on its own
// camera (starting from the group's intrinsics) with the points held
// (RefineImagesWithPointsFixed: one small problem per image, a fraction of
// a BA round; a full round with a camera per image doubled the mapper's
// time on dino-363). Groups that fit clearly better apart
// (SplitMaxErrorRatio) are split and all rounds rerun; the others stay
// merged.
// The split groups without a focal prior are appended to
// `split_without_prior` (focal_check.h).
Status SplitGroupsThatFitApart(
    const GlobalBundleAdjustmentOptions& options,
    const PositionPriorTerm* priors, const Interrupt& interrupt,
    MergedCameras* merged, colmap::Reconstruction* work,
    std::vector<SplitCameraGroup>* split_without_prior) {
  std::set<colmap::camera_t> groups;
  for (const auto& [image_id, camera_id] : merged->original_camera_of_image) {
    groups.insert(merged->group_of.at(camera_id));
  }
  const std::map<colmap::camera_t, GroupFit> merged_fits =
      GroupFits(*work, *merged, groups);
  colmap::Reconstruction trial = *work;
  SplitMergedCameras(*merged, &trial);
  std::vector<colmap::image_t> trial_image_ids;
  for (const auto& [image_id, camera_id] : merged->original_camera_of_image) {
    if (trial.IsImageRegistered(image_id)) trial_image_ids.push_back(image_id);
  }
  const Status status =
      RefineImagesWithPointsFixed(options, trial_image_ids, &trial, interrupt);
  if (!status.ok()) return status;
  MergedCameras apart;  // every image on its own camera
  apart.group_of = merged->group_of;
  const std::map<colmap::camera_t, GroupFit> trial_fits =
      GroupFits(trial, apart, groups);
  std::set<colmap::camera_t> split;
  for (const colmap::camera_t group : groups) {
    const GroupFit& merged_fit = merged_fits.at(group);
    const double trial_error_px = trial_fits.at(group).mean_error_px;
    const double max_ratio = SplitMaxErrorRatio(
        merged_fit, NumRefitParams(options, work->Camera(group)));
    const bool fits_apart =
        trial_error_px < max_ratio * merged_fit.mean_error_px;
    LOG(INFO) << "Identical cameras (" << group
              << ", ...): mean reprojection error " << std::fixed
              << std::setprecision(3) << merged_fit.mean_error_px
              << " px as one camera, " << trial_error_px
              << " px each on its own (ratio "
              << (merged_fit.mean_error_px > 0
                      ? trial_error_px / merged_fit.mean_error_px
                      : 1.0)
              << ", split below " << max_ratio << "): "
              << (fits_apart ? "their intrinsics differ, each image keeps "
                               "its own camera"
                             : "one camera");
    if (fits_apart) split.insert(group);
  }
  if (split.empty()) return Status::Ok();
  for (const colmap::camera_t group : split) {
    const colmap::Camera& camera = work->Camera(group);
    if (camera.HasPriorFocalLength()) continue;
    SplitCameraGroup entry;
    entry.camera_id = group;
    entry.width = camera.Width();
    entry.height = camera.Height();
    // Until the split every image of the group is on the group's camera.
    for (const colmap::image_t image_id : work->RegImageIds()) {
      if (work->Image(image_id).CameraId() == group) ++entry.num_images;
    }
    split_without_prior->push_back(entry);
  }
  // The split groups start the rounds again from the merged solution, each
  // image on a copy of the group's camera (the trial's intrinsics, fitted
  // with the points held, are a worse start: a 40-image zoom ring then
  // ended with focals 7.5% off, AUC@3 18.8); groups that stay merged point
  // their images at the group's camera again.
  trial = *work;
  SplitMergedCameras(*merged, &trial);
  for (auto it = merged->original_camera_of_image.begin();
       it != merged->original_camera_of_image.end();) {
    const colmap::camera_t group = merged->group_of.at(it->second);
    if (split.count(group) > 0) {
      it = merged->original_camera_of_image.erase(it);
      continue;
    }
    if (trial.ExistsImage(it->first)) {
      trial.Image(it->first).SetCameraId(group);
    }
    ++it;
  }
  for (auto& [camera_id, group] : merged->group_of) {
    if (split.count(group) > 0) group = camera_id;
  }
  merged->num_groups -= split.size();
  *work = std::move(trial);
  // The rounds so far refined poses with one focal where there are several:
  // all rounds again, now with each image's own intrinsics.
  // With a focal per image the joint solve has many more weakly determined
  // parameters and needs more iterations: twice the cap (40-image zoom
  // rings: 74 and 52 iterations to converge, AUC@3 79.6 and 76.2; stopped
  // at 41, 11.2 and 63.7).
  GlobalBundleAdjustmentOptions rerun_options = options;
  rerun_options.max_num_iterations *= 2;
  return RunGlobalBundleAdjustment(rerun_options, work, interrupt, {}, priors);
}

// The error when fewer images than min_model_size can take part: no model
// can be kept, so the user learns at once which option decides that.
Status TooFewImagesForModel(size_t num_images, int min_model_size,
                            const std::string& which_images) {
  return Status::Error("Only " + std::to_string(num_images) + " images " +
                       which_images + ", but models need at least " +
                       std::to_string(min_model_size) +
                       " images (GlobalMapper.min_model_size): set it to " +
                       std::to_string(num_images) + " to reconstruct them.");
}

// The options as the stages get them: one seed, one thread count and one
// Ceres thread policy for the whole pipeline (stage fields that are no
// GlobalMapper.* option are set here).
GlobalMapperOptions WithGeneralOptionsPropagated(GlobalMapperOptions options) {
  options.relative_pose.random_seed = options.random_seed;
  options.global_positioning.random_seed = options.random_seed + 1;
  options.relative_pose.num_threads = options.num_threads;
  options.view_graph_calibration.num_threads = options.num_threads;
  options.global_positioning.num_threads = options.num_threads;
  options.global_positioning.start_from_image_centers =
      options.init_positions_from_pairs;
  options.position_initialization.num_threads = options.num_threads;
  options.position_initialization.min_residuals_per_ceres_thread =
      options.min_residuals_per_ceres_thread;
  options.bundle_adjustment.num_threads = options.num_threads;
  options.pose_verification.num_threads = options.num_threads;
  options.pose_verification.random_seed = options.random_seed + 2;
  options.view_graph_calibration.min_residuals_per_ceres_thread =
      options.min_residuals_per_ceres_thread;
  options.global_positioning.min_residuals_per_ceres_thread =
      options.min_residuals_per_ceres_thread;
  options.bundle_adjustment.min_residuals_per_ceres_thread =
      options.min_residuals_per_ceres_thread;
  // The bundle adjustment after retriangulation is one joint round with the
  // solver settings of the rounds before it (one set of ba_* options), and
  // its own iteration cap.
  GlobalBundleAdjustmentOptions& final_ba =
      options.retriangulation.bundle_adjustment;
  final_ba = options.bundle_adjustment;
  final_ba.num_rounds = 1;
  final_ba.skip_fixed_rotation_stage = true;
  final_ba.skip_joint_stage = false;
  final_ba.max_num_iterations =
      options.retriangulation.final_ba_max_num_iterations;
  final_ba.loss_scale_px = options.retriangulation.final_ba_loss_scale_px;
  return options;
}

// What the stages of one run hand on to each other.
struct RunState {
  RunState(const GlobalMapperOptions& options, colmap::Reconstruction* work,
           std::vector<colmap::Reconstruction>* models,
           const GlobalMapperCallbacks& callbacks, GlobalMapperSummary* summary,
           MapperPriors* priors)
      : options(options),
        work(work),
        models(models),
        interrupt(callbacks.interrupt),
        model_changed([&callbacks]() {
          if (callbacks.on_model_changed) callbacks.on_model_changed();
        }),
        summary(summary),
        priors(priors) {}

  const GlobalMapperOptions& options;
  colmap::Reconstruction* work;
  std::vector<colmap::Reconstruction>* models;
  const Interrupt& interrupt;
  const std::function<void()> model_changed;
  GlobalMapperSummary* summary;
  MapperPriors* priors;

  ViewGraph view_graph;
  TrackStore tracks;
  MergedCameras merged_cameras;
  // Focal lengths known before the solve (EXIF, or given by the user), by
  // database camera id: the bundle adjustment holds them softly (see
  // GlobalBundleAdjustmentOptions::prior_focal_lengths_px).
  std::map<colmap::camera_t, double> prior_focal_lengths_px;
  // The focal check's record (focal_check.h): focal lengths without a prior
  // before and after view-graph calibration, and each image's camera then.
  std::map<colmap::camera_t, double> start_focals;
  std::map<colmap::camera_t, double> calibrated_focals;
  std::map<colmap::image_t, colmap::camera_t> calibrated_camera_of_image;
  std::vector<SplitCameraGroup> split_without_prior;
  // The options of the bundle adjustment rounds and of retriangulation (its
  // final bundle adjustment), as ChooseRefinedIntrinsics set them.
  GlobalBundleAdjustmentOptions bundle_adjustment;
  RetriangulationOptions retriangulation;
  // The single cluster's model was moved out of `work` (now empty).
  bool work_moved = false;
};

// 1. View graph from the database (read-only).
Status ReadInput(const std::string& database_path, RunState* run,
                 std::string* counts) {
  const Status status = ReadDatabase(database_path, run->options.database,
                                     run->work, &run->view_graph);
  if (!status.ok()) return status;
  run->summary->num_images = run->work->NumImages();
  *counts = Counts({{"cameras", run->work->NumCameras()},
                    {"images", run->work->NumImages()},
                    {"pairs", run->view_graph.NumPairs()}});
  return Status::Ok();
}

// Identical cameras are one camera until the output; the focal priors and
// the focal lengths the calibration starts from are noted.
Status PrepareCameras(RunState* run, std::string*) {
  for (const auto& [camera_id, camera] : run->work->Cameras()) {
    if (camera.HasPriorFocalLength()) {
      run->prior_focal_lengths_px[camera_id] = camera.MeanFocalLength();
    }
  }
  if (run->options.merge_identical_cameras) {
    run->merged_cameras =
        MergeIdenticalCameras(IdenticalCameraGroups(*run->work), run->work);
  }
  if (run->merged_cameras.num_groups > 0) {
    LOG(INFO) << run->merged_cameras.num_cameras
              << " cameras are identical in the database ("
              << run->merged_cameras.num_groups
              << " group(s)): each group is calibrated and refined as one "
                 "camera, and every image keeps its own camera in the output "
                 "(GlobalMapper.merge_identical_cameras).";
  }
  run->start_focals = FocalsWithoutPrior(*run->work);
  return Status::Ok();
}

// 2. View-graph calibration of focal lengths without a prior (Sec. 3).
Status CalibrateFocalLengths(RunState* run, std::string* counts) {
  size_t num_invalidated = 0;
  const Status status =
      CalibrateViewGraph(run->options.view_graph_calibration, run->work,
                         &run->view_graph, &num_invalidated, run->interrupt);
  if (!status.ok()) return status;
  *counts = Counts({{"pairs_rejected", num_invalidated},
                    {"pairs_kept", run->view_graph.NumValidPairs()}});
  return Status::Ok();
}

// The focal lengths as calibration left them, for the focal check.
Status NoteCalibratedFocals(RunState* run, std::string*) {
  run->calibrated_focals = FocalsWithoutPrior(*run->work);
  for (const auto& [image_id, image] : run->work->Images()) {
    run->calibrated_camera_of_image.emplace(image_id, image.CameraId());
  }
  return Status::Ok();
}

// 3. Relative poses, inlier re-scoring, largest connected component.
Status EstimatePairPoses(RunState* run, std::string* counts) {
  RelativePoseStatistics statistics;
  const Status status =
      EstimateRelativePoses(run->options.relative_pose, *run->work,
                            &run->view_graph, &statistics, run->interrupt);
  if (!status.ok()) return status;
  const std::vector<colmap::image_t> component =
      run->view_graph.LargestConnectedComponent();
  if (component.size() < 2) {
    return Status::Error(
        "No two images share enough consistent matches to start a "
        "reconstruction (the view graph has no connected pair).");
  }
  const size_t num_connected_images = component.size();
  const size_t num_images = run->work->NumImages();
  if (num_connected_images < static_cast<size_t>(run->options.min_model_size)) {
    return TooFewImagesForModel(num_connected_images,
                                run->options.min_model_size,
                                "are connected by consistent matches");
  }
  if (num_connected_images < run->view_graph.ImagesWithValidPairs().size() ||
      num_connected_images < num_images) {
    LOG(WARNING) << "The view graph is disconnected: "
                 << num_images - num_connected_images << " of " << num_images
                 << " images are not connected to the largest component and "
                    "cannot be registered.";
  }
  run->view_graph.InvalidatePairsOutside(
      std::unordered_set<colmap::image_t>(component.begin(), component.end()));
  *counts =
      Counts({{"pairs_rejected", statistics.num_invalidated_pairs},
              {"from_stored_geometry", statistics.num_from_stored_geometry},
              {"from_ransac", statistics.num_from_ransac},
              {"pairs_kept", run->view_graph.NumValidPairs()},
              {"images_connected", num_connected_images}});
  return Status::Ok();
}

// 4. Rotation averaging with rejection of inconsistent pairs.
Status AverageImageRotations(RunState* run, std::string* counts) {
  size_t num_rejected = 0;
  const Status status =
      AverageRotations(run->options.rotation_averaging, &run->view_graph,
                       run->work, &num_rejected, run->interrupt);
  if (!status.ok()) return status;
  const size_t num_registered = run->work->NumRegImages();
  if (num_registered < static_cast<size_t>(run->options.min_model_size)) {
    return TooFewImagesForModel(num_registered, run->options.min_model_size,
                                "have consistent rotations");
  }
  *counts = Counts({{"pairs_rejected", num_rejected},
                    {"pairs_kept", run->view_graph.NumValidPairs()},
                    {"images_registered", num_registered}});
  return Status::Ok();
}

// 5. Tracks from the filtered inlier matches.
Status MakeTracks(RunState* run, std::string* counts) {
  size_t num_inconsistent = 0;
  TrackEstablishmentOptions track_options = run->options.tracks;
  if (run->work->NumRegImages() == 2) {
    // A two-view model (min_model_size 2): its tracks have two views.
    track_options.min_num_views_per_track = 2;
    LOG(INFO) << "Two registered images: tracks of two views are kept.";
  }
  run->tracks = EstablishTracks(track_options, run->view_graph, *run->work,
                                &num_inconsistent);
  // The tracks were the last reader of the inlier indices.
  run->view_graph.ReleaseInlierIdxs();
  ReturnFreedMemory();
  if (run->tracks.NumTracks() == 0) {
    return Status::Error(
        "No feature track is seen in three or more registered images: the "
        "matches are too sparse to reconstruct.");
  }
  *counts = Counts({{"tracks", run->tracks.NumTracks()},
                    {"observations", run->tracks.NumObservations()},
                    {"inconsistent_tracks", num_inconsistent}});
  return Status::Ok();
}

// "images_registered=.., points=.., observations=..".
std::string ModelCounts(const colmap::Reconstruction& model) {
  return Counts({{"images_registered", model.NumRegImages()},
                 {"points", model.NumPoints3D()},
                 {"observations", model.ComputeNumObservations()}});
}

// 6. Global positioning: cameras and points jointly (Sec. 3, the bounded
// ray objective), started from the centres that the pairs' translation
// directions give (and from the paper's random start where that solve does
// not converge, or the problem is small; the lower cost is kept).
Status PositionCamerasAndPoints(RunState* run, std::string* counts) {
  if (run->options.init_positions_from_pairs) {
    const Status status =
        InitializeCameraCenters(run->options.position_initialization,
                                run->view_graph, run->work, run->interrupt);
    if (!status.ok()) return status;
  }
  GlobalPositioningSummary positioning;
  const Status status = RunGlobalPositioning(
      run->options.global_positioning, run->tracks, run->work, run->interrupt,
      run->priors->Term(), &positioning);
  if (!status.ok()) return status;
  run->tracks.Clear();  // The points hold the tracks now.
  ReturnFreedMemory();
  *counts = ModelCounts(*run->work);
  const std::string prior_counts = run->priors->AcceptPositioning(
      positioning.georegistered, positioning.num_priors_used,
      positioning.rejected_image_ids, run->work);
  if (!prior_counts.empty()) *counts += ", " + prior_counts;
  return Status::Ok();
}

// 7. Every camera checked against the structure the others observe: a
// camera that positioning could not constrain is re-placed or left out.
Status VerifyPositionedPoses(RunState* run, std::string* counts) {
  PoseVerificationOptions verification = run->options.pose_verification;
  verification.max_reproj_error_px =
      verification.positioning_max_reproj_error_px;
  return VerifyPosesAndCount(verification, run->view_graph, run->work,
                             run->interrupt, run->summary, counts);
}

// Which intrinsics bundle adjustment and retriangulation refine: principal
// points, when they are to be refined, only where the viewing directions
// make them observable (min_view_spread_deg_for_principal_point; a user who
// fixes them keeps them fixed); known focal lengths held softly. A nadir
// block that refines radial distortion without position priors can bend
// into a dome that its reprojection error does not show (NadirBlockShape):
// the user learns it, and what prevents it.
Status ChooseRefinedIntrinsics(RunState* run, std::string*) {
  GlobalBundleAdjustmentOptions& ba = run->bundle_adjustment;
  ba = run->options.bundle_adjustment;
  run->retriangulation = run->options.retriangulation;
  ba.prior_focal_lengths_px = run->prior_focal_lengths_px;
  run->retriangulation.bundle_adjustment.prior_focal_lengths_px =
      run->prior_focal_lengths_px;
  if (ba.min_view_spread_deg_for_principal_point > 0 &&
      ba.refine_principal_point) {
    const double spread_deg = ViewDirectionSpreadDeg(*run->work);
    const bool observable =
        spread_deg >= ba.min_view_spread_deg_for_principal_point;
    LOG(INFO) << "Viewing directions spread by " << std::fixed
              << std::setprecision(1) << spread_deg << " deg: principal points "
              << (observable ? "are refined" : "stay fixed") << ".";
    ba.refine_principal_point = observable;
    run->retriangulation.bundle_adjustment.refine_principal_point = observable;
  }
  if (!run->priors->georegistered() && ba.refine_extra_params) {
    WarnIfDomeCanHide(*run->work);
  }
  return Status::Ok();
}

// 8. Rounds of global bundle adjustment with filtering; merged cameras that
// fit clearly better apart are split.
Status AdjustBundle(RunState* run, std::string* counts) {
  Status status = RunGlobalBundleAdjustment(run->bundle_adjustment, run->work,
                                            run->interrupt, run->model_changed,
                                            run->priors->Term());
  if (!status.ok()) return status;
  if (run->merged_cameras.num_groups > 0) {
    status = SplitGroupsThatFitApart(
        run->bundle_adjustment, run->priors->Term(), run->interrupt,
        &run->merged_cameras, run->work, &run->split_without_prior);
    if (!status.ok()) return status;
  }
  ReturnFreedMemory();
  *counts = ModelCounts(*run->work);
  return Status::Ok();
}

// 9. Retriangulation on the database matches, then bundle adjustment.
Status RetriangulateAndAdjust(RunState* run, std::string* counts) {
  const Status status =
      Retriangulate(run->retriangulation, run->view_graph, run->work,
                    run->interrupt, run->priors->Term());
  if (!status.ok()) return status;
  *counts = ModelCounts(*run->work);
  return Status::Ok();
}

// Focal lengths that the view graph left at their start values and bundle
// adjustment then moved: the model was built on a focal length nothing
// fixed; and focal lengths of split cameras that the camera motion cannot
// fix image by image (focal_check.h).
Status WarnOfUndeterminedFocals(RunState* run, std::string*) {
  const FocalCheckOptions& options = run->options.focal_check;
  const std::string undetermined = UndeterminedFocalWarning(
      FindUndeterminedFocals(options, run->start_focals, run->calibrated_focals,
                             run->calibrated_camera_of_image, *run->work));
  const std::string split =
      run->split_without_prior.empty()
          ? ""
          : SplitFocalWarning(options, run->split_without_prior,
                              ViewDirectionSpreadDeg(*run->work));
  for (const std::string& warning : {undetermined, split}) {
    if (warning.empty()) continue;
    LOG(WARNING) << warning;
    run->summary->warnings.push_back(warning);
  }
  return Status::Ok();
}

// 10. The same check on the final poses, before anything is written.
Status VerifyFinalPoses(RunState* run, std::string* counts) {
  return VerifyPosesAndCount(run->options.pose_verification, run->view_graph,
                             run->work, run->interrupt, run->summary, counts);
}

// No later stage reads the view graph: its matches go before the models are
// made.
Status ReleaseViewGraph(RunState* run, std::string*) {
  run->view_graph = ViewGraph();
  ReturnFreedMemory();
  return Status::Ok();
}

// 11. Camera clustering into separate models, each in its output frame
// with its own cameras again, point errors and colours.
Status MakeModels(RunState* run, std::string* counts) {
  colmap::Reconstruction* work = run->work;
  std::vector<std::vector<colmap::image_t>> clusters;
  if (run->options.skip_clustering) {
    clusters.push_back(work->RegImageIds());
    std::sort(clusters.back().begin(), clusters.back().end());
  } else {
    clusters = ClusterCameras(run->options.clustering, *work);
  }
  // What the summary needs of `work`, taken before a single cluster's model
  // is moved out of it.
  const size_t num_images = work->NumImages();
  run->priors->NoteRejectedImageNames(*work);
  for (const auto& cluster : clusters) {
    if (static_cast<int>(cluster.size()) < run->options.min_model_size) {
      continue;
    }
    // A single cluster is the whole working model: it is moved, and `work`
    // is left empty (the caller replaces it by the models).
    run->work_moved = clusters.size() == 1;
    colmap::Reconstruction model =
        run->work_moved ? std::exchange(*work, colmap::Reconstruction())
                        : ExtractCluster(*work, cluster);
    SplitMergedCameras(run->merged_cameras, &model);
    run->priors->ToOutputFrame(&model);
    UpdatePointErrors(&model);
    if (!run->options.image_path.empty()) {
      ExtractColors(run->options.image_path, &model);
    }
    run->models->push_back(std::move(model));
  }
  if (run->models->empty()) {
    return Status::Error(
        "Nothing was reconstructed: no camera cluster has at least " +
        std::to_string(run->options.min_model_size) +
        " images (GlobalMapper.min_model_size).");
  }
  size_t num_registered = 0;
  for (const auto& model : *run->models) num_registered += model.NumRegImages();
  run->summary->num_registered_images = num_registered;
  run->priors->ReportOnModels(*run->models);
  *counts = Counts({{"models", run->models->size()},
                    {"images_registered", num_registered},
                    {"images", num_images}});
  return Status::Ok();
}

// One step of the pipeline: a stage (named: timed, logged and reported to
// on_stage_begin with its index) or a step between stages (unnamed). A step
// that is not enabled is skipped; a stage keeps its index either way.
struct PipelineStep {
  const char* stage_name;
  bool enabled;
  std::function<Status(RunState*, std::string* counts)> run;
  // Call on_model_changed after the stage's line.
  bool model_changed = false;
};

}  // namespace

Status GlobalMapperOptions::Check() const {
  // In the order of the option table (and of `-h`), the general options
  // first. The stages are checked as the mapper runs them, with the general
  // options set in their fields, so that those fields (which have no keys of
  // their own) are judged under the general keys only.
  OptionChecker check("GlobalMapper.");
  check.Add(database.Check("GlobalMapper."));
  check.AtLeast("min_model_size", min_model_size, 2);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  check.AtLeast("min_residuals_per_ceres_thread",
                min_residuals_per_ceres_thread, 1);
  // Position priors: keys without a stage prefix (fixed by issue 12).
  check.Add(position_priors.Check("GlobalMapper."));
  const GlobalMapperOptions stages = WithGeneralOptionsPropagated(*this);
  check.Add(stages.view_graph_calibration.Check("GlobalMapper.vgc_"));
  check.Add(stages.relative_pose.Check("GlobalMapper.rp_"));
  check.Add(stages.rotation_averaging.Check("GlobalMapper.ra_"));
  check.Add(stages.tracks.Check("GlobalMapper.track_"));
  check.Add(stages.position_initialization.Check("GlobalMapper.pi_"));
  check.Add(stages.global_positioning.Check("GlobalMapper.gp_"));
  check.Add(stages.pose_verification.Check("GlobalMapper.pv_"));
  check.Add(stages.bundle_adjustment.Check("GlobalMapper.ba_"));
  check.Add(stages.retriangulation.Check("GlobalMapper.tri_"));
  check.Add(stages.clustering.Check("GlobalMapper.cc_"));
  return check.status();
}

GlobalMapper::GlobalMapper(GlobalMapperOptions options)
    : options_(WithGeneralOptionsPropagated(std::move(options))) {}

Status GlobalMapper::Run(const std::string& database_path,
                         colmap::Reconstruction* work,
                         std::vector<colmap::Reconstruction>* models,
                         const GlobalMapperCallbacks& callbacks) {
  // The libraries under the stages (CHOLMOD's OpenMP loops, OpenBLAS) start
  // no threads of their own: GlobalMapper.num_threads bounds every stage.
  const ScopedLibraryThreads library_threads;
  // COLMAP 3.8 sets glog's verbosity to 2, at which Ceres prints its
  // internals (allocation sizes, iteration tables, CHOLMOD's analysis) for
  // every solve: hundreds of lines per run. Below --log_level 3 a run prints
  // its stage lines, warnings and summary; at 3 and above, every detail.
  if (FLAGS_v < 3) google::SetVLOGLevel("*", 0);
  summary_ = GlobalMapperSummary();
  priors_ = MapperPriors();
  models->clear();
  // The stages check their options too, but only this names them as the
  // user set them (GlobalMapper.<key>).
  if (const Status check = options_.Check(); !check.ok()) return check;
  colmap::Timer total_timer;
  total_timer.Start();
  RunState run(options_, work, models, callbacks, &summary_, &priors_);
  const GlobalMapperOptions& o = options_;
  const bool adjusts = !o.skip_bundle_adjustment;
  // The pipeline, top to bottom (the numbers are the README's).
  const std::vector<PipelineStep> steps = {
      {"Database", true,
       [&database_path](RunState* r, std::string* counts) {
         return ReadInput(database_path, r, counts);
       }},
      {nullptr, true, PrepareCameras},
      {nullptr, true,
       [](RunState* r, std::string*) {
         return r->priors->Prepare(r->options.position_priors, *r->work);
       }},
      {"View graph calibration", !o.skip_view_graph_calibration,
       CalibrateFocalLengths},
      {nullptr, true, NoteCalibratedFocals},
      {"Relative poses", true, EstimatePairPoses},
      {"Rotation averaging", true, AverageImageRotations},
      {"Tracks", true, MakeTracks},
      {"Global positioning", true, PositionCamerasAndPoints, true},
      {"Pose verification", !o.skip_pose_verification, VerifyPositionedPoses},
      {nullptr, true, ChooseRefinedIntrinsics},
      {"Bundle adjustment", adjusts, AdjustBundle},
      {nullptr, adjusts,
       [](RunState* r, std::string*) {
         r->priors->RecheckAfterBundleAdjustment(*r->work);
         return Status::Ok();
       }},
      {"Retriangulation", !o.skip_retriangulation, RetriangulateAndAdjust,
       true},
      {nullptr, adjusts, WarnOfUndeterminedFocals},
      {"Final pose verification", !o.skip_pose_verification, VerifyFinalPoses},
      {nullptr, true, ReleaseViewGraph},
      {"Camera clustering", true, MakeModels},
  };
  // Each step in turn; the run stops at the first error, and at a cancel
  // between two steps (the stages also stop inside at a cancel).
  int stage_index = 0;
  for (size_t i = 0; i < steps.size(); ++i) {
    const PipelineStep& step = steps[i];
    const int index = step.stage_name == nullptr ? -1 : stage_index++;
    if (!step.enabled) continue;
    std::optional<StageTimer> stage;
    if (index >= 0) stage.emplace(step.stage_name, index, &summary_, callbacks);
    std::string counts;
    if (const Status status = step.run(&run, &counts); !status.ok()) {
      return status;
    }
    if (stage) stage->Finish(counts);
    if (step.model_changed) run.model_changed();
    if (i + 1 < steps.size() && run.interrupt.IsStopped()) {
      return Status::Cancelled();
    }
  }
  summary_.total_seconds = total_timer.ElapsedSeconds();
  LOG(INFO) << "Global mapper finished in " << std::fixed
            << std::setprecision(3) << summary_.total_seconds
            << " s: " << models->size() << " model(s), "
            << summary_.num_registered_images << " of " << summary_.num_images
            << " images registered; pose verification re-placed "
            << summary_.num_replaced_images << " and left out "
            << summary_.num_deregistered_images << " image(s)"
            << (summary_.warnings.empty()
                    ? "."
                    : "; " + std::to_string(summary_.warnings.size()) +
                          " warning(s): " + summary_.warnings.front());
  // An emptied `work` is not worth showing: the caller shows the models.
  if (!run.work_moved) {
    SplitMergedCameras(run.merged_cameras, work);
    run.model_changed();
  }
  return Status::Ok();
}

}  // namespace glomap
