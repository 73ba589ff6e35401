#include "glomap/estimators/relative_pose.h"

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include "base/cost_functions.h"
#include "base/essential_matrix.h"
#include "base/pose.h"
#include "estimators/essential_matrix.h"
#include "estimators/two_view_geometry.h"
#include "glomap/estimators/cost_functions/sampson_error.h"
#include "glomap/util/options_check.h"
#include "glomap/util/parallel_for.h"
#include "optim/loransac.h"
#include "util/random.h"

namespace glomap {
namespace {

using TwoViewGeometry = colmap::TwoViewGeometry;

double SquaredSampsonError(const Eigen::Matrix3d& E, const Eigen::Vector3d& x1,
                           const Eigen::Vector3d& x2) {
  const Eigen::Vector3d Ex1 = E * x1;
  const Eigen::Vector3d Etx2 = E.transpose() * x2;
  const double x2tEx1 = x2.dot(Ex1);
  const double denominator =
      Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) + Etx2(0) * Etx2(0) + Etx2(1) * Etx2(1);
  if (!(denominator > 0)) {
    return std::numeric_limits<double>::infinity();
  }
  return x2tEx1 * x2tEx1 / denominator;
}

// Depths along ray1 (camera 1) and ray2 (camera 2) of the point where the
// two rays of a correspondence come closest, for cam2_from_cam1 = (R, t);
// returns false when the rays' parallax is too small for a meaningful depth.
bool TwoRayDepths(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const Eigen::Vector3d& ray1, const Eigen::Vector3d& ray2,
                  double min_sin_sq_parallax, double* depth1, double* depth2) {
  // Camera 1's frame: ray1 from the origin, ray2 from camera 2's centre.
  const Eigen::Vector3d ray2_in_cam1 = R.transpose() * ray2;
  const Eigen::Vector3d center2_in_cam1 = -R.transpose() * t;
  const double a = ray1.squaredNorm();
  const double b = ray1.dot(ray2_in_cam1);
  const double c = ray2_in_cam1.squaredNorm();
  const double sin_sq_parallax = 1.0 - b * b / (a * c);
  if (!(sin_sq_parallax > min_sin_sq_parallax)) {
    return false;
  }
  // Normal equations of min |d1 ray1 - center2 - d2 ray2|^2.
  const double e = ray1.dot(center2_in_cam1);
  const double g = ray2_in_cam1.dot(center2_in_cam1);
  const double det = b * b - a * c;  // < 0 for non-parallel rays.
  *depth1 = (b * g - c * e) / det;
  *depth2 = (a * g - b * e) / det;
  return true;
}

// Rays whose squared sine of parallax is below this are parallel for
// PoseFromEssentialMatrixFast: their depth is undefined, and only the sign
// of well-defined depths decides the decomposition (a numerical guard, as
// colmap::PoseFromEssentialMatrix has in its triangulation).
constexpr double kMinSinSqParallax = 1e-12;

// Picks the decomposition of E with the most correspondences in front of
// both cameras: colmap::PoseFromEssentialMatrix's criterion, but with
// closed-form two-ray depths instead of an SVD triangulation per point and
// candidate, which took half of this stage's run time.
bool PoseFromEssentialMatrixFast(const Eigen::Matrix3d& E,
                                 const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2,
                                 Eigen::Matrix3d* R, Eigen::Vector3d* t) {
  Eigen::Matrix3d R1, R2;
  Eigen::Vector3d t1;
  colmap::DecomposeEssentialMatrix(E, &R1, &R2, &t1);
  if (!R1.allFinite() || !R2.allFinite() || !t1.allFinite()) {
    return false;
  }
  const std::array<std::pair<Eigen::Matrix3d, Eigen::Vector3d>, 4> candidates =
      {{{R1, t1}, {R2, t1}, {R1, -t1}, {R2, -t1}}};
  int best_num_in_front = 0;
  for (const auto& [candidate_R, candidate_t] : candidates) {
    int num_in_front = 0;
    for (size_t i = 0; i < points1.size(); ++i) {
      double depth1 = 0, depth2 = 0;
      if (TwoRayDepths(candidate_R, candidate_t, points1[i].homogeneous(),
                       points2[i].homogeneous(), kMinSinSqParallax, &depth1,
                       &depth2) &&
          depth1 > 0 && depth2 > 0) {
        ++num_in_front;
      }
    }
    if (num_in_front > best_num_in_front) {
      best_num_in_front = num_in_front;
      *R = candidate_R;
      *t = candidate_t;
    }
  }
  return best_num_in_front > 0;
}

// Everything one pair's worker needs, gathered before the parallel section.
struct PairTask {
  colmap::image_pair_t pair_id = 0;
  ImagePair* pair = nullptr;
  const colmap::Camera* camera1 = nullptr;
  const colmap::Camera* camera2 = nullptr;
  const colmap::Image* image1 = nullptr;
  const colmap::Image* image2 = nullptr;
  const std::vector<Eigen::Vector2d>* normalized1 = nullptr;
  const std::vector<Eigen::Vector2d>* normalized2 = nullptr;
};

// Refines cam2_from_cam1 on the start's inliers (robust Sampson distance).
void RefinePose(const RelativePoseOptions& options,
                const std::vector<Eigen::Vector2d>& inliers1,
                const std::vector<Eigen::Vector2d>& inliers2, double loss_scale,
                Eigen::Vector4d* qvec, Eigen::Vector3d* tvec) {
  Eigen::Vector4d refined_qvec = *qvec;
  Eigen::Vector3d refined_tvec = *tvec;
  ceres::Problem problem;
  ceres::LossFunction* loss = new ceres::CauchyLoss(loss_scale);
  const size_t num_points =
      std::min<size_t>(inliers1.size(), options.max_num_refinement_points);
  for (size_t k = 0; k < num_points; ++k) {
    const size_t i = k * inliers1.size() / num_points;
    problem.AddResidualBlock(new SampsonErrorCost(inliers1[i], inliers2[i]),
                             loss, refined_qvec.data(), refined_tvec.data());
  }
  colmap::SetQuaternionManifold(&problem, refined_qvec.data());
  colmap::SetSphereManifold<3>(&problem, refined_tvec.data());
  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = options.max_num_refinement_iterations;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.num_threads = 1;  // Pairs already run in parallel.
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (summary.IsSolutionUsable() && refined_qvec.allFinite() &&
      refined_tvec.allFinite() && refined_tvec.norm() > 0) {
    *qvec = colmap::NormalizeQuaternion(refined_qvec);
    *tvec = refined_tvec.normalized();
  }
}

// The matches of one pair whose keypoints exist, as normalised coordinates.
struct PairPoints {
  std::vector<int> match_idxs;  // into ImagePair::matches
  std::vector<Eigen::Vector2d> points1;
  std::vector<Eigen::Vector2d> points2;
};

PairPoints GatherPoints(const PairTask& task) {
  const ImagePair& pair = *task.pair;
  PairPoints points;
  points.match_idxs.reserve(pair.matches.size());
  points.points1.reserve(pair.matches.size());
  points.points2.reserve(pair.matches.size());
  for (size_t i = 0; i < pair.matches.size(); ++i) {
    const colmap::FeatureMatch& match = pair.matches[i];
    if (match.point2D_idx1 >= task.normalized1->size() ||
        match.point2D_idx2 >= task.normalized2->size()) {
      continue;  // Out of range: never an inlier.
    }
    points.match_idxs.push_back(static_cast<int>(i));
    points.points1.push_back((*task.normalized1)[match.point2D_idx1]);
    points.points2.push_back((*task.normalized2)[match.point2D_idx2]);
  }
  return points;
}

// A start for the pose: an essential matrix and the points that agree with
// it.
struct EssentialStart {
  Eigen::Matrix3d E;
  std::vector<Eigen::Vector2d> inliers1;
  std::vector<Eigen::Vector2d> inliers2;
};

bool IsPlanarOrPanoramic(int config) {
  return config == TwoViewGeometry::PLANAR ||
         config == TwoViewGeometry::PANORAMIC ||
         config == TwoViewGeometry::PLANAR_OR_PANORAMIC;
}

// The start's inliers: the points within `max_error` (Sampson, normalised
// units) of its E.
void SelectAgreeing(const PairPoints& points, double max_error,
                    EssentialStart* start) {
  const double max_squared_error = max_error * max_error;
  start->inliers1.clear();
  start->inliers2.clear();
  for (size_t i = 0; i < points.points1.size(); ++i) {
    if (SquaredSampsonError(start->E, points.points1[i].homogeneous(),
                            points.points2[i].homogeneous()) <=
        max_squared_error) {
      start->inliers1.push_back(points.points1[i]);
      start->inliers2.push_back(points.points2[i]);
    }
  }
}

// E = K2^T F K1 from the database's F and the current cameras, projected
// onto the essential matrices (two equal singular values, one zero), with
// the points within `max_error` (Sampson, normalised units) of it. False
// when the pair has no usable F or fewer than `min_num_agreeing` points
// agree: then the projection moved the epipolar geometry (the focal lengths
// F implies are not the calibrated ones), and a pose decomposed from it is
// no start to trust. On dino-363 (an object ring), starting such pairs from
// all their matches instead kept wrong poses that passed re-scoring: rotation
// averaging rejected twice the pairs, and one run lost the model.
bool StartFromStoredGeometry(const ImagePair& pair,
                             const colmap::Camera& camera1,
                             const colmap::Camera& camera2,
                             const PairPoints& points, double max_error,
                             int min_num_agreeing, EssentialStart* start) {
  if (IsPlanarOrPanoramic(pair.config) || !pair.F.allFinite() ||
      !(pair.F.norm() > 0)) {
    return false;
  }
  const Eigen::Matrix3d E_raw = camera2.CalibrationMatrix().transpose() *
                                pair.F * camera1.CalibrationMatrix();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      E_raw, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d singular_values = svd.singularValues();
  const double mean = 0.5 * (singular_values(0) + singular_values(1));
  if (!(mean > 0) || !std::isfinite(mean)) {
    return false;
  }
  start->E = svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() *
             svd.matrixV().transpose();
  SelectAgreeing(points, max_error, start);
  return static_cast<int>(start->inliers1.size()) >= min_num_agreeing;
}

// LO-RANSAC with the five-point solver on the points; its inliers.
bool StartFromRansac(const RelativePoseOptions& options,
                     colmap::image_pair_t pair_id, const PairPoints& points,
                     double max_error, EssentialStart* start) {
  // COLMAP's RANSAC samples from a thread-local PRNG; seeding it per pair
  // makes the result independent of which thread runs the pair.
  colmap::SetPRNGSeed(static_cast<unsigned>(options.random_seed) ^
                      static_cast<unsigned>(pair_id ^ (pair_id >> 32)));
  colmap::RANSACOptions ransac_options;
  ransac_options.max_error = max_error;
  ransac_options.confidence = options.confidence;
  ransac_options.min_num_trials = options.min_num_trials;
  ransac_options.max_num_trials = options.max_num_trials;
  colmap::LORANSAC<colmap::EssentialMatrixFivePointEstimator,
                   colmap::EssentialMatrixFivePointEstimator>
      ransac(ransac_options);
  const auto report = ransac.Estimate(points.points1, points.points2);
  if (!report.success || !report.model.allFinite()) {
    return false;
  }
  start->E = report.model;
  start->inliers1.clear();
  start->inliers2.clear();
  start->inliers1.reserve(report.support.num_inliers);
  start->inliers2.reserve(report.support.num_inliers);
  for (size_t i = 0; i < points.points1.size(); ++i) {
    if (report.inlier_mask[i]) {
      start->inliers1.push_back(points.points1[i]);
      start->inliers2.push_back(points.points2[i]);
    }
  }
  return true;
}

// cam2_from_cam1 from the start: the decomposition with its inliers in front
// of both cameras, refined on them (unit translation).
bool PoseFromStart(const RelativePoseOptions& options,
                   const EssentialStart& start, double loss_scale,
                   Eigen::Vector4d* qvec, Eigen::Vector3d* tvec) {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  if (!PoseFromEssentialMatrixFast(start.E, start.inliers1, start.inliers2, &R,
                                   &t) ||
      !(t.norm() > 0)) {
    return false;
  }
  *qvec = colmap::RotationMatrixToQuaternion(R);
  *tvec = t.normalized();
  RefinePose(options, start.inliers1, start.inliers2, loss_scale, qvec, tvec);
  return true;
}

// Re-scores the pair's matches against the pose (writes the pose,
// has_relative_pose and inlier_idxs); returns whether the inliers pass the
// count and ratio checks.
//
// UNCALIBRATED pairs are judged by the same pose-consistent epipolar test as
// CALIBRATED ones: after view-graph calibration their focals are known, and
// the inliers must agree with the pose that rotation averaging and
// positioning will use, not with the database F. Their threshold is the
// looser F one because the calibrated focals are only estimates. Planar and
// panoramic pairs keep the database homography test: for (near) pure
// rotation the translation, and hence E, is meaningless.
bool RescoreMatches(const RelativePoseOptions& options, const PairTask& task,
                    const PairPoints& points, double px_to_normalized,
                    const Eigen::Vector4d& qvec, const Eigen::Vector3d& tvec) {
  ImagePair& pair = *task.pair;
  pair.inlier_idxs.clear();
  const Eigen::Matrix3d R = colmap::QuaternionToRotationMatrix(qvec);
  const bool use_homography = IsPlanarOrPanoramic(pair.config) &&
                              pair.H.allFinite() && pair.H.norm() > 0;
  const double epipolar_threshold_px =
      pair.config == TwoViewGeometry::CALIBRATED
          ? options.max_epipolar_error_E_px
          : options.max_epipolar_error_F_px;
  const double epipolar_threshold = epipolar_threshold_px * px_to_normalized;
  const double max_squared_sampson = epipolar_threshold * epipolar_threshold;
  const double max_squared_transfer =
      options.max_epipolar_error_H_px * options.max_epipolar_error_H_px;
  const double max_epipole_cos =
      std::cos(options.min_epipole_angle_deg * M_PI / 180.0);

  const Eigen::Matrix3d E = colmap::CrossProductMatrix(tvec) * R;
  // Epipoles as unit rays: camera 2's centre seen from camera 1, and camera
  // 1's centre seen from camera 2.
  const Eigen::Vector3d center2_in_cam1 = -R.transpose() * tvec;
  const Eigen::Vector3d center1_in_cam2 = tvec;

  for (size_t k = 0; k < points.match_idxs.size(); ++k) {
    const Eigen::Vector3d ray1 = points.points1[k].homogeneous();
    const Eigen::Vector3d ray2 = points.points2[k].homogeneous();
    if (use_homography) {
      const colmap::FeatureMatch& match = pair.matches[points.match_idxs[k]];
      const Eigen::Vector3d x1 =
          task.image1->Point2D(match.point2D_idx1).XY().homogeneous();
      const Eigen::Vector2d& x2 = task.image2->Point2D(match.point2D_idx2).XY();
      const Eigen::Vector3d Hx1 = pair.H * x1;
      if (!(std::abs(Hx1(2)) > 0) ||
          !((Hx1.hnormalized() - x2).squaredNorm() <= max_squared_transfer)) {
        continue;
      }
      pair.inlier_idxs.push_back(points.match_idxs[k]);
      continue;
    }
    if (std::abs(ray1.normalized().dot(center2_in_cam1)) > max_epipole_cos ||
        std::abs(ray2.normalized().dot(center1_in_cam2)) > max_epipole_cos) {
      continue;
    }
    if (!(SquaredSampsonError(E, ray1, ray2) <= max_squared_sampson)) {
      continue;
    }
    // Cheirality: the two rays (in camera 1's frame) must meet in front of
    // both cameras. Below the measurement accuracy in parallax the depth
    // sign is noise (points near infinity), so such matches are kept.
    double depth1 = 0, depth2 = 0;
    if (TwoRayDepths(R, tvec, ray1, ray2,
                     epipolar_threshold * epipolar_threshold, &depth1,
                     &depth2) &&
        (!(depth1 > 0) || !(depth2 > 0))) {
      continue;
    }
    pair.inlier_idxs.push_back(points.match_idxs[k]);
  }

  pair.inlier_idxs.shrink_to_fit();
  pair.qvec2_from_1 = qvec;
  pair.tvec2_from_1 = tvec;
  pair.has_relative_pose = true;

  const int num_raw_matches = pair.num_raw_matches > 0
                                  ? pair.num_raw_matches
                                  : static_cast<int>(pair.matches.size());
  const int num_inliers = static_cast<int>(pair.inlier_idxs.size());
  return num_inliers >= options.min_num_inliers &&
         num_inliers >= options.min_inlier_ratio * num_raw_matches;
}

// Where a pair's pose came from; kNone: the pair is invalid.
enum class PoseSource { kNone, kStoredGeometry, kRansac };

// Estimates the pose and re-scores the matches of one pair: from the stored
// geometry when it is used and holds, else from a RANSAC.
PoseSource ProcessPair(const RelativePoseOptions& options,
                       const PairTask& task) {
  ImagePair& pair = *task.pair;
  pair.inlier_idxs.clear();
  pair.has_relative_pose = false;
  const size_t min_num_points = std::max<size_t>(
      std::max(options.min_num_inliers, 0),
      colmap::EssentialMatrixFivePointEstimator::kMinNumSamples);
  if (pair.matches.size() < min_num_points) {
    return PoseSource::kNone;  // Can never reach the minimum inlier count.
  }
  const double focal1 = task.camera1->MeanFocalLength();
  const double focal2 = task.camera2->MeanFocalLength();
  if (!(focal1 > 0) || !(focal2 > 0) || !std::isfinite(focal1) ||
      !std::isfinite(focal2)) {
    return PoseSource::kNone;
  }
  // Pixel thresholds to normalised units (the reference's convention).
  const double px_to_normalized = 0.5 * (1.0 / focal1 + 1.0 / focal2);
  const double max_error = options.max_epipolar_error_px * px_to_normalized;
  const PairPoints points = GatherPoints(task);
  if (points.points1.size() < min_num_points) {
    return PoseSource::kNone;
  }

  EssentialStart start;
  Eigen::Vector4d qvec;
  Eigen::Vector3d tvec;
  // The start must already pass the pair's inlier checks at the RANSAC
  // threshold.
  const int num_raw_matches = pair.num_raw_matches > 0
                                  ? pair.num_raw_matches
                                  : static_cast<int>(pair.matches.size());
  const int min_num_agreeing = std::max<int>(
      static_cast<int>(min_num_points),
      static_cast<int>(std::ceil(options.min_inlier_ratio * num_raw_matches)));
  if (options.use_stored_geometry &&
      StartFromStoredGeometry(pair, *task.camera1, *task.camera2, points,
                              max_error, min_num_agreeing, &start) &&
      PoseFromStart(options, start, max_error, &qvec, &tvec)) {
    // The stored F fits the matches at the matcher's threshold (4 px in
    // 3.8), coarser than this stage's, so the first inliers can be a biased
    // part of the true ones. As LO-RANSAC's local optimisation does, the
    // inliers are selected again under the refined pose and the pose refined
    // on them while they grow.
    constexpr int kMaxReselectionRounds = 10;
    for (int round = 0; round < kMaxReselectionRounds; ++round) {
      const size_t num_before = start.inliers1.size();
      start.E = colmap::CrossProductMatrix(tvec) *
                colmap::QuaternionToRotationMatrix(qvec);
      SelectAgreeing(points, max_error, &start);
      if (start.inliers1.size() <= num_before) break;
      RefinePose(options, start.inliers1, start.inliers2, max_error, &qvec,
                 &tvec);
    }
    if (RescoreMatches(options, task, points, px_to_normalized, qvec, tvec)) {
      return PoseSource::kStoredGeometry;
    }
  }
  pair.inlier_idxs.clear();
  pair.has_relative_pose = false;
  if (!StartFromRansac(options, task.pair_id, points, max_error, &start) ||
      !PoseFromStart(options, start, max_error, &qvec, &tvec)) {
    return PoseSource::kNone;
  }
  return RescoreMatches(options, task, points, px_to_normalized, qvec, tvec)
             ? PoseSource::kRansac
             : PoseSource::kNone;
}

}  // namespace

Status RelativePoseOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("max_epipolar_error_px", max_epipolar_error_px, 0);
  check.AtLeast("max_num_trials", max_num_trials, 1);
  check.AtLeast("min_num_trials", min_num_trials, 0);
  check.AtMostField("min_num_trials", min_num_trials, "max_num_trials",
                    max_num_trials);
  check.InRange("confidence", confidence, 0, 1, Interval::kLeftOpen);
  check.AtLeast("max_num_refinement_iterations", max_num_refinement_iterations,
                0);
  // The refinement fits five degrees of freedom.
  check.AtLeast("max_num_refinement_points", max_num_refinement_points, 5);
  check.GreaterThan("max_epipolar_error_E_px", max_epipolar_error_E_px, 0);
  check.GreaterThan("max_epipolar_error_F_px", max_epipolar_error_F_px, 0);
  check.GreaterThan("max_epipolar_error_H_px", max_epipolar_error_H_px, 0);
  check.InRange("min_epipole_angle_deg", min_epipole_angle_deg, 0, 90,
                Interval::kRightOpen);
  check.AtLeast("min_num_inliers", min_num_inliers, 0);
  check.InRange("min_inlier_ratio", min_inlier_ratio, 0, 1);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  return check.status();
}

Status EstimateRelativePoses(const RelativePoseOptions& options,
                             const colmap::Reconstruction& reconstruction,
                             ViewGraph* view_graph,
                             RelativePoseStatistics* statistics,
                             const Interrupt& interrupt) {
  if (statistics != nullptr) {
    *statistics = RelativePoseStatistics();
  }
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid relative pose options: " + check.message());
  }

  size_t num_invalidated = 0;
  std::vector<PairTask> tasks;
  // Normalised coordinates of every keypoint, once per image (undistortion
  // can be iterative, and an image takes part in many pairs).
  std::unordered_map<colmap::image_t, std::vector<Eigen::Vector2d>>
      normalized_points;
  std::vector<colmap::image_t> image_ids;
  for (auto& [pair_id, pair] : view_graph->Pairs()) {
    if (!pair.is_valid) {
      continue;
    }
    if (!reconstruction.ExistsImage(pair.image_id1) ||
        !reconstruction.ExistsImage(pair.image_id2)) {
      pair.is_valid = false;
      ++num_invalidated;
      continue;
    }
    const colmap::Image& image1 = reconstruction.Image(pair.image_id1);
    const colmap::Image& image2 = reconstruction.Image(pair.image_id2);
    if (!reconstruction.ExistsCamera(image1.CameraId()) ||
        !reconstruction.ExistsCamera(image2.CameraId())) {
      pair.is_valid = false;
      ++num_invalidated;
      continue;
    }
    PairTask task;
    task.pair_id = pair_id;
    task.pair = &pair;
    task.image1 = &image1;
    task.image2 = &image2;
    task.camera1 = &reconstruction.Camera(image1.CameraId());
    task.camera2 = &reconstruction.Camera(image2.CameraId());
    for (const colmap::image_t image_id : {pair.image_id1, pair.image_id2}) {
      if (normalized_points.emplace(image_id, std::vector<Eigen::Vector2d>())
              .second) {
        image_ids.push_back(image_id);
      }
    }
    tasks.push_back(task);
  }
  for (PairTask& task : tasks) {
    task.normalized1 = &normalized_points.at(task.pair->image_id1);
    task.normalized2 = &normalized_points.at(task.pair->image_id2);
  }

  ParallelFor(options.num_threads, image_ids.size(), [&](size_t i) {
    const colmap::Image& image = reconstruction.Image(image_ids[i]);
    const colmap::Camera& camera = reconstruction.Camera(image.CameraId());
    std::vector<Eigen::Vector2d>& points = normalized_points.at(image_ids[i]);
    points.reserve(image.NumPoints2D());
    for (const colmap::Point2D& point2D : image.Points2D()) {
      points.push_back(camera.ImageToWorld(point2D.XY()));
    }
  });

  // A stop skips the remaining pairs.
  std::vector<PoseSource> sources(tasks.size(), PoseSource::kNone);
  ParallelFor(options.num_threads, tasks.size(), [&](size_t i) {
    if (!interrupt.IsStopped()) sources[i] = ProcessPair(options, tasks[i]);
  });
  if (interrupt.IsStopped()) return Status::Cancelled();

  RelativePoseStatistics counts;
  for (size_t i = 0; i < tasks.size(); ++i) {
    if (sources[i] == PoseSource::kStoredGeometry) {
      ++counts.num_from_stored_geometry;
    } else if (sources[i] == PoseSource::kRansac) {
      ++counts.num_from_ransac;
    } else {
      tasks[i].pair->is_valid = false;
      // No later stage reads the inliers of an invalid pair.
      std::vector<int>().swap(tasks[i].pair->inlier_idxs);
      ++num_invalidated;
    }
  }
  counts.num_invalidated_pairs = num_invalidated;
  if (statistics != nullptr) {
    *statistics = counts;
  }
  return Status::Ok();
}

}  // namespace glomap
