#include "glomap/estimators/view_graph_calibration.h"

#include <ceres/ceres.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "base/correspondence_graph.h"
#include "base/database_cache.h"
#include "base/essential_matrix.h"
#include "controllers/incremental_mapper.h"
#include "estimators/essential_matrix.h"
#include "estimators/two_view_geometry.h"
#include "glomap/util/ceres_interrupt.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/options_check.h"
#include "optim/loransac.h"
#include "sfm/incremental_mapper.h"
#include "util/logging.h"
#include "util/random.h"
#include "util/threading.h"

namespace glomap {
namespace {

// Denominators below this (in focal-normalised units, where every
// coefficient is O(1)) are clamped, so that the residuals stay finite for
// near-degenerate geometry (the reference produced NaNs here, glomap#13).
// A numerical guard, not an option: it only decides whether a residual is
// finite, never which focal fits.
constexpr double kMinDenominator = 1e-6;

// F is treated as rank < 2 (not a fundamental matrix) when its second
// singular value is below this fraction of the first: a numerical guard
// against dividing by a zero singular value, like kMinDenominator.
constexpr double kMinSingularValueRatio = 1e-6;

// Lower bound of every normalised focal phi (relative residuals divide by
// phi^2): a numerical guard, not an option; a focal of 1/1000 of its start
// lies far below any sensible min_focal_ratio (0.1), which rejects it.
constexpr double kMinNormalisedFocal = 1e-3;

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
  if (!(sigma(0) > 0) || !(sigma(1) / sigma(0) > kMinSingularValueRatio)) {
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
// falls back to COLMAP's default guess (1.2 times the larger image side, as
// its feature extractor sets it) so that the problem stays finite.
double ReferenceFocal(const colmap::Camera& camera) {
  const double focal = camera.MeanFocalLength();
  if (std::isfinite(focal) && focal > 0) {
    return focal;
  }
  const double guess = 1.2 * std::max(camera.Width(), camera.Height());
  return guess > 0 ? guess : 1.0;
}

// Members of every calibration group (see IdenticalCameraGroups), by group.
std::map<colmap::camera_t, std::vector<colmap::camera_t>> GroupMembers(
    const CameraGroups& group_of) {
  std::map<colmap::camera_t, std::vector<colmap::camera_t>> members;
  for (const auto& [camera_id, group] : group_of) {
    members[group].push_back(camera_id);
  }
  return members;
}

// Writes `focal_px` into every focal parameter of every camera of `group`.
void SetGroupFocal(
    const std::map<colmap::camera_t, std::vector<colmap::camera_t>>& members,
    colmap::camera_t group, double focal_px,
    colmap::Reconstruction* reconstruction) {
  for (const colmap::camera_t camera_id : members.at(group)) {
    colmap::Camera& camera = reconstruction->Camera(camera_id);
    for (const size_t idx : camera.FocalLengthIdxs()) {
      camera.Params(idx) = focal_px;
    }
  }
}

struct PairConstraint {
  ImagePair* pair = nullptr;
  colmap::camera_t camera_id1 = colmap::kInvalidCameraId;
  colmap::camera_t camera_id2 = colmap::kInvalidCameraId;
  KruppaCoefficients coeffs;
};

// The image with the most matches over valid pairs with at least
// `min_num_matches` (among images of cameras without a prior), followed by
// its neighbours in decreasing number of matches, `num_images` at most. Ties
// go to the smaller image id.
std::vector<colmap::image_t> SelectCalibrationImages(
    const ViewGraph& view_graph, const colmap::Reconstruction& reconstruction,
    size_t num_images, size_t min_num_matches) {
  std::map<colmap::image_t, size_t> num_matches;
  std::map<colmap::image_t, std::vector<std::pair<size_t, colmap::image_t>>>
      neighbours;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (!pair.is_valid || pair.matches.size() < min_num_matches ||
        pair.image_id1 == pair.image_id2 ||
        !reconstruction.ExistsImage(pair.image_id1) ||
        !reconstruction.ExistsImage(pair.image_id2)) {
      continue;
    }
    num_matches[pair.image_id1] += pair.matches.size();
    num_matches[pair.image_id2] += pair.matches.size();
    neighbours[pair.image_id1].emplace_back(pair.matches.size(),
                                            pair.image_id2);
    neighbours[pair.image_id2].emplace_back(pair.matches.size(),
                                            pair.image_id1);
  }
  colmap::image_t seed = colmap::kInvalidImageId;
  for (const auto& [image_id, count] : num_matches) {
    const colmap::Image& image = reconstruction.Image(image_id);
    if (!reconstruction.ExistsCamera(image.CameraId()) ||
        reconstruction.Camera(image.CameraId()).HasPriorFocalLength()) {
      continue;
    }
    if (seed == colmap::kInvalidImageId || count > num_matches.at(seed)) {
      seed = image_id;
    }
  }
  if (seed == colmap::kInvalidImageId) return {};
  std::vector<std::pair<size_t, colmap::image_t>>& candidates =
      neighbours.at(seed);
  std::sort(
      candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
  std::vector<colmap::image_t> image_ids = {seed};
  for (const auto& [count, image_id] : candidates) {
    if (image_ids.size() >= num_images) break;
    image_ids.push_back(image_id);
  }
  return image_ids;
}

// Median angle (deg) between the relative rotations of `small` and those
// that five-point RANSAC (as the relative-pose stage runs it, without the
// refinement; COLMAP's RANSAC defaults otherwise) estimates from the same
// matches with the cameras of `reconstruction`, over the pairs of two images
// registered in `small`; negative without such a pair.
double MedianRotationBiasDeg(
    const ViewGraphCalibrationOptions& options,
    const colmap::Reconstruction& small,
    const colmap::Reconstruction& reconstruction,
    const std::vector<std::pair<const ImagePair*, colmap::FeatureMatches>>&
        matches) {
  colmap::SetPRNGSeed(0);
  std::vector<double> angles_deg;
  for (const auto& [pair, pair_matches] : matches) {
    if (pair_matches.size() <
            static_cast<size_t>(options.multi_view_min_num_matches) ||
        !small.IsImageRegistered(pair->image_id1) ||
        !small.IsImageRegistered(pair->image_id2)) {
      continue;
    }
    const colmap::Image& image1 = reconstruction.Image(pair->image_id1);
    const colmap::Image& image2 = reconstruction.Image(pair->image_id2);
    const colmap::Camera& camera1 = reconstruction.Camera(image1.CameraId());
    const colmap::Camera& camera2 = reconstruction.Camera(image2.CameraId());
    std::vector<Eigen::Vector2d> points1, points2;
    for (const colmap::FeatureMatch& match : pair_matches) {
      points1.push_back(
          camera1.ImageToWorld(image1.Point2D(match.point2D_idx1).XY()));
      points2.push_back(
          camera2.ImageToWorld(image2.Point2D(match.point2D_idx2).XY()));
    }
    colmap::RANSACOptions ransac_options;
    ransac_options.max_error =
        options.multi_view_max_epipolar_error_px *
        (0.5 * (1 / camera1.MeanFocalLength() + 1 / camera2.MeanFocalLength()));
    colmap::LORANSAC<colmap::EssentialMatrixFivePointEstimator,
                     colmap::EssentialMatrixFivePointEstimator>
        ransac(ransac_options);
    const auto report = ransac.Estimate(points1, points2);
    if (!report.success) continue;
    std::vector<Eigen::Vector2d> inliers1, inliers2;
    for (size_t i = 0; i < points1.size(); ++i) {
      if (!report.inlier_mask[i]) continue;
      inliers1.push_back(points1[i]);
      inliers2.push_back(points2[i]);
    }
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    std::vector<Eigen::Vector3d> points3D;
    colmap::PoseFromEssentialMatrix(report.model, inliers1, inliers2, &R, &t,
                                    &points3D);
    const Eigen::Matrix3d R_small =
        small.Image(pair->image_id2).RotationMatrix() *
        small.Image(pair->image_id1).RotationMatrix().transpose();
    const double angle_deg =
        Eigen::AngleAxisd(R * R_small.transpose()).angle() * 180 / M_PI;
    if (std::isfinite(angle_deg)) angles_deg.push_back(angle_deg);
  }
  if (angles_deg.empty()) return -1;
  const size_t mid = angles_deg.size() / 2;
  std::nth_element(angles_deg.begin(), angles_deg.begin() + mid,
                   angles_deg.end());
  return angles_deg[mid];
}

// The camera a free camera is replaced by in the small reconstruction: one
// focal and one radial coefficient (SIMPLE_RADIAL, or SIMPLE_RADIAL_FISHEYE
// for fisheye models), starting from the camera's mean focal and principal
// point. Fifteen images do not determine the four to eight distortion
// parameters of OPENCV-type models, and with them free the focal runs off
// (templeRing with one OPENCV camera: 922 px for a true 1520 px; the
// incremental mapper then broke up); the small reconstruction is only there
// for the focal.
colmap::Camera FocalProxyCamera(const colmap::Camera& camera) {
  const std::string model = camera.ModelName();
  if (model == "SIMPLE_RADIAL" || model == "SIMPLE_RADIAL_FISHEYE") {
    return camera;
  }
  const bool fisheye = model == "OPENCV_FISHEYE" || model == "FOV" ||
                       model == "RADIAL_FISHEYE" ||
                       model == "THIN_PRISM_FISHEYE";
  colmap::Camera proxy;
  proxy.SetCameraId(camera.CameraId());
  proxy.InitializeWithName(fisheye ? "SIMPLE_RADIAL_FISHEYE" : "SIMPLE_RADIAL",
                           camera.MeanFocalLength(), camera.Width(),
                           camera.Height());
  proxy.SetPrincipalPointX(camera.PrincipalPointX());
  proxy.SetPrincipalPointY(camera.PrincipalPointY());
  proxy.SetPriorFocalLength(camera.HasPriorFocalLength());
  return proxy;
}

struct SmallReconstructionResult {
  // Refined focal of every calibration group without a prior (by group id)
  // that has at least multi_view_min_num_images_per_camera registered images
  // in it.
  std::map<colmap::camera_t, double> focals;
  // The radial coefficient of those cameras whose stand-in (see
  // FocalProxyCamera) is SIMPLE_RADIAL_FISHEYE, by group id.
  std::map<colmap::camera_t, double> fisheye_radials;
  // MedianRotationBiasDeg of the cameras on entry.
  double rotation_bias_deg = -1;
  size_t num_registered = 0;
};

// Builds the small reconstruction of `image_ids` with COLMAP's incremental
// mapper, every camera starting from `initial_cameras`; the images of one
// calibration group see one camera there (the group's, with the group's id),
// so that a group of single-image cameras has one focal that all its images
// determine. Stops early when `interrupt` fires (the result is then not
// used).
// The matches of the small reconstruction's pairs: valid pairs among the
// selected images with at least multi_view_min_num_matches matches.
using SmallPairMatches =
    std::vector<std::pair<const ImagePair*, colmap::FeatureMatches>>;

// The keypoints each image keeps (by image, one flag per keypoint): at most
// multi_view_max_num_keypoints_per_image, those matched in the most pairs
// (ties: the smaller index).
std::map<colmap::image_t, std::vector<bool>> KeptKeypoints(
    const ViewGraphCalibrationOptions& options,
    const std::map<colmap::image_t, std::vector<int>>& num_pairs_per_keypoint) {
  std::map<colmap::image_t, std::vector<bool>> kept;
  for (const auto& [image_id, counts] : num_pairs_per_keypoint) {
    std::vector<colmap::point2D_t> order(counts.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    const size_t num_kept = std::min(
        order.size(),
        static_cast<size_t>(options.multi_view_max_num_keypoints_per_image));
    std::partial_sort(
        order.begin(), order.begin() + num_kept, order.end(),
        [&counts = counts](colmap::point2D_t a, colmap::point2D_t b) {
          return counts[a] != counts[b] ? counts[a] > counts[b] : a < b;
        });
    std::vector<bool>& image_kept = kept[image_id];
    image_kept.assign(counts.size(), false);
    for (size_t i = 0; i < num_kept; ++i) {
      if (counts[order[i]] > 0) image_kept[order[i]] = true;
    }
  }
  return kept;
}

// Fills `cache` (the incremental mapper's input, in memory, from the view
// graph as retriangulation does; never from the database) with the images
// `image_ids` on their groups' cameras (free ones as FocalProxyCamera of
// their initial camera) and the kept keypoints' correspondences of their
// pairs, whose matches go to `matches`. False when fewer than
// multi_view_min_num_images_per_camera images have correspondences.
bool FillSmallCache(
    const ViewGraphCalibrationOptions& options, const ViewGraph& view_graph,
    const colmap::Reconstruction& reconstruction,
    const std::map<colmap::camera_t, colmap::Camera>& initial_cameras,
    const CameraGroups& group_of, const std::vector<colmap::image_t>& image_ids,
    colmap::DatabaseCache* cache_out, SmallPairMatches* matches_out) {
  const size_t min_num_matches =
      static_cast<size_t>(options.multi_view_min_num_matches);
  colmap::DatabaseCache& cache = *cache_out;
  SmallPairMatches& matches = *matches_out;
  const std::unordered_set<colmap::image_t> selected(image_ids.begin(),
                                                     image_ids.end());
  for (const colmap::image_t image_id : image_ids) {
    const colmap::Image& source = reconstruction.Image(image_id);
    const colmap::camera_t group = group_of.at(source.CameraId());
    if (!cache.ExistsCamera(group)) {
      const auto initial = initial_cameras.find(group);
      cache.AddCamera(initial != initial_cameras.end()
                          ? FocalProxyCamera(initial->second)
                          : reconstruction.Camera(group));
    }
    colmap::Image image = KeypointImage(source);
    image.SetCameraId(group);
    cache.AddImage(image);  // Also adds it to the graph.
  }
  std::map<colmap::image_t, std::vector<int>> num_pairs_per_keypoint;
  for (const colmap::image_t image_id : image_ids) {
    num_pairs_per_keypoint[image_id].assign(cache.Image(image_id).NumPoints2D(),
                                            0);
  }
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (!pair.is_valid || pair.matches.size() < min_num_matches ||
        pair.image_id1 == pair.image_id2 ||
        selected.count(pair.image_id1) == 0 ||
        selected.count(pair.image_id2) == 0) {
      continue;
    }
    matches.emplace_back(
        &pair,
        CleanMatches(pair.matches, cache.Image(pair.image_id1).NumPoints2D(),
                     cache.Image(pair.image_id2).NumPoints2D()));
    for (const colmap::FeatureMatch& match : matches.back().second) {
      ++num_pairs_per_keypoint[pair.image_id1][match.point2D_idx1];
      ++num_pairs_per_keypoint[pair.image_id2][match.point2D_idx2];
    }
  }
  const std::map<colmap::image_t, std::vector<bool>> kept =
      KeptKeypoints(options, num_pairs_per_keypoint);
  colmap::CorrespondenceGraph& graph = MutableCorrespondenceGraph(&cache);
  for (auto& [pair, pair_matches] : matches) {
    const std::vector<bool>& kept1 = kept.at(pair->image_id1);
    const std::vector<bool>& kept2 = kept.at(pair->image_id2);
    pair_matches.erase(std::remove_if(pair_matches.begin(), pair_matches.end(),
                                      [&](const colmap::FeatureMatch& match) {
                                        return !kept1[match.point2D_idx1] ||
                                               !kept2[match.point2D_idx2];
                                      }),
                       pair_matches.end());
    if (pair_matches.size() < min_num_matches) continue;
    graph.AddCorrespondences(pair->image_id1, pair->image_id2, pair_matches);
  }
  graph.Finalize();
  if (graph.NumImages() <
      static_cast<size_t>(options.multi_view_min_num_images_per_camera)) {
    return false;
  }
  for (const colmap::image_t image_id : image_ids) {
    if (!graph.ExistsImage(image_id)) continue;
    colmap::Image& image = cache.Image(image_id);
    image.SetNumObservations(graph.NumObservationsForImage(image_id));
    image.SetNumCorrespondences(graph.NumCorrespondencesForImage(image_id));
  }
  return true;
}

// COLMAP's incremental mapper on the small cache, with COLMAP's mapper
// defaults except for the bounds of its bogus-camera test (the incremental
// mapper drops images whose focal leaves them), which are this stage's own
// bounds on the focal ratio around the seed camera's. One thread and a fixed
// seed: the same input gives the same focal (the problems are small, far
// below the size at which this project's Ceres solves use more threads, see
// ceres_threads.h).
class SmallMapper {
 public:
  SmallMapper(const ViewGraphCalibrationOptions& options,
              const colmap::Camera& seed_camera, const Interrupt& interrupt)
      : options_(options), interrupt_(interrupt) {
    mapper_options_.num_threads = 1;
    init_options_ = mapper_options_.Mapper();
    const double seed_focal_ratio =
        seed_camera.MeanFocalLength() /
        std::max<double>(1.0,
                         std::max(seed_camera.Width(), seed_camera.Height()));
    init_options_.min_focal_length_ratio =
        std::min(init_options_.min_focal_length_ratio,
                 options.min_focal_ratio * seed_focal_ratio);
    init_options_.max_focal_length_ratio =
        std::max(init_options_.max_focal_length_ratio,
                 options.max_focal_ratio * seed_focal_ratio);
    tri_options_ = mapper_options_.Triangulation();
    local_ba_ = mapper_options_.LocalBundleAdjustment();
    global_ba_ = mapper_options_.GlobalBundleAdjustment();
    for (colmap::BundleAdjustmentOptions* ba : {&local_ba_, &global_ba_}) {
      ba->print_summary = false;
      ba->solver_options.logging_type = ceres::SILENT;
      ba->solver_options.num_threads = 1;
    }
  }

  // The mapper options of the first relaxation level.
  const colmap::IncrementalMapper::Options& InitOptions() const {
    return init_options_;
  }
  const colmap::BundleAdjustmentOptions& GlobalBundleAdjustment() const {
    return global_ba_;
  }

  // Tracks completed and merged, retriangulation, the global bundle
  // adjustment and filtering (multi_view_num_global_refinements times).
  void GlobalRefinement(colmap::IncrementalMapper* mapper,
                        const colmap::IncrementalMapper::Options& mo) const {
    mapper->CompleteTracks(tri_options_);
    mapper->MergeTracks(tri_options_);
    mapper->Retriangulate(tri_options_);
    for (int i = 0; i < options_.multi_view_num_global_refinements; ++i) {
      mapper->AdjustGlobalBundle(mo, global_ba_);
      mapper->FilterPoints(mo);
    }
    mapper->FilterImages(mo);
  }

  // Registration of the other images as COLMAP's mapper does it: local
  // bundle adjustment after each image, global refinement whenever the
  // model grew by its ba_global_images_ratio or ba_global_points_ratio
  // (10%), when no image registers (then once more), and at the end.
  void Grow(colmap::IncrementalMapper* mapper,
            const colmap::IncrementalMapper::Options& mo,
            const colmap::Reconstruction& small) const {
    size_t num_images_at_refinement = small.NumRegImages();
    size_t num_points_at_refinement = small.NumPoints3D();
    bool refined_after_failure = false;
    while (!interrupt_.IsStopped()) {
      bool registered = false;
      for (const colmap::image_t image_id : mapper->FindNextImages(mo)) {
        if (!mapper->RegisterNextImage(mo, image_id)) continue;
        mapper->TriangulateImage(tri_options_, image_id);
        mapper->AdjustLocalBundle(mo, local_ba_, tri_options_, image_id,
                                  mapper->GetModifiedPoints3D());
        mapper->ClearModifiedPoints3D();
        if (small.NumRegImages() >= mapper_options_.ba_global_images_ratio *
                                        num_images_at_refinement ||
            small.NumPoints3D() >= mapper_options_.ba_global_points_ratio *
                                       num_points_at_refinement) {
          GlobalRefinement(mapper, mo);
          num_images_at_refinement = small.NumRegImages();
          num_points_at_refinement = small.NumPoints3D();
        }
        registered = true;
        break;
      }
      if (registered) {
        refined_after_failure = false;
        continue;
      }
      if (refined_after_failure) break;
      GlobalRefinement(mapper, mo);
      refined_after_failure = true;
    }
    GlobalRefinement(mapper, mo);
  }

 private:
  const ViewGraphCalibrationOptions& options_;
  const Interrupt& interrupt_;
  colmap::IncrementalMapperOptions mapper_options_;
  colmap::IncrementalMapper::Options init_options_;
  colmap::IncrementalTriangulator::Options tri_options_;
  colmap::BundleAdjustmentOptions local_ba_;
  colmap::BundleAdjustmentOptions global_ba_;
};

SmallReconstructionResult FocalsFromSmallReconstruction(
    const ViewGraphCalibrationOptions& options, const ViewGraph& view_graph,
    const colmap::Reconstruction& reconstruction,
    const std::map<colmap::camera_t, colmap::Camera>& initial_cameras,
    const CameraGroups& group_of, const std::vector<colmap::image_t>& image_ids,
    const Interrupt& interrupt) {
  const size_t min_num_images_per_camera =
      static_cast<size_t>(options.multi_view_min_num_images_per_camera);
  colmap::DatabaseCache cache;
  SmallPairMatches matches;
  if (!FillSmallCache(options, view_graph, reconstruction, initial_cameras,
                      group_of, image_ids, &cache, &matches)) {
    return {};
  }
  // COLMAP's mapper prints a report of every image's pose refinement to
  // stdout (AbsolutePoseRefinementOptions::print_summary, which its
  // IncrementalMapper does not expose); the small reconstruction is silent.
  // No other stage runs while the view graph is calibrated.
  struct SilenceStdout {
    SilenceStdout() : saved(std::cout.rdbuf(nullptr)) {}
    ~SilenceStdout() { std::cout.rdbuf(saved); }
    std::streambuf* saved;
  } silence_stdout;

  colmap::SetPRNGSeed(0);
  const SmallMapper small_mapper(
      options, cache.Camera(cache.Image(image_ids.front()).CameraId()),
      interrupt);
  const colmap::BundleAdjustmentOptions& global_ba =
      small_mapper.GlobalBundleAdjustment();

  // Initial pairs as COLMAP's mapper tries them, relaxed when none is found;
  // a model that stays small (a weak initial pair) is discarded and the next
  // pair tried. The largest model decides.
  const size_t enough_images = std::max(
      min_num_images_per_camera,
      static_cast<size_t>(std::ceil(options.multi_view_min_model_ratio *
                                    static_cast<double>(image_ids.size()))));
  SmallReconstructionResult result;
  size_t best_num_images = 0;
  colmap::IncrementalMapper::Options mo = small_mapper.InitOptions();
  for (int level = 0; level < options.multi_view_num_init_relaxations &&
                      best_num_images < enough_images;
       ++level) {
    // A new mapper per level, so that pairs tried before are tried again.
    colmap::IncrementalMapper mapper(&cache);
    for (int attempt = 0;
         attempt < options.multi_view_max_num_init_attempts &&
         best_num_images < enough_images && !interrupt.IsStopped();
         ++attempt) {
      colmap::Reconstruction small;
      mapper.BeginReconstruction(&small);
      colmap::image_t image_id1 = colmap::kInvalidImageId;
      colmap::image_t image_id2 = colmap::kInvalidImageId;
      const bool found =
          mapper.FindInitialImagePair(mo, &image_id1, &image_id2);
      if (found && mapper.RegisterInitialImagePair(mo, image_id1, image_id2)) {
        mapper.AdjustGlobalBundle(mo, global_ba);
        mapper.FilterPoints(mo);
        mapper.FilterImages(mo);
        if (small.NumRegImages() >= 2 && small.NumPoints3D() > 0) {
          small_mapper.Grow(&mapper, mo, small);
          VLOG(3) << "View-graph calibration: small reconstruction of "
                  << small.NumRegImages() << " of " << image_ids.size()
                  << " images, " << small.NumPoints3D() << " points.";
          if (small.NumRegImages() > best_num_images) {
            best_num_images = small.NumRegImages();
            std::map<colmap::camera_t, size_t> num_registered;
            for (const colmap::image_t image_id : small.RegImageIds()) {
              ++num_registered[small.Image(image_id).CameraId()];
            }
            result.focals.clear();
            for (const auto& [camera_id, count] : num_registered) {
              const colmap::Camera& camera = small.Camera(camera_id);
              if (count >= min_num_images_per_camera &&
                  !camera.HasPriorFocalLength()) {
                result.focals[camera_id] = camera.MeanFocalLength();
                if (camera.ModelName() == "SIMPLE_RADIAL_FISHEYE") {
                  result.fisheye_radials[camera_id] = camera.Params(3);
                }
              }
            }
            result.num_registered = small.NumRegImages();
            result.rotation_bias_deg =
                MedianRotationBiasDeg(options, small, reconstruction, matches);
          }
        }
      }
      mapper.EndReconstruction(/*discard=*/true);
      if (!found) break;
    }
    mo.init_min_num_inliers /= 2;
    mo.init_min_tri_angle /= 2;
  }
  // A model that could not register most of the best-connected images is
  // itself the failure (a forward-motion street from a focal 36% off: 3 of
  // 15 images, a focal of 4377 px where the truth is 900, relative
  // rotations 129 deg from the pairs'); its focal is not evidence.
  if (best_num_images < enough_images) {
    LOG(INFO) << "View-graph calibration: the small reconstruction holds "
              << best_num_images << " of " << image_ids.size()
              << " images (fewer than " << enough_images
              << "); its focal lengths are not used.";
    return {};
  }
  return result;
}

// The multi-view step of CalibrateViewGraph: sets the focal of every camera
// of every free calibration group that the small reconstruction calibrates
// (within the ratio bounds relative to `initial_cameras`) and returns the
// ids of those groups.
std::vector<colmap::camera_t> CalibrateFromSmallReconstruction(
    const ViewGraphCalibrationOptions& options, const ViewGraph& view_graph,
    const std::map<colmap::camera_t, colmap::Camera>& initial_cameras,
    const CameraGroups& group_of, colmap::Reconstruction* reconstruction,
    const Interrupt& interrupt) {
  if (options.multi_view_num_images <= 0 || initial_cameras.empty()) {
    return {};
  }
  const std::vector<colmap::image_t> image_ids = SelectCalibrationImages(
      view_graph, *reconstruction,
      static_cast<size_t>(options.multi_view_num_images),
      static_cast<size_t>(options.multi_view_min_num_matches));
  if (image_ids.size() <
      static_cast<size_t>(options.multi_view_min_num_images_per_camera)) {
    return {};
  }
  const SmallReconstructionResult small = FocalsFromSmallReconstruction(
      options, view_graph, *reconstruction, initial_cameras, group_of,
      image_ids, interrupt);
  if (small.focals.empty() || interrupt.IsStopped()) return {};
  // The focal matters before bundle adjustment only through the relative
  // poses: where the current focals give the same relative rotations as the
  // small reconstruction, up to less than the bias that counts, they stay.
  if (small.rotation_bias_deg < options.multi_view_min_rotation_bias_deg) {
    LOG(INFO) << "View-graph calibration: a small reconstruction of "
              << small.num_registered << " images agrees with the current "
              << "focal lengths (median relative rotation difference "
              << small.rotation_bias_deg << " deg); they are kept.";
    return {};
  }
  const auto members = GroupMembers(group_of);
  std::vector<colmap::camera_t> calibrated;
  for (const auto& [group, focal] : small.focals) {
    const auto initial = initial_cameras.find(group);
    if (initial == initial_cameras.end()) continue;
    const double ratio = focal / initial->second.MeanFocalLength();
    if (!std::isfinite(ratio) || ratio < options.min_focal_ratio ||
        ratio > options.max_focal_ratio) {
      continue;
    }
    const size_t num_cameras = members.at(group).size();
    LOG(INFO) << "View-graph calibration: "
              << (num_cameras == 1
                      ? "camera " + std::to_string(group)
                      : std::to_string(num_cameras) + " identical cameras (" +
                            std::to_string(group) + ", ...)")
              << " focal " << focal << " px from a small reconstruction of "
              << small.num_registered << " images (fundamental matrices: "
              << reconstruction->Camera(group).MeanFocalLength()
              << " px, start " << initial->second.MeanFocalLength()
              << " px; relative rotations differ by " << small.rotation_bias_deg
              << " deg in the median)";
    SetGroupFocal(members, group, focal, reconstruction);
    // A fisheye model starts equidistant (k1 = 0): an ordinary lens is k1
    // = 1/3 away from that at the corner (tan(theta) = theta + theta^3 / 3
    // ...), which bends every ray the relative poses use; the stand-in's
    // radial coefficient is that k1.
    const auto radial = small.fisheye_radials.find(group);
    if (radial != small.fisheye_radials.end()) {
      for (const colmap::camera_t camera_id : members.at(group)) {
        colmap::Camera& camera = reconstruction->Camera(camera_id);
        const std::string model = camera.ModelName();
        if ((model == "OPENCV_FISHEYE" || model == "RADIAL_FISHEYE" ||
             model == "SIMPLE_RADIAL_FISHEYE") &&
            !camera.ExtraParamsIdxs().empty()) {
          camera.Params(camera.ExtraParamsIdxs()[0]) = radial->second;
        }
      }
    }
    calibrated.push_back(group);
  }
  return calibrated;
}

// The focal problem of the fundamental matrices: one constraint per valid
// pair with an F between cameras of which at least one has no focal prior,
// and one unknown per calibration group, phi_g = f_g / s_g (1 at the start;
// std::map keeps the parameter addresses stable and the order
// deterministic), with s_g the group's reference focal.
struct FocalProblem {
  std::vector<PairConstraint> constraints;
  std::map<colmap::camera_t, double> phis;
  std::map<colmap::camera_t, double> reference_focals;
};

bool CameraIsFree(const colmap::Reconstruction& reconstruction,
                  colmap::camera_t camera_id) {
  return !reconstruction.Camera(camera_id).HasPriorFocalLength();
}

FocalProblem CollectConstraints(const CameraGroups& group_of,
                                const colmap::Reconstruction& reconstruction,
                                ViewGraph* view_graph) {
  auto camera_is_free = [&](colmap::camera_t camera_id) {
    return CameraIsFree(reconstruction, camera_id);
  };
  FocalProblem problem;
  std::vector<PairConstraint>& constraints = problem.constraints;
  std::map<colmap::camera_t, double>& phis = problem.phis;
  std::map<colmap::camera_t, double>& reference_focals =
      problem.reference_focals;
  for (auto& [pair_id, pair] : view_graph->Pairs()) {
    if (!pair.is_valid ||
        (pair.config != colmap::TwoViewGeometry::CALIBRATED &&
         pair.config != colmap::TwoViewGeometry::UNCALIBRATED)) {
      continue;
    }
    if (!reconstruction.ExistsImage(pair.image_id1) ||
        !reconstruction.ExistsImage(pair.image_id2)) {
      continue;
    }
    PairConstraint constraint;
    constraint.pair = &pair;
    constraint.camera_id1 = reconstruction.Image(pair.image_id1).CameraId();
    constraint.camera_id2 = reconstruction.Image(pair.image_id2).CameraId();
    if (!reconstruction.ExistsCamera(constraint.camera_id1) ||
        !reconstruction.ExistsCamera(constraint.camera_id2)) {
      continue;
    }
    // Pairs between two cameras with priors say nothing about the unknowns;
    // their geometry is checked by the relative-pose stage instead.
    if (!camera_is_free(constraint.camera_id1) &&
        !camera_is_free(constraint.camera_id2)) {
      continue;
    }
    const colmap::Camera& camera1 =
        reconstruction.Camera(constraint.camera_id1);
    const colmap::Camera& camera2 =
        reconstruction.Camera(constraint.camera_id2);
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
    // Cameras of one group have identical parameters, so s and the
    // principal point are the group's.
    const colmap::camera_t group1 = group_of.at(constraint.camera_id1);
    const colmap::camera_t group2 = group_of.at(constraint.camera_id2);
    reference_focals[group1] = s1;
    reference_focals[group2] = s2;
    phis.emplace(group1, 1.0);
    phis.emplace(group2, 1.0);
    constraints.push_back(constraint);
  }

  return problem;
}

// Solves the focal problem: two solves, since from the initial guess (often
// 20-50% off) every residual lies in the flat tail of the narrow Cauchy
// loss, where the steps stall, so a wide loss first brings the focals near
// the optimum, and the narrow one then fits them while ignoring
// inconsistent pairs. Cameras with a focal prior are held.
Status SolveFocals(const ViewGraphCalibrationOptions& options,
                   const CameraGroups& group_of,
                   const colmap::Reconstruction& reconstruction,
                   const Interrupt& interrupt, FocalProblem* focal_problem) {
  auto camera_is_free = [&](colmap::camera_t camera_id) {
    return CameraIsFree(reconstruction, camera_id);
  };
  std::map<colmap::camera_t, double>& phis = focal_problem->phis;
  const std::vector<PairConstraint>& constraints = focal_problem->constraints;
  ceres::Problem problem;
  ceres::LossFunctionWrapper* loss = new ceres::LossFunctionWrapper(
      new ceres::CauchyLoss(
          std::max(options.coarse_loss_scale, options.loss_scale)),
      ceres::TAKE_OWNERSHIP);
  for (const PairConstraint& constraint : constraints) {
    const colmap::camera_t group1 = group_of.at(constraint.camera_id1);
    const colmap::camera_t group2 = group_of.at(constraint.camera_id2);
    if (group1 == group2) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SharedCameraFocalCost, 2, 1>(
              new SharedCameraFocalCost(constraint.coeffs)),
          loss, &phis[group1]);
    } else {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<TwoCameraFocalCost, 2, 1, 1>(
              new TwoCameraFocalCost(constraint.coeffs)),
          loss, &phis[group1], &phis[group2]);
    }
  }
  size_t num_free_cameras = 0;
  for (auto& [camera_id, phi] : phis) {
    if (camera_is_free(camera_id)) {
      ++num_free_cameras;
      // Keeps phi^2 away from zero (relative residuals divide by it).
      problem.SetParameterLowerBound(&phi, 0, kMinNormalisedFocal);
    } else {
      problem.SetParameterBlockConstant(&phi);
    }
  }

  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads =
      CeresNumThreads(options.num_threads, problem.NumResidualBlocks(),
                      options.min_residuals_per_ceres_thread);
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  InterruptCallback interrupt_callback(interrupt);
  solver_options.callbacks.push_back(&interrupt_callback);
  // One scalar per camera: dense is exact and robust for small problems
  // (see min_num_free_cameras_sparse); large ones need the sparse structure.
  if (num_free_cameras <
      static_cast<size_t>(options.min_num_free_cameras_sparse)) {
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
       {std::max(options.coarse_loss_scale, options.loss_scale),
        options.loss_scale}) {
    loss->Reset(new ceres::CauchyLoss(loss_scale), ceres::TAKE_OWNERSHIP);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    if (interrupt.IsStopped()) return Status::Cancelled();
    if (!summary.IsSolutionUsable()) {
      return Status::Error("View-graph calibration failed: " + summary.message);
    }
  }

  return Status::Ok();
}

// Accepts the plausible focals (within [min_focal_ratio, max_focal_ratio]
// of the old one); a rejected camera keeps its old focal, which is also
// what its pairs are judged against.
void AcceptFocals(const ViewGraphCalibrationOptions& options,
                  const CameraGroups& group_of, FocalProblem* focal_problem,
                  colmap::Reconstruction* reconstruction) {
  auto camera_is_free = [&](colmap::camera_t camera_id) {
    return CameraIsFree(*reconstruction, camera_id);
  };
  const auto members = GroupMembers(group_of);
  std::map<colmap::camera_t, double>& phis = focal_problem->phis;
  const std::map<colmap::camera_t, double>& reference_focals =
      focal_problem->reference_focals;
  for (auto& [group, phi] : phis) {
    if (!camera_is_free(group)) {
      continue;
    }
    const double old_focal = reconstruction->Camera(group).MeanFocalLength();
    const double new_focal = phi * reference_focals.at(group);
    const double ratio = new_focal / old_focal;
    if (!std::isfinite(ratio) || ratio < options.min_focal_ratio ||
        ratio > options.max_focal_ratio) {
      phi = 1.0;
      continue;
    }
    VLOG(3) << "View-graph calibration: camera " << group << " ("
            << members.at(group).size() << " identical) focal " << old_focal
            << " -> " << new_focal << " px";
    SetGroupFocal(members, group, new_focal, reconstruction);
  }
}

// Judges every pair at the final focals with the equations best conditioned
// there (the solve picked them at the initial focals), so that the decision
// equals FundamentalMatrixFocalResiduals at the result: pairs beyond
// max_two_view_error are invalidated. Returns their number.
size_t InvalidateInconsistentPairs(
    const ViewGraphCalibrationOptions& options, const CameraGroups& group_of,
    const FocalProblem& focal_problem,
    const colmap::Reconstruction& reconstruction) {
  const std::map<colmap::camera_t, double>& phis = focal_problem.phis;
  const std::map<colmap::camera_t, double>& reference_focals =
      focal_problem.reference_focals;
  size_t num_invalidated = 0;
  for (const PairConstraint& constraint : focal_problem.constraints) {
    const colmap::Camera& camera1 =
        reconstruction.Camera(constraint.camera_id1);
    const colmap::Camera& camera2 =
        reconstruction.Camera(constraint.camera_id2);
    Eigen::Vector2d residuals;
    if (!FundamentalMatrixFocalResiduals(
            constraint.pair->F,
            Eigen::Vector2d(camera1.PrincipalPointX(),
                            camera1.PrincipalPointY()),
            Eigen::Vector2d(camera2.PrincipalPointX(),
                            camera2.PrincipalPointY()),
            phis.at(group_of.at(constraint.camera_id1)) *
                reference_focals.at(group_of.at(constraint.camera_id1)),
            phis.at(group_of.at(constraint.camera_id2)) *
                reference_focals.at(group_of.at(constraint.camera_id2)),
            &residuals) ||
        !(residuals.norm() <= options.max_two_view_error)) {
      constraint.pair->is_valid = false;
      ++num_invalidated;
    }
  }
  return num_invalidated;
}

}  // namespace

Status ViewGraphCalibrationOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("min_focal_ratio", min_focal_ratio, 0);
  check.GreaterThanField("max_focal_ratio", max_focal_ratio, "min_focal_ratio",
                         min_focal_ratio);
  check.GreaterThan("max_two_view_error", max_two_view_error, 0);
  check.GreaterThan("loss_scale", loss_scale, 0);
  check.GreaterThan("coarse_loss_scale", coarse_loss_scale, 0);
  check.AtLeast("max_num_iterations", max_num_iterations, 0);
  check.AtLeast("function_tolerance", function_tolerance, 0);
  check.AtLeast("min_num_free_cameras_sparse", min_num_free_cameras_sparse, 0);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  check.AtLeast("min_residuals_per_ceres_thread",
                min_residuals_per_ceres_thread, 1);
  check.AtLeast("multi_view_num_images", multi_view_num_images, 0);
  check.AtLeast("multi_view_min_rotation_bias_deg",
                multi_view_min_rotation_bias_deg, 0);
  check.AtLeast("multi_view_min_num_matches", multi_view_min_num_matches, 1);
  check.AtLeast("multi_view_min_num_images_per_camera",
                multi_view_min_num_images_per_camera, 2);
  check.AtLeast("multi_view_max_num_keypoints_per_image",
                multi_view_max_num_keypoints_per_image, 1);
  check.AtLeast("multi_view_max_num_init_attempts",
                multi_view_max_num_init_attempts, 1);
  check.AtLeast("multi_view_num_init_relaxations",
                multi_view_num_init_relaxations, 1);
  check.InRange("multi_view_min_model_ratio", multi_view_min_model_ratio, 0, 1);
  check.AtLeast("multi_view_num_global_refinements",
                multi_view_num_global_refinements, 1);
  check.GreaterThan("multi_view_max_epipolar_error_px",
                    multi_view_max_epipolar_error_px, 0);
  return check.status();
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
                          ViewGraph* view_graph, size_t* num_invalidated_pairs,
                          const Interrupt& interrupt) {
  if (num_invalidated_pairs != nullptr) {
    *num_invalidated_pairs = 0;
  }
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid view-graph calibration options: " +
                         check.message());
  }

  // One unknown focal per calibration group (IdenticalCameraGroups), each
  // group named by its smallest camera id.
  CameraGroups group_of;
  if (options.calibrate_identical_cameras_as_one) {
    group_of = IdenticalCameraGroups(*reconstruction);
  } else {
    for (const auto& [camera_id, camera] : reconstruction->Cameras()) {
      group_of.emplace(camera_id, camera_id);
    }
  }
  // The free cameras as they are on entry: the small reconstruction starts
  // from them, not from the fundamental matrices' estimate.
  std::map<colmap::camera_t, colmap::Camera> initial_cameras;
  for (const auto& [camera_id, camera] : reconstruction->Cameras()) {
    if (CameraIsFree(*reconstruction, camera_id)) {
      initial_cameras.emplace(camera_id, camera);
    }
  }

  FocalProblem focal_problem =
      CollectConstraints(group_of, *reconstruction, view_graph);
  if (focal_problem.constraints.empty()) {
    CalibrateFromSmallReconstruction(options, *view_graph, initial_cameras,
                                     group_of, reconstruction, interrupt);
    return interrupt.IsStopped() ? Status::Cancelled() : Status::Ok();
  }
  if (const Status status = SolveFocals(options, group_of, *reconstruction,
                                        interrupt, &focal_problem);
      !status.ok()) {
    return status;
  }
  AcceptFocals(options, group_of, &focal_problem, reconstruction);
  std::map<colmap::camera_t, double>& phis = focal_problem.phis;
  const std::map<colmap::camera_t, double>& reference_focals =
      focal_problem.reference_focals;
  // Where the fundamental matrices do not determine the focal, a small
  // reconstruction does (see the header).
  for (const colmap::camera_t group :
       CalibrateFromSmallReconstruction(options, *view_graph, initial_cameras,
                                        group_of, reconstruction, interrupt)) {
    const auto phi = phis.find(group);
    if (phi != phis.end()) {
      phi->second = reconstruction->Camera(group).MeanFocalLength() /
                    reference_focals.at(group);
    }
  }

  if (interrupt.IsStopped()) return Status::Cancelled();
  const size_t num_invalidated = InvalidateInconsistentPairs(
      options, group_of, focal_problem, *reconstruction);
  if (num_invalidated_pairs != nullptr) {
    *num_invalidated_pairs = num_invalidated;
  }
  return Status::Ok();
}

}  // namespace glomap
