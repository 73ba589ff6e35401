// Groups of identical cameras: what COLMAP's feature extractor writes by
// default is one camera per image, and without EXIF every image of one size
// gets the same start values (focal 1.2 x the larger side, principal point
// at the centre, no distortion). Such a project usually comes from one
// physical camera, but a single image says almost nothing about its own
// intrinsics: calibrated and refined one by one, 47 images of templeRing
// kept the 768 px guess (true 1520 px) and, once calibrated, drifted apart
// in bundle adjustment by +-5% (1451-1600 px), which turned the relative
// rotations by ~5 deg (AUC@3 5.5 against 89.8 with one shared camera).
//
// So the mapper works with one camera per group of identical cameras
// without a focal prior (MergeIdenticalCameras) and gives every image its
// own camera back at the end (SplitMergedCameras), each with the group's
// refined intrinsics: the written model has the database's camera ids.
// Cameras with an EXIF focal (prior_focal_length) are merged likewise when
// identical (one camera writes one EXIF focal), never with cameras without
// one; cameras whose start values differ are never merged.
#pragma once

#include <map>
#include <vector>

#include "base/reconstruction.h"

namespace glomap {

// Calibration groups: camera id -> group id (the smallest camera id of the
// group), for every camera of a reconstruction. Cameras whose focal prior
// flag, model, image size and every parameter are identical form one group;
// every other camera is a group of its own.
using CameraGroups = std::map<colmap::camera_t, colmap::camera_t>;
CameraGroups IdenticalCameraGroups(
    const colmap::Reconstruction& reconstruction);

// Which images MergeIdenticalCameras moved to their group's camera, and the
// camera each had before.
struct MergedCameras {
  std::map<colmap::image_t, colmap::camera_t> original_camera_of_image;
  CameraGroups group_of;
  // Groups of more than one camera, and the cameras in them.
  size_t num_groups = 0;
  size_t num_cameras = 0;
};

// Points every image whose camera belongs to a group of several cameras in
// `group_of` (IdenticalCameraGroups, or a part of it) to the group's camera.
// The other cameras of the group stay in the reconstruction, unused, until
// SplitMergedCameras.
MergedCameras MergeIdenticalCameras(const CameraGroups& group_of,
                                    colmap::Reconstruction* reconstruction);

// Undoes MergeIdenticalCameras on `model` (the working reconstruction or a
// model extracted from it): every image gets its original camera back
// (added to `model` where missing) with the intrinsics of its group's camera
// in `model`; cameras whose group is not in `model` are left alone.
void SplitMergedCameras(const MergedCameras& merged,
                        colmap::Reconstruction* model);

}  // namespace glomap
