// Camera position priors inside the solve (issue 12): the prior term that
// global positioning and bundle adjustment add, the robust similarity that
// brings global positioning's free frame into the prior frame, and the test
// whether a set of priors fixes a similarity at all.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/priors/position_priors.h"
#include "glomap/util/status.h"

namespace glomap {

// The priors as a solve uses them: one residual (c - p) / std_m per axis on
// the camera centre c of every image listed, under a Cauchy loss of scale
// loss_scale_std (in standard deviations), so that a prior far off pulls
// less and less instead of bending the model.
struct PositionPriorTerm {
  // Camera centre priors in the solve's frame [m]; images not listed (no
  // prior, or a rejected one) take part without a prior.
  std::unordered_map<colmap::image_t, Eigen::Vector3d> center_in_frame;
  // One standard deviation of a prior, every axis [m].
  double std_m = 1.0;
  // Cauchy scale of the loss on the residual's norm [std].
  double loss_scale_std = 3.0;
  // Global positioning rejects a prior farther than this from its aligned
  // camera [std] (see PositionPriorOptions::prior_max_error_std).
  double max_error_std = 5.0;

  bool empty() const { return center_in_frame.empty(); }
  double MaxErrorM() const { return max_error_std * std_m; }
};

// The term of `priors` with the weights of `options`.
PositionPriorTerm MakePositionPriorTerm(const PositionPriors& priors,
                                        const PositionPriorOptions& options);

// Whether camera centre priors at `positions` fix the 7 degrees of freedom
// of a similarity: at least three, and not on one line (a turn about the
// line would leave them in place). The test is PreparePositionPriors' (RMS
// distance from the best-fitting line above 1e-4 of the RMS spread along
// it); priors it accepted can fail it here when wrong ones were left out.
bool PriorsFixSimilarity(const std::vector<Eigen::Vector3d>& positions);

// x_prior = scale * rotation * x_model + translation.
struct PriorAlignment {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  // Images whose aligned centre lies within the inlier threshold of its
  // prior, and the others; sorted by id.
  std::vector<colmap::image_t> inlier_image_ids;
  std::vector<colmap::image_t> outlier_image_ids;

  Eigen::Vector3d Apply(const Eigen::Vector3d& x_model) const {
    return scale * rotation * x_model + translation;
  }
};

// Similarity from model camera centres to their priors (images present in
// both maps), robust to wrong priors: RANSAC over 3-point samples (Umeyama,
// Eigen's closed form) scored by the number of priors within
// `inlier_threshold_m` of their aligned centre, then least squares on the
// inliers, repeated while the inlier set grows. The model frame's scale is
// unknown, so the threshold is applied in the prior frame (metres), after
// each candidate similarity. Deterministic for a given `random_seed` (COLMAP
// 3.8's RANSAC draws from a thread-local generator shared with every other
// caller on the thread). Fails when fewer than three images have both, or
// when the inliers of the best sample do not fix a similarity.
Status AlignCentersToPriors(
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& centers,
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& priors,
    double inlier_threshold_m, int random_seed, PriorAlignment* alignment);

// The similarity that minimises the prior term of `priors` (the Cauchy loss
// on |scale * rotation * c + translation - p| / std, summed over the
// registered images of `reconstruction` with a prior) over the model's
// frame, its shape held: iteratively reweighted least squares with the
// Cauchy weights (weighted Umeyama), from the current frame. Bundle
// adjustment converges along these 7 directions only slowly (only the
// priors see them, and Levenberg-Marquardt damps them by the stiff
// reprojection terms), so this takes the step in closed form. False when
// fewer than three priors, or they do not fix a similarity.
bool FitSimilarityToPriors(const colmap::Reconstruction& reconstruction,
                           const PositionPriorTerm& priors,
                           PriorAlignment* alignment);

// Applies x -> scale * rotation * x + translation to every registered
// image's pose and every 3D point (colmap::Reconstruction::Transform).
void TransformReconstruction(const PriorAlignment& alignment,
                             colmap::Reconstruction* reconstruction);

// Registered images whose camera centre is farther than `max_error_m` from
// their prior, sorted by id.
std::vector<colmap::image_t> ImagesFartherFromPrior(
    const colmap::Reconstruction& reconstruction,
    const std::unordered_map<colmap::image_t, Eigen::Vector3d>& priors,
    double max_error_m);

// The priors' noise, one standard deviation per axis [m], from the
// distances between cameras and their priors: the median distance divided by
// 1.5382, the median distance of a 3-D isotropic Gaussian of unit deviation
// from its mean (chi distribution, 3 degrees of freedom). The median keeps
// wrong priors out while they are a minority (10% of them move it by about
// 7%). NaN for fewer than kMinPriorsForNoiseEstimate distances.
constexpr size_t kMinPriorsForNoiseEstimate = 5;
double EstimatePriorNoiseStdM(std::vector<double> distances_m);

// "a.png, b.png, ..." of the images' names, in the given order.
std::string ImageNames(const colmap::Reconstruction& reconstruction,
                       const std::vector<colmap::image_t>& image_ids);

}  // namespace glomap
