// Filters on the structure of a colmap::Reconstruction, used right after
// global positioning (paper Sec. 3, "Global positioning"), between bundle
// adjustment rounds and after retriangulation.
//
// Every filter looks only at observations in registered images; observations
// in unregistered images are neither tested nor counted. Points are visited in
// ascending id order so that the result never depends on hash-map order.
// Observations are removed with Reconstruction::DeleteObservation, which in
// COLMAP 3.8 deletes the whole point once its track would drop below two
// observations; the counts below include observations lost that way.
#pragma once

#include <cstddef>
#include <vector>

#include "base/reconstruction.h"

namespace glomap {

// The ids of all 3D points, ascending: the order in which every filter here
// visits them, so that results never depend on hash-map order.
std::vector<colmap::point3D_t> SortedPoint3DIds(
    const colmap::Reconstruction& reconstruction);

// Deletes every 3D point, in ascending id order (the order decides the state
// of COLMAP's point hash map, and with it the order in which points added
// later are iterated and written). Returns the number of points deleted.
size_t DeleteAllPoints3D(colmap::Reconstruction* reconstruction);

// Removes observations whose observed ray (Camera::ImageToWorld of the
// keypoint) and the ray from the camera centre to the 3D point are more than
// the given angle apart, and observations of points behind the camera. The
// looser limit applies to cameras without a prior focal length, whose
// intrinsics are less certain (glomap.md §2.6: 1° and 2°). Returns the number
// of observations removed.
size_t FilterObservationsByAngularError(colmap::Reconstruction* reconstruction,
                                        double max_angle_deg_with_prior,
                                        double max_angle_deg_without_prior);

// Deletes points whose largest angle between any two viewing rays (from the
// centres of registered images observing them) is below `min_angle_deg`;
// points seen by fewer than two registered images are deleted too, since their
// depth is unconstrained. Returns the number of points deleted.
size_t FilterPointsByTriangulationAngle(colmap::Reconstruction* reconstruction,
                                        double min_angle_deg);

// Removes observations whose reprojection error on the normalized image plane
// (z = 1, i.e. pixels / focal length) exceeds `max_error`, and observations
// behind the camera. Returns the number of observations removed.
size_t FilterObservationsByNormalizedReprojectionError(
    colmap::Reconstruction* reconstruction, double max_error);

// Same in pixels (projection through the camera model, distortion included).
size_t FilterObservationsByReprojectionErrorPx(
    colmap::Reconstruction* reconstruction, double max_error_px);

// Sets every point's Error() to its mean pixel reprojection error over the
// observations in registered images with positive depth (-1 if there is
// none), so that COLMAP's model_analyzer and viewer show true values.
void UpdatePointErrors(colmap::Reconstruction* reconstruction);

}  // namespace glomap
