#include "glomap/processors/focal_check.h"

#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace glomap {

// What both warnings name as the remedy.
constexpr char kKnownFocalsFixIt[] =
    "Known focal lengths fix it: images with EXIF focal lengths, or "
    "feature_extractor --ImageReader.camera_params (a focal prior)";

std::map<colmap::camera_t, double> FocalsWithoutPrior(
    const colmap::Reconstruction& reconstruction) {
  std::map<colmap::camera_t, double> focals;
  for (const auto& [camera_id, camera] : reconstruction.Cameras()) {
    if (!camera.HasPriorFocalLength()) {
      focals.emplace(camera_id, camera.MeanFocalLength());
    }
  }
  return focals;
}

std::vector<UndeterminedFocal> FindUndeterminedFocals(
    const FocalCheckOptions& options,
    const std::map<colmap::camera_t, double>& start_focals,
    const std::map<colmap::camera_t, double>& calibrated_focals,
    const std::map<colmap::image_t, colmap::camera_t>&
        calibrated_camera_of_image,
    const colmap::Reconstruction& adjusted) {
  // Adjusted focal lengths of the registered images, by calibrated camera.
  std::map<colmap::camera_t, std::vector<double>> adjusted_focals;
  for (const colmap::image_t image_id : adjusted.RegImageIds()) {
    const auto camera = calibrated_camera_of_image.find(image_id);
    if (camera == calibrated_camera_of_image.end()) continue;
    adjusted_focals[camera->second].push_back(
        adjusted.Camera(adjusted.Image(image_id).CameraId()).MeanFocalLength());
  }
  std::vector<UndeterminedFocal> undetermined;
  for (auto& [camera_id, focals] : adjusted_focals) {
    const auto start = start_focals.find(camera_id);
    const auto calibrated = calibrated_focals.find(camera_id);
    if (start == start_focals.end() || calibrated == calibrated_focals.end()) {
      continue;  // a camera with a prior
    }
    if (std::abs(calibrated->second / start->second - 1) >
        options.min_calibration_change) {
      continue;  // the view graph fixed it
    }
    std::nth_element(focals.begin(), focals.begin() + focals.size() / 2,
                     focals.end());
    const double median_px = focals[focals.size() / 2];
    LOG(INFO) << "Focal check: camera " << camera_id << " (" << focals.size()
              << " images): " << start->second << " px at the start, "
              << calibrated->second << " px after view-graph calibration, "
              << median_px << " px after bundle adjustment (median).";
    if (std::abs(median_px / calibrated->second - 1) <=
        options.min_adjustment_change) {
      continue;
    }
    UndeterminedFocal entry;
    entry.camera_id = camera_id;
    entry.num_images = focals.size();
    if (adjusted.ExistsCamera(camera_id)) {
      entry.width = adjusted.Camera(camera_id).Width();
      entry.height = adjusted.Camera(camera_id).Height();
    }
    entry.calibrated_px = calibrated->second;
    entry.adjusted_px = median_px;
    undetermined.push_back(entry);
  }
  return undetermined;
}

std::string UndeterminedFocalWarning(
    const std::vector<UndeterminedFocal>& undetermined) {
  if (undetermined.empty()) return "";
  std::ostringstream message;
  message << std::fixed << std::setprecision(0)
          << "Focal lengths not determined: the camera motion did not fix "
             "the focal length of ";
  for (size_t i = 0; i < undetermined.size(); ++i) {
    const UndeterminedFocal& camera = undetermined[i];
    if (i > 0) message << (i + 1 == undetermined.size() ? " and " : ", ");
    message << "camera " << camera.camera_id;
    if (camera.width > 0) {
      message << " (" << camera.width << "x" << camera.height;
    } else {
      message << " (";
    }
    message << (camera.width > 0 ? ", " : "") << camera.num_images
            << " images, " << camera.calibrated_px << " px at the start, "
            << camera.adjusted_px << " px after bundle adjustment)";
  }
  message << ", so the model and these focal lengths may be wrong although "
             "they reproject well. "
          << kKnownFocalsFixIt;
  // Cameras of one size that were not merged differ in their start values:
  // if they are one camera, one camera for all of them helps too.
  bool same_size = false;
  for (size_t i = 0; i < undetermined.size(); ++i) {
    for (size_t j = i + 1; j < undetermined.size(); ++j) {
      same_size =
          same_size || (undetermined[i].width == undetermined[j].width &&
                        undetermined[i].height == undetermined[j].height);
    }
  }
  if (same_size) {
    message << "; if the images of one size come from one camera, also "
               "--ImageReader.single_camera 1";
  }
  message << ".";
  return message.str();
}

std::string SplitFocalWarning(const FocalCheckOptions& options,
                              const std::vector<SplitCameraGroup>& split,
                              double view_spread_deg) {
  if (split.empty() ||
      view_spread_deg >= options.min_view_spread_deg_for_split_focals) {
    return "";
  }
  std::ostringstream message;
  message << std::fixed << std::setprecision(1)
          << "Focal lengths not determined: the images of ";
  for (size_t i = 0; i < split.size(); ++i) {
    const SplitCameraGroup& group = split[i];
    if (i > 0) message << (i + 1 == split.size() ? " and " : ", ");
    message << "camera " << group.camera_id << " and its identical cameras ("
            << group.width << "x" << group.height << ", " << group.num_images
            << " images)";
  }
  message << " fit different intrinsics (a zoom lens, or several cameras of "
             "one size) and have no focal prior, and with viewing directions "
             "that spread by only "
          << view_spread_deg
          << " deg their views cannot fix each image's focal length, so the "
             "model and these focal lengths may be wrong although they "
             "reproject well. "
          << kKnownFocalsFixIt << ".";
  return message.str();
}

}  // namespace glomap
