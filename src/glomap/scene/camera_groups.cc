#include "glomap/scene/camera_groups.h"

#include <algorithm>
#include <tuple>
#include <vector>

namespace glomap {
namespace {

// Key of a camera: focal prior flag, model, size and every parameter,
// compared exactly (the feature extractor writes the same values for every
// image of one size and EXIF focal, and nothing else makes two cameras
// identical by chance).
using CameraKey = std::tuple<bool, int, size_t, size_t, std::vector<double>>;

CameraKey KeyOf(const colmap::Camera& camera) {
  return CameraKey(camera.HasPriorFocalLength(), camera.ModelId(),
                   camera.Width(), camera.Height(), camera.Params());
}

}  // namespace

CameraGroups IdenticalCameraGroups(
    const colmap::Reconstruction& reconstruction) {
  std::map<CameraKey, colmap::camera_t> smallest_id;
  for (const auto& [camera_id, camera] : reconstruction.Cameras()) {
    const auto [it, inserted] = smallest_id.emplace(KeyOf(camera), camera_id);
    if (!inserted) it->second = std::min(it->second, camera_id);
  }
  CameraGroups group_of;
  for (const auto& [camera_id, camera] : reconstruction.Cameras()) {
    group_of.emplace(camera_id, smallest_id.at(KeyOf(camera)));
  }
  return group_of;
}

MergedCameras MergeIdenticalCameras(const CameraGroups& group_of,
                                    colmap::Reconstruction* reconstruction) {
  MergedCameras merged;
  merged.group_of = group_of;
  std::map<colmap::camera_t, size_t> group_sizes;
  for (const auto& [camera_id, group] : merged.group_of) ++group_sizes[group];
  for (const auto& [group, size] : group_sizes) {
    if (size < 2) continue;
    ++merged.num_groups;
    merged.num_cameras += size;
  }
  std::vector<colmap::image_t> image_ids;
  for (const auto& [image_id, image] : reconstruction->Images()) {
    image_ids.push_back(image_id);
  }
  std::sort(image_ids.begin(), image_ids.end());
  for (const colmap::image_t image_id : image_ids) {
    colmap::Image& image = reconstruction->Image(image_id);
    const auto group = merged.group_of.find(image.CameraId());
    if (group == merged.group_of.end() || group->second == image.CameraId()) {
      continue;
    }
    merged.original_camera_of_image.emplace(image_id, image.CameraId());
    image.SetCameraId(group->second);
  }
  return merged;
}

void SplitMergedCameras(const MergedCameras& merged,
                        colmap::Reconstruction* model) {
  for (const auto& [image_id, camera_id] : merged.original_camera_of_image) {
    if (!model->ExistsImage(image_id)) continue;
    colmap::Image& image = model->Image(image_id);
    const colmap::camera_t group = image.CameraId();
    if (!model->ExistsCamera(camera_id)) {
      colmap::Camera camera = model->Camera(group);
      camera.SetCameraId(camera_id);
      model->AddCamera(camera);
    }
    image.SetCameraId(camera_id);
  }
  // Every camera of a group present in `model` takes the group's intrinsics
  // (also those whose images are not in it: the working reconstruction
  // keeps every database camera).
  for (const auto& [camera_id, group] : merged.group_of) {
    if (camera_id == group || !model->ExistsCamera(camera_id) ||
        !model->ExistsCamera(group)) {
      continue;
    }
    model->Camera(camera_id).SetParams(model->Camera(group).Params());
  }
}

}  // namespace glomap
