#include "glomap/estimators/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "base/camera_models.h"
#include "base/cost_functions.h"
#include "glomap/estimators/cost_functions/pose_manifold.h"
#include "glomap/estimators/point_refinement.h"
#include "glomap/processors/track_filters.h"
#include "glomap/util/ceres_interrupt.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/options_check.h"
#include "glomap/util/parallel_for.h"
#include "glomap/util/union_find.h"
#include "optim/bundle_adjustment.h"
#include "util/logging.h"
#include "util/threading.h"
#include "util/timer.h"

namespace glomap {
namespace {

// COLMAP 3.8 has no automatic gauge. With one image's pose fixed, the
// remaining freedom is the scale (for the joint solve; with all rotations
// fixed the gauge is translation + scale, and fixing the same image's
// translation removes the translation part). Scale is fixed by one
// translation coordinate of a second image: its derivative with respect to a
// scale change about the first centre is -R2 (c2 - c1), so we pick the
// second image farthest from the first and the coordinate where that vector
// is largest, which keeps the gauge well conditioned (COLMAP always takes
// coordinate 0, which degenerates when the baseline lies along the second
// camera's optical axis).
struct Gauge {
  colmap::image_t fixed_pose_image_id = colmap::kInvalidImageId;
  colmap::image_t scale_image_id = colmap::kInvalidImageId;
  int scale_tvec_idx = 0;
};

Gauge ChooseGauge(const colmap::Reconstruction& reconstruction,
                  const std::vector<colmap::image_t>& image_ids) {
  Gauge gauge;
  gauge.fixed_pose_image_id = image_ids.front();
  const Eigen::Vector3d center1 =
      reconstruction.Image(gauge.fixed_pose_image_id).ProjectionCenter();
  double max_distance = -1;
  for (size_t i = 1; i < image_ids.size(); ++i) {
    const double distance =
        (reconstruction.Image(image_ids[i]).ProjectionCenter() - center1)
            .norm();
    if (distance > max_distance) {
      max_distance = distance;
      gauge.scale_image_id = image_ids[i];
    }
  }
  const colmap::Image& image2 = reconstruction.Image(gauge.scale_image_id);
  const Eigen::Vector3d baseline_in_cam2 =
      image2.RotationMatrix() * (image2.ProjectionCenter() - center1);
  baseline_in_cam2.cwiseAbs().maxCoeff(&gauge.scale_tvec_idx);
  return gauge;
}

// The gauges of a solve. Without priors, the one above. With priors (issue
// 12), each part of the problem that shares no 3D point with the rest (a
// connected component of images through their points) is held in place by
// its own priors when they fix a similarity (three or more, not collinear),
// and gets no fixed pose and no fixed scale: the priors' frame is the
// solution. A part with fewer priors keeps the gauge above (its pose and
// scale as they are, i.e. as global positioning's alignment left them in the
// prior frame), its priors only pulling its shape.
std::vector<Gauge> ChooseGauges(
    const colmap::Reconstruction& reconstruction,
    const std::vector<colmap::image_t>& image_ids,
    const std::unordered_set<colmap::point3D_t>& left_out,
    const PositionPriorTerm* priors) {
  if (priors == nullptr || priors->empty()) {
    return {ChooseGauge(reconstruction, image_ids)};
  }
  std::unordered_map<colmap::image_t, size_t> index_of_id;
  for (size_t i = 0; i < image_ids.size(); ++i) index_of_id[image_ids[i]] = i;
  UnionFind<size_t> components(image_ids.size());
  for (const auto& [point3D_id, point3D] : reconstruction.Points3D()) {
    if (left_out.count(point3D_id) > 0) continue;
    const std::vector<colmap::TrackElement>& elements =
        point3D.Track().Elements();
    for (size_t k = 1; k < elements.size(); ++k) {
      const auto first = index_of_id.find(elements[0].image_id);
      const auto other = index_of_id.find(elements[k].image_id);
      if (first != index_of_id.end() && other != index_of_id.end()) {
        components.Union(first->second, other->second);
      }
    }
  }
  // Components by their root (the smallest index: deterministic order).
  std::map<size_t, std::vector<colmap::image_t>> component_images;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    component_images[components.Find(i)].push_back(image_ids[i]);
  }
  std::vector<Gauge> gauges;
  for (const auto& [root, component] : component_images) {
    std::vector<Eigen::Vector3d> component_priors;
    for (const colmap::image_t image_id : component) {
      const auto prior = priors->center_in_frame.find(image_id);
      if (prior != priors->center_in_frame.end()) {
        component_priors.push_back(prior->second);
      }
    }
    if (component.size() >= 2 && !PriorsFixSimilarity(component_priors)) {
      gauges.push_back(ChooseGauge(reconstruction, component));
    }
  }
  return gauges;
}

bool IsFixedPoseImage(const std::vector<Gauge>& gauges,
                      colmap::image_t image_id) {
  for (const Gauge& gauge : gauges) {
    if (gauge.fixed_pose_image_id == image_id) return true;
  }
  return false;
}

// The gauge whose scale coordinate is in the image's translation, or null.
const Gauge* ScaleGaugeOfImage(const std::vector<Gauge>& gauges,
                               colmap::image_t image_id) {
  for (const Gauge& gauge : gauges) {
    if (gauge.scale_image_id == image_id) return &gauge;
  }
  return nullptr;
}

// (c - p) / std with the camera centre c = -R^T t of a rotation-fixed
// image, on its translation block; linear in t, so the analytic Jacobian
// -R^T / std is exact.
class FixedRotationPriorCostFunction : public ceres::SizedCostFunction<3, 3> {
 public:
  FixedRotationPriorCostFunction(const Eigen::Matrix3d& cam_from_world,
                                 const Eigen::Vector3d& prior, double std_m)
      : world_from_cam_(cam_from_world.transpose()),
        prior_(prior),
        inv_std_(1 / std_m) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> tvec(parameters[0]);
    Eigen::Map<Eigen::Vector3d> residual(residuals);
    residual = inv_std_ * (-(world_from_cam_ * tvec) - prior_);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> jacobian(
          jacobians[0]);
      jacobian = -inv_std_ * world_from_cam_;
    }
    return true;
  }

 private:
  const Eigen::Matrix3d world_from_cam_;
  const Eigen::Vector3d prior_;
  const double inv_std_;
};

// (c - p) / std with c = -R(q)^T t on a pose block [qw, qx, qy, qz, tx, ty,
// tz] (see PoseCostFunction).
class PosePriorCostFunction {
 public:
  PosePriorCostFunction(const Eigen::Vector3d& prior, double std_m)
      : prior_x_(prior(0)),
        prior_y_(prior(1)),
        prior_z_(prior(2)),
        inv_std_(1 / std_m) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& prior,
                                     double std_m) {
    return new ceres::AutoDiffCostFunction<PosePriorCostFunction, 3, 7>(
        new PosePriorCostFunction(prior, std_m));
  }

  template <typename T>
  bool operator()(const T* const pose, T* residuals) const {
    // The inverse of a unit quaternion is its conjugate.
    const T world_from_cam[4] = {pose[0], -pose[1], -pose[2], -pose[3]};
    T rotated_tvec[3];
    ceres::UnitQuaternionRotatePoint(world_from_cam, pose + 4, rotated_tvec);
    residuals[0] = T(inv_std_) * (-rotated_tvec[0] - T(prior_x_));
    residuals[1] = T(inv_std_) * (-rotated_tvec[1] - T(prior_y_));
    residuals[2] = T(inv_std_) * (-rotated_tvec[2] - T(prior_z_));
    return true;
  }

 private:
  // Plain doubles: a Vector3d member would need aligned allocation.
  const double prior_x_;
  const double prior_y_;
  const double prior_z_;
  const double inv_std_;
};

// Registered images that observe at least one 3D point, sorted by id.
std::vector<colmap::image_t> ImagesWithPoints(
    const colmap::Reconstruction& reconstruction) {
  std::vector<colmap::image_t> image_ids;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    if (reconstruction.Image(image_id).NumPoints3D() > 0) {
      image_ids.push_back(image_id);
    }
  }
  std::sort(image_ids.begin(), image_ids.end());
  return image_ids;
}

colmap::BundleAdjustmentOptions ColmapOptions(
    const GlobalBundleAdjustmentOptions& options, InterruptCallback* callback) {
  colmap::BundleAdjustmentOptions ba_options;
  ba_options.loss_function_type =
      options.loss_scale_px > 0
          ? colmap::BundleAdjustmentOptions::LossFunctionType::SOFT_L1
          : colmap::BundleAdjustmentOptions::LossFunctionType::TRIVIAL;
  ba_options.loss_function_scale = options.loss_scale_px;
  ba_options.refine_focal_length = options.refine_focal_length;
  ba_options.refine_principal_point = options.refine_principal_point;
  ba_options.refine_extra_params = options.refine_extra_params;
  ba_options.refine_extrinsics = true;
  ba_options.print_summary = false;
  ba_options.solver_options.max_num_iterations = options.max_num_iterations;
  ba_options.solver_options.function_tolerance = options.function_tolerance;
  ba_options.solver_options.num_threads =
      colmap::GetEffectiveNumThreads(options.num_threads);
  // Progress goes through our own round summary; Ceres' per-iteration log
  // (glog, at the GUI's verbosity) would flood the output.
  ba_options.solver_options.logging_type = ceres::SILENT;
  ba_options.solver_options.callbacks.push_back(callback);
  return ba_options;
}

// Intrinsic parameter indices held constant by the options.
std::vector<int> ConstantCameraParams(
    const colmap::Camera& camera,
    const colmap::BundleAdjustmentOptions& ba_options) {
  std::vector<int> constant_params;
  const auto append = [&constant_params](const std::vector<size_t>& idxs) {
    for (const size_t idx : idxs)
      constant_params.push_back(static_cast<int>(idx));
  };
  if (!ba_options.refine_focal_length) append(camera.FocalLengthIdxs());
  if (!ba_options.refine_principal_point) append(camera.PrincipalPointIdxs());
  if (!ba_options.refine_extra_params) append(camera.ExtraParamsIdxs());
  std::sort(constant_params.begin(), constant_params.end());
  constant_params.erase(
      std::unique(constant_params.begin(), constant_params.end()),
      constant_params.end());
  return constant_params;
}

// The intrinsics that the solve with fixed rotations refines: focal lengths
// only. A shift of the principal point is nearly the same as a small
// rotation of the camera, and distortion bends rays like a rotation error
// that grows outwards; with the rotations held, these take up the rotation
// averaging's errors and carry them into the joint solve, which then stays
// in the wrong minimum (templeRing, one camera per image with an EXIF focal
// 1.6% off: principal point 30 px off, k1 -0.47, AUC@3 43.4; with them held
// in that solve 89.9, as with an exact focal). The focal length is a scale
// that no rotation can take, and after view-graph calibration it is the
// intrinsic furthest from the truth.
colmap::BundleAdjustmentOptions FocalOnly(
    colmap::BundleAdjustmentOptions ba_options) {
  ba_options.refine_principal_point = false;
  ba_options.refine_extra_params = false;
  return ba_options;
}

// Pixel residual of a point given in camera coordinates, as in COLMAP's
// cost functions.
template <typename CameraModel, typename T>
void ReprojectionResidual(const T* point_in_cam, const T* camera_params,
                          double observed_x, double observed_y, T* residuals) {
  CameraModel::WorldToImage(camera_params, point_in_cam[0] / point_in_cam[2],
                            point_in_cam[1] / point_in_cam[2], &residuals[0],
                            &residuals[1]);
  residuals[0] -= T(observed_x);
  residuals[1] -= T(observed_y);
}

// Reprojection error with the world-to-camera rotation held fixed, on the
// parameter blocks (tvec, point, camera params). Same model as COLMAP's
// BundleAdjustmentCostFunction, without the quaternion block: the solve
// needs no derivatives for it, which saves about a third of the Jacobian
// work of this stage.
template <typename CameraModel>
class FixedRotationCostFunction {
 public:
  FixedRotationCostFunction(const Eigen::Matrix3d& rotation,
                            const Eigen::Vector2d& point2D)
      : rotation_(rotation), observed_x_(point2D(0)), observed_y_(point2D(1)) {}

  static ceres::CostFunction* Create(const Eigen::Matrix3d& rotation,
                                     const Eigen::Vector2d& point2D) {
    return new ceres::AutoDiffCostFunction<FixedRotationCostFunction, 2, 3, 3,
                                           CameraModel::kNumParams>(
        new FixedRotationCostFunction(rotation, point2D));
  }

  template <typename T>
  bool operator()(const T* const tvec, const T* const point3D,
                  const T* const camera_params, T* residuals) const {
    T point_in_cam[3];
    for (int r = 0; r < 3; ++r) {
      point_in_cam[r] = T(rotation_(r, 0)) * point3D[0] +
                        T(rotation_(r, 1)) * point3D[1] +
                        T(rotation_(r, 2)) * point3D[2] + tvec[r];
    }
    ReprojectionResidual<CameraModel>(point_in_cam, camera_params, observed_x_,
                                      observed_y_, residuals);
    return true;
  }

 private:
  const Eigen::Matrix3d rotation_;
  // Plain doubles: a Vector2d member would need aligned allocation.
  const double observed_x_;
  const double observed_y_;
};

// Reprojection error on one pose block [qw, qx, qy, qz, tx, ty, tz] (COLMAP's
// quaternion convention, world to camera), the point and the camera
// parameters. Same model as COLMAP's BundleAdjustmentCostFunction, which
// takes rotation and translation as two blocks: one block per image halves
// the camera blocks in every point's part of the Schur complement, and with
// it the cell updates (each under a mutex in Ceres 2.1) that dominate the
// linear solver (measured on KITTI_sequence_1: 60 % of a joint iteration).
template <typename CameraModel>
class PoseCostFunction {
 public:
  explicit PoseCostFunction(const Eigen::Vector2d& point2D)
      : observed_x_(point2D(0)), observed_y_(point2D(1)) {}

  static ceres::CostFunction* Create(const Eigen::Vector2d& point2D) {
    return new ceres::AutoDiffCostFunction<PoseCostFunction, 2, 7, 3,
                                           CameraModel::kNumParams>(
        new PoseCostFunction(point2D));
  }

  template <typename T>
  bool operator()(const T* const pose, const T* const point3D,
                  const T* const camera_params, T* residuals) const {
    T point_in_cam[3];
    ceres::UnitQuaternionRotatePoint(pose, point3D, point_in_cam);
    point_in_cam[0] += pose[4];
    point_in_cam[1] += pose[5];
    point_in_cam[2] += pose[6];
    ReprojectionResidual<CameraModel>(point_in_cam, camera_params, observed_x_,
                                      observed_y_, residuals);
    return true;
  }

 private:
  const double observed_x_;
  const double observed_y_;
};

// PoseCostFunction of `camera`'s model for the keypoint `point2D`.
ceres::CostFunction* NewPoseCostFunction(const colmap::Camera& camera,
                                         const Eigen::Vector2d& point2D) {
  switch (camera.ModelId()) {
#define CAMERA_MODEL_CASE(CameraModel) \
  case colmap::CameraModel::kModelId:  \
    return PoseCostFunction<colmap::CameraModel>::Create(point2D);
    CAMERA_MODEL_SWITCH_CASES
#undef CAMERA_MODEL_CASE
  }
  return nullptr;
}

// Pose blocks of the joint solve, copied from and back to the images
// (colmap::Image keeps rotation and translation in separate vectors).
using PoseBlock = std::array<double, 7>;

PoseBlock ToPoseBlock(const colmap::Image& image) {
  return {image.Qvec(0), image.Qvec(1), image.Qvec(2), image.Qvec(3),
          image.Tvec(0), image.Tvec(1), image.Tvec(2)};
}

void FromPoseBlock(const PoseBlock& pose, colmap::Image* image) {
  image->SetQvec(Eigen::Vector4d(pose[0], pose[1], pose[2], pose[3]));
  image->NormalizeQvec();
  image->SetTvec(Eigen::Vector3d(pose[4], pose[5], pose[6]));
}

// The linear solver for the number of images (see
// max_num_images_dense_schur). Both factorize the reduced camera system
// exactly, so every Levenberg-Marquardt step is the step its model asks for;
// without a sparse library (Debian's Ceres has SuiteSparse) the dense one is
// slower but as exact.
void ChooseLinearSolver(const GlobalBundleAdjustmentOptions& options,
                        size_t num_images,
                        ceres::Solver::Options* solver_options) {
  const bool has_sparse =
      solver_options->sparse_linear_algebra_library_type != ceres::NO_SPARSE;
  if (num_images <= static_cast<size_t>(options.max_num_images_dense_schur) ||
      !has_sparse) {
    solver_options->linear_solver_type = ceres::DENSE_SCHUR;
  } else {
    solver_options->linear_solver_type = ceres::SPARSE_SCHUR;
  }
}

// GlobalBundleAdjustmentOptions::function_tolerance, scaled for the number
// of images.
double ScaledFunctionTolerance(const GlobalBundleAdjustmentOptions& options,
                               size_t num_images) {
  const double ratio =
      std::min(1.0, static_cast<double>(options.function_tolerance_num_images) /
                        static_cast<double>(num_images));
  return options.function_tolerance * ratio * ratio;
}

// Solves at least this large take seconds per iteration (7 to 17 s for the
// 10,000-image survey's 3.2 million residual blocks on 2 cores): each of
// their iterations gets a log line, so that a long solve shows progress and
// its log shows how it converged.
constexpr int kMinResidualBlocksToLogIterations = 1000000;

// Logs one line per Levenberg-Marquardt iteration.
class IterationLogger : public ceres::IterationCallback {
 public:
  explicit IterationLogger(std::string solve_name)
      : solve_name_(std::move(solve_name)) {}

  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& iteration) override {
    const double relative_decrease =
        iteration.cost > 0 ? iteration.cost_change / iteration.cost : 0;
    LOG(INFO) << solve_name_ << " iteration " << iteration.iteration
              << ": cost " << iteration.cost << ", relative decrease "
              << relative_decrease << ", step "
              << (iteration.step_is_successful ? "accepted" : "rejected")
              << ", trust region radius " << iteration.trust_region_radius
              << ", " << iteration.cumulative_time_in_seconds << " s";
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::string solve_name_;
};

// One Ceres problem for both stages. COLMAP 3.8's BundleAdjustmentConfig can
// hold a whole pose constant but not the rotation alone, so in the
// rotation-fixed solve rotations are not parameters at all; in the joint
// solve each image has one pose block (see PoseCostFunction) on
// PoseAboutCenterManifold (the image that holds the scale gauge on the product
// of Ceres' quaternion manifold and a subset of t). The loss and the
// parameterization of intrinsics follow colmap::BundleAdjuster; the linear
// solver does not (see ChooseLinearSolver).
// Residuals A * params of IntrinsicsPriorMatrix.
class IntrinsicsPriorCost : public ceres::CostFunction {
 public:
  IntrinsicsPriorCost(Eigen::MatrixXd A, Eigen::VectorXd b)
      : A_(std::move(A)), b_(std::move(b)) {
    set_num_residuals(static_cast<int>(A_.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(A_.cols()));
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> params(parameters[0], A_.cols());
    Eigen::Map<Eigen::VectorXd>(residuals, A_.rows()) = A_ * params - b_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic,
                               Eigen::RowMajor>>(jacobians[0], A_.rows(),
                                                 A_.cols()) = A_;
    }
    return true;
  }

 private:
  const Eigen::MatrixXd A_;
  const Eigen::VectorXd b_;
};

// The soft priors on `camera`'s intrinsics (residuals A * params - b, one
// block): IntrinsicsPriorMatrix's rows, and for a camera with a known focal
// length (prior_focal_lengths_px) one row per focal parameter, (f - f0) /
// (prior_focal_length_std * f0), when focal lengths are refined.
void AddIntrinsicsPriors(const GlobalBundleAdjustmentOptions& options,
                         const colmap::BundleAdjustmentOptions& ba_options,
                         colmap::Camera* camera, ceres::Problem* problem) {
  const int num_params = static_cast<int>(camera->NumParams());
  Eigen::MatrixXd A(0, num_params);
  if (options.intrinsics_prior_px > 0) {
    A = IntrinsicsPriorMatrix(*camera, options.intrinsics_prior_px);
  }
  Eigen::VectorXd b = Eigen::VectorXd::Zero(A.rows());
  const auto known = options.prior_focal_lengths_px.find(camera->CameraId());
  if (options.prior_focal_length_std > 0 && ba_options.refine_focal_length &&
      known != options.prior_focal_lengths_px.end()) {
    const std::vector<size_t>& focal_idxs = camera->FocalLengthIdxs();
    const Eigen::Index first_row = A.rows();
    A.conservativeResize(first_row + focal_idxs.size(), Eigen::NoChange);
    b.conservativeResize(first_row + focal_idxs.size());
    const double std_px = options.prior_focal_length_std * known->second;
    for (size_t k = 0; k < focal_idxs.size(); ++k) {
      A.row(first_row + k).setZero();
      A(first_row + k, focal_idxs[k]) = 1 / std_px;
      b(first_row + k) = known->second / std_px;
    }
  }
  if (A.rows() > 0) {
    problem->AddResidualBlock(
        new IntrinsicsPriorCost(std::move(A), std::move(b)), nullptr,
        camera->ParamsData());
  }
}

// `camera`'s parameter block in `problem`: its soft priors
// (AddIntrinsicsPriors), the parameters `ba_options` holds and those in
// `held` (parameters that ran beyond their bounds in an earlier solve).
void SetUpCameraBlock(const GlobalBundleAdjustmentOptions& options,
                      const colmap::BundleAdjustmentOptions& ba_options,
                      colmap::Camera* camera, ceres::Problem* problem,
                      const std::vector<int>& held = {}) {
  AddIntrinsicsPriors(options, ba_options, camera, problem);
  std::vector<int> constant_params = ConstantCameraParams(*camera, ba_options);
  constant_params.insert(constant_params.end(), held.begin(), held.end());
  std::sort(constant_params.begin(), constant_params.end());
  constant_params.erase(
      std::unique(constant_params.begin(), constant_params.end()),
      constant_params.end());
  if (constant_params.size() == camera->NumParams()) {
    problem->SetParameterBlockConstant(camera->ParamsData());
  } else if (!constant_params.empty()) {
    colmap::SetSubsetManifold(static_cast<int>(camera->NumParams()),
                              constant_params, problem, camera->ParamsData());
  }
}

// Intrinsic parameters held at their bounds, by camera (sorted indices).
using HeldParams = std::map<colmap::camera_t, std::vector<int>>;

// The bounds of each camera's intrinsics at the start of a solve (empty
// without bound_intrinsics).
std::map<colmap::camera_t, std::vector<std::pair<double, double>>>
BoundsAtStart(const GlobalBundleAdjustmentOptions& options,
              const colmap::Reconstruction& reconstruction,
              const std::set<colmap::camera_t>& camera_ids) {
  std::map<colmap::camera_t, std::vector<std::pair<double, double>>> bounds;
  if (!options.bound_intrinsics) return bounds;
  for (const colmap::camera_t camera_id : camera_ids) {
    bounds.emplace(camera_id,
                   IntrinsicsBounds(reconstruction.Camera(camera_id)));
  }
  return bounds;
}

// Clamps every parameter of `camera` that a solve moved beyond its bound
// back onto it, adds it to `held` and describes it in `description`
// ("camera 3 k2 -357.8 -> -16"). Returns how many were clamped.
int ClampToBounds(const std::vector<std::pair<double, double>>& bounds,
                  colmap::Camera* camera, std::vector<int>* held,
                  std::ostringstream* description) {
  // The parameters' names ("f, cx, cy, k"), read at the first clamp only:
  // this runs for every camera after every solve.
  std::vector<std::string> names;
  const auto name_of = [&names, camera](size_t idx) {
    if (names.empty()) {
      std::istringstream info(camera->ParamsInfo());
      for (std::string name; std::getline(info, name, ',');) {
        name.erase(0, name.find_first_not_of(' '));
        names.push_back(name);
      }
    }
    return idx < names.size() ? names[idx] : std::to_string(idx);
  };
  int num_clamped = 0;
  std::vector<double>& params = camera->Params();
  for (size_t idx = 0; idx < bounds.size() && idx < params.size(); ++idx) {
    const double clamped =
        std::clamp(params[idx], bounds[idx].first, bounds[idx].second);
    if (clamped == params[idx]) continue;
    *description << (description->tellp() > 0 ? "; " : "") << "camera "
                 << camera->CameraId() << " " << name_of(idx) << " "
                 << params[idx] << " -> " << clamped;
    params[idx] = clamped;
    held->insert(
        std::upper_bound(held->begin(), held->end(), static_cast<int>(idx)),
        static_cast<int>(idx));
    ++num_clamped;
  }
  return num_clamped;
}

// One solve. With bound_intrinsics, intrinsic parameters that it moved
// beyond their bounds (IntrinsicsBounds at its start) are clamped onto them
// and added to `held`, and `*num_clamped` counts them: the caller solves
// again with them held. Ceres' own bounds are not used: a bounded problem
// takes Ceres' projected line search in every iteration, a different path
// also where no bound is ever reached (a synthetic street of 40 cameras:
// AUC@3 54.4 -> 37.4 with only the focal length bounded, far from its
// bound), and a principal point bounded while still moving stayed in a
// wrong minimum (a fisheye ring: 87.4 -> 3.5).
Status Solve(const GlobalBundleAdjustmentOptions& options,
             const colmap::BundleAdjustmentOptions& ba_options,
             const std::vector<colmap::image_t>& image_ids,
             const std::vector<Gauge>& gauges,
             const std::unordered_set<colmap::point3D_t>& left_out,
             const PositionPriorTerm* priors, bool fix_rotations,
             colmap::Reconstruction* reconstruction, int* num_iterations,
             HeldParams* held, int* num_clamped) {
  *num_clamped = 0;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const std::unique_ptr<ceres::LossFunction> loss_function(
      ba_options.CreateLossFunction());
  // Cauchy on the prior residual's norm in standard deviations: reprojection
  // residuals are in pixels, so with about 1 px of keypoint noise both terms
  // are in units of their own noise and weigh each other as they should.
  std::unique_ptr<ceres::LossFunction> prior_loss;
  if (priors != nullptr && !priors->empty()) {
    prior_loss = std::make_unique<ceres::CauchyLoss>(priors->loss_scale_std);
  }

  // Pose blocks of the joint solve; std::map keeps their addresses stable.
  std::map<colmap::image_t, PoseBlock> poses;
  std::set<colmap::camera_t> camera_ids;
  for (const colmap::image_t image_id : image_ids) {
    colmap::Image& image = reconstruction->Image(image_id);
    colmap::Camera& camera = reconstruction->Camera(image.CameraId());
    image.NormalizeQvec();
    const Eigen::Matrix3d rotation = image.RotationMatrix();
    double* tvec_data = image.Tvec().data();
    double* pose_data = nullptr;
    if (!fix_rotations) {
      pose_data =
          poses.emplace(image_id, ToPoseBlock(image)).first->second.data();
    }
    bool has_residuals = false;
    for (const colmap::Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D() || left_out.count(point2D.Point3DId()) > 0) {
        continue;
      }
      colmap::Point3D& point3D = reconstruction->Point3D(point2D.Point3DId());
      ceres::CostFunction* cost_function = nullptr;
      if (fix_rotations) {
        switch (camera.ModelId()) {
#define CAMERA_MODEL_CASE(CameraModel)                                      \
  case colmap::CameraModel::kModelId:                                       \
    cost_function = FixedRotationCostFunction<colmap::CameraModel>::Create( \
        rotation, point2D.XY());                                            \
    break;
          CAMERA_MODEL_SWITCH_CASES
#undef CAMERA_MODEL_CASE
        }
        problem.AddResidualBlock(cost_function, loss_function.get(), tvec_data,
                                 point3D.XYZ().data(), camera.ParamsData());
      } else {
        problem.AddResidualBlock(NewPoseCostFunction(camera, point2D.XY()),
                                 loss_function.get(), pose_data,
                                 point3D.XYZ().data(), camera.ParamsData());
      }
      has_residuals = true;
    }
    if (has_residuals && prior_loss != nullptr) {
      const auto prior = priors->center_in_frame.find(image_id);
      if (prior != priors->center_in_frame.end()) {
        if (fix_rotations) {
          problem.AddResidualBlock(new FixedRotationPriorCostFunction(
                                       rotation, prior->second, priors->std_m),
                                   prior_loss.get(), tvec_data);
        } else {
          problem.AddResidualBlock(
              PosePriorCostFunction::Create(prior->second, priors->std_m),
              prior_loss.get(), pose_data);
        }
      }
    }
    if (has_residuals && !fix_rotations) {
      const Gauge* scale_gauge = ScaleGaugeOfImage(gauges, image_id);
      if (IsFixedPoseImage(gauges, image_id)) {
        problem.SetParameterBlockConstant(pose_data);
      } else if (scale_gauge != nullptr) {
        problem.SetManifold(
            pose_data,
            new ceres::ProductManifold<ceres::QuaternionManifold,
                                       ceres::SubsetManifold>(
                ceres::QuaternionManifold(),
                ceres::SubsetManifold(3, {scale_gauge->scale_tvec_idx})));
      } else {
        problem.SetManifold(pose_data, NewPoseAboutCenterManifold());
      }
    }
    camera_ids.insert(image.CameraId());
  }
  if (problem.NumResiduals() == 0) {
    return Status::Error("Bundle adjustment has no observations.");
  }

  if (fix_rotations) {
    for (const Gauge& gauge : gauges) {
      problem.SetParameterBlockConstant(
          reconstruction->Image(gauge.fixed_pose_image_id).Tvec().data());
      colmap::SetSubsetManifold(
          3, {gauge.scale_tvec_idx}, &problem,
          reconstruction->Image(gauge.scale_image_id).Tvec().data());
    }
  }

  for (const colmap::camera_t camera_id : camera_ids) {
    colmap::Camera& camera = reconstruction->Camera(camera_id);
    SetUpCameraBlock(options,
                     fix_rotations ? FocalOnly(ba_options) : ba_options,
                     &camera, &problem, (*held)[camera_id]);
  }
  const auto bounds = BoundsAtStart(options, *reconstruction, camera_ids);

  ceres::Solver::Options solver_options = ba_options.solver_options;
  const std::string solve_name =
      fix_rotations ? "BA solve (fixed rotations)" : "BA solve (joint)";
  IterationLogger iteration_logger(solve_name);
  if (problem.NumResidualBlocks() >= kMinResidualBlocksToLogIterations) {
    solver_options.callbacks.push_back(&iteration_logger);
  }
  ChooseLinearSolver(options, image_ids.size(), &solver_options);
  solver_options.function_tolerance =
      ScaledFunctionTolerance(options, image_ids.size());
  solver_options.num_threads = CeresNumThreads(
      ba_options.solver_options.num_threads, problem.NumResidualBlocks(),
      options.min_residuals_per_ceres_thread);
  std::string solver_error;
  if (!solver_options.IsValid(&solver_error)) {
    return Status::Error("Invalid Ceres options: " + solver_error);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  *num_iterations = static_cast<int>(summary.iterations.size());
  // One line per solve: whether it converged or hit the iteration cap, the
  // cost it reached, and where its time went (the linear solver factorizes
  // the reduced camera system; the evaluations are the residuals and
  // Jacobians of every observation).
  VLOG(3) << "BA solve (" << (fix_rotations ? "fixed rotations" : "joint")
          << ", " << image_ids.size() << " images, "
          << problem.NumResidualBlocks() << " residual blocks, "
          << ceres::LinearSolverTypeToString(summary.linear_solver_type_used)
          << ", " << summary.num_threads_used
          << " threads): " << summary.iterations.size() << " iterations ("
          << ceres::TerminationTypeToString(summary.termination_type)
          << "), cost " << summary.initial_cost << " -> " << summary.final_cost
          << ", " << summary.total_time_in_seconds << " s (linear solver "
          << summary.linear_solver_time_in_seconds << " s, evaluation "
          << summary.residual_evaluation_time_in_seconds +
                 summary.jacobian_evaluation_time_in_seconds
          << " s)";
  // Ceres leaves the last accepted state in the blocks, also when stopped.
  for (const auto& [image_id, pose] : poses) {
    FromPoseBlock(pose, &reconstruction->Image(image_id));
  }
  std::ostringstream clamped;
  for (const auto& [camera_id, camera_bounds] : bounds) {
    *num_clamped +=
        ClampToBounds(camera_bounds, &reconstruction->Camera(camera_id),
                      &(*held)[camera_id], &clamped);
  }
  if (*num_clamped > 0) {
    LOG(INFO) << "Bundle adjustment: " << *num_clamped
              << " intrinsic parameter(s) the images do not fix ran beyond "
                 "their bounds and are held on them ("
              << clamped.str() << ").";
  }
  if (summary.termination_type == ceres::FAILURE) {
    return Status::Error(std::string(fix_rotations
                                         ? "Bundle adjustment with fixed "
                                           "rotations failed: "
                                         : "Joint bundle adjustment failed: ") +
                         summary.message);
  }
  return Status::Ok();
}

// Filters by normalized reprojection error and returns the number of tracks
// that lost at least one observation (deleted points included), the quantity
// of the reference's stopping rule (glomap.md §2.7, Appendix A.5).
size_t FilterAndCountChangedTracks(double max_normalized_reproj_error,
                                   colmap::Reconstruction* reconstruction) {
  std::vector<std::pair<colmap::point3D_t, size_t>> track_lengths;
  track_lengths.reserve(reconstruction->NumPoints3D());
  for (const auto& point3D : reconstruction->Points3D()) {
    track_lengths.emplace_back(point3D.first, point3D.second.Track().Length());
  }
  FilterObservationsByNormalizedReprojectionError(reconstruction,
                                                  max_normalized_reproj_error);
  size_t num_changed = 0;
  for (const auto& [point3D_id, length] : track_lengths) {
    if (!reconstruction->ExistsPoint3D(point3D_id) ||
        reconstruction->Point3D(point3D_id).Track().Length() != length) {
      ++num_changed;
    }
  }
  return num_changed;
}

// The image corner's distance from the centre on the normalized image plane
// (half the diagonal over the mean focal length).
double CornerNormalizedRadius(const colmap::Camera& camera) {
  return 0.5 *
         std::hypot(static_cast<double>(camera.Width()),
                    static_cast<double>(camera.Height())) /
         std::max(camera.MeanFocalLength(), 1e-9);
}

}  // namespace

// How much weaker the prior on OPENCV_FISHEYE's k2, k3, k4 is than on the
// perspective models' higher orders (see IntrinsicsPriorMatrix).
constexpr double kFisheyeHigherOrderFactor = 5;

Eigen::MatrixXd IntrinsicsPriorMatrix(const colmap::Camera& camera,
                                      double sigma_px) {
  const std::string model = camera.ModelName();
  const double focal = camera.MeanFocalLength();
  // (parameter index, shift at the corner per unit, pixels).
  std::vector<std::pair<size_t, double>> terms;
  const double r = CornerNormalizedRadius(camera);
  if (model == "RADIAL" || model == "RADIAL_FISHEYE") {
    terms = {{4, focal * std::pow(r, 5)}};  // k2
  } else if (model == "OPENCV" || model == "FULL_OPENCV") {
    // k2; p1, p2 (a tangential shift of about 3 p r^2); FULL_OPENCV's k3 and
    // its rational k4, k5, k6 (same orders as k1, k2, k3).
    terms = {{5, focal * std::pow(r, 5)},
             {6, 3 * focal * r * r},
             {7, 3 * focal * r * r}};
    if (model == "FULL_OPENCV") {
      terms.push_back({8, focal * std::pow(r, 7)});
      terms.push_back({9, focal * std::pow(r, 3)});
      terms.push_back({10, focal * std::pow(r, 5)});
      terms.push_back({11, focal * std::pow(r, 7)});
    }
  } else if (model == "OPENCV_FISHEYE") {
    // theta_d = theta (1 + k1 theta^2 + ...). Its higher orders are weighted
    // kFisheyeHigherOrderFactor times less: they are how far a lens departs
    // from equidistance, far for many lenses (an ordinary one is tan(theta)
    // = theta (1 + theta^2 / 3 + 2 theta^4 / 15 + ...): k2 = 0.13 shifts
    // fountain-P11's corners by 26 px; pulled to zero at the perspective
    // weight, AUC@3 fell from 95.9 to 87.9).
    const double theta = std::atan(r);
    const double scale = 1 / kFisheyeHigherOrderFactor;
    terms = {{5, scale * focal * std::pow(theta, 5)},
             {6, scale * focal * std::pow(theta, 7)},
             {7, scale * focal * std::pow(theta, 9)}};
  }
  const std::vector<size_t>& focal_idxs = camera.FocalLengthIdxs();
  const size_t num_rows = terms.size() + (focal_idxs.size() == 2 ? 1 : 0);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(num_rows, camera.NumParams());
  size_t row = 0;
  if (focal_idxs.size() == 2) {
    // fx - fy shifts the corner by about (fx - fy) r / 2 in each direction.
    A(row, focal_idxs[0]) = 0.5 * r / sigma_px;
    A(row, focal_idxs[1]) = -0.5 * r / sigma_px;
    ++row;
  }
  for (const auto& [idx, shift_px] : terms) {
    A(row++, idx) = shift_px / sigma_px;
  }
  return A;
}

// The focal length's bounds as multiples of the larger image side, COLMAP's
// IncrementalMapperOptions::min/max_focal_length_ratio: a camera outside
// them is bogus to its mapper.
constexpr double kMinFocalLengthRatio = 0.1;
constexpr double kMaxFocalLengthRatio = 10;
// How far one distortion parameter alone may move the image corner, as a
// fraction of the corner's distance from the principal point (COLMAP's
// mapper calls a camera with a distortion parameter beyond 1 bogus, i.e. a
// shift of 100% at a normalized radius of 1); half that for the rational
// denominator of FULL_OPENCV, which would otherwise reach zero.
constexpr double kMaxCornerShiftFraction = 1;
constexpr double kMaxRationalCornerShiftFraction = 0.5;

std::vector<std::pair<double, double>> IntrinsicsBounds(
    const colmap::Camera& camera) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::vector<double>& params = camera.Params();
  std::vector<std::pair<double, double>> bounds(params.size(), {-kInf, kInf});
  const double width = static_cast<double>(camera.Width());
  const double height = static_cast<double>(camera.Height());
  for (const size_t idx : camera.FocalLengthIdxs()) {
    bounds[idx] = {kMinFocalLengthRatio * std::max(width, height),
                   kMaxFocalLengthRatio * std::max(width, height)};
  }
  // The principal point stays inside the image. (Tighter bounds hurt: with
  // Ceres' bounds at the central half of the image, reached while it was
  // still moving, a fisheye ring with every image its own camera stayed in a
  // wrong minimum, AUC@3 87.4 -> 3.5.)
  const std::vector<size_t>& pp_idxs = camera.PrincipalPointIdxs();
  for (size_t k = 0; k < pp_idxs.size(); ++k) {
    bounds[pp_idxs[k]] = {0, k == 0 ? width : height};
  }

  // The corner's normalized radius, or its angle for the fisheye models.
  const std::string model = camera.ModelName();
  const bool fisheye = model.find("FISHEYE") != std::string::npos;
  const double radius = CornerNormalizedRadius(camera);
  const double r = fisheye ? std::atan(radius) : radius;
  // A parameter whose term is param * r^power relative to the radius.
  const auto radial = [&](size_t idx, int power, double fraction) {
    const double limit = fraction / std::pow(r, power);
    bounds[idx] = {-limit, limit};
  };
  // Tangential and thin-prism terms shift the corner by about 3 p r^2 and
  // s r^2 (in focal lengths) where it lies r from the principal point.
  const auto tangential = [&](size_t idx, double factor) {
    const double limit = kMaxCornerShiftFraction / (factor * r);
    bounds[idx] = {-limit, limit};
  };
  if (model == "SIMPLE_RADIAL" || model == "SIMPLE_RADIAL_FISHEYE") {
    radial(3, 2, kMaxCornerShiftFraction);
    // The lone k is the whole radial mapping r (1 + k r^2), which folds
    // back where its derivative 1 + 3 k r^2 reaches zero: not inside the
    // image.
    bounds[3].first = -1 / (3 * r * r);
  } else if (model == "RADIAL" || model == "RADIAL_FISHEYE") {
    radial(3, 2, kMaxCornerShiftFraction);
    radial(4, 4, kMaxCornerShiftFraction);
  } else if (model == "OPENCV" || model == "FULL_OPENCV") {
    radial(4, 2, kMaxCornerShiftFraction);
    radial(5, 4, kMaxCornerShiftFraction);
    tangential(6, 3);
    tangential(7, 3);
    if (model == "FULL_OPENCV") {
      radial(8, 6, kMaxCornerShiftFraction);
      radial(9, 2, kMaxRationalCornerShiftFraction);
      radial(10, 4, kMaxRationalCornerShiftFraction);
      radial(11, 6, kMaxRationalCornerShiftFraction);
    }
  } else if (model == "OPENCV_FISHEYE") {
    for (int k = 0; k < 4; ++k)
      radial(4 + k, 2 * (k + 1), kMaxCornerShiftFraction);
  } else if (model == "THIN_PRISM_FISHEYE") {
    radial(4, 2, kMaxCornerShiftFraction);
    radial(5, 4, kMaxCornerShiftFraction);
    tangential(6, 3);
    tangential(7, 3);
    radial(8, 6, kMaxCornerShiftFraction);
    radial(9, 8, kMaxCornerShiftFraction);
    tangential(10, 1);
    tangential(11, 1);
  }
  // A start value outside its bound widens the bound to it.
  for (size_t idx = 0; idx < params.size(); ++idx) {
    bounds[idx].first = std::min(bounds[idx].first, params[idx]);
    bounds[idx].second = std::max(bounds[idx].second, params[idx]);
  }
  return bounds;
}

namespace {

// The tracks a solve may hold, in the order they are taken (decreasing
// length, then id), each observation as the index of its image's grid cell
// (image index * kSolveGridSize^2 + cell): computed once, so that a choice
// of the quota costs one pass over the observations.
struct SolveCandidates {
  std::vector<colmap::point3D_t> point3D_ids;
  std::vector<size_t> track_begin;  // point3D_ids.size() + 1 offsets.
  std::vector<uint32_t> cells;
  size_t num_cells = 0;
};

SolveCandidates CollectSolveCandidates(
    const colmap::Reconstruction& reconstruction) {
  constexpr int kNumCells = kSolveGridSize * kSolveGridSize;
  std::vector<std::pair<size_t, colmap::point3D_t>> by_length;
  by_length.reserve(reconstruction.NumPoints3D());
  for (const auto& [point3D_id, point3D] : reconstruction.Points3D()) {
    by_length.emplace_back(point3D.Track().Length(), point3D_id);
  }
  std::sort(
      by_length.begin(), by_length.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
  std::unordered_map<colmap::image_t, uint32_t> image_index;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    image_index.emplace(image_id, static_cast<uint32_t>(image_index.size()));
  }
  const auto cell_index = [](double value, size_t size) {
    const int cell = static_cast<int>(
        std::floor(value / std::max<size_t>(size, 1) * kSolveGridSize));
    return std::clamp(cell, 0, kSolveGridSize - 1);
  };
  SolveCandidates candidates;
  candidates.point3D_ids.reserve(by_length.size());
  candidates.track_begin.reserve(by_length.size() + 1);
  candidates.track_begin.push_back(0);
  for (const auto& [length, point3D_id] : by_length) {
    for (const colmap::TrackElement& element :
         reconstruction.Point3D(point3D_id).Track().Elements()) {
      const colmap::Image& image = reconstruction.Image(element.image_id);
      const colmap::Camera& camera = reconstruction.Camera(image.CameraId());
      const Eigen::Vector2d& xy = image.Point2D(element.point2D_idx).XY();
      auto index = image_index.find(element.image_id);
      if (index == image_index.end()) {  // Not registered: a cell of its own.
        index = image_index
                    .emplace(element.image_id,
                             static_cast<uint32_t>(image_index.size()))
                    .first;
      }
      candidates.cells.push_back(index->second * kNumCells +
                                 cell_index(xy.y(), camera.Height()) *
                                     kSolveGridSize +
                                 cell_index(xy.x(), camera.Width()));
    }
    candidates.point3D_ids.push_back(point3D_id);
    candidates.track_begin.push_back(candidates.cells.size());
  }
  candidates.num_cells = image_index.size() * kNumCells;
  return candidates;
}

// Whether each candidate is taken at `tracks_per_image` (> 0): while some
// observation of its track falls in a cell that holds fewer than the
// cell's quota; the number of observations taken in `num_observations`.
std::vector<bool> TakeTracks(const SolveCandidates& candidates,
                             int tracks_per_image, size_t* num_observations) {
  constexpr int kNumCells = kSolveGridSize * kSolveGridSize;
  const int tracks_per_cell = (tracks_per_image + kNumCells - 1) / kNumCells;
  std::vector<int> num_taken(candidates.num_cells, 0);
  std::vector<bool> taken(candidates.point3D_ids.size(), false);
  *num_observations = 0;
  for (size_t i = 0; i < candidates.point3D_ids.size(); ++i) {
    const auto begin = candidates.cells.begin() + candidates.track_begin[i];
    const auto end = candidates.cells.begin() + candidates.track_begin[i + 1];
    if (std::none_of(begin, end, [&](uint32_t cell) {
          return num_taken[cell] < tracks_per_cell;
        })) {
      continue;
    }
    for (auto cell = begin; cell != end; ++cell) ++num_taken[*cell];
    taken[i] = true;
    *num_observations += end - begin;
  }
  return taken;
}

// The points of `candidates` not taken at `tracks_per_image` (> 0); the
// observations of those taken in `num_solve_observations`.
std::unordered_set<colmap::point3D_t> LeftOut(const SolveCandidates& candidates,
                                              int tracks_per_image,
                                              size_t* num_solve_observations) {
  const std::vector<bool> taken =
      TakeTracks(candidates, tracks_per_image, num_solve_observations);
  std::unordered_set<colmap::point3D_t> left_out;
  for (size_t i = 0; i < taken.size(); ++i) {
    if (!taken[i]) left_out.insert(candidates.point3D_ids[i]);
  }
  return left_out;
}

// `max_num_observations` raised to kMinSolveObservationsPerImage per image
// with points.
size_t RaisedBudget(const colmap::Reconstruction& reconstruction,
                    size_t max_num_observations) {
  size_t num_images_with_points = 0;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    if (reconstruction.Image(image_id).NumPoints3D() > 0) {
      ++num_images_with_points;
    }
  }
  return std::max(max_num_observations,
                  kMinSolveObservationsPerImage * num_images_with_points);
}

// The largest quota whose solve holds at most `max_num_observations` (already
// raised) observations (bisection over TakeTracks; at least 1).
int QuotaWithin(const colmap::Reconstruction& reconstruction,
                const SolveCandidates& candidates,
                size_t max_num_observations) {
  // A quota of the most observations any image has takes every point.
  int high = 1;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    high = std::max(
        high, static_cast<int>(reconstruction.Image(image_id).NumPoints3D()));
  }
  int low = 1;
  while (low < high) {
    const int middle = low + (high - low + 1) / 2;
    size_t num_observations = 0;
    TakeTracks(candidates, middle, &num_observations);
    if (num_observations <= max_num_observations) {
      low = middle;
    } else {
      high = middle - 1;
    }
  }
  return low;
}

// One pose refined with every point it observes held: a resection, under
// the bundle adjustment's loss, with the image's position prior if it has
// one. The intrinsics are held (they are refined by the solves, where all
// images of a camera take part).
void RefinePoseWithPointsHeld(const GlobalBundleAdjustmentOptions& options,
                              const colmap::BundleAdjustmentOptions& ba_options,
                              const colmap::Reconstruction& points,
                              const PositionPriorTerm* priors,
                              const colmap::Camera& camera,
                              colmap::Image* image) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const std::unique_ptr<ceres::LossFunction> loss_function(
      ba_options.CreateLossFunction());
  image->NormalizeQvec();
  PoseBlock pose = ToPoseBlock(*image);
  // Copies of the held blocks: other threads read the model's.
  std::vector<double> params = camera.Params();
  std::vector<std::array<double, 3>> xyzs;
  xyzs.reserve(image->NumPoints3D());
  for (const colmap::Point2D& point2D : image->Points2D()) {
    if (!point2D.HasPoint3D()) continue;
    const Eigen::Vector3d& xyz = points.Point3D(point2D.Point3DId()).XYZ();
    xyzs.push_back({xyz.x(), xyz.y(), xyz.z()});
    problem.AddResidualBlock(NewPoseCostFunction(camera, point2D.XY()),
                             loss_function.get(), pose.data(),
                             xyzs.back().data(), params.data());
    problem.SetParameterBlockConstant(xyzs.back().data());
  }
  if (problem.NumResiduals() == 0) return;
  problem.SetParameterBlockConstant(params.data());
  std::unique_ptr<ceres::LossFunction> prior_loss;
  if (priors != nullptr && !priors->empty()) {
    const auto prior = priors->center_in_frame.find(image->ImageId());
    if (prior != priors->center_in_frame.end()) {
      prior_loss = std::make_unique<ceres::CauchyLoss>(priors->loss_scale_std);
      problem.AddResidualBlock(
          PosePriorCostFunction::Create(prior->second, priors->std_m),
          prior_loss.get(), pose.data());
    }
  }
  problem.SetManifold(pose.data(), NewPoseAboutCenterManifold());
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  FromPoseBlock(pose, image);
}

// Sweeps of block-coordinate descent over every observation of the model
// (see left_out_sweeps): every pose but the gauges' refined with the points
// held, then every point with the poses held. Each step lowers the cost of
// all observations, the solve's and the left-out ones alike.
Status SweepAllObservations(const GlobalBundleAdjustmentOptions& options,
                            const colmap::BundleAdjustmentOptions& ba_options,
                            const std::vector<colmap::image_t>& image_ids,
                            const std::vector<Gauge>& gauges,
                            const PositionPriorTerm* priors,
                            const PointRefinementOptions& refinement_options,
                            colmap::Reconstruction* reconstruction,
                            const Interrupt& interrupt) {
  std::vector<colmap::image_t> free_ids;
  for (const colmap::image_t image_id : image_ids) {
    if (!IsFixedPoseImage(gauges, image_id) &&
        ScaleGaugeOfImage(gauges, image_id) == nullptr) {
      free_ids.push_back(image_id);
    }
  }
  colmap::Timer total_timer;
  total_timer.Start();
  double final_cost = 0;
  size_t num_observations = 0;
  for (int sweep = 0; sweep < options.left_out_sweeps; ++sweep) {
    colmap::Timer timer;
    timer.Start();
    ParallelFor(options.num_threads, free_ids.size(), [&](size_t i) {
      if (interrupt.IsStopped()) return;
      colmap::Image& image = reconstruction->Image(free_ids[i]);
      RefinePoseWithPointsHeld(options, ba_options, *reconstruction, priors,
                               reconstruction->Camera(image.CameraId()),
                               &image);
    });
    if (interrupt.IsStopped()) return Status::Cancelled();
    const double poses_s = timer.ElapsedSeconds();
    PointRefinementSummary summary;
    const Status status = RefinePointsWithFixedPoses(
        refinement_options, {}, reconstruction, interrupt, &summary);
    if (!status.ok()) return status;
    VLOG(3) << "BA sweep " << sweep + 1
            << " over all observations: " << free_ids.size() << " poses ("
            << poses_s << " s), " << summary.num_points << " points, cost "
            << summary.initial_cost << " -> " << summary.final_cost << ", "
            << timer.ElapsedSeconds() << " s";
    final_cost = summary.final_cost;
    num_observations = summary.num_observations;
  }
  LOG(INFO) << "Global BA: " << options.left_out_sweeps << " sweeps over all "
            << num_observations << " observations, cost " << final_cost << ", "
            << total_timer.ElapsedSeconds() << " s";
  return Status::Ok();
}

}  // namespace

std::unordered_set<colmap::point3D_t> PointsLeftOutOfSolve(
    const colmap::Reconstruction& reconstruction, int tracks_per_image) {
  if (tracks_per_image <= 0) return {};
  size_t num_solve_observations = 0;
  return LeftOut(CollectSolveCandidates(reconstruction), tracks_per_image,
                 &num_solve_observations);
}

int SolveTracksPerImageWithin(const colmap::Reconstruction& reconstruction,
                              size_t max_num_observations) {
  max_num_observations = RaisedBudget(reconstruction, max_num_observations);
  if (reconstruction.ComputeNumObservations() <= max_num_observations) {
    return 0;
  }
  return QuotaWithin(reconstruction, CollectSolveCandidates(reconstruction),
                     max_num_observations);
}

Status GlobalBundleAdjustmentOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("intrinsics_prior_px", intrinsics_prior_px, 0);
  check.AtLeast("prior_focal_length_std", prior_focal_length_std, 0);
  check.AtLeast("num_rounds", num_rounds, 1);
  check.AtLeast("loss_scale_px", loss_scale_px, 0);
  check.AtLeast("max_num_iterations", max_num_iterations, 1);
  check.AtLeast("function_tolerance", function_tolerance, 0);
  check.AtLeast("function_tolerance_num_images", function_tolerance_num_images,
                1);
  check.AtLeast("max_num_images_dense_schur", max_num_images_dense_schur, 0);
  check.AtLeast("min_view_spread_deg_for_principal_point",
                min_view_spread_deg_for_principal_point, 0);
  check.GreaterThan("max_normalized_reproj_error", max_normalized_reproj_error,
                    0);
  check.AtLeast("initial_reproj_error_multiplier",
                initial_reproj_error_multiplier, 1);
  check.AtLeast("min_tri_angle_deg", min_tri_angle_deg, 0);
  check.InRange("min_changed_tracks_ratio", min_changed_tracks_ratio, 0, 1);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  check.AtLeast("min_residuals_per_ceres_thread",
                min_residuals_per_ceres_thread, 1);
  check.AtLeast("solve_tracks_per_image", solve_tracks_per_image, 0);
  check.AtLeast("max_num_solve_observations", max_num_solve_observations, 0);
  check.AtLeast("left_out_sweeps", left_out_sweeps, 0);
  return check.status();
}

Status RunGlobalBundleAdjustment(const GlobalBundleAdjustmentOptions& options,
                                 colmap::Reconstruction* reconstruction,
                                 const Interrupt& interrupt,
                                 const std::function<void()>& on_round_done,
                                 const PositionPriorTerm* priors) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid global bundle adjustment options: " +
                         check.message());
  }
  if (reconstruction == nullptr) {
    return Status::Error("No reconstruction for bundle adjustment.");
  }
  InterruptCallback callback(interrupt);
  const colmap::BundleAdjustmentOptions ba_options =
      ColmapOptions(options, &callback);

  // Threshold multipliers of successive filtering levels (see
  // max_normalized_reproj_error): loose while poses are still coarse, then
  // the nominal value.
  const auto threshold_multiplier = [&options](int level) {
    return std::max(options.initial_reproj_error_multiplier - level, 1);
  };

  // With priors the frame is theirs, in metres: normalising would undo it.
  // Instead the frame takes the step along the 7 directions that only the
  // priors see, which the solves leave mostly untaken (see
  // FitSimilarityToPriors; measured on KITTI_sequence_1 with 2 m priors:
  // mean absolute camera error 0.77 m without it, 0.45 m, as a similarity
  // fitted afterwards, with it). It is taken before each solve too: the
  // fixed-rotation solve cannot turn the model, so a frame turned away from
  // the priors would be pulled into a bend, and the joint solve then spends
  // its iterations undoing it. A part with its own gauge keeps its frame.
  const auto step_frame_to_priors = [&](const std::vector<Gauge>& gauges) {
    if (priors == nullptr || priors->empty() || !gauges.empty()) return;
    PriorAlignment frame_step;
    if (FitSimilarityToPriors(*reconstruction, *priors, &frame_step)) {
      TransformReconstruction(frame_step, reconstruction);
    }
  };

  // A solve that moved intrinsics beyond their bounds runs again with them
  // held (each parameter at most once; they stay held in later rounds).
  HeldParams held;
  // The points a solve left out follow its poses (see
  // solve_tracks_per_image).
  PointRefinementOptions refinement_options;
  refinement_options.num_threads = options.num_threads;
  refinement_options.loss_scale_px = options.loss_scale_px;
  const auto RefineLeftOut =
      [&](const std::unordered_set<colmap::point3D_t>& left_out) {
        if (left_out.empty()) return Status::Ok();
        std::vector<colmap::point3D_t> ids(left_out.begin(), left_out.end());
        std::sort(ids.begin(), ids.end());
        return RefinePointsWithFixedPoses(refinement_options, ids,
                                          reconstruction, interrupt);
      };
  const auto SolveWithinBounds =
      [&](bool fix_rotations, const std::vector<colmap::image_t>& image_ids,
          const std::vector<Gauge>& gauges,
          const std::unordered_set<colmap::point3D_t>& left_out,
          int* num_iterations) {
        for (;;) {
          int num_clamped = 0;
          const Status status =
              Solve(options, ba_options, image_ids, gauges, left_out, priors,
                    fix_rotations, reconstruction, num_iterations, &held,
                    &num_clamped);
          if (!status.ok() || interrupt.IsStopped()) return status;
          if (num_clamped == 0) return RefineLeftOut(left_out);
        }
      };

  bool first_round = true;
  // The last round's images and gauges, when its solves left points out.
  std::vector<colmap::image_t> swept_image_ids;
  std::vector<Gauge> swept_gauges;
  for (int level = 0; level < options.num_rounds; ++level) {
    if (interrupt.IsStopped()) return Status::Cancelled();
    colmap::Timer round_timer;
    round_timer.Start();

    // Points behind a camera make the projection degenerate.
    reconstruction->FilterObservationsWithNegativeDepth();
    const std::vector<colmap::image_t> image_ids =
        ImagesWithPoints(*reconstruction);
    if (image_ids.size() < 2) {
      return Status::Error(
          "Bundle adjustment needs at least two registered images with 3D "
          "points.");
    }
    // The points this round's solves leave out (solve_tracks_per_image, or
    // the quota within max_num_solve_observations).
    int tracks_per_image = options.solve_tracks_per_image;
    const size_t num_observations = reconstruction->ComputeNumObservations();
    const size_t budget =
        options.max_num_solve_observations > 0
            ? RaisedBudget(
                  *reconstruction,
                  static_cast<size_t>(options.max_num_solve_observations))
            : num_observations;
    std::unordered_set<colmap::point3D_t> left_out;
    if (tracks_per_image > 0 || num_observations > budget) {
      const SolveCandidates candidates =
          CollectSolveCandidates(*reconstruction);
      if (tracks_per_image == 0) {
        tracks_per_image = QuotaWithin(*reconstruction, candidates, budget);
      }
      size_t num_solve_observations = 0;
      left_out = LeftOut(candidates, tracks_per_image, &num_solve_observations);
      if (!left_out.empty()) {
        LOG(INFO) << "Global BA round: the solves hold "
                  << reconstruction->NumPoints3D() - left_out.size() << " of "
                  << reconstruction->NumPoints3D() << " points ("
                  << num_solve_observations << " of " << num_observations
                  << " observations"
                  << (options.solve_tracks_per_image == 0
                          ? ", budget " + std::to_string(budget)
                          : std::string())
                  << "): the longest tracks that give every image "
                  << tracks_per_image
                  << " spread over it; the other points are refined with the "
                     "poses fixed";
      }
    }
    const std::vector<Gauge> gauges =
        ChooseGauges(*reconstruction, image_ids, left_out, priors);

    // Rotations are held fixed only in the first solve, right after global
    // positioning, where the positions are coarse and the rotations from
    // averaging are the better estimate; later rounds start from a converged
    // joint solution, where that stage only repeats work.
    int num_fixed_rotation_iterations = 0;
    if (!options.skip_fixed_rotation_stage && first_round) {
      step_frame_to_priors(gauges);
      const Status status =
          SolveWithinBounds(/*fix_rotations=*/true, image_ids, gauges, left_out,
                            &num_fixed_rotation_iterations);
      if (!status.ok()) return status;
      if (interrupt.IsStopped()) return Status::Cancelled();
    }
    int num_joint_iterations = 0;
    if (!options.skip_joint_stage) {
      step_frame_to_priors(gauges);
      const Status status =
          SolveWithinBounds(/*fix_rotations=*/false, image_ids, gauges,
                            left_out, &num_joint_iterations);
      if (!status.ok()) return status;
      if (interrupt.IsStopped()) return Status::Cancelled();
    }
    if (priors == nullptr || priors->empty()) {
      reconstruction->Normalize();
    } else {
      step_frame_to_priors(gauges);
    }
    first_round = false;
    swept_image_ids.clear();
    if (!left_out.empty()) {
      swept_image_ids = image_ids;
      swept_gauges = gauges;
    }

    // Filter with a tightening threshold. If few tracks change, tighten
    // without another solve; another round only runs when the filter removed
    // enough to make re-solving worthwhile (the 0.1 % rule counts tracks
    // touched, cumulatively over the levels tried after this round's solve).
    const size_t num_tracks = reconstruction->NumPoints3D();
    size_t num_changed_tracks = 0;
    bool converged = false;
    for (;;) {
      num_changed_tracks += FilterAndCountChangedTracks(
          threshold_multiplier(level) * options.max_normalized_reproj_error,
          reconstruction);
      if (num_changed_tracks >
          options.min_changed_tracks_ratio * static_cast<double>(num_tracks)) {
        break;
      }
      if (level + 1 >= options.num_rounds) {
        converged = true;
        break;
      }
      ++level;
    }
    VLOG(3) << "Global BA round: " << num_fixed_rotation_iterations
            << " fixed-rotation + " << num_joint_iterations
            << " joint iterations, " << num_changed_tracks << " / "
            << num_tracks << " tracks changed, "
            << reconstruction->NumPoints3D() << " points, "
            << round_timer.ElapsedSeconds() << " s";
    if (on_round_done) on_round_done();
    if (converged) break;
  }

  if (!swept_image_ids.empty() && options.left_out_sweeps > 0) {
    const Status status = SweepAllObservations(
        options, ba_options, swept_image_ids, swept_gauges, priors,
        refinement_options, reconstruction, interrupt);
    if (!status.ok()) return status;
  }
  FilterObservationsByNormalizedReprojectionError(
      reconstruction, options.max_normalized_reproj_error);
  FilterPointsByTriangulationAngle(reconstruction, options.min_tri_angle_deg);
  return Status::Ok();
}

Status RefineImagesWithPointsFixed(
    const GlobalBundleAdjustmentOptions& options,
    const std::vector<colmap::image_t>& image_ids,
    colmap::Reconstruction* reconstruction, const Interrupt& interrupt) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid global bundle adjustment options: " +
                         check.message());
  }
  {
    std::set<colmap::camera_t> camera_ids;
    for (const colmap::image_t image_id : image_ids) {
      if (!camera_ids.insert(reconstruction->Image(image_id).CameraId())
               .second) {
        return Status::Error(
            "Refining images with the points fixed needs a camera per image.");
      }
    }
  }
  const colmap::BundleAdjustmentOptions ba_options =
      ColmapOptions(options, /*callback=*/nullptr);
  const colmap::Reconstruction& points = *reconstruction;
  // One resection with self-calibration; parameters in `held` constant.
  const auto refine = [&](colmap::Image* image, colmap::Camera* camera,
                          const std::vector<int>& held) {
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    const std::unique_ptr<ceres::LossFunction> loss_function(
        ba_options.CreateLossFunction());
    image->NormalizeQvec();
    PoseBlock pose = ToPoseBlock(*image);
    // Copies of the points: the blocks are held, and the model's points are
    // shared by the images refined in parallel.
    std::vector<std::array<double, 3>> xyzs;
    xyzs.reserve(image->NumPoints3D());
    for (const colmap::Point2D& point2D : image->Points2D()) {
      if (!point2D.HasPoint3D()) continue;
      const Eigen::Vector3d& xyz = points.Point3D(point2D.Point3DId()).XYZ();
      xyzs.push_back({xyz.x(), xyz.y(), xyz.z()});
      problem.AddResidualBlock(NewPoseCostFunction(*camera, point2D.XY()),
                               loss_function.get(), pose.data(),
                               xyzs.back().data(), camera->ParamsData());
      problem.SetParameterBlockConstant(xyzs.back().data());
    }
    if (problem.NumResiduals() == 0) return;
    problem.SetManifold(pose.data(), NewPoseAboutCenterManifold());
    SetUpCameraBlock(options, ba_options, camera, &problem, held);
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_num_iterations;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    FromPoseBlock(pose, image);
  };
  ParallelFor(options.num_threads, image_ids.size(), [&](size_t i) {
    if (interrupt.IsStopped()) return;
    colmap::Image& image = reconstruction->Image(image_ids[i]);
    colmap::Camera& camera = reconstruction->Camera(image.CameraId());
    std::vector<int> held;
    const std::vector<std::pair<double, double>> bounds =
        options.bound_intrinsics ? IntrinsicsBounds(camera)
                                 : std::vector<std::pair<double, double>>();
    refine(&image, &camera, held);
    // Parameters beyond their bounds are clamped and held, and the image
    // refined again (as in the bundle adjustment's solves; at VLOG 2 only:
    // a refit is a trial, its camera is kept only if the group splits).
    std::ostringstream clamped;
    if (ClampToBounds(bounds, &camera, &held, &clamped) > 0) {
      VLOG(2) << "Refit of image " << image.ImageId() << ": " << clamped.str();
      refine(&image, &camera, held);
    }
  });
  if (interrupt.IsStopped()) return Status::Cancelled();
  return Status::Ok();
}

}  // namespace glomap
