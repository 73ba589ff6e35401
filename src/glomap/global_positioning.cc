#include "glomap/global_positioning.h"

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <unordered_map>
#include <vector>

#include "base/camera.h"
#include "base/image.h"
#include "glomap/ceres_interrupt.h"
#include "glomap/ceres_threads.h"
#include "glomap/options_check.h"
#include "glomap/track_filters.h"
#include "util/timer.h"

namespace glomap {
namespace {

// r = v - d (X - c) with the unit observed ray v in world coordinates (paper
// Eq. 5). Parameter blocks: camera centre c, point X, scale d. Analytic
// Jacobians: the residual is bilinear, so this is exact and cheap.
class RayResidual : public ceres::SizedCostFunction<3, 3, 3, 1> {
 public:
  explicit RayResidual(const Eigen::Vector3d& ray_in_world)
      : ray_in_world_(ray_in_world) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* center = parameters[0];
    const double* point = parameters[1];
    const double scale = parameters[2][0];
    const double diff[3] = {point[0] - center[0], point[1] - center[1],
                            point[2] - center[2]};
    for (int i = 0; i < 3; ++i) {
      residuals[i] = ray_in_world_[i] - scale * diff[i];
    }
    if (jacobians == nullptr) return true;
    for (int block = 0; block < 2; ++block) {
      if (jacobians[block] == nullptr) continue;
      // d r / d c = d I, d r / d X = -d I (row-major 3x3).
      const double value = block == 0 ? scale : -scale;
      double* jacobian = jacobians[block];
      for (int i = 0; i < 9; ++i) jacobian[i] = 0;
      jacobian[0] = jacobian[4] = jacobian[8] = value;
    }
    if (jacobians[2] != nullptr) {
      for (int i = 0; i < 3; ++i) jacobians[2][i] = -diff[i];
    }
    return true;
  }

 private:
  const Eigen::Vector3d ray_in_world_;
};

struct Observation {
  size_t image_idx;  // Into the sorted registered image ids.
  size_t point_idx;  // Into the problem's points.
  colmap::point2D_t point2D_idx;
};

bool AllFinite(const std::vector<Eigen::Vector3d>& vectors) {
  for (const Eigen::Vector3d& v : vectors) {
    if (!v.allFinite()) return false;
  }
  return true;
}

}  // namespace

Status GlobalPositioningOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("loss_scale", loss_scale, 0);
  check.AtLeast("max_num_iterations", max_num_iterations, 0);
  check.AtLeast("function_tolerance", function_tolerance, 0);
  check.GreaterThan("init_box_size", init_box_size, 0);
  check.GreaterThan("uncalibrated_weight", uncalibrated_weight, 0);
  check.AtLeast("max_num_images_eigen_sparse", max_num_images_eigen_sparse, 0);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  check.AtLeast("min_residuals_per_ceres_thread",
                min_residuals_per_ceres_thread, 1);
  check.GreaterThan("min_scale", min_scale, 0);
  check.GreaterThan("max_angular_error_deg", max_angular_error_deg, 0);
  check.GreaterThan("uncalibrated_angular_error_factor",
                    uncalibrated_angular_error_factor, 0);
  check.AtLeast("min_tri_angle_deg", min_tri_angle_deg, 0);
  check.InRange("min_inlier_observation_ratio", min_inlier_observation_ratio, 0,
                1);
  return check.status();
}

Status RunGlobalPositioning(const GlobalPositioningOptions& options,
                            const TrackStore& tracks,
                            colmap::Reconstruction* reconstruction,
                            const Interrupt& interrupt) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid global positioning options: " +
                         check.message());
  }
  colmap::Timer timer;
  timer.Start();

  std::vector<colmap::image_t> image_ids = reconstruction->RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  std::unordered_map<colmap::image_t, size_t> image_idx_of_id;
  std::vector<Eigen::Matrix3d> world_from_cam_rotations(image_ids.size());
  for (size_t i = 0; i < image_ids.size(); ++i) {
    image_idx_of_id[image_ids[i]] = i;
    world_from_cam_rotations[i] =
        reconstruction->Image(image_ids[i]).RotationMatrix().transpose();
  }

  // Observations of the usable tracks: registered images only, one per image,
  // at least two per track.
  std::vector<Observation> observations;
  observations.reserve(tracks.NumObservations());
  std::vector<size_t> point_offsets = {0};
  std::vector<size_t> num_observations_per_image(image_ids.size(), 0);
  for (size_t track_idx = 0; track_idx < tracks.NumTracks(); ++track_idx) {
    const size_t begin = observations.size();
    for (const TrackObservation* obs = tracks.TrackBegin(track_idx);
         obs != tracks.TrackEnd(track_idx); ++obs) {
      const auto image_idx = image_idx_of_id.find(obs->image_id);
      if (image_idx == image_idx_of_id.end()) continue;
      if (obs->point2D_idx >=
          reconstruction->Image(obs->image_id).NumPoints2D()) {
        continue;
      }
      bool is_duplicate = false;
      for (size_t k = begin; k < observations.size(); ++k) {
        is_duplicate |= observations[k].image_idx == image_idx->second;
      }
      if (is_duplicate) continue;
      observations.push_back(
          {image_idx->second, point_offsets.size() - 1, obs->point2D_idx});
    }
    if (observations.size() - begin < 2) {
      observations.resize(begin);
      continue;
    }
    point_offsets.push_back(observations.size());
  }
  const size_t num_points = point_offsets.size() - 1;
  for (const Observation& obs : observations) {
    ++num_observations_per_image[obs.image_idx];
  }
  size_t num_problem_images = 0;
  for (const size_t count : num_observations_per_image) {
    num_problem_images += count > 0;
  }
  if (num_points == 0 || num_problem_images < 2) {
    return Status::Error(
        "Global positioning: no tracks with two or more registered images.");
  }

  // Random start (seeded; images and tracks in a fixed order).
  std::mt19937 rng(options.random_seed);
  std::uniform_real_distribution<double> uniform(-options.init_box_size,
                                                 options.init_box_size);
  auto random_vector = [&]() {
    const double x = uniform(rng);
    const double y = uniform(rng);
    const double z = uniform(rng);
    return Eigen::Vector3d(x, y, z);
  };
  std::vector<Eigen::Vector3d> centers(image_ids.size());
  for (size_t i = 0; i < image_ids.size(); ++i) {
    centers[i] = options.optimize_positions
                     ? random_vector()
                     : reconstruction->Image(image_ids[i]).ProjectionCenter();
  }
  std::vector<Eigen::Vector3d> points(num_points);
  for (Eigen::Vector3d& point : points) point = random_vector();
  std::vector<double> scales(observations.size(), 1.0);

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss calibrated_loss(options.loss_scale);
  ceres::ScaledLoss uncalibrated_loss(&calibrated_loss,
                                      options.uncalibrated_weight,
                                      ceres::DO_NOT_TAKE_OWNERSHIP);
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& obs = observations[k];
    const colmap::Image& image =
        reconstruction->Image(image_ids[obs.image_idx]);
    const colmap::Camera& camera = reconstruction->Camera(image.CameraId());
    const Eigen::Vector3d ray_in_world =
        world_from_cam_rotations[obs.image_idx] *
        camera.ImageToWorld(image.Point2D(obs.point2D_idx).XY())
            .homogeneous()
            .normalized();
    problem.AddResidualBlock(
        new RayResidual(ray_in_world),
        camera.HasPriorFocalLength()
            ? static_cast<ceres::LossFunction*>(&calibrated_loss)
            : &uncalibrated_loss,
        centers[obs.image_idx].data(), points[obs.point_idx].data(),
        &scales[k]);
  }

  // Gauge: the problem is invariant to translation (left to the damping) and
  // to scale, fixed by holding one scale at 1.
  for (size_t k = 0; k < scales.size(); ++k) {
    if (!options.optimize_scales || k == 0) {
      problem.SetParameterBlockConstant(&scales[k]);
    } else {
      problem.SetParameterLowerBound(&scales[k], 0, options.min_scale);
    }
  }
  if (!options.optimize_points) {
    for (Eigen::Vector3d& point : points) {
      problem.SetParameterBlockConstant(point.data());
    }
  }
  for (size_t i = 0; i < image_ids.size(); ++i) {
    if (num_observations_per_image[i] > 0 && !options.optimize_positions) {
      problem.SetParameterBlockConstant(centers[i].data());
    }
  }

  // Schur elimination order: scales (each in one residual), points, centres
  // (as the reference).
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (double& scale : scales) ordering->AddElementToGroup(&scale, 0);
  for (Eigen::Vector3d& point : points) {
    ordering->AddElementToGroup(point.data(), 1);
  }
  for (size_t i = 0; i < image_ids.size(); ++i) {
    if (num_observations_per_image[i] > 0) {
      ordering->AddElementToGroup(centers[i].data(), 2);
    }
  }

  ceres::Solver::Options solver_options;
  if (static_cast<int>(num_problem_images) <
      options.max_num_images_eigen_sparse) {
    // Measured on 40 and 200 images: Eigen's simplicial Cholesky on the full
    // normal equations (its AMD ordering eliminates the scales, then the
    // points, like the Schur complement) beats CHOLMOD behind SPARSE_SCHUR by
    // 1.5-3x, whose supernodal overhead does not pay off at this size.
    solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  } else {
    solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
    solver_options.linear_solver_ordering = ordering;
  }
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads =
      CeresNumThreads(options.num_threads, problem.NumResidualBlocks(),
                      options.min_residuals_per_ceres_thread);
  solver_options.logging_type = ceres::SILENT;
  InterruptCallback interrupt_callback(interrupt);
  solver_options.callbacks.push_back(&interrupt_callback);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  if (interrupt.IsStopped()) return Status::Cancelled();
  if (!summary.IsSolutionUsable()) {
    return Status::Error("Global positioning: solver failed: " +
                         summary.message);
  }
  if (!AllFinite(centers) || !AllFinite(points)) {
    return Status::Error("Global positioning: non-finite solution.");
  }

  // Write the result: poses, then one point per track.
  for (size_t i = 0; i < image_ids.size(); ++i) {
    if (num_observations_per_image[i] == 0) continue;
    colmap::Image& image = reconstruction->Image(image_ids[i]);
    image.SetTvec(-(world_from_cam_rotations[i].transpose() * centers[i]));
  }
  DeleteAllPoints3D(reconstruction);
  size_t num_added_observations = 0;
  for (size_t point_idx = 0; point_idx < num_points; ++point_idx) {
    colmap::Track track;
    for (size_t k = point_offsets[point_idx]; k < point_offsets[point_idx + 1];
         ++k) {
      const colmap::image_t image_id = image_ids[observations[k].image_idx];
      // A caller's TrackStore could reuse a keypoint in two tracks; COLMAP
      // would abort on that, so the later track loses the observation.
      if (reconstruction->Image(image_id)
              .Point2D(observations[k].point2D_idx)
              .HasPoint3D()) {
        continue;
      }
      track.AddElement(image_id, observations[k].point2D_idx);
    }
    if (track.Length() < 2) continue;
    num_added_observations += track.Length();
    reconstruction->AddPoint3D(points[point_idx], std::move(track));
  }

  const size_t num_angular_outliers = FilterObservationsByAngularError(
      reconstruction, options.max_angular_error_deg,
      options.uncalibrated_angular_error_factor *
          options.max_angular_error_deg);
  const size_t num_small_angle_points = FilterPointsByTriangulationAngle(
      reconstruction, options.min_tri_angle_deg);
  const double inlier_ratio =
      num_added_observations == 0
          ? 0.0
          : 1.0 - static_cast<double>(num_angular_outliers) /
                      num_added_observations;

  size_t num_deregistered = 0;
  for (const colmap::image_t image_id : image_ids) {
    if (reconstruction->Image(image_id).NumPoints3D() == 0) {
      reconstruction->DeRegisterImage(image_id);
      ++num_deregistered;
    }
  }

  LOG(INFO) << "Global positioning: " << num_problem_images << " images, "
            << num_points << " points, " << observations.size()
            << " observations, " << summary.iterations.size() << " iterations ("
            << ceres::TerminationTypeToString(summary.termination_type)
            << "), cost " << summary.initial_cost << " -> "
            << summary.final_cost << "; filtered " << num_angular_outliers
            << " observations by angle, " << num_small_angle_points
            << " points by triangulation angle; " << num_deregistered
            << " images without points deregistered; " << timer.ElapsedSeconds()
            << " s";

  if (inlier_ratio < options.min_inlier_observation_ratio ||
      reconstruction->NumRegImages() < 2 ||
      reconstruction->NumPoints3D() == 0) {
    return Status::Error(
        "Global positioning: degenerate solution (only " +
        std::to_string(static_cast<int>(100 * inlier_ratio)) +
        "% of the observations agree with the points; cameras likely stuck "
        "near the random start).");
  }
  reconstruction->Normalize();
  return Status::Ok();
}

}  // namespace glomap
