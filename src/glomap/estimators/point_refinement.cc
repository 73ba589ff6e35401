#include "glomap/estimators/point_refinement.h"

#include <ceres/jet.h>

#include <Eigen/Core>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "base/camera_models.h"
#include "glomap/util/options_check.h"
#include "glomap/util/parallel_for.h"

namespace glomap {
namespace {

// What one image contributes to the reprojection of a point: its pose and
// its camera's intrinsics.
struct View {
  Eigen::Matrix3d rotation;  // cam_from_world
  Eigen::Vector3d translation;
  int model_id = colmap::kInvalidCameraModelId;
  const double* params = nullptr;
};

struct Observation {
  const View* view = nullptr;
  Eigen::Vector2d point2D;
};

using Jet3 = ceres::Jet<double, 3>;

// COLMAP's HasPointPositiveDepth bound: a point must be at least this far in
// front of a camera.
constexpr double kMinDepth = std::numeric_limits<double>::epsilon();

// Projection of `xyz` into `view` and its derivative by `xyz`; false if
// `xyz` is not in front of the camera.
template <typename CameraModel>
bool ProjectWithJacobian(const View& view, const Eigen::Vector3d& xyz,
                         Eigen::Vector2d* projection,
                         Eigen::Matrix<double, 2, 3>* jacobian) {
  const Jet3 point[3] = {Jet3(xyz(0), 0), Jet3(xyz(1), 1), Jet3(xyz(2), 2)};
  Jet3 in_camera[3];
  for (int row = 0; row < 3; ++row) {
    in_camera[row] = view.rotation(row, 0) * point[0] +
                     view.rotation(row, 1) * point[1] +
                     view.rotation(row, 2) * point[2] + view.translation(row);
  }
  if (!(in_camera[2].a >= kMinDepth)) return false;
  Jet3 params[CameraModel::kNumParams];
  for (size_t i = 0; i < CameraModel::kNumParams; ++i) {
    params[i] = Jet3(view.params[i]);
  }
  Jet3 image[2];
  CameraModel::WorldToImage(params, in_camera[0] / in_camera[2],
                            in_camera[1] / in_camera[2], &image[0], &image[1]);
  for (int row = 0; row < 2; ++row) {
    (*projection)(row) = image[row].a;
    jacobian->row(row) = image[row].v.transpose();
  }
  return true;
}

bool ProjectWithJacobian(const View& view, const Eigen::Vector3d& xyz,
                         Eigen::Vector2d* projection,
                         Eigen::Matrix<double, 2, 3>* jacobian) {
  switch (view.model_id) {
#define CAMERA_MODEL_CASE(CameraModel)                                     \
  case colmap::CameraModel::kModelId:                                      \
    return ProjectWithJacobian<colmap::CameraModel>(view, xyz, projection, \
                                                    jacobian);
    CAMERA_MODEL_SWITCH_CASES
#undef CAMERA_MODEL_CASE
  }
  return false;
}

// The point's cost (half the loss of its squared reprojection errors) and
// Gauss-Newton system at `xyz`, each observation weighted by the loss's
// slope (iteratively reweighted least squares; the step is accepted on the
// true cost); false if `xyz` is behind a camera or not finite.
struct Linearization {
  double cost = 0;
  Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
  Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
};

bool Linearize(const std::vector<Observation>& observations,
               const Eigen::Vector3d& xyz, double loss_scale_px,
               Linearization* result) {
  const double inverse_squared_scale =
      loss_scale_px > 0 ? 1 / (loss_scale_px * loss_scale_px) : 0;
  *result = Linearization();
  Eigen::Vector2d projection;
  Eigen::Matrix<double, 2, 3> jacobian;
  for (const Observation& observation : observations) {
    if (!ProjectWithJacobian(*observation.view, xyz, &projection, &jacobian)) {
      return false;
    }
    const Eigen::Vector2d residual = projection - observation.point2D;
    const double squared_error = residual.squaredNorm();
    double weight = 1;
    if (inverse_squared_scale > 0) {
      // Soft-L1: rho(s) = 2 b^2 (sqrt(1 + s / b^2) - 1), rho'(s) =
      // 1 / sqrt(1 + s / b^2).
      const double root = std::sqrt(1 + squared_error * inverse_squared_scale);
      result->cost += (root - 1) / inverse_squared_scale;
      weight = 1 / root;
    } else {
      result->cost += 0.5 * squared_error;
    }
    result->jtj.noalias() += weight * jacobian.transpose() * jacobian;
    result->jtr.noalias() += weight * jacobian.transpose() * residual;
  }
  return std::isfinite(result->cost) && result->jtj.allFinite() &&
         result->jtr.allFinite();
}

// Levenberg-Marquardt on one point, as Ceres' (the damping is mu times the
// diagonal of J^T J, clamped as Ceres clamps it; mu starts at Ceres' 1e-4,
// falls by 3 after an accepted step and grows by a doubling factor after a
// rejected one). Returns the final cost; `xyz` is moved only by accepted
// steps.
double RefinePoint(const PointRefinementOptions& options,
                   const std::vector<Observation>& observations,
                   Linearization linearization, Eigen::Vector3d* xyz) {
  constexpr double kMinDiagonal = 1e-6;
  constexpr double kMaxDiagonal = 1e32;
  constexpr double kMinMu = 1e-32;
  double mu = 1e-4;
  double mu_growth = 2;
  Linearization trial;
  double cost = linearization.cost;
  for (int iteration = 0; iteration < options.max_num_iterations; ++iteration) {
    if (cost <= 0) break;
    Eigen::Matrix3d damped = linearization.jtj;
    for (int i = 0; i < 3; ++i) {
      damped(i, i) +=
          mu * std::clamp(linearization.jtj(i, i), kMinDiagonal, kMaxDiagonal);
    }
    const Eigen::Vector3d step = damped.ldlt().solve(-linearization.jtr);
    if (!step.allFinite()) {
      mu *= mu_growth;
      mu_growth *= 2;
      continue;
    }
    if (step.norm() <= options.parameter_tolerance *
                           (xyz->norm() + options.parameter_tolerance)) {
      break;
    }
    const Eigen::Vector3d candidate = *xyz + step;
    if (Linearize(observations, candidate, options.loss_scale_px, &trial) &&
        trial.cost < cost) {
      const double relative_decrease = (cost - trial.cost) / cost;
      *xyz = candidate;
      cost = trial.cost;
      linearization = trial;
      mu = std::max(mu / 3, kMinMu);
      mu_growth = 2;
      if (relative_decrease < options.function_tolerance) break;
    } else {
      mu *= mu_growth;
      mu_growth *= 2;
    }
  }
  return cost;
}

}  // namespace

Status PointRefinementOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("max_num_iterations", max_num_iterations, 1);
  check.AtLeast("function_tolerance", function_tolerance, 0);
  check.AtLeast("parameter_tolerance", parameter_tolerance, 0);
  check.AtLeast("loss_scale_px", loss_scale_px, 0);
  return check.status();
}

Status RefinePointsWithFixedPoses(
    const PointRefinementOptions& options,
    const std::vector<colmap::point3D_t>& point3D_ids,
    colmap::Reconstruction* reconstruction, const Interrupt& interrupt,
    PointRefinementSummary* summary) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid point refinement options: " +
                         check.message());
  }
  if (reconstruction == nullptr) {
    return Status::Error("No reconstruction to refine points in.");
  }
  std::vector<colmap::point3D_t> ids = point3D_ids;
  if (ids.empty()) {
    ids.reserve(reconstruction->NumPoints3D());
    for (const auto& [point3D_id, point3D] : reconstruction->Points3D()) {
      ids.push_back(point3D_id);
    }
    std::sort(ids.begin(), ids.end());
  }

  std::unordered_map<colmap::image_t, View> views;
  for (const auto& [image_id, image] : reconstruction->Images()) {
    const colmap::Camera& camera = reconstruction->Camera(image.CameraId());
    View& view = views[image_id];
    view.rotation = image.RotationMatrix();
    view.translation = image.Tvec();
    view.model_id = camera.ModelId();
    view.params = camera.ParamsData();
  }

  // Points go in blocks, so that a cancel is seen within one block.
  constexpr size_t kBlockSize = 1024;
  const size_t num_blocks = (ids.size() + kBlockSize - 1) / kBlockSize;
  std::vector<Eigen::Vector3d> refined(ids.size());
  std::vector<double> initial_costs(ids.size(), 0);
  std::vector<double> final_costs(ids.size(), 0);
  std::vector<char> block_done(num_blocks, 0);
  const colmap::Reconstruction& model = *reconstruction;
  ParallelFor(options.num_threads, num_blocks, [&](size_t block) {
    if (interrupt.IsStopped()) return;
    std::vector<Observation> observations;
    Linearization linearization;
    const size_t end = std::min(ids.size(), (block + 1) * kBlockSize);
    for (size_t i = block * kBlockSize; i < end; ++i) {
      const colmap::Point3D& point3D = model.Point3D(ids[i]);
      observations.clear();
      for (const colmap::TrackElement& element : point3D.Track().Elements()) {
        observations.push_back(
            {&views.at(element.image_id),
             model.Image(element.image_id).Point2D(element.point2D_idx).XY()});
      }
      refined[i] = point3D.XYZ();
      if (!Linearize(observations, refined[i], options.loss_scale_px,
                     &linearization)) {
        continue;
      }
      initial_costs[i] = linearization.cost;
      final_costs[i] =
          RefinePoint(options, observations, linearization, &refined[i]);
    }
    block_done[block] = 1;
  });

  PointRefinementSummary totals;
  for (size_t block = 0; block < num_blocks; ++block) {
    if (!block_done[block]) continue;
    const size_t end = std::min(ids.size(), (block + 1) * kBlockSize);
    for (size_t i = block * kBlockSize; i < end; ++i) {
      colmap::Point3D& point3D = reconstruction->Point3D(ids[i]);
      point3D.SetXYZ(refined[i]);
      ++totals.num_points;
      totals.num_observations += point3D.Track().Length();
      totals.initial_cost += initial_costs[i];
      totals.final_cost += final_costs[i];
    }
  }
  if (summary != nullptr) *summary = totals;
  if (interrupt.IsStopped()) return Status::Cancelled();
  return Status::Ok();
}

}  // namespace glomap
