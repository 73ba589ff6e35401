#include "glomap/estimators/global_positioning.h"

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <unordered_map>
#include <vector>

#include "base/camera.h"
#include "base/image.h"
#include "base/pose.h"
#include "glomap/estimators/cost_functions/ray_residual.h"
#include "glomap/processors/track_filters.h"
#include "glomap/util/ceres_interrupt.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/options_check.h"
#include "util/timer.h"

namespace glomap {
namespace {

// Floor of the ray noise that weights the prior term (radians, 1e-3 px at
// f = 1000 px): noise-free rays would otherwise give the priors no weight at
// all, and the solve no gauge.
constexpr double kMinRayNoise = 1e-6;

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

// (c - p) / std on a camera centre c with prior p (issue 12); linear, so the
// analytic Jacobian is exact.
class CenterPriorResidual : public ceres::SizedCostFunction<3, 3> {
 public:
  CenterPriorResidual(const Eigen::Vector3d& prior, double std_m)
      : prior_(prior), inv_std_(1 / std_m) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (int i = 0; i < 3; ++i) {
      residuals[i] = inv_std_ * (parameters[0][i] - prior_[i]);
    }
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      for (int i = 0; i < 9; ++i) jacobians[0][i] = 0;
      jacobians[0][0] = jacobians[0][4] = jacobians[0][8] = inv_std_;
    }
    return true;
  }

 private:
  const Eigen::Vector3d prior_;
  const double inv_std_;
};

// What the solve reads: the observations and their unit rays in world
// coordinates.
struct PositioningData {
  const std::vector<Observation>& observations;
  const std::vector<size_t>& num_observations_per_image;
  std::vector<Eigen::Vector3d> rays_in_world;
  // Whether the observation's camera has a prior focal length.
  std::vector<bool> calibrated;
};

// The unknowns: one centre per registered image (in image-id order), one
// point per usable track, one scale per observation.
struct PositioningState {
  std::vector<Eigen::Vector3d> centers;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> scales;
};

// Position priors of the images of the problem: (index into the sorted
// registered images, prior centre), with their weights: the residual
// (c - p) / std_m under a Cauchy loss of scale loss_scale_std, the cost
// multiplied by weight.
struct PriorResiduals {
  const std::vector<std::pair<size_t, Eigen::Vector3d>>& image_priors;
  double std_m;
  double loss_scale_std;
  double weight;
};

// Median over the observations of the ray residual's norm |v - d (X - c)|
// at the current state, divided by its median for an isotropic Gaussian
// error of one unit per axis across the ray (sqrt(2 ln 2)): the ray
// residuals' noise per axis, robust to the wrong matches.
double RayNoisePerAxis(const PositioningData& data,
                       const PositioningState& state) {
  std::vector<double> norms;
  norms.reserve(data.observations.size());
  for (size_t k = 0; k < data.observations.size(); ++k) {
    const Observation& obs = data.observations[k];
    norms.push_back((data.rays_in_world[k] -
                     state.scales[k] * (state.points[obs.point_idx] -
                                        state.centers[obs.image_idx]))
                        .norm());
  }
  if (norms.empty()) return 0;
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2,
                   norms.end());
  return norms[norms.size() / 2] / std::sqrt(2 * std::log(2.0));
}

// Every scale at its best value for the current centres and points
// (BestRayScale).
void SetBestScales(const PositioningData& data, double min_scale,
                   PositioningState* state) {
  state->scales.resize(data.observations.size());
  for (size_t k = 0; k < data.observations.size(); ++k) {
    const Observation& obs = data.observations[k];
    state->scales[k] = BestRayScale(
        data.rays_in_world[k],
        state->points[obs.point_idx] - state->centers[obs.image_idx],
        min_scale);
  }
}

// The start of the joint solve from given centres (state->centers): each
// point where its rays pass closest (the least-squares point of the rays), or,
// when the rays are near parallel or the point would lie behind one of its
// cameras, on its first ray at the median depth of the points that could be
// placed; each scale at its best value for these (BestRayScale). Observation
// 0's scale, which the free solve holds fixed as the gauge, is kept away from
// its lower bound.
void TriangulateStart(const PositioningData& data,
                      const std::vector<size_t>& point_offsets,
                      double min_scale, PositioningState* state) {
  const size_t num_points = point_offsets.size() - 1;
  state->points.assign(num_points, Eigen::Vector3d::Zero());
  std::vector<bool> triangulated(num_points, false);
  std::vector<double> depths;
  for (size_t p = 0; p < num_points; ++p) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (size_t k = point_offsets[p]; k < point_offsets[p + 1]; ++k) {
      const Eigen::Vector3d& ray = data.rays_in_world[k];
      const Eigen::Matrix3d across =
          Eigen::Matrix3d::Identity() - ray * ray.transpose();
      normal += across;
      rhs += across * state->centers[data.observations[k].image_idx];
    }
    // Rays within about 1 deg of each other fix no depth.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal);
    const size_t num_rays = point_offsets[p + 1] - point_offsets[p];
    if (eigen.eigenvalues()(0) < 1e-4 * num_rays) continue;
    const Eigen::Vector3d point = normal.ldlt().solve(rhs);
    bool in_front = point.allFinite();
    for (size_t k = point_offsets[p]; in_front && k < point_offsets[p + 1];
         ++k) {
      in_front =
          data.rays_in_world[k].dot(
              point - state->centers[data.observations[k].image_idx]) > 0;
    }
    if (!in_front) continue;
    state->points[p] = point;
    triangulated[p] = true;
    const size_t first = point_offsets[p];
    depths.push_back(
        (point - state->centers[data.observations[first].image_idx]).norm());
  }
  double median_depth = 1;
  if (!depths.empty()) {
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2,
                     depths.end());
    if (depths[depths.size() / 2] > 0) median_depth = depths[depths.size() / 2];
  }
  for (size_t p = 0; p < num_points; ++p) {
    if (triangulated[p]) continue;
    const size_t first = point_offsets[p];
    state->points[p] = state->centers[data.observations[first].image_idx] +
                       median_depth * data.rays_in_world[first];
  }
  SetBestScales(data, min_scale, state);
  if (!state->scales.empty() && state->scales[0] <= 2 * min_scale) {
    state->scales[0] = 1 / median_depth;
  }
}

// Stops a solve at one iteration if its cost is not below a bound then
// (GlobalPositioningOptions::random_start_check_iterations).
class StopIfBehind : public ceres::IterationCallback {
 public:
  StopIfBehind(int check_iteration, double cost_to_beat)
      : check_iteration_(check_iteration), cost_to_beat_(cost_to_beat) {}

  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& summary) override {
    if (summary.iteration == check_iteration_ &&
        summary.cost >= cost_to_beat_) {
      stopped_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }

  bool stopped() const { return stopped_; }

 private:
  const int check_iteration_;
  const double cost_to_beat_;
  bool stopped_ = false;
};

// One Levenberg-Marquardt solve of the positioning problem from `state`.
// Without priors the gauge (translation left to the damping, scale fixed by
// one scale at 1) is as in the reference; with them the priors fix it, and
// every scale is free. `stop_if_behind`, if not null, may end the solve
// early.
Status SolvePositions(const GlobalPositioningOptions& options,
                      const PositioningData& data, const PriorResiduals* priors,
                      const Interrupt& interrupt, PositioningState* state,
                      ceres::Solver::Summary* summary,
                      StopIfBehind* stop_if_behind = nullptr) {
  const std::vector<Observation>& observations = data.observations;
  std::vector<Eigen::Vector3d>& centers = state->centers;
  std::vector<Eigen::Vector3d>& points = state->points;
  std::vector<double>& scales = state->scales;

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss calibrated_loss(options.loss_scale);
  ceres::ScaledLoss uncalibrated_loss(&calibrated_loss,
                                      options.uncalibrated_weight,
                                      ceres::DO_NOT_TAKE_OWNERSHIP);
  const bool project_out_scales =
      options.project_out_scales && options.optimize_scales;
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& obs = observations[k];
    ceres::LossFunction* loss =
        data.calibrated[k] ? static_cast<ceres::LossFunction*>(&calibrated_loss)
                           : &uncalibrated_loss;
    if (project_out_scales) {
      problem.AddResidualBlock(
          new ProjectedRayResidual(data.rays_in_world[k], options.min_scale),
          loss, centers[obs.image_idx].data(), points[obs.point_idx].data());
    } else {
      problem.AddResidualBlock(new RayResidual(data.rays_in_world[k]), loss,
                               centers[obs.image_idx].data(),
                               points[obs.point_idx].data(), &scales[k]);
    }
  }
  std::unique_ptr<ceres::LossFunction> prior_loss;
  if (priors != nullptr) {
    prior_loss = std::make_unique<ceres::ScaledLoss>(
        new ceres::CauchyLoss(priors->loss_scale_std), priors->weight,
        ceres::TAKE_OWNERSHIP);
    for (const auto& [image_idx, prior] : priors->image_priors) {
      problem.AddResidualBlock(new CenterPriorResidual(prior, priors->std_m),
                               prior_loss.get(), centers[image_idx].data());
    }
  }

  // Gauge: the problem is invariant to translation (left to the damping) and
  // to scale, fixed by holding one scale at 1 (with the scales projected out,
  // left to the damping too); priors fix both.
  for (size_t k = 0; k < scales.size() && !project_out_scales; ++k) {
    if (!options.optimize_scales || (k == 0 && priors == nullptr)) {
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
  size_t num_problem_images = 0;
  for (size_t i = 0; i < centers.size(); ++i) {
    if (data.num_observations_per_image[i] == 0) continue;
    ++num_problem_images;
    if (!options.optimize_positions) {
      problem.SetParameterBlockConstant(centers[i].data());
    }
  }

  // Schur elimination order: scales (each in one residual), points, centres
  // (as the reference).
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  // Without scale unknowns: points, centres.
  int group = 0;
  if (!project_out_scales) {
    for (double& scale : scales) ordering->AddElementToGroup(&scale, group);
    ++group;
  }
  for (Eigen::Vector3d& point : points) {
    ordering->AddElementToGroup(point.data(), group);
  }
  ++group;
  for (size_t i = 0; i < centers.size(); ++i) {
    if (data.num_observations_per_image[i] > 0) {
      ordering->AddElementToGroup(centers[i].data(), group);
    }
  }

  ceres::Solver::Options solver_options;
  if (static_cast<int>(num_problem_images) <
      options.max_num_images_eigen_sparse) {
    // Measured on 40 and 200 images: Eigen's simplicial Cholesky on the full
    // normal equations (its AMD ordering eliminates the scales, then the
    // points, like the Schur complement) beats CHOLMOD behind SPARSE_SCHUR by
    // 1.5-3x, whose supernodal overhead does not pay off at this size. With
    // the scales projected out it still does on a 500-image street (5.5 s
    // against 7.7 s; a dense Schur complement 7.5 s).
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
  if (stop_if_behind != nullptr) {
    solver_options.callbacks.push_back(stop_if_behind);
  }
  ceres::Solve(solver_options, &problem, summary);

  if (interrupt.IsStopped()) return Status::Cancelled();
  if (!summary->IsSolutionUsable()) {
    return Status::Error("Global positioning: solver failed: " +
                         summary->message);
  }
  if (!AllFinite(centers) || !AllFinite(points)) {
    return Status::Error("Global positioning: non-finite solution.");
  }
  if (project_out_scales) SetBestScales(data, options.min_scale, state);
  return Status::Ok();
}

// The positioning problem: the registered images (in id order) with their
// rotations, and the usable tracks' observations (registered images only,
// one per image, at least two per track; point k's observations are
// [point_offsets[k], point_offsets[k + 1])).
struct PositioningProblem {
  std::vector<colmap::image_t> image_ids;
  std::vector<Eigen::Matrix3d> world_from_cam_rotations;
  std::vector<Observation> observations;
  std::vector<size_t> point_offsets = {0};
  std::vector<size_t> num_observations_per_image;

  size_t NumPoints() const { return point_offsets.size() - 1; }
  size_t NumProblemImages() const {
    size_t num_images = 0;
    for (const size_t count : num_observations_per_image) {
      num_images += count > 0;
    }
    return num_images;
  }
};

// Set-up: the problem of `tracks` on `reconstruction`'s registered images.
Status SetUpProblem(const TrackStore& tracks,
                    const colmap::Reconstruction& reconstruction,
                    PositioningProblem* problem) {
  problem->image_ids = reconstruction.RegImageIds();
  std::vector<colmap::image_t>& image_ids = problem->image_ids;
  std::sort(image_ids.begin(), image_ids.end());
  std::unordered_map<colmap::image_t, size_t> image_idx_of_id;
  problem->world_from_cam_rotations.resize(image_ids.size());
  for (size_t i = 0; i < image_ids.size(); ++i) {
    image_idx_of_id[image_ids[i]] = i;
    problem->world_from_cam_rotations[i] =
        reconstruction.Image(image_ids[i]).RotationMatrix().transpose();
  }
  std::vector<Observation>& observations = problem->observations;
  std::vector<size_t>& point_offsets = problem->point_offsets;
  observations.reserve(tracks.NumObservations());
  for (size_t track_idx = 0; track_idx < tracks.NumTracks(); ++track_idx) {
    const size_t begin = observations.size();
    for (const TrackObservation* obs = tracks.TrackBegin(track_idx);
         obs != tracks.TrackEnd(track_idx); ++obs) {
      const auto image_idx = image_idx_of_id.find(obs->image_id);
      if (image_idx == image_idx_of_id.end()) continue;
      if (obs->point2D_idx >=
          reconstruction.Image(obs->image_id).NumPoints2D()) {
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
  problem->num_observations_per_image.assign(image_ids.size(), 0);
  for (const Observation& obs : observations) {
    ++problem->num_observations_per_image[obs.image_idx];
  }
  if (problem->NumPoints() == 0 || problem->NumProblemImages() < 2) {
    return Status::Error(
        "Global positioning: no tracks with two or more registered images.");
  }
  return Status::Ok();
}

// The observations' rays in the world frame, and whether each camera has a
// prior focal length.
PositioningData MakeRays(const PositioningProblem& problem,
                         const colmap::Reconstruction& reconstruction) {
  PositioningData data{
      problem.observations, problem.num_observations_per_image, {}, {}};
  data.rays_in_world.reserve(problem.observations.size());
  data.calibrated.reserve(problem.observations.size());
  for (const Observation& obs : problem.observations) {
    const colmap::Image& image =
        reconstruction.Image(problem.image_ids[obs.image_idx]);
    const colmap::Camera& camera = reconstruction.Camera(image.CameraId());
    data.rays_in_world.push_back(
        problem.world_from_cam_rotations[obs.image_idx] *
        camera.ImageToWorld(image.Point2D(obs.point2D_idx).XY())
            .homogeneous()
            .normalized());
    data.calibrated.push_back(camera.HasPriorFocalLength());
  }
  return data;
}

// The paper's random start (seeded; images and tracks in a fixed order);
// centres held fixed keep the images' poses.
PositioningState RandomStart(const GlobalPositioningOptions& options,
                             const PositioningProblem& problem,
                             const colmap::Reconstruction& reconstruction) {
  std::mt19937 rng(options.random_seed);
  std::uniform_real_distribution<double> uniform(-options.init_box_size,
                                                 options.init_box_size);
  auto random_vector = [&]() {
    const double x = uniform(rng);
    const double y = uniform(rng);
    const double z = uniform(rng);
    return Eigen::Vector3d(x, y, z);
  };
  PositioningState state;
  state.centers.resize(problem.image_ids.size());
  for (size_t i = 0; i < problem.image_ids.size(); ++i) {
    state.centers[i] =
        options.optimize_positions
            ? random_vector()
            : reconstruction.Image(problem.image_ids[i]).ProjectionCenter();
  }
  state.points.resize(problem.NumPoints());
  for (Eigen::Vector3d& point : state.points) point = random_vector();
  state.scales.assign(problem.observations.size(), 1.0);
  return state;
}

// `options` for a solve from the random start: the scales stay unknowns of
// the solve (project_out_scales false). Projected out, the objective is the
// sine of each ray's angle, whose minima are the same but which gathers the
// cameras out of the random box far more slowly: on a 500-image street the
// random start reached cost 41 in 101 iterations with the scales projected
// out, 1.68 with them as unknowns (from the image centres both converge to
// the same cost, projected in 9 iterations instead of 101).
GlobalPositioningOptions WithScaleUnknowns(GlobalPositioningOptions options) {
  options.project_out_scales = false;
  return options;
}

// The free solve (without priors): from the images' centres
// (start_from_image_centers) or the random start. A solve from the centres,
// stopped at its iteration cap or (in small problems, where the random
// solve is cheap) converged, may be in a worse minimum of the same
// objective than the random start reaches (measured on dino-363, where many
// pairs' directions are wrong): the random start is solved too and the
// lower cost kept. Both minimise the same cost, so the comparison is fair;
// the random solve is the one a run without position initialization makes
// (same seed, same draws), unless it is stopped while still behind
// (random_start_check_iterations; a solve stopped there would not be kept
// anyway, its cost being above).
Status SolveFree(const GlobalPositioningOptions& options,
                 const PositioningProblem& problem, const PositioningData& data,
                 const colmap::Reconstruction& reconstruction,
                 const Interrupt& interrupt, PositioningState* state,
                 ceres::Solver::Summary* summary,
                 GlobalPositioningSummary* positioning_summary) {
  if (options.start_from_image_centers) {
    state->centers.resize(problem.image_ids.size());
    for (size_t i = 0; i < problem.image_ids.size(); ++i) {
      state->centers[i] =
          reconstruction.Image(problem.image_ids[i]).ProjectionCenter();
    }
    TriangulateStart(data, problem.point_offsets, options.min_scale, state);
  } else {
    *state = RandomStart(options, problem, reconstruction);
  }
  if (const Status status = SolvePositions(
          options.start_from_image_centers ? options
                                           : WithScaleUnknowns(options),
          data, nullptr, interrupt, state, summary);
      !status.ok()) {
    return status;
  }
  positioning_summary->kept_random_start = !options.start_from_image_centers;
  if (options.start_from_image_centers &&
      options.random_start_unless_converged &&
      (summary->termination_type != ceres::CONVERGENCE ||
       problem.NumProblemImages() <=
           static_cast<size_t>(options.random_start_max_num_images))) {
    PositioningState random_state =
        RandomStart(options, problem, reconstruction);
    ceres::Solver::Summary random_summary;
    std::unique_ptr<StopIfBehind> stop_if_behind;
    if (options.random_start_check_iterations > 0) {
      stop_if_behind = std::make_unique<StopIfBehind>(
          options.random_start_check_iterations, summary->final_cost);
    }
    if (const Status status = SolvePositions(
            WithScaleUnknowns(options), data, nullptr, interrupt, &random_state,
            &random_summary, stop_if_behind.get());
        !status.ok()) {
      return status;
    }
    const bool stopped_early =
        stop_if_behind != nullptr && stop_if_behind->stopped();
    const bool keep_random =
        !stopped_early && random_summary.final_cost < summary->final_cost;
    // The usual outcome (the centres' solution kept) is a detail; the other
    // is worth a line in the default log.
    LOG_IF(INFO, keep_random || VLOG_IS_ON(3))
        << "Global positioning: from the image centres "
        << summary->iterations.size() << " iterations ("
        << ceres::TerminationTypeToString(summary->termination_type)
        << "), cost " << summary->final_cost << "; from the random start "
        << random_summary.iterations.size() << " iterations ("
        << (stopped_early ? "stopped, still behind"
                          : ceres::TerminationTypeToString(
                                random_summary.termination_type))
        << "), cost " << random_summary.final_cost << "; kept the "
        << (keep_random ? "random" : "image-centre") << " start's solution.";
    positioning_summary->other_start_cost =
        keep_random ? summary->final_cost : random_summary.final_cost;
    positioning_summary->random_start_stopped_early = stopped_early;
    positioning_summary->kept_random_start = keep_random;
    if (keep_random) {
      *state = std::move(random_state);
      *summary = random_summary;
    }
  }
  positioning_summary->free_solve_cost = summary->final_cost;
  return Status::Ok();
}

// With priors: the free solution into the prior frame by a robust
// similarity, then solved again from there with the prior term (issue 12).
// The free solve is what makes global positioning robust; the second solve
// starts at its solution, so it only has to bend it where the priors
// disagree with the rays (scale drift, a bent trajectory), which no
// similarity can do. Where no similarity is found the priors are not used
// (a warning; georegistered stays false). `free_solve` is for the log.
Status SolveWithPriors(const GlobalPositioningOptions& options,
                       const PositionPriorTerm& priors,
                       const ceres::Solver::Summary& free_solve,
                       const Interrupt& interrupt, PositioningProblem* problem,
                       PositioningData* data, PositioningState* state,
                       colmap::Reconstruction* reconstruction,
                       GlobalPositioningSummary* positioning_summary) {
  const std::vector<colmap::image_t>& image_ids = problem->image_ids;
  std::unordered_map<colmap::image_t, Eigen::Vector3d> problem_centers;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    if (problem->num_observations_per_image[i] > 0) {
      problem_centers[image_ids[i]] = state->centers[i];
    }
  }
  PriorAlignment alignment;
  const Status aligned =
      AlignCentersToPriors(problem_centers, priors.center_in_frame,
                           priors.MaxErrorM(), options.random_seed, &alignment);
  if (!aligned.ok()) {
    LOG(WARNING) << aligned.message()
                 << " The position priors are not used: the model stays in "
                    "an arbitrary frame.";
    return Status::Ok();
  }
  positioning_summary->georegistered = true;
  // x' = s R x + t: rays turn with the frame, and d (X - c) keeps its
  // length with d' = d / s.
  for (Eigen::Vector3d& center : state->centers) {
    center = alignment.Apply(center);
  }
  for (Eigen::Vector3d& point : state->points) point = alignment.Apply(point);
  for (double& scale : state->scales) scale /= alignment.scale;
  for (Eigen::Vector3d& ray : data->rays_in_world) {
    ray = alignment.rotation * ray;
  }
  for (Eigen::Matrix3d& rotation : problem->world_from_cam_rotations) {
    rotation = alignment.rotation * rotation;
  }
  // Every registered image turns with the frame (those outside the problem
  // are deregistered later, but keep a consistent pose).
  for (size_t i = 0; i < image_ids.size(); ++i) {
    reconstruction->Image(image_ids[i])
        .SetQvec(colmap::RotationMatrixToQuaternion(
            problem->world_from_cam_rotations[i].transpose()));
  }
  // Every prior takes part, under the Cauchy loss: one that the alignment
  // found too far may be right where the free solution is bent, and a wrong
  // one pulls its camera with a bounded force against hundreds of rays.
  std::vector<std::pair<size_t, Eigen::Vector3d>> image_priors;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    const auto prior = priors.center_in_frame.find(image_ids[i]);
    if (problem->num_observations_per_image[i] > 0 &&
        prior != priors.center_in_frame.end()) {
      image_priors.emplace_back(i, prior->second);
    }
  }
  // The ray residual is about the angle between observed and predicted ray
  // (radians), with noise of about keypoint noise / focal length. Each term
  // counts in units of its own noise, as in bundle adjustment, so the prior
  // cost is weighted by the ray noise squared: with weight 1 the priors
  // (metres of noise) would outweigh the rays (a milliradian of noise) a
  // million times, and each camera would be pulled a good part of the prior
  // noise towards its prior, bending the rays beyond the angular filter
  // (measured on a forward sequence with 3 m prior noise: 87% of the
  // observations filtered).
  const double ray_noise =
      std::max(RayNoisePerAxis(*data, *state), kMinRayNoise);
  PriorResiduals prior_residuals{image_priors, priors.std_m,
                                 priors.loss_scale_std, ray_noise * ray_noise};
  ceres::Solver::Summary prior_solve;
  GlobalPositioningOptions prior_options = options;
  prior_options.max_num_iterations = options.prior_max_num_iterations;
  if (const Status status =
          SolvePositions(prior_options, *data, &prior_residuals, interrupt,
                         state, &prior_solve);
      !status.ok()) {
    return status;
  }
  LOG(INFO) << "Global positioning with position priors: aligned to "
            << alignment.inlier_image_ids.size() << " of "
            << alignment.inlier_image_ids.size() +
                   alignment.outlier_image_ids.size()
            << " priors within " << priors.MaxErrorM() << " m (scale "
            << alignment.scale << "), ray noise " << ray_noise << ", then "
            << prior_solve.iterations.size() << " iterations ("
            << ceres::TerminationTypeToString(prior_solve.termination_type)
            << ") with the prior term, cost " << prior_solve.initial_cost
            << " -> " << prior_solve.final_cost << ", "
            << prior_solve.total_time_in_seconds
            << " s (free solve: " << free_solve.iterations.size()
            << " iterations, " << free_solve.total_time_in_seconds << " s)";
  return Status::Ok();
}

// Conversion: the poses of the problem's images, then one point per track
// (in `reconstruction`, whose points are replaced). Returns the number of
// observations added.
size_t WriteSolution(const PositioningProblem& problem,
                     const PositioningState& state,
                     colmap::Reconstruction* reconstruction) {
  for (size_t i = 0; i < problem.image_ids.size(); ++i) {
    if (problem.num_observations_per_image[i] == 0) continue;
    colmap::Image& image = reconstruction->Image(problem.image_ids[i]);
    image.SetTvec(
        -(problem.world_from_cam_rotations[i].transpose() * state.centers[i]));
  }
  DeleteAllPoints3D(reconstruction);
  size_t num_added_observations = 0;
  for (size_t point_idx = 0; point_idx < problem.NumPoints(); ++point_idx) {
    colmap::Track track;
    for (size_t k = problem.point_offsets[point_idx];
         k < problem.point_offsets[point_idx + 1]; ++k) {
      const Observation& obs = problem.observations[k];
      const colmap::image_t image_id = problem.image_ids[obs.image_idx];
      // A caller's TrackStore could reuse a keypoint in two tracks; COLMAP
      // would abort on that, so the later track loses the observation.
      if (reconstruction->Image(image_id)
              .Point2D(obs.point2D_idx)
              .HasPoint3D()) {
        continue;
      }
      track.AddElement(image_id, obs.point2D_idx);
    }
    if (track.Length() < 2) continue;
    num_added_observations += track.Length();
    reconstruction->AddPoint3D(state.points[point_idx], std::move(track));
  }
  return num_added_observations;
}

// After the solve with priors: a prior still this far from its camera is
// wrong (or its camera is), and bundle adjustment leaves it out; when the
// others do not fix a similarity the model is left in the free frame rather
// than pinned to fewer priors than a similarity needs.
void JudgePriorsOnSolution(const PositionPriorTerm& priors,
                           const colmap::Reconstruction& reconstruction,
                           GlobalPositioningSummary* positioning_summary) {
  positioning_summary->rejected_image_ids = ImagesFartherFromPrior(
      reconstruction, priors.center_in_frame, priors.MaxErrorM());
  const std::vector<colmap::image_t>& rejected =
      positioning_summary->rejected_image_ids;
  std::vector<Eigen::Vector3d> used_priors;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    const auto prior = priors.center_in_frame.find(image_id);
    if (prior != priors.center_in_frame.end() &&
        !std::binary_search(rejected.begin(), rejected.end(), image_id)) {
      used_priors.push_back(prior->second);
    }
  }
  positioning_summary->num_priors_used = used_priors.size();
  if (!PriorsFixSimilarity(used_priors)) {
    // The alignment found three non-collinear priors that agree with the
    // cameras, so this takes a solve that moved cameras away from them.
    LOG(WARNING) << "Global positioning: only "
                 << positioning_summary->num_priors_used
                 << " position priors (or collinear ones) lie within "
                 << priors.MaxErrorM()
                 << " m of their camera: the priors are not used, the model "
                    "stays in an arbitrary frame.";
    positioning_summary->georegistered = false;
  }
}

}  // namespace

Status GlobalPositioningOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("loss_scale", loss_scale, 0);
  check.AtLeast("max_num_iterations", max_num_iterations, 0);
  check.AtLeast("prior_max_num_iterations", prior_max_num_iterations, 0);
  check.AtLeast("random_start_check_iterations", random_start_check_iterations,
                0);
  check.AtLeast("random_start_max_num_images", random_start_max_num_images, 0);
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
                            const Interrupt& interrupt,
                            const PositionPriorTerm* priors,
                            GlobalPositioningSummary* summary_out) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid global positioning options: " +
                         check.message());
  }
  const bool use_priors = priors != nullptr && !priors->empty();
  if (use_priors && !(priors->std_m > 0 && priors->loss_scale_std > 0 &&
                      priors->max_error_std > 0)) {
    return Status::Error(
        "Global positioning: the position priors' standard deviation, loss "
        "scale and rejection threshold must be > 0.");
  }
  if (summary_out != nullptr) *summary_out = GlobalPositioningSummary();
  colmap::Timer timer;
  timer.Start();

  PositioningProblem problem;
  if (const Status status = SetUpProblem(tracks, *reconstruction, &problem);
      !status.ok()) {
    return status;
  }
  PositioningData data = MakeRays(problem, *reconstruction);
  PositioningState state;
  ceres::Solver::Summary summary;
  GlobalPositioningSummary positioning_summary;
  if (const Status status =
          SolveFree(options, problem, data, *reconstruction, interrupt, &state,
                    &summary, &positioning_summary);
      !status.ok()) {
    return status;
  }
  if (use_priors) {
    if (const Status status = SolveWithPriors(
            options, *priors, summary, interrupt, &problem, &data, &state,
            reconstruction, &positioning_summary);
        !status.ok()) {
      return status;
    }
  }

  const size_t num_added_observations =
      WriteSolution(problem, state, reconstruction);
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
  for (const colmap::image_t image_id : problem.image_ids) {
    if (reconstruction->Image(image_id).NumPoints3D() == 0) {
      reconstruction->DeRegisterImage(image_id);
      ++num_deregistered;
    }
  }
  VLOG(3) << "Global positioning: " << problem.NumProblemImages() << " images, "
          << problem.NumPoints() << " points, " << problem.observations.size()
          << " observations, " << summary.iterations.size() << " iterations ("
          << ceres::TerminationTypeToString(summary.termination_type)
          << "), cost " << summary.initial_cost << " -> " << summary.final_cost
          << "; filtered " << num_angular_outliers << " observations by angle, "
          << num_small_angle_points << " points by triangulation angle; "
          << num_deregistered << " images without points deregistered; "
          << timer.ElapsedSeconds() << " s";
  if (inlier_ratio < options.min_inlier_observation_ratio ||
      reconstruction->NumRegImages() < 2 ||
      reconstruction->NumPoints3D() == 0) {
    return Status::Error(
        "Global positioning: degenerate solution (only " +
        std::to_string(static_cast<int>(100 * inlier_ratio)) +
        "% of the observations agree with the points; cameras likely stuck "
        "near the random start).");
  }

  if (positioning_summary.georegistered) {
    JudgePriorsOnSolution(*priors, *reconstruction, &positioning_summary);
  }
  if (!positioning_summary.georegistered) {
    positioning_summary.num_priors_used = 0;
    positioning_summary.rejected_image_ids.clear();
    reconstruction->Normalize();
  }
  if (summary_out != nullptr) *summary_out = positioning_summary;
  return Status::Ok();
}

}  // namespace glomap
