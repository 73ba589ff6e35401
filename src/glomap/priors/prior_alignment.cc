#include "glomap/priors/prior_alignment.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "base/pose.h"
#include "base/similarity_transform.h"

namespace glomap {
namespace {

// RANSAC effort: 3-point samples until a sample free of wrong priors has
// been drawn with this confidence (at the best inlier ratio so far), within
// these bounds. At 10% wrong priors 20 samples would do; at 50%, 70. The
// floor guards against a lucky early sample on a bent model, the cap keeps
// the cost negligible next to global positioning.
constexpr double kRansacConfidence = 0.9999;
constexpr int kRansacMinNumTrials = 100;
constexpr int kRansacMaxNumTrials = 2000;
// Least-squares refits on the inliers after a new best sample, at most.
constexpr int kMaxNumLocalRefits = 10;
// Reweightings of FitSimilarityToPriors at most, and the largest change of
// a Cauchy weight (in [0, 1]) at which they stop.
constexpr int kMaxNumReweightings = 50;
constexpr double kWeightChangeTolerance = 1e-6;
// Positions whose RMS distance from their best-fitting line is at most this
// fraction of their RMS spread along it are collinear: the threshold of
// PreparePositionPriors (position_priors.cc), so that both agree.
constexpr double kCollinearRelativeSpread = 1e-4;

bool Umeyama(const std::vector<Eigen::Vector3d>& src,
             const std::vector<Eigen::Vector3d>& dst,
             const std::vector<size_t>& indices, PriorAlignment* alignment) {
  Eigen::Matrix3Xd src_mat(3, indices.size());
  Eigen::Matrix3Xd dst_mat(3, indices.size());
  for (size_t k = 0; k < indices.size(); ++k) {
    src_mat.col(k) = src[indices[k]];
    dst_mat.col(k) = dst[indices[k]];
  }
  const Eigen::Matrix4d transform = Eigen::umeyama(src_mat, dst_mat, true);
  if (!transform.allFinite()) return false;
  const Eigen::Matrix3d scaled_rotation = transform.topLeftCorner<3, 3>();
  const double scale = std::cbrt(scaled_rotation.determinant());
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  alignment->scale = scale;
  alignment->rotation = scaled_rotation / scale;
  alignment->translation = transform.topRightCorner<3, 1>();
  return true;
}

std::vector<size_t> Inliers(const std::vector<Eigen::Vector3d>& src,
                            const std::vector<Eigen::Vector3d>& dst,
                            const PriorAlignment& alignment, double threshold) {
  std::vector<size_t> inliers;
  for (size_t i = 0; i < src.size(); ++i) {
    if ((alignment.Apply(src[i]) - dst[i]).norm() <= threshold) {
      inliers.push_back(i);
    }
  }
  return inliers;
}

}  // namespace

PositionPriorTerm MakePositionPriorTerm(const PositionPriors& priors,
                                        const PositionPriorOptions& options) {
  PositionPriorTerm term;
  term.center_in_frame = priors.center_in_frame;
  term.std_m = options.prior_position_std_m;
  term.loss_scale_std = options.prior_loss_scale;
  term.max_error_std = options.prior_max_error_std;
  return term;
}

bool PriorsFixSimilarity(const std::vector<Eigen::Vector3d>& positions) {
  if (positions.size() < 3) return false;
  const Eigen::Vector3d variances = PrincipalVariances(positions);
  return variances(2) > 0 &&
         std::sqrt(variances(0) + variances(1)) >
             kCollinearRelativeSpread * std::sqrt(variances(2));
}

Status AlignCentersToPriors(
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& centers,
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& priors,
    double inlier_threshold_m, int random_seed, PriorAlignment* alignment) {
  if (!(inlier_threshold_m > 0)) {
    return Status::Error("Prior alignment: the inlier threshold must be > 0.");
  }
  // Pairs in image-id order, so that the samples do not depend on the hash
  // maps' order.
  std::vector<colmap::image_t> image_ids;
  for (const auto& [image_id, center] : centers) {
    if (priors.count(image_id) > 0 && center.allFinite() &&
        priors.at(image_id).allFinite()) {
      image_ids.push_back(image_id);
    }
  }
  std::sort(image_ids.begin(), image_ids.end());
  if (image_ids.size() < 3) {
    return Status::Error(
        "Prior alignment: fewer than three registered images have a prior.");
  }
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (const colmap::image_t image_id : image_ids) {
    src.push_back(centers.at(image_id));
    dst.push_back(priors.at(image_id));
  }

  const size_t num_pairs = src.size();
  std::mt19937 rng(random_seed);
  std::uniform_int_distribution<size_t> pick(0, num_pairs - 1);
  PriorAlignment best;
  std::vector<size_t> best_inliers;
  int num_trials_needed = kRansacMaxNumTrials;
  for (int trial = 0; trial < std::min(num_trials_needed, kRansacMaxNumTrials);
       ++trial) {
    std::vector<size_t> sample;
    while (sample.size() < 3) {
      const size_t index = pick(rng);
      if (std::find(sample.begin(), sample.end(), index) == sample.end()) {
        sample.push_back(index);
      }
    }
    PriorAlignment candidate;
    if (!Umeyama(src, dst, sample, &candidate)) continue;
    std::vector<size_t> inliers =
        Inliers(src, dst, candidate, inlier_threshold_m);
    if (inliers.size() <= best_inliers.size()) continue;
    // Local optimisation: the minimal sample extrapolates its own noise over
    // the whole model; a fit on all its inliers does not.
    for (int refit = 0; refit < kMaxNumLocalRefits && inliers.size() >= 3;
         ++refit) {
      PriorAlignment refined;
      if (!Umeyama(src, dst, inliers, &refined)) break;
      std::vector<size_t> refined_inliers =
          Inliers(src, dst, refined, inlier_threshold_m);
      if (refined_inliers.size() < inliers.size()) break;
      const bool same = refined_inliers == inliers;
      candidate = refined;
      inliers = std::move(refined_inliers);
      if (same) break;
    }
    if (inliers.size() <= best_inliers.size()) continue;
    best = candidate;
    best_inliers = std::move(inliers);
    const double inlier_ratio =
        static_cast<double>(best_inliers.size()) / num_pairs;
    const double all_inlier_probability = std::pow(inlier_ratio, 3);
    if (all_inlier_probability >= 1) break;
    num_trials_needed = std::max(
        kRansacMinNumTrials,
        static_cast<int>(std::ceil(std::log(1 - kRansacConfidence) /
                                   std::log(1 - all_inlier_probability))));
  }

  std::vector<Eigen::Vector3d> inlier_priors;
  for (const size_t index : best_inliers) inlier_priors.push_back(dst[index]);
  if (best_inliers.size() < 3 || !PriorsFixSimilarity(inlier_priors)) {
    return Status::Error(
        "Prior alignment: no similarity brings three non-collinear camera "
        "centres within " +
        std::to_string(inlier_threshold_m) + " m of their priors.");
  }
  *alignment = best;
  alignment->inlier_image_ids.clear();
  alignment->outlier_image_ids.clear();
  size_t next_inlier = 0;
  for (size_t i = 0; i < num_pairs; ++i) {
    if (next_inlier < best_inliers.size() && best_inliers[next_inlier] == i) {
      alignment->inlier_image_ids.push_back(image_ids[i]);
      ++next_inlier;
    } else {
      alignment->outlier_image_ids.push_back(image_ids[i]);
    }
  }
  return Status::Ok();
}

bool FitSimilarityToPriors(const colmap::Reconstruction& reconstruction,
                           const PositionPriorTerm& priors,
                           PriorAlignment* alignment) {
  std::vector<colmap::image_t> image_ids = reconstruction.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  std::vector<Eigen::Vector3d> centers;
  std::vector<Eigen::Vector3d> targets;
  for (const colmap::image_t image_id : image_ids) {
    const auto prior = priors.center_in_frame.find(image_id);
    if (prior == priors.center_in_frame.end()) continue;
    centers.push_back(reconstruction.Image(image_id).ProjectionCenter());
    targets.push_back(prior->second);
  }
  if (!PriorsFixSimilarity(targets) || !(priors.std_m > 0) ||
      !(priors.loss_scale_std > 0)) {
    return false;
  }
  const double inv_loss_variance_m2 =
      1 / std::pow(priors.loss_scale_std * priors.std_m, 2);
  PriorAlignment fit;  // Identity: the current frame.
  std::vector<double> weights(centers.size());
  for (int iteration = 0; iteration < kMaxNumReweightings; ++iteration) {
    // Cauchy weights rho'(s) = 1 / (1 + s / a^2) at the current residuals.
    double max_weight_change = 0;
    for (size_t i = 0; i < centers.size(); ++i) {
      const double weight =
          1 / (1 + (fit.Apply(centers[i]) - targets[i]).squaredNorm() *
                       inv_loss_variance_m2);
      max_weight_change =
          std::max(max_weight_change, std::abs(weight - weights[i]));
      weights[i] = weight;
    }
    if (iteration > 0 && max_weight_change < kWeightChangeTolerance) break;
    // Weighted Umeyama (Umeyama, PAMI 1991, with weights in every sum).
    double weight_sum = 0;
    Eigen::Vector3d center_mean = Eigen::Vector3d::Zero();
    Eigen::Vector3d target_mean = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < centers.size(); ++i) {
      weight_sum += weights[i];
      center_mean += weights[i] * centers[i];
      target_mean += weights[i] * targets[i];
    }
    center_mean /= weight_sum;
    target_mean /= weight_sum;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    double center_variance = 0;
    for (size_t i = 0; i < centers.size(); ++i) {
      covariance += weights[i] * (targets[i] - target_mean) *
                    (centers[i] - center_mean).transpose();
      center_variance += weights[i] * (centers[i] - center_mean).squaredNorm();
    }
    if (!(center_variance > 0)) return false;
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
        covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Vector3d signs = Eigen::Vector3d::Ones();
    if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) {
      signs(2) = -1;
    }
    fit.rotation =
        svd.matrixU() * signs.asDiagonal() * svd.matrixV().transpose();
    fit.scale = svd.singularValues().dot(signs) / center_variance;
    fit.translation = target_mean - fit.scale * fit.rotation * center_mean;
    if (!(fit.scale > 0) || !fit.rotation.allFinite() ||
        !fit.translation.allFinite()) {
      return false;
    }
  }
  *alignment = fit;
  return true;
}

void TransformReconstruction(const PriorAlignment& alignment,
                             colmap::Reconstruction* reconstruction) {
  const colmap::SimilarityTransform3 transform(
      alignment.scale, colmap::RotationMatrixToQuaternion(alignment.rotation),
      alignment.translation);
  reconstruction->Transform(transform);
}

std::vector<colmap::image_t> ImagesFartherFromPrior(
    const colmap::Reconstruction& reconstruction,
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& priors,
    double max_error_m) {
  std::vector<colmap::image_t> image_ids;
  for (const colmap::image_t image_id : reconstruction.RegImageIds()) {
    const auto prior = priors.find(image_id);
    if (prior == priors.end()) continue;
    const Eigen::Vector3d center =
        reconstruction.Image(image_id).ProjectionCenter();
    if (!((center - prior->second).norm() <= max_error_m)) {
      image_ids.push_back(image_id);
    }
  }
  std::sort(image_ids.begin(), image_ids.end());
  return image_ids;
}

double EstimatePriorNoiseStdM(std::vector<double> distances_m) {
  if (distances_m.size() < kMinPriorsForNoiseEstimate) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // Median of the chi distribution with 3 degrees of freedom: the square
  // root of chi-square(3)'s median, 2.36597.
  constexpr double kChi3Median = 1.53817;
  const auto middle = distances_m.begin() + distances_m.size() / 2;
  std::nth_element(distances_m.begin(), middle, distances_m.end());
  return *middle / kChi3Median;
}

std::string ImageNames(const colmap::Reconstruction& reconstruction,
                       const std::vector<colmap::image_t>& image_ids) {
  std::ostringstream names;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    if (i > 0) names << ", ";
    names << reconstruction.Image(image_ids[i]).Name();
  }
  return names.str();
}

}  // namespace glomap
