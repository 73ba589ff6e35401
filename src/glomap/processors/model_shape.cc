#include "glomap/processors/model_shape.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "util/math.h"

namespace glomap {
namespace {

// The median of `values` (reordered); 0 when empty.
double Median(std::vector<double>* values) {
  if (values->empty()) return 0;
  const auto middle = values->begin() + values->size() / 2;
  std::nth_element(values->begin(), middle, values->end());
  return *middle;
}

// The registered images' optical axes in world coordinates, and their mean
// direction (zero if they cancel).
Eigen::Vector3d MeanViewDirection(const colmap::Reconstruction& model,
                                  std::vector<Eigen::Vector3d>* axes) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const colmap::image_t image_id : model.RegImageIds()) {
    axes->push_back(model.Image(image_id).RotationMatrix().row(2).transpose());
    mean += axes->back();
  }
  return mean.norm() > 0 ? Eigen::Vector3d(mean.normalized())
                         : Eigen::Vector3d::Zero();
}

// Median angle [deg] between `axes` and `mean`; 180 without either.
double SpreadDeg(const std::vector<Eigen::Vector3d>& axes,
                 const Eigen::Vector3d& mean) {
  if (axes.empty() || mean.isZero()) return 180;
  std::vector<double> angles_deg;
  for (const Eigen::Vector3d& axis : axes) {
    angles_deg.push_back(
        colmap::RadToDeg(std::acos(std::clamp(axis.dot(mean), -1.0, 1.0))));
  }
  return Median(&angles_deg);
}

}  // namespace

double ViewDirectionSpreadDeg(const colmap::Reconstruction& model) {
  std::vector<Eigen::Vector3d> axes;
  const Eigen::Vector3d mean = MeanViewDirection(model, &axes);
  return SpreadDeg(axes, mean);
}

NadirBlockShape MeasureNadirBlock(const colmap::Reconstruction& model) {
  NadirBlockShape shape;
  if (model.NumRegImages() < 3) return shape;
  std::vector<Eigen::Vector3d> axes;
  const Eigen::Vector3d mean_axis = MeanViewDirection(model, &axes);
  shape.view_spread_deg = SpreadDeg(axes, mean_axis);

  Eigen::Vector3d mean_center = Eigen::Vector3d::Zero();
  for (const colmap::image_t image_id : model.RegImageIds()) {
    mean_center += model.Image(image_id).ProjectionCenter();
  }
  mean_center /= static_cast<double>(model.NumRegImages());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  std::vector<double> depths;
  for (const colmap::image_t image_id : model.RegImageIds()) {
    const colmap::Image& image = model.Image(image_id);
    const Eigen::Vector3d offset = image.ProjectionCenter() - mean_center;
    covariance += offset * offset.transpose();
    const Eigen::Matrix3x4d cam_from_world = image.ProjectionMatrix();
    for (const colmap::Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D()) continue;
      const Eigen::Vector3d point_in_cam =
          cam_from_world *
          model.Point3D(point2D.Point3DId()).XYZ().homogeneous();
      depths.push_back(point_in_cam.z());
    }
  }
  covariance /= static_cast<double>(model.NumRegImages());
  // Eigenvalues in increasing order: the first vector is the plane's
  // normal, the second the narrower direction within the plane.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  const Eigen::Vector3d normal = eigen.eigenvectors().col(0);
  if (!mean_axis.isZero()) {
    shape.view_to_plane_normal_deg = colmap::RadToDeg(
        std::acos(std::clamp(std::abs(normal.dot(mean_axis)), 0.0, 1.0)));
  }
  shape.width = 2 * std::sqrt(std::max(0.0, eigen.eigenvalues()(1)));
  shape.height = Median(&depths);
  return shape;
}

}  // namespace glomap
