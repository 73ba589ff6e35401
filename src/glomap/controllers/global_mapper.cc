#include "glomap/controllers/global_mapper.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <unordered_set>
#include <utility>

#include "base/pose.h"
#include "base/projection.h"
#include "base/similarity_transform.h"
#include "glomap/priors/prior_alignment.h"
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

// Mean reprojection error (px) of each merged group's registered images, by
// group id, in one pass over the model: an image belongs to the group of its
// original camera (`original_camera_of_image`) or of its current one.
std::map<colmap::camera_t, double> GroupMeanReprojectionErrorsPx(
    const colmap::Reconstruction& model, const MergedCameras& merged,
    const std::set<colmap::camera_t>& groups) {
  std::map<colmap::camera_t, std::pair<double, size_t>> sums;
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
    auto& [sum_px, count] = sums[group->second];
    for (const colmap::Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D()) continue;
      sum_px += std::sqrt(colmap::CalculateSquaredReprojectionError(
          point2D.XY(), model.Point3D(point2D.Point3DId()).XYZ(), image.Qvec(),
          image.Tvec(), camera));
      ++count;
    }
  }
  std::map<colmap::camera_t, double> means;
  for (const colmap::camera_t group : groups) {
    const auto sum = sums.find(group);
    means[group] = sum == sums.end() || sum->second.second == 0
                       ? 0
                       : sum->second.first / sum->second.second;
  }
  return means;
}

// A group of merged cameras whose images, each on its own camera, fit with a
// mean reprojection error below this fraction of the merged one is not one
// physical camera. Measured (each image refitted alone, points held, against
// the merged rounds): the shared datasets with one camera per image 0.995
// to 0.997, synthetic scenes of one physical camera per image (rings,
// streets; three cameras of different sizes) 0.99 to 1.01; synthetic rings
// with every image its own focal (+-10%) 0.75 and 0.77.
constexpr double kSplitMaxErrorRatio = 0.9;

// The trial of MergeIdenticalCameras' assumption: after the bundle
// adjustment rounds, every image of a merged group is refitted on its own
// camera (starting from the group's intrinsics) with the points held
// (RefineImagesWithPointsFixed: one small problem per image, a fraction of
// a BA round; a full round with a camera per image doubled the mapper's
// time on dino-363). Groups that fit clearly better apart
// (kSplitMaxErrorRatio) are split and all rounds rerun; the others stay
// merged.
Status SplitGroupsThatFitApart(const GlobalBundleAdjustmentOptions& options,
                               const PositionPriorTerm* priors,
                               const Interrupt& interrupt,
                               MergedCameras* merged,
                               colmap::Reconstruction* work) {
  std::set<colmap::camera_t> groups;
  for (const auto& [image_id, camera_id] : merged->original_camera_of_image) {
    groups.insert(merged->group_of.at(camera_id));
  }
  const std::map<colmap::camera_t, double> merged_error_px =
      GroupMeanReprojectionErrorsPx(*work, *merged, groups);
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
  const std::map<colmap::camera_t, double> trial_error_px_of =
      GroupMeanReprojectionErrorsPx(trial, apart, groups);
  std::set<colmap::camera_t> split;
  for (const colmap::camera_t group : groups) {
    const double trial_error_px = trial_error_px_of.at(group);
    const bool fits_apart =
        trial_error_px < kSplitMaxErrorRatio * merged_error_px.at(group);
    LOG(INFO) << "Identical cameras (" << group
              << ", ...): mean reprojection error " << std::fixed
              << std::setprecision(3) << merged_error_px.at(group)
              << " px as one camera, " << trial_error_px
              << " px each on its own: "
              << (fits_apart ? "their intrinsics differ, each image keeps "
                               "its own camera"
                             : "one camera");
    if (fits_apart) split.insert(group);
  }
  if (split.empty()) return Status::Ok();
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
  return options;
}

// The priors' mean, taken out of the frame the solves work in and put back
// in the output: ECEF or projected coordinates (millions of metres) would
// otherwise cost the solves most of their precision in t = -R c and in
// every point. Whole metres, so that the shift itself is exact.
Eigen::Vector3d PriorFrameOffset(const PositionPriorTerm& priors) {
  if (priors.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [image_id, center] : priors.center_in_frame) mean += center;
  mean /= static_cast<double>(priors.center_in_frame.size());
  return mean.array().round().matrix();
}

// "Rejected N position priors (farther than X m from their camera): a, b".
void LogRejectedPriors(const colmap::Reconstruction& model,
                       const std::vector<colmap::image_t>& rejected_image_ids,
                       double max_error_m) {
  if (rejected_image_ids.empty()) return;
  LOG(WARNING) << "Rejected " << rejected_image_ids.size()
               << " position priors (farther than " << max_error_m
               << " m from their camera): "
               << ImageNames(model, rejected_image_ids);
}

// Rejects the priors of `all_priors` farther than the threshold from their
// camera in `model`, re-admits the others, and says what changed. Keeps the
// previous choice if the new one would not fix a similarity.
void RecheckPriors(const colmap::Reconstruction& model,
                   const PositionPriorTerm& all_priors,
                   std::vector<colmap::image_t>* rejected_image_ids,
                   PositionPriorTerm* used_priors) {
  const std::vector<colmap::image_t> rejected = ImagesFartherFromPrior(
      model, all_priors.center_in_frame, all_priors.MaxErrorM());
  if (rejected == *rejected_image_ids) return;
  PositionPriorTerm used = all_priors;
  for (const colmap::image_t image_id : rejected) {
    used.center_in_frame.erase(image_id);
  }
  std::vector<Eigen::Vector3d> registered_priors;
  for (const auto& [image_id, center] : used.center_in_frame) {
    if (model.IsImageRegistered(image_id)) registered_priors.push_back(center);
  }
  if (!PriorsFixSimilarity(registered_priors)) return;
  std::vector<colmap::image_t> readmitted;
  std::set_difference(rejected_image_ids->begin(), rejected_image_ids->end(),
                      rejected.begin(), rejected.end(),
                      std::back_inserter(readmitted));
  std::vector<colmap::image_t> newly_rejected;
  std::set_difference(rejected.begin(), rejected.end(),
                      rejected_image_ids->begin(), rejected_image_ids->end(),
                      std::back_inserter(newly_rejected));
  LOG(INFO) << "Position priors checked again after bundle adjustment: "
            << readmitted.size() << " re-admitted (within "
            << all_priors.MaxErrorM() << " m of their camera now), "
            << newly_rejected.size() << " newly rejected.";
  *rejected_image_ids = rejected;
  *used_priors = std::move(used);
  LogRejectedPriors(model, *rejected_image_ids, all_priors.MaxErrorM());
}

// Logs how far the used priors are from their cameras in the output models
// (in the output frame: `priors` minus `offset`), and names those beyond the
// rejection threshold, which the robust loss down-weighted. Returns the
// number of used priors whose image is registered.
size_t ReportFinalPriorErrors(const std::vector<colmap::Reconstruction>& models,
                              const PositionPriorTerm& priors,
                              const Eigen::Vector3d& offset) {
  std::vector<double> errors_m;
  std::vector<std::string> far_names;
  for (const colmap::Reconstruction& model : models) {
    std::vector<colmap::image_t> image_ids = model.RegImageIds();
    std::sort(image_ids.begin(), image_ids.end());
    for (const colmap::image_t image_id : image_ids) {
      const auto prior = priors.center_in_frame.find(image_id);
      if (prior == priors.center_in_frame.end()) continue;
      const double error_m =
          (model.Image(image_id).ProjectionCenter() - (prior->second + offset))
              .norm();
      errors_m.push_back(error_m);
      if (!(error_m <= priors.MaxErrorM())) {
        far_names.push_back(model.Image(image_id).Name());
      }
    }
  }
  if (errors_m.empty()) return 0;
  std::sort(errors_m.begin(), errors_m.end());
  LOG(INFO) << "Position priors: camera to prior distance median "
            << errors_m[errors_m.size() / 2] << " m, max " << errors_m.back()
            << " m over " << errors_m.size() << " images.";
  if (!far_names.empty()) {
    std::ostringstream names;
    for (size_t i = 0; i < far_names.size(); ++i) {
      names << (i > 0 ? ", " : "") << far_names[i];
    }
    LOG(WARNING) << far_names.size() << " position priors are farther than "
                 << priors.MaxErrorM()
                 << " m from their camera after bundle adjustment "
                    "(down-weighted by the robust loss): "
                 << names.str();
  }
  return errors_m.size();
}

// The priors' noise as the output models show it (every prior of a
// registered image, rejected ones included, so that a standard deviation
// set too small cannot hide its own symptom), and a warning when it is well
// above GlobalMapper.prior_position_std_m: good priors are then rejected as
// wrong and the others pull harder than they should. Returns the estimate
// [m], NaN with too few priors.
double ReportPriorNoise(const std::vector<colmap::Reconstruction>& models,
                        const PositionPriorTerm& all_priors,
                        const Eigen::Vector3d& offset, size_t num_rejected) {
  std::vector<double> distances_m;
  for (const colmap::Reconstruction& model : models) {
    for (const colmap::image_t image_id : model.RegImageIds()) {
      const auto prior = all_priors.center_in_frame.find(image_id);
      if (prior == all_priors.center_in_frame.end()) continue;
      distances_m.push_back(
          (model.Image(image_id).ProjectionCenter() - (prior->second + offset))
              .norm());
    }
  }
  const size_t num_priors = distances_m.size();
  const double noise_m = EstimatePriorNoiseStdM(std::move(distances_m));
  if (!std::isfinite(noise_m)) return noise_m;
  // Twice the stated deviation: 10% of wrong priors raise the estimate by
  // about 7%, so a warning means the stated value is wrong.
  constexpr double kTooNoisyFactor = 2;
  if (noise_m > kTooNoisyFactor * all_priors.std_m) {
    LOG(WARNING) << "The position priors look noisier than "
                    "GlobalMapper.prior_position_std_m says: their distances "
                    "from the cameras imply about "
                 << noise_m << " m per axis, against " << all_priors.std_m
                 << " m; " << num_rejected << " of " << num_priors
                 << " were rejected as wrong and the rest were weighted too "
                    "strongly. Set prior_position_std_m to the priors' "
                    "accuracy.";
  } else {
    LOG(INFO) << "Position priors: noise about " << noise_m
              << " m per axis as the model shows it (prior_position_std_m "
              << all_priors.std_m << " m).";
  }
  return noise_m;
}

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
  georegistration_ = Georegistration();
  models->clear();
  // The stages check their options too, but only this names them as the
  // user set them (GlobalMapper.<key>).
  if (const Status check = options_.Check(); !check.ok()) return check;
  colmap::Timer total_timer;
  total_timer.Start();
  const Interrupt& interrupt = callbacks.interrupt;
  auto model_changed = [&callbacks]() {
    if (callbacks.on_model_changed) callbacks.on_model_changed();
  };
  ViewGraph view_graph;

  // 1. View graph from the database (read-only).
  {
    StageTimer stage("Database", 0, &summary_, callbacks);
    const Status status =
        ReadDatabase(database_path, options_.database, work, &view_graph);
    if (!status.ok()) return status;
    summary_.num_images = work->NumImages();
    stage.Finish(Counts({{"cameras", work->NumCameras()},
                         {"images", work->NumImages()},
                         {"pairs", view_graph.NumPairs()}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // Focal lengths known before the solve (EXIF, or given by the user), by
  // database camera id: the bundle adjustment holds them softly (see
  // GlobalBundleAdjustmentOptions::prior_focal_lengths_px).
  std::map<colmap::camera_t, double> prior_focal_lengths_px;
  for (const auto& [camera_id, camera] : work->Cameras()) {
    if (camera.HasPriorFocalLength()) {
      prior_focal_lengths_px[camera_id] = camera.MeanFocalLength();
    }
  }

  // Identical cameras are one camera until the output.
  MergedCameras merged_cameras;
  if (options_.merge_identical_cameras) {
    merged_cameras = MergeIdenticalCameras(IdenticalCameraGroups(*work), work);
    if (merged_cameras.num_groups > 0) {
      LOG(INFO) << merged_cameras.num_cameras
                << " cameras are identical in the database ("
                << merged_cameras.num_groups
                << " group(s)): each group is calibrated and refined as one "
                   "camera, and every image keeps its own camera in the "
                   "output (GlobalMapper.merge_identical_cameras).";
    }
  }

  // Position priors (issue 12), validated and in one metric frame; empty
  // when off or unusable (the free solve, as without priors).
  PositionPriorTerm prior_term;
  // All priors, also those rejected (they are checked again after bundle
  // adjustment).
  PositionPriorTerm all_priors;
  Eigen::Vector3d prior_frame_offset = Eigen::Vector3d::Zero();
  {
    PositionPriors priors;
    const Status status =
        PreparePositionPriors(options_.position_priors, *work, &priors);
    if (!status.ok()) return status;
    georegistration_ = priors.georegistration;
    georegistration_.georegistered = false;
    prior_term = MakePositionPriorTerm(priors, options_.position_priors);
    prior_frame_offset = PriorFrameOffset(prior_term);
    for (auto& [image_id, center] : prior_term.center_in_frame) {
      center -= prior_frame_offset;
    }
    all_priors = prior_term;
  }
  std::vector<colmap::image_t> rejected_prior_ids;

  // 2. View-graph calibration of focal lengths without a prior (Sec. 3).
  const std::map<colmap::camera_t, double> start_focals =
      FocalsWithoutPrior(*work);
  if (!options_.skip_view_graph_calibration) {
    StageTimer stage("View graph calibration", 1, &summary_, callbacks);
    size_t num_invalidated = 0;
    const Status status =
        CalibrateViewGraph(options_.view_graph_calibration, work, &view_graph,
                           &num_invalidated, interrupt);
    if (!status.ok()) return status;
    stage.Finish(Counts({{"pairs_rejected", num_invalidated},
                         {"pairs_kept", view_graph.NumValidPairs()}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();
  const std::map<colmap::camera_t, double> calibrated_focals =
      FocalsWithoutPrior(*work);
  std::map<colmap::image_t, colmap::camera_t> calibrated_camera_of_image;
  for (const auto& [image_id, image] : work->Images()) {
    calibrated_camera_of_image.emplace(image_id, image.CameraId());
  }

  // 3. Relative poses, inlier re-scoring, largest connected component.
  {
    StageTimer stage("Relative poses", 2, &summary_, callbacks);
    RelativePoseStatistics statistics;
    const Status status = EstimateRelativePoses(
        options_.relative_pose, *work, &view_graph, &statistics, interrupt);
    if (!status.ok()) return status;
    const std::vector<colmap::image_t> component =
        view_graph.LargestConnectedComponent();
    if (component.size() < 2) {
      return Status::Error(
          "No two images share enough consistent matches to start a "
          "reconstruction (the view graph has no connected pair).");
    }
    const size_t num_connected_images = component.size();
    if (num_connected_images < static_cast<size_t>(options_.min_model_size)) {
      return TooFewImagesForModel(num_connected_images, options_.min_model_size,
                                  "are connected by consistent matches");
    }
    if (num_connected_images < view_graph.ImagesWithValidPairs().size() ||
        num_connected_images < work->NumImages()) {
      LOG(WARNING) << "The view graph is disconnected: "
                   << work->NumImages() - num_connected_images << " of "
                   << work->NumImages()
                   << " images are not connected to the largest component "
                      "and cannot be registered.";
    }
    view_graph.InvalidatePairsOutside(std::unordered_set<colmap::image_t>(
        component.begin(), component.end()));
    stage.Finish(
        Counts({{"pairs_rejected", statistics.num_invalidated_pairs},
                {"from_stored_geometry", statistics.num_from_stored_geometry},
                {"from_ransac", statistics.num_from_ransac},
                {"pairs_kept", view_graph.NumValidPairs()},
                {"images_connected", num_connected_images}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // 4. Rotation averaging with rejection of inconsistent pairs.
  {
    StageTimer stage("Rotation averaging", 3, &summary_, callbacks);
    size_t num_rejected = 0;
    const Status status =
        AverageRotations(options_.rotation_averaging, &view_graph, work,
                         &num_rejected, interrupt);
    if (!status.ok()) return status;
    if (work->NumRegImages() < static_cast<size_t>(options_.min_model_size)) {
      return TooFewImagesForModel(work->NumRegImages(), options_.min_model_size,
                                  "have consistent rotations");
    }
    stage.Finish(Counts({{"pairs_rejected", num_rejected},
                         {"pairs_kept", view_graph.NumValidPairs()},
                         {"images_registered", work->NumRegImages()}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // 5. Tracks from the filtered inlier matches.
  TrackStore tracks;
  {
    StageTimer stage("Tracks", 4, &summary_, callbacks);
    size_t num_inconsistent = 0;
    TrackEstablishmentOptions track_options = options_.tracks;
    if (work->NumRegImages() == 2) {
      // A two-view model (min_model_size 2): its tracks have two views.
      track_options.min_num_views_per_track = 2;
      LOG(INFO) << "Two registered images: tracks of two views are kept.";
    }
    tracks =
        EstablishTracks(track_options, view_graph, *work, &num_inconsistent);
    // The tracks were the last reader of the inlier indices.
    view_graph.ReleaseInlierIdxs();
    ReturnFreedMemory();
    if (tracks.NumTracks() == 0) {
      return Status::Error(
          "No feature track is seen in three or more registered images: "
          "the matches are too sparse to reconstruct.");
    }
    stage.Finish(Counts({{"tracks", tracks.NumTracks()},
                         {"observations", tracks.NumObservations()},
                         {"inconsistent_tracks", num_inconsistent}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // 6. Global positioning: cameras and points jointly (Sec. 3, the bounded
  // ray objective), started from the centres that the pairs' translation
  // directions give (and from the paper's random start where that solve
  // does not converge; the lower cost is kept).
  {
    StageTimer stage("Global positioning", 5, &summary_, callbacks);
    if (options_.init_positions_from_pairs) {
      const Status status = InitializeCameraCenters(
          options_.position_initialization, view_graph, work, interrupt);
      if (!status.ok()) return status;
    }
    GlobalPositioningSummary prior_summary;
    const Status status = RunGlobalPositioning(
        options_.global_positioning, tracks, work, interrupt,
        prior_term.empty() ? nullptr : &prior_term, &prior_summary);
    if (!status.ok()) return status;
    tracks.Clear();  // The points hold the tracks now.
    ReturnFreedMemory();
    std::string counts =
        Counts({{"images_registered", work->NumRegImages()},
                {"points", work->NumPoints3D()},
                {"observations", work->ComputeNumObservations()}});
    if (prior_summary.georegistered) {
      // The model is in the prior frame, in metres: no normalisation. The
      // rejected priors are left out of every later solve.
      rejected_prior_ids = prior_summary.rejected_image_ids;
      for (const colmap::image_t image_id : rejected_prior_ids) {
        prior_term.center_in_frame.erase(image_id);
      }
      georegistration_.georegistered = true;
      LogRejectedPriors(*work, rejected_prior_ids, prior_term.MaxErrorM());
      counts += ", " + Counts({{"priors_used", prior_summary.num_priors_used},
                               {"priors_rejected",
                                prior_summary.rejected_image_ids.size()}});
    } else {
      // No priors, or they could not fix the frame (global positioning
      // said why): the free solve, as without priors.
      prior_term.center_in_frame.clear();
      georegistration_.num_priors_used = 0;
      work->Normalize();
    }
    stage.Finish(counts);
    model_changed();
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // 7. Every camera checked against the structure the others observe: a
  // camera that positioning could not constrain is re-placed or left out.
  if (!options_.skip_pose_verification) {
    StageTimer stage("Pose verification", 6, &summary_, callbacks);
    PoseVerificationOptions verification = options_.pose_verification;
    verification.max_reproj_error_px =
        verification.positioning_max_reproj_error_px;
    std::string counts;
    const Status status = VerifyPosesAndCount(verification, view_graph, work,
                                              interrupt, &summary_, &counts);
    if (!status.ok()) return status;
    stage.Finish(counts);
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // Principal points, when they are to be refined, are refined only where
  // the viewing directions make them observable (see
  // min_view_spread_deg_for_principal_point); a user who fixes them keeps
  // them fixed.
  GlobalBundleAdjustmentOptions ba_options = options_.bundle_adjustment;
  RetriangulationOptions retriangulation_options = options_.retriangulation;
  ba_options.prior_focal_lengths_px = prior_focal_lengths_px;
  retriangulation_options.bundle_adjustment.prior_focal_lengths_px =
      prior_focal_lengths_px;
  if (ba_options.min_view_spread_deg_for_principal_point > 0 &&
      ba_options.refine_principal_point) {
    const double spread_deg = ViewDirectionSpreadDeg(*work);
    const bool observable =
        spread_deg >= ba_options.min_view_spread_deg_for_principal_point;
    LOG(INFO) << "Viewing directions spread by " << std::fixed
              << std::setprecision(1) << spread_deg << " deg: principal points "
              << (observable ? "are refined" : "stay fixed") << ".";
    ba_options.refine_principal_point = observable;
    retriangulation_options.bundle_adjustment.refine_principal_point =
        observable;
  }

  // A nadir block that refines radial distortion without position priors
  // can bend into a dome that its reprojection error does not show (see
  // NadirBlockShape): the user learns it, and what prevents it.
  if (!georegistration_.georegistered && ba_options.refine_extra_params) {
    WarnIfDomeCanHide(*work);
  }

  // 8. Rounds of global bundle adjustment with filtering.
  if (!options_.skip_bundle_adjustment) {
    StageTimer stage("Bundle adjustment", 7, &summary_, callbacks);
    const Status status =
        RunGlobalBundleAdjustment(ba_options, work, interrupt, model_changed,
                                  prior_term.empty() ? nullptr : &prior_term);
    if (!status.ok()) return status;
    if (merged_cameras.num_groups > 0) {
      const Status split_status = SplitGroupsThatFitApart(
          ba_options, prior_term.empty() ? nullptr : &prior_term, interrupt,
          &merged_cameras, work);
      if (!split_status.ok()) return split_status;
    }
    ReturnFreedMemory();
    stage.Finish(Counts({{"images_registered", work->NumRegImages()},
                         {"points", work->NumPoints3D()},
                         {"observations", work->ComputeNumObservations()}}));
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // The priors judged again on the adjusted model: global positioning's
  // solution can still be bent where its cameras are far from good priors
  // (it is a coarse solve, stopped after a few iterations with the priors),
  // and bundle adjustment with the other priors straightens it.
  if (georegistration_.georegistered && !options_.skip_bundle_adjustment) {
    RecheckPriors(*work, all_priors, &rejected_prior_ids, &prior_term);
  }

  // 9. Retriangulation on the database matches, then bundle adjustment.
  if (!options_.skip_retriangulation) {
    StageTimer stage("Retriangulation", 8, &summary_, callbacks);
    const Status status =
        Retriangulate(retriangulation_options, view_graph, work, interrupt,
                      prior_term.empty() ? nullptr : &prior_term);
    if (!status.ok()) return status;
    stage.Finish(Counts({{"images_registered", work->NumRegImages()},
                         {"points", work->NumPoints3D()},
                         {"observations", work->ComputeNumObservations()}}));
    model_changed();
  }
  if (interrupt.IsStopped()) return Status::Cancelled();

  // Focal lengths that the view graph left at their start values and bundle
  // adjustment then moved: the model was built on a focal length nothing
  // fixed (focal_check.h).
  if (!options_.skip_bundle_adjustment) {
    const std::string warning = UndeterminedFocalWarning(FindUndeterminedFocals(
        options_.focal_check, start_focals, calibrated_focals,
        calibrated_camera_of_image, *work));
    if (!warning.empty()) {
      LOG(WARNING) << warning;
      summary_.warnings.push_back(warning);
    }
  }

  // 10. The same check on the final poses, before anything is written.
  if (!options_.skip_pose_verification) {
    StageTimer stage("Final pose verification", 9, &summary_, callbacks);
    std::string counts;
    const Status status =
        VerifyPosesAndCount(options_.pose_verification, view_graph, work,
                            interrupt, &summary_, &counts);
    if (!status.ok()) return status;
    stage.Finish(counts);
  }
  if (interrupt.IsStopped()) return Status::Cancelled();
  // No later stage reads the view graph: its matches go before the models
  // are made.
  view_graph = ViewGraph();
  ReturnFreedMemory();

  // 11. Camera clustering into separate models, then output preparation.
  bool work_moved = false;
  {
    StageTimer stage("Camera clustering", 10, &summary_, callbacks);
    std::vector<std::vector<colmap::image_t>> clusters;
    if (options_.skip_clustering) {
      clusters.push_back(work->RegImageIds());
      std::sort(clusters.back().begin(), clusters.back().end());
    } else {
      clusters = ClusterCameras(options_.clustering, *work);
    }
    // What the summary needs of `work`, taken before a single cluster's
    // model is moved out of it.
    const size_t num_images = work->NumImages();
    if (georegistration_.georegistered) {
      for (const colmap::image_t image_id : rejected_prior_ids) {
        georegistration_.rejected_prior_image_names.push_back(
            work->Image(image_id).Name());
      }
    }
    for (const auto& cluster : clusters) {
      if (static_cast<int>(cluster.size()) < options_.min_model_size) continue;
      // A single cluster is the whole working model: it is moved, and
      // `work` is left empty (the caller replaces it by the models).
      work_moved = clusters.size() == 1;
      colmap::Reconstruction model =
          work_moved ? std::exchange(*work, colmap::Reconstruction())
                     : ExtractCluster(*work, cluster);
      SplitMergedCameras(merged_cameras, &model);
      if (georegistration_.georegistered) {
        // In the prior frame, in metres: only the offset taken out for the
        // solve is put back.
        model.Transform(colmap::SimilarityTransform3(
            1, colmap::ComposeIdentityQuaternion(), prior_frame_offset));
      } else {
        model.Normalize();
      }
      UpdatePointErrors(&model);
      if (!options_.image_path.empty())
        ExtractColors(options_.image_path, &model);
      models->push_back(std::move(model));
    }
    if (models->empty()) {
      return Status::Error(
          "Nothing was reconstructed: no camera cluster has at least " +
          std::to_string(options_.min_model_size) +
          " images (GlobalMapper.min_model_size).");
    }
    size_t num_registered = 0;
    for (const auto& model : *models) num_registered += model.NumRegImages();
    summary_.num_registered_images = num_registered;
    if (georegistration_.georegistered) {
      georegistration_.num_priors_used =
          ReportFinalPriorErrors(*models, prior_term, prior_frame_offset);
      georegistration_.prior_noise_estimate_m =
          ReportPriorNoise(*models, all_priors, prior_frame_offset,
                           georegistration_.rejected_prior_image_names.size());
      LOG(INFO) << "The model is georegistered: frame "
                << georegistration_.frame << ", in metres, "
                << georegistration_.num_priors_used << " position priors used, "
                << georegistration_.rejected_prior_image_names.size()
                << " rejected.";
    }
    stage.Finish(Counts({{"models", models->size()},
                         {"images_registered", num_registered},
                         {"images", num_images}}));
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
  if (!work_moved) {
    SplitMergedCameras(merged_cameras, work);
    model_changed();
  }
  return Status::Ok();
}

}  // namespace glomap
