#include "glomap/priors/mapper_priors.h"

#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>
#include <utility>

#include "base/pose.h"
#include "base/similarity_transform.h"

namespace glomap {
namespace {

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

Status MapperPriors::Prepare(const PositionPriorOptions& options,
                             const colmap::Reconstruction& work) {
  PositionPriors priors;
  const Status status = PreparePositionPriors(options, work, &priors);
  if (!status.ok()) return status;
  georegistration_ = priors.georegistration;
  georegistration_.georegistered = false;
  used_ = MakePositionPriorTerm(priors, options);
  frame_offset_ = PriorFrameOffset(used_);
  for (auto& [image_id, center] : used_.center_in_frame) {
    center -= frame_offset_;
  }
  all_ = used_;
  rejected_image_ids_.clear();
  return Status::Ok();
}

std::string MapperPriors::AcceptPositioning(
    bool georegistered, size_t num_priors_used,
    const std::vector<colmap::image_t>& rejected_image_ids,
    colmap::Reconstruction* work) {
  if (!georegistered) {
    // No priors, or they could not fix the frame (global positioning said
    // why): the free solve, as without priors.
    used_.center_in_frame.clear();
    georegistration_.num_priors_used = 0;
    work->Normalize();
    return "";
  }
  // The model is in the prior frame, in metres: no normalisation. The
  // rejected priors are left out of every later solve.
  rejected_image_ids_ = rejected_image_ids;
  for (const colmap::image_t image_id : rejected_image_ids_) {
    used_.center_in_frame.erase(image_id);
  }
  georegistration_.georegistered = true;
  LogRejectedPriors(*work, rejected_image_ids_, used_.MaxErrorM());
  std::ostringstream counts;
  counts << "priors_used=" << num_priors_used
         << ", priors_rejected=" << rejected_image_ids.size();
  return counts.str();
}

void MapperPriors::RecheckAfterBundleAdjustment(
    const colmap::Reconstruction& work) {
  if (!georegistered()) return;
  RecheckPriors(work, all_, &rejected_image_ids_, &used_);
}

void MapperPriors::NoteRejectedImageNames(const colmap::Reconstruction& work) {
  if (!georegistered()) return;
  for (const colmap::image_t image_id : rejected_image_ids_) {
    georegistration_.rejected_prior_image_names.push_back(
        work.Image(image_id).Name());
  }
}

void MapperPriors::ToOutputFrame(colmap::Reconstruction* model) const {
  if (georegistered()) {
    // In the prior frame, in metres: only the offset taken out for the
    // solve is put back.
    model->Transform(colmap::SimilarityTransform3(
        1, colmap::ComposeIdentityQuaternion(), frame_offset_));
  } else {
    model->Normalize();
  }
}

void MapperPriors::ReportOnModels(
    const std::vector<colmap::Reconstruction>& models) {
  if (!georegistered()) return;
  georegistration_.num_priors_used =
      ReportFinalPriorErrors(models, used_, frame_offset_);
  georegistration_.prior_noise_estimate_m =
      ReportPriorNoise(models, all_, frame_offset_,
                       georegistration_.rejected_prior_image_names.size());
  LOG(INFO) << "The model is georegistered: frame " << georegistration_.frame
            << ", in metres, " << georegistration_.num_priors_used
            << " position priors used, "
            << georegistration_.rejected_prior_image_names.size()
            << " rejected.";
}

}  // namespace glomap
