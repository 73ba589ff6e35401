#include "glomap/processors/track_filters.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include "base/camera.h"
#include "base/image.h"
#include "base/point3d.h"
#include "util/math.h"

namespace glomap {
namespace {

// The pose and camera of one registered image, looked up once per filter
// instead of once per observation.
struct RegisteredView {
  const colmap::Image* image = nullptr;
  const colmap::Camera* camera = nullptr;
  Eigen::Matrix3d cam_from_world_rotation;
  Eigen::Vector3d cam_from_world_translation;
  Eigen::Vector3d center_in_world;

  Eigen::Vector3d PointInCamera(const Eigen::Vector3d& point_in_world) const {
    return cam_from_world_rotation * point_in_world +
           cam_from_world_translation;
  }
};

using RegisteredViews = std::unordered_map<colmap::image_t, RegisteredView>;

RegisteredViews FindRegisteredViews(
    const colmap::Reconstruction& reconstruction) {
  RegisteredViews views;
  views.reserve(reconstruction.NumRegImages());
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    const colmap::Image& image = reconstruction.Image(image_id);
    RegisteredView& view = views[image_id];
    view.image = &image;
    view.camera = &reconstruction.Camera(image.CameraId());
    view.cam_from_world_rotation = image.RotationMatrix();
    view.cam_from_world_translation = image.Tvec();
    view.center_in_world =
        -view.cam_from_world_rotation.transpose() * image.Tvec();
  }
  return views;
}

// Calls `visit(view, element)` for each observation of `point3D`, in track
// order, that is in a registered image: the only observations any filter
// here tests or counts.
template <typename Visit>
void ForEachRegisteredObservation(const RegisteredViews& views,
                                  const colmap::Point3D& point3D,
                                  const Visit& visit) {
  for (const colmap::TrackElement& el : point3D.Track().Elements()) {
    const auto view = views.find(el.image_id);
    if (view != views.end()) visit(view->second, el);
  }
}

// Whether a point at `point_in_cam` (camera frame) lies behind the camera or
// on its centre plane, where no projection or ray angle is defined.
bool IsBehindCamera(const Eigen::Vector3d& point_in_cam) {
  return point_in_cam.z() <= std::numeric_limits<double>::epsilon();
}

// Removes every observation (in a registered image) of a point behind the
// camera, and every one for which
// `is_outlier(view, keypoint_xy, point_in_cam)` holds. A point left with
// fewer than two observations is deleted as a whole (COLMAP cannot hold it).
// Returns the number of observations removed, those lost with a deleted point
// included.
template <typename IsOutlier>
size_t FilterObservations(colmap::Reconstruction* reconstruction,
                          const IsOutlier& is_outlier) {
  const RegisteredViews views = FindRegisteredViews(*reconstruction);
  size_t num_removed = 0;
  std::vector<colmap::TrackElement> outliers;
  for (const colmap::point3D_t point3D_id : SortedPoint3DIds(*reconstruction)) {
    const colmap::Point3D& point3D = reconstruction->Point3D(point3D_id);
    outliers.clear();
    ForEachRegisteredObservation(
        views, point3D,
        [&](const RegisteredView& view, const colmap::TrackElement& el) {
          const Eigen::Vector3d point_in_cam =
              view.PointInCamera(point3D.XYZ());
          if (IsBehindCamera(point_in_cam) ||
              is_outlier(view, view.image->Point2D(el.point2D_idx).XY(),
                         point_in_cam)) {
            outliers.push_back(el);
          }
        });
    if (outliers.empty()) continue;
    const size_t track_length = point3D.Track().Length();
    if (track_length - outliers.size() < 2) {
      num_removed += track_length;
      reconstruction->DeletePoint3D(point3D_id);
    } else {
      num_removed += outliers.size();
      for (const colmap::TrackElement& el : outliers) {
        reconstruction->DeleteObservation(el.image_id, el.point2D_idx);
      }
    }
  }
  return num_removed;
}

// Removes the observations (in front of their camera) whose squared
// `residual(view, keypoint_xy, point_in_cam)` exceeds `max_error` squared.
template <typename Residual>
size_t FilterObservationsByResidual(colmap::Reconstruction* reconstruction,
                                    const double max_error,
                                    const Residual& residual) {
  const double max_squared_error = max_error * max_error;
  return FilterObservations(
      reconstruction, [&](const RegisteredView& view, const Eigen::Vector2d& xy,
                          const Eigen::Vector3d& point_in_cam) {
        return residual(view, xy, point_in_cam).squaredNorm() >
               max_squared_error;
      });
}

}  // namespace

std::vector<colmap::point3D_t> SortedPoint3DIds(
    const colmap::Reconstruction& reconstruction) {
  std::vector<colmap::point3D_t> ids;
  ids.reserve(reconstruction.NumPoints3D());
  for (const auto& point3D : reconstruction.Points3D()) {
    ids.push_back(point3D.first);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

size_t DeleteAllPoints3D(colmap::Reconstruction* reconstruction) {
  const std::vector<colmap::point3D_t> point3D_ids =
      SortedPoint3DIds(*reconstruction);
  for (const colmap::point3D_t point3D_id : point3D_ids) {
    reconstruction->DeletePoint3D(point3D_id);
  }
  return point3D_ids.size();
}

size_t FilterObservationsByAngularError(
    colmap::Reconstruction* reconstruction,
    const double max_angle_deg_with_prior,
    const double max_angle_deg_without_prior) {
  const double min_cos_with_prior =
      std::cos(colmap::DegToRad(max_angle_deg_with_prior));
  const double min_cos_without_prior =
      std::cos(colmap::DegToRad(max_angle_deg_without_prior));
  return FilterObservations(
      reconstruction, [&](const RegisteredView& view, const Eigen::Vector2d& xy,
                          const Eigen::Vector3d& point_in_cam) {
        const Eigen::Vector3d observed_ray =
            view.camera->ImageToWorld(xy).homogeneous();
        const double min_cos = view.camera->HasPriorFocalLength()
                                   ? min_cos_with_prior
                                   : min_cos_without_prior;
        // cos(angle) < cos(max) without acos; both norms are > 0 here.
        return observed_ray.dot(point_in_cam) <
               min_cos * observed_ray.norm() * point_in_cam.norm();
      });
}

size_t FilterPointsByTriangulationAngle(colmap::Reconstruction* reconstruction,
                                        const double min_angle_deg) {
  const RegisteredViews views = FindRegisteredViews(*reconstruction);
  const double max_cos = std::cos(colmap::DegToRad(min_angle_deg));
  size_t num_deleted = 0;
  std::vector<Eigen::Vector3d> rays;
  for (const colmap::point3D_t point3D_id : SortedPoint3DIds(*reconstruction)) {
    const colmap::Point3D& point3D = reconstruction->Point3D(point3D_id);
    rays.clear();
    ForEachRegisteredObservation(
        views, point3D,
        [&](const RegisteredView& view, const colmap::TrackElement&) {
          const Eigen::Vector3d ray = point3D.XYZ() - view.center_in_world;
          const double norm = ray.norm();
          if (norm > 0) rays.push_back(ray / norm);
        });
    bool is_triangulated = false;
    for (size_t i = 0; i < rays.size() && !is_triangulated; ++i) {
      for (size_t j = i + 1; j < rays.size(); ++j) {
        if (rays[i].dot(rays[j]) < max_cos) {
          is_triangulated = true;
          break;
        }
      }
    }
    if (!is_triangulated) {
      reconstruction->DeletePoint3D(point3D_id);
      ++num_deleted;
    }
  }
  return num_deleted;
}

size_t FilterObservationsByNormalizedReprojectionError(
    colmap::Reconstruction* reconstruction, const double max_error) {
  return FilterObservationsByResidual(
      reconstruction, max_error,
      [](const RegisteredView& view, const Eigen::Vector2d& xy,
         const Eigen::Vector3d& point_in_cam) -> Eigen::Vector2d {
        return point_in_cam.hnormalized() - view.camera->ImageToWorld(xy);
      });
}

size_t FilterObservationsByReprojectionErrorPx(
    colmap::Reconstruction* reconstruction, const double max_error_px) {
  return FilterObservationsByResidual(
      reconstruction, max_error_px,
      [](const RegisteredView& view, const Eigen::Vector2d& xy,
         const Eigen::Vector3d& point_in_cam) -> Eigen::Vector2d {
        return view.camera->WorldToImage(point_in_cam.hnormalized()) - xy;
      });
}

void UpdatePointErrors(colmap::Reconstruction* reconstruction) {
  const RegisteredViews views = FindRegisteredViews(*reconstruction);
  for (const colmap::point3D_t point3D_id : SortedPoint3DIds(*reconstruction)) {
    colmap::Point3D& point3D = reconstruction->Point3D(point3D_id);
    double sum_error_px = 0;
    size_t num_errors = 0;
    ForEachRegisteredObservation(
        views, point3D,
        [&](const RegisteredView& view, const colmap::TrackElement& el) {
          const Eigen::Vector3d point_in_cam =
              view.PointInCamera(point3D.XYZ());
          if (IsBehindCamera(point_in_cam)) return;
          const Eigen::Vector2d& xy = view.image->Point2D(el.point2D_idx).XY();
          sum_error_px +=
              (view.camera->WorldToImage(point_in_cam.hnormalized()) - xy)
                  .norm();
          ++num_errors;
        });
    point3D.SetError(num_errors > 0 ? sum_error_px / num_errors : -1.0);
  }
}

}  // namespace glomap
