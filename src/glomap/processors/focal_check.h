// Focal lengths that nothing in the data fixed (issue 27, item 5). Without
// a focal prior, the focal length comes from the view graph: fundamental
// matrices fix it where optical axes do not meet, a small reconstruction
// where they do. When the camera motion fixes neither (forward motion,
// a street, a nadir survey), view-graph calibration leaves the start value
// (1.2 x the larger image side, as the feature extractor writes it), the
// model is built on it, and bundle adjustment moves it afterwards along a
// direction the data barely constrain: KITTI_sequence_1 went from 1471 px
// to 783 px (true 707, AUC@3 69); synthetic streets of three cameras
// without priors ended 8-10% off (AUC@3 52-72, upstream's global_mapper
// 52-55). The model then looks fine (low reprojection error) and is not;
// the mapper says so (FindUndeterminedFocals, UndeterminedFocalWarning).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "base/reconstruction.h"

namespace glomap {

// The mean focal length (px) of each camera without a focal prior.
std::map<colmap::camera_t, double> FocalsWithoutPrior(
    const colmap::Reconstruction& reconstruction);

struct FocalCheckOptions {
  // View-graph calibration fixed a focal length when it moved it by more
  // than this fraction of its start value. (Where it could not, it moved it
  // by 0.006-0.4% on the shared datasets; where it could, by 26-330%.)
  double min_calibration_change = 0.01;
  // Bundle adjustment moved such a focal length when the median over its
  // images changed by more than this fraction: the model was built on a
  // focal length the data do not support. (A start value that happens to be
  // right stays within a fraction of a percent.)
  double min_adjustment_change = 0.02;
  // Identical cameras without a focal prior that were split (their images
  // fit clearly better apart: a zoom lens, several phones of one size) have
  // each image's focal length fixed by its own views alone, which a spread
  // of viewing directions below this (degrees; the median angle between an
  // optical axis and the mean axis, ViewDirectionSpreadDeg) does not do.
  // Measured on synthetic scenes of 40 images, each its own focal (+-10%),
  // no prior, OPENCV_FISHEYE and FULL_OPENCV: rings (spread 75 deg) focal
  // lengths within 1.4%, AUC@3 78-89; nadir grids (6 deg) 2-7% off in the
  // median, AUC@3 7-40; streets 14-120% off, AUC@3 35-62.
  double min_view_spread_deg_for_split_focals = 10;
};

// One camera (as view-graph calibration had it: a merged group of
// identical cameras is one) whose focal length no stage could fix.
struct UndeterminedFocal {
  colmap::camera_t camera_id = colmap::kInvalidCameraId;
  size_t num_images = 0;  // registered images on it
  size_t width = 0;
  size_t height = 0;
  double calibrated_px = 0;  // after view-graph calibration (= its start)
  double adjusted_px = 0;    // after bundle adjustment (median over images)
};

// The cameras without a prior that view-graph calibration left at their
// start value (`start_focals` before it, `calibrated_focals` after, both
// from FocalsWithoutPrior) and whose registered images' cameras in
// `adjusted` (after bundle adjustment, where a merged group may have been
// split) have a median focal length that moved by more than
// min_adjustment_change. `calibrated_camera_of_image` maps every image to
// its camera at calibration time.
std::vector<UndeterminedFocal> FindUndeterminedFocals(
    const FocalCheckOptions& options,
    const std::map<colmap::camera_t, double>& start_focals,
    const std::map<colmap::camera_t, double>& calibrated_focals,
    const std::map<colmap::image_t, colmap::camera_t>&
        calibrated_camera_of_image,
    const colmap::Reconstruction& adjusted);

// One warning that names the cameras and what would help.
std::string UndeterminedFocalWarning(
    const std::vector<UndeterminedFocal>& undetermined);

// A group of identical cameras without a focal prior that bundle adjustment
// split, each image on its own camera.
struct SplitCameraGroup {
  colmap::camera_t camera_id = colmap::kInvalidCameraId;  // the group's id
  size_t num_images = 0;  // registered images in it
  size_t width = 0;
  size_t height = 0;
};

// The warning for `split` groups when the viewing directions spread by less
// than min_view_spread_deg_for_split_focals; empty otherwise.
std::string SplitFocalWarning(const FocalCheckOptions& options,
                              const std::vector<SplitCameraGroup>& split,
                              double view_spread_deg);

}  // namespace glomap
