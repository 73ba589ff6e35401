#include "glomap/view_graph_calibration.h"

#include <ceres/ceres.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include "estimators/two_view_geometry.h"
#include "glomap/ceres_threads.h"
#include "util/threading.h"

namespace glomap {
namespace {

// Denominators below this (in focal-normalised units, where every
// coefficient is O(1)) are clamped, so that the residuals stay finite for
// near-degenerate geometry (the reference produced NaNs here, glomap#13).
constexpr double kMinDenominator = 1e-6;

// Cauchy scale of the first, coarse solve (relative focal^2 error).
constexpr double kCoarseLossScale = 0.5;

// Kruppa constraints of one pair. With F's principal points removed and
// each camera's image coordinates divided by a reference focal s_c, the
// calibration of camera c is diag(phi_c, phi_c, 1), phi_c = f_c / s_c. Let
// G = U diag(r, s, 0) V^T be the SVD of that normalised F (image 2 on the
// left). Hartley's simplified Kruppa equations say
//   a1 / b1 = a2 / b2 = a3 / b3  with
//   a1 = u2^T W2 u2,  a2 = u1^T W2 u2,  a3 = u1^T W2 u1,
//   b1 = r^2 v1^T W1 v1,  b2 = -r s v1^T W1 v2,  b3 = s^2 v2^T W1 v2,
// where W_c = diag(phi_c^2, phi_c^2, 1) is the dual image of the absolute
// conic. Every a_k is affine in x = phi2^2 and every b_k affine in
// y = phi1^2, so each of the three cross-multiplied equalities
// a_i b_j - a_j b_i = 0 is bilinear:
//   c[0] x y + c[1] x + c[2] y + c[3] = 0.
// Only two of the three are independent; one is solved for y (the focal of
// camera 1 implied by camera 2) and another for x, which gives Fetzer et
// al.'s two relative residuals (y - y_hat) / y and (x - x_hat) / x.
struct KruppaCoefficients {
  std::array<Eigen::Vector4d, 3> equations;
  int equation_for_focal1 = 0;
  int equation_for_focal2 = 1;
};

bool ComputeKruppaCoefficients(const Eigen::Matrix3d& F,
                               const Eigen::Vector2d& pp1,
                               const Eigen::Vector2d& pp2,
                               double reference_focal1, double reference_focal2,
                               KruppaCoefficients* coeffs) {
  if (!F.allFinite() || F.norm() <= 0) {
    return false;
  }
  // x_pixel = T_c diag(s_c, s_c, 1) x_normalised with T_c moving the origin
  // to the principal point.
  Eigen::Matrix3d T1 = Eigen::Matrix3d::Identity();
  T1(0, 2) = pp1(0);
  T1(1, 2) = pp1(1);
  Eigen::Matrix3d T2 = Eigen::Matrix3d::Identity();
  T2(0, 2) = pp2(0);
  T2(1, 2) = pp2(1);
  const Eigen::Matrix3d S1 =
      Eigen::Vector3d(reference_focal1, reference_focal1, 1).asDiagonal();
  const Eigen::Matrix3d S2 =
      Eigen::Vector3d(reference_focal2, reference_focal2, 1).asDiagonal();
  Eigen::Matrix3d G = S2 * T2.transpose() * F * T1 * S1;
  const double norm = G.norm();
  if (!std::isfinite(norm) || norm <= 0) {
    return false;
  }
  G /= norm;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      G, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sigma = svd.singularValues();
  if (!(sigma(0) > 0) || !(sigma(1) / sigma(0) > 1e-6)) {
    return false;  // Rank < 2: not a fundamental matrix.
  }
  const double r = 1.0;
  const double s = sigma(1) / sigma(0);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  const Eigen::Vector3d u1 = U.col(0), u2 = U.col(1);
  const Eigen::Vector3d v1 = V.col(0), v2 = V.col(1);

  // a_k = alpha_k x + beta_k and b_k = gamma_k y + delta_k.
  const std::array<double, 3> alpha = {u2(0) * u2(0) + u2(1) * u2(1),
                                       u1(0) * u2(0) + u1(1) * u2(1),
                                       u1(0) * u1(0) + u1(1) * u1(1)};
  const std::array<double, 3> beta = {u2(2) * u2(2), u1(2) * u2(2),
                                      u1(2) * u1(2)};
  const std::array<double, 3> gamma = {r * r * (v1(0) * v1(0) + v1(1) * v1(1)),
                                       -r * s * (v1(0) * v2(0) + v1(1) * v2(1)),
                                       s * s * (v2(0) * v2(0) + v2(1) * v2(1))};
  const std::array<double, 3> delta = {
      r * r * v1(2) * v1(2), -r * s * v1(2) * v2(2), s * s * v2(2) * v2(2)};

  const std::array<std::array<int, 2>, 3> index_pairs = {
      {{0, 1}, {0, 2}, {1, 2}}};
  for (int k = 0; k < 3; ++k) {
    const int i = index_pairs[k][0];
    const int j = index_pairs[k][1];
    Eigen::Vector4d& c = coeffs->equations[k];
    c(0) = alpha[i] * gamma[j] - alpha[j] * gamma[i];
    c(1) = alpha[i] * delta[j] - alpha[j] * delta[i];
    c(2) = beta[i] * gamma[j] - beta[j] * gamma[i];
    c(3) = beta[i] * delta[j] - beta[j] * delta[i];
    const double c_norm = c.norm();
    if (!std::isfinite(c_norm)) {
      return false;
    }
    if (c_norm > 0) {
      c /= c_norm;
    }
  }

  // Pick the two best-conditioned equations (largest denominators at the
  // initial focals, phi = 1) for the two residuals; they must differ, else
  // a pair of two free cameras would constrain only one combination.
  double best_score = -1;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      if (a == b) continue;
      const Eigen::Vector4d& ca = coeffs->equations[a];
      const Eigen::Vector4d& cb = coeffs->equations[b];
      const double score =
          std::min(std::abs(ca(0) + ca(2)), std::abs(cb(0) + cb(1)));
      if (score > best_score) {
        best_score = score;
        coeffs->equation_for_focal1 = a;
        coeffs->equation_for_focal2 = b;
      }
    }
  }
  return best_score > 0;
}

template <typename T>
T ClampAwayFromZero(const T& value) {
  if (value >= T(0)) {
    return value < T(kMinDenominator) ? T(kMinDenominator) : value;
  }
  return value > T(-kMinDenominator) ? T(-kMinDenominator) : value;
}

// Fetzer et al.'s residuals: relative errors of phi1^2 and phi2^2 against
// the values implied by the other camera through the Kruppa equations.
template <typename T>
void FocalResiduals(const KruppaCoefficients& coeffs, const T& phi1,
                    const T& phi2, T* residuals) {
  const T y = phi1 * phi1;
  const T x = phi2 * phi2;
  const Eigen::Vector4d& c1 = coeffs.equations[coeffs.equation_for_focal1];
  const T y_hat =
      -(c1(1) * x + c1(3)) / ClampAwayFromZero<T>(c1(0) * x + c1(2));
  const Eigen::Vector4d& c2 = coeffs.equations[coeffs.equation_for_focal2];
  const T x_hat =
      -(c2(2) * y + c2(3)) / ClampAwayFromZero<T>(c2(0) * y + c2(1));
  residuals[0] = (y - y_hat) / ClampAwayFromZero<T>(y);
  residuals[1] = (x - x_hat) / ClampAwayFromZero<T>(x);
}

struct TwoCameraFocalCost {
  explicit TwoCameraFocalCost(const KruppaCoefficients& coeffs)
      : coeffs(coeffs) {}
  template <typename T>
  bool operator()(const T* const phi1, const T* const phi2,
                  T* residuals) const {
    FocalResiduals(coeffs, phi1[0], phi2[0], residuals);
    return true;
  }
  KruppaCoefficients coeffs;
};

// Both images of the pair share one camera: one parameter, same residuals.
struct SharedCameraFocalCost {
  explicit SharedCameraFocalCost(const KruppaCoefficients& coeffs)
      : coeffs(coeffs) {}
  template <typename T>
  bool operator()(const T* const phi, T* residuals) const {
    FocalResiduals(coeffs, phi[0], phi[0], residuals);
    return true;
  }
  KruppaCoefficients coeffs;
};

// The focal every camera's parameters are scaled by; a broken stored focal
// falls back to COLMAP's default guess so that the problem stays finite.
double ReferenceFocal(const colmap::Camera& camera) {
  const double focal = camera.MeanFocalLength();
  if (std::isfinite(focal) && focal > 0) {
    return focal;
  }
  const double guess = 1.2 * std::max(camera.Width(), camera.Height());
  return guess > 0 ? guess : 1.0;
}

struct PairConstraint {
  ImagePair* pair = nullptr;
  colmap::camera_t camera_id1 = colmap::kInvalidCameraId;
  colmap::camera_t camera_id2 = colmap::kInvalidCameraId;
  KruppaCoefficients coeffs;
};

}  // namespace

bool ViewGraphCalibrationOptions::Check() const {
  return min_focal_ratio > 0 && max_focal_ratio > min_focal_ratio &&
         max_two_view_error > 0 && loss_scale > 0 && max_num_iterations >= 0;
}

bool FundamentalMatrixFocalResiduals(const Eigen::Matrix3d& F,
                                     const Eigen::Vector2d& pp1,
                                     const Eigen::Vector2d& pp2, double f1,
                                     double f2, Eigen::Vector2d* residuals) {
  if (!(f1 > 0) || !(f2 > 0)) {
    return false;
  }
  KruppaCoefficients coeffs;
  if (!ComputeKruppaCoefficients(F, pp1, pp2, f1, f2, &coeffs)) {
    return false;
  }
  FocalResiduals(coeffs, 1.0, 1.0, residuals->data());
  return true;
}

Status CalibrateViewGraph(const ViewGraphCalibrationOptions& options,
                          colmap::Reconstruction* reconstruction,
                          ViewGraph* view_graph,
                          size_t* num_invalidated_pairs) {
  if (num_invalidated_pairs != nullptr) {
    *num_invalidated_pairs = 0;
  }
  if (!options.Check()) {
    return Status::Error("Invalid view-graph calibration options.");
  }

  // Normalised focal phi_c = f_c / s_c per camera, 1 at the start; std::map
  // keeps the parameter addresses stable and the order deterministic.
  std::map<colmap::camera_t, double> phis;
  std::map<colmap::camera_t, double> reference_focals;
  auto camera_is_free = [&](colmap::camera_t camera_id) {
    return !reconstruction->Camera(camera_id).HasPriorFocalLength();
  };

  std::vector<PairConstraint> constraints;
  for (auto& [pair_id, pair] : view_graph->Pairs()) {
    if (!pair.is_valid ||
        (pair.config != colmap::TwoViewGeometry::CALIBRATED &&
         pair.config != colmap::TwoViewGeometry::UNCALIBRATED)) {
      continue;
    }
    if (!reconstruction->ExistsImage(pair.image_id1) ||
        !reconstruction->ExistsImage(pair.image_id2)) {
      continue;
    }
    PairConstraint constraint;
    constraint.pair = &pair;
    constraint.camera_id1 = reconstruction->Image(pair.image_id1).CameraId();
    constraint.camera_id2 = reconstruction->Image(pair.image_id2).CameraId();
    if (!reconstruction->ExistsCamera(constraint.camera_id1) ||
        !reconstruction->ExistsCamera(constraint.camera_id2)) {
      continue;
    }
    // Pairs between two cameras with priors say nothing about the unknowns;
    // their geometry is checked by the relative-pose stage instead.
    if (!camera_is_free(constraint.camera_id1) &&
        !camera_is_free(constraint.camera_id2)) {
      continue;
    }
    const colmap::Camera& camera1 =
        reconstruction->Camera(constraint.camera_id1);
    const colmap::Camera& camera2 =
        reconstruction->Camera(constraint.camera_id2);
    const double s1 = ReferenceFocal(camera1);
    const double s2 = ReferenceFocal(camera2);
    const Eigen::Vector2d pp1(camera1.PrincipalPointX(),
                              camera1.PrincipalPointY());
    const Eigen::Vector2d pp2(camera2.PrincipalPointX(),
                              camera2.PrincipalPointY());
    // A zero or rank-deficient F (no geometry stored) carries no focal
    // information; the pair is left to the relative-pose stage.
    if (!ComputeKruppaCoefficients(pair.F, pp1, pp2, s1, s2,
                                   &constraint.coeffs)) {
      continue;
    }
    reference_focals[constraint.camera_id1] = s1;
    reference_focals[constraint.camera_id2] = s2;
    phis.emplace(constraint.camera_id1, 1.0);
    phis.emplace(constraint.camera_id2, 1.0);
    constraints.push_back(constraint);
  }

  if (constraints.empty()) {
    return Status::Ok();
  }

  // Two solves: from the initial guess (often 20-50% off) every residual lies
  // in the flat tail of the narrow Cauchy loss, where the steps stall, so a
  // wide loss first brings the focals near the optimum, and the narrow one
  // then fits them while ignoring inconsistent pairs.
  ceres::Problem problem;
  ceres::LossFunctionWrapper* loss = new ceres::LossFunctionWrapper(
      new ceres::CauchyLoss(std::max(kCoarseLossScale, options.loss_scale)),
      ceres::TAKE_OWNERSHIP);
  for (const PairConstraint& constraint : constraints) {
    if (constraint.camera_id1 == constraint.camera_id2) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SharedCameraFocalCost, 2, 1>(
              new SharedCameraFocalCost(constraint.coeffs)),
          loss, &phis[constraint.camera_id1]);
    } else {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<TwoCameraFocalCost, 2, 1, 1>(
              new TwoCameraFocalCost(constraint.coeffs)),
          loss, &phis[constraint.camera_id1], &phis[constraint.camera_id2]);
    }
  }
  size_t num_free_cameras = 0;
  for (auto& [camera_id, phi] : phis) {
    if (camera_is_free(camera_id)) {
      ++num_free_cameras;
      // Keeps phi^2 away from zero (relative residuals divide by it).
      problem.SetParameterLowerBound(&phi, 0, 1e-3);
    } else {
      problem.SetParameterBlockConstant(&phi);
    }
  }

  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = 1e-5;
  solver_options.num_threads =
      CeresNumThreads(options.num_threads, problem.NumResidualBlocks());
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  // One scalar per camera: dense is exact and robust for small problems
  // (a sparse Cholesky on a near-singular system failed upstream, glomap
  // #147); large ones need the sparse structure.
  if (num_free_cameras < 50) {
    solver_options.linear_solver_type = ceres::DENSE_QR;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(
                 ceres::SUITE_SPARSE)) {
    solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(
                 ceres::EIGEN_SPARSE)) {
    solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  } else {
    solver_options.linear_solver_type = ceres::CGNR;
  }
  for (const double loss_scale :
       {std::max(kCoarseLossScale, options.loss_scale), options.loss_scale}) {
    loss->Reset(new ceres::CauchyLoss(loss_scale), ceres::TAKE_OWNERSHIP);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    if (!summary.IsSolutionUsable()) {
      return Status::Error("View-graph calibration failed: " + summary.message);
    }
  }

  // Accept plausible focals; a rejected camera keeps its old focal, which is
  // also what its pairs are judged against below.
  for (auto& [camera_id, phi] : phis) {
    if (!camera_is_free(camera_id)) {
      continue;
    }
    colmap::Camera& camera = reconstruction->Camera(camera_id);
    const double new_focal = phi * reference_focals.at(camera_id);
    const double ratio = new_focal / camera.MeanFocalLength();
    if (!std::isfinite(ratio) || ratio < options.min_focal_ratio ||
        ratio > options.max_focal_ratio) {
      phi = 1.0;
      continue;
    }
    VLOG(1) << "View-graph calibration: camera " << camera_id << " focal "
            << camera.MeanFocalLength() << " -> " << new_focal << " px";
    for (const size_t idx : camera.FocalLengthIdxs()) {
      camera.Params(idx) = new_focal;
    }
  }

  // Judge every pair at the final focals with the equations best
  // conditioned there (the solve picked them at the initial focals), so that
  // the decision equals FundamentalMatrixFocalResiduals at the result.
  size_t num_invalidated = 0;
  for (const PairConstraint& constraint : constraints) {
    const colmap::Camera& camera1 =
        reconstruction->Camera(constraint.camera_id1);
    const colmap::Camera& camera2 =
        reconstruction->Camera(constraint.camera_id2);
    Eigen::Vector2d residuals;
    if (!FundamentalMatrixFocalResiduals(
            constraint.pair->F,
            Eigen::Vector2d(camera1.PrincipalPointX(),
                            camera1.PrincipalPointY()),
            Eigen::Vector2d(camera2.PrincipalPointX(),
                            camera2.PrincipalPointY()),
            phis.at(constraint.camera_id1) *
                reference_focals.at(constraint.camera_id1),
            phis.at(constraint.camera_id2) *
                reference_focals.at(constraint.camera_id2),
            &residuals) ||
        !(residuals.norm() <= options.max_two_view_error)) {
      constraint.pair->is_valid = false;
      ++num_invalidated;
    }
  }
  if (num_invalidated_pairs != nullptr) {
    *num_invalidated_pairs = num_invalidated;
  }
  return Status::Ok();
}

}  // namespace glomap
