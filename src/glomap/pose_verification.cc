#include "glomap/pose_verification.h"

#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "base/pose.h"
#include "estimators/absolute_pose.h"
#include "estimators/pose.h"
#include "glomap/parallel_for.h"
#include "optim/loransac.h"
#include "util/random.h"

namespace glomap {
namespace {

using Outcome = PoseVerificationResult::Outcome;

// One 2D-3D correspondence of the image being checked.
struct Correspondence {
  colmap::point2D_t point2D_idx;
  colmap::point3D_t point3D_id;

  bool operator<(const Correspondence& other) const {
    return std::tie(point2D_idx, point3D_id) <
           std::tie(other.point2D_idx, other.point3D_id);
  }
  bool operator==(const Correspondence& other) const {
    return point2D_idx == other.point2D_idx && point3D_id == other.point3D_id;
  }
};

// What the parallel part computes per image; applied serially afterwards.
struct Check {
  PoseVerificationResult result;
  std::vector<Correspondence> correspondences;
  // The refined RANSAC pose and its inliers (parallel to correspondences).
  Eigen::Vector4d qvec = Eigen::Vector4d(1, 0, 0, 0);
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  std::vector<char> estimate_inliers;
};

// Median distance of the registered camera centres from their
// coordinate-wise median: the scene size of the comparisons.
double SceneSize(const colmap::Reconstruction& reconstruction,
                 const std::vector<colmap::image_t>& image_ids) {
  if (image_ids.empty()) return 1;
  std::vector<Eigen::Vector3d> centers;
  centers.reserve(image_ids.size());
  for (const colmap::image_t image_id : image_ids) {
    centers.push_back(reconstruction.Image(image_id).ProjectionCenter());
  }
  Eigen::Vector3d median;
  std::vector<double> values(centers.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (size_t i = 0; i < centers.size(); ++i) values[i] = centers[i][axis];
    std::nth_element(values.begin(), values.begin() + values.size() / 2,
                     values.end());
    median[axis] = values[values.size() / 2];
  }
  for (size_t i = 0; i < centers.size(); ++i) {
    values[i] = (centers[i] - median).norm();
  }
  std::nth_element(values.begin(), values.begin() + values.size() / 2,
                   values.end());
  const double size = values[values.size() / 2];
  return size > 0 ? size : 1;
}

// Whether the point reprojects within `max_error_px` under the pose.
bool IsInlier(const colmap::Camera& camera, const Eigen::Matrix3x4d& pose,
              const Eigen::Vector2d& xy, const Eigen::Vector3d& xyz,
              double max_error_px) {
  const Eigen::Vector3d in_camera = pose * xyz.homogeneous();
  if (!(in_camera.z() > std::numeric_limits<double>::epsilon())) return false;
  const Eigen::Vector2d projected =
      camera.WorldToImage(in_camera.hnormalized());
  return (projected - xy).squaredNorm() <= max_error_px * max_error_px;
}

size_t CountInliers(const colmap::Camera& camera, const Eigen::Matrix3x4d& pose,
                    const std::vector<Eigen::Vector2d>& points2D,
                    const std::vector<Eigen::Vector3d>& points3D,
                    double max_error_px, std::vector<char>* inliers) {
  inliers->assign(points2D.size(), 0);
  size_t num_inliers = 0;
  for (size_t k = 0; k < points2D.size(); ++k) {
    if (IsInlier(camera, pose, points2D[k], points3D[k], max_error_px)) {
      (*inliers)[k] = 1;
      ++num_inliers;
    }
  }
  return num_inliers;
}

std::string DescribeChange(const PoseVerificationResult& r,
                           const PoseVerificationOptions& options) {
  std::ostringstream out;
  out << std::setprecision(3);
  if (r.outcome == Outcome::kReplaced) {
    out << "its pose explains " << r.num_current_inliers << " of "
        << r.num_correspondences
        << " correspondences to points seen by other images, the re-estimated "
           "pose "
        << r.num_estimate_inliers << " (rotation differs by "
        << r.rotation_difference_deg << " deg, centre by "
        << r.center_distance_ratio << " of the scene size)";
  } else {
    out << "its pose explains " << r.num_current_inliers << " of "
        << r.num_correspondences
        << " correspondences to points seen by other images and no pose "
           "explains more than "
        << r.num_estimate_inliers << " (needs " << options.min_num_inliers
        << " and " << 100 * options.min_inlier_ratio << "%)";
  }
  return out.str();
}

// Number of distinct registered, unsuspected images observing each point.
std::unordered_map<colmap::point3D_t, int> CountTrustedObservers(
    const colmap::Reconstruction& model,
    const std::unordered_map<colmap::image_t, char>& suspect_by_id) {
  std::unordered_map<colmap::point3D_t, int> counts;
  counts.reserve(model.NumPoints3D());
  std::vector<colmap::image_t> observers;
  for (const auto& [point3D_id, point3D] : model.Points3D()) {
    observers.clear();
    for (const colmap::TrackElement& element : point3D.Track().Elements()) {
      const auto it = suspect_by_id.find(element.image_id);
      if (it != suspect_by_id.end() && !it->second) {
        observers.push_back(element.image_id);
      }
    }
    std::sort(observers.begin(), observers.end());
    counts[point3D_id] = static_cast<int>(
        std::unique(observers.begin(), observers.end()) - observers.begin());
  }
  return counts;
}

bool Observes(const colmap::Reconstruction& model, colmap::point3D_t point3D_id,
              colmap::image_t image_id) {
  for (const colmap::TrackElement& element :
       model.Point3D(point3D_id).Track().Elements()) {
    if (element.image_id == image_id) return true;
  }
  return false;
}

// The image's 2D-3D correspondences: its own observations, and its keypoints
// matched to keypoints of other registered images that observe a point;
// only points that at least `min_point_support` trusted images other than
// this one observe.
std::vector<Correspondence> FindCorrespondences(
    const PoseVerificationOptions& options, const colmap::Reconstruction& model,
    colmap::image_t image_id, bool image_is_suspect,
    const std::vector<const ImagePair*>& pairs,
    const std::unordered_map<colmap::point3D_t, int>& num_trusted_observers) {
  const colmap::Image& image = model.Image(image_id);
  std::vector<Correspondence> correspondences;
  auto add = [&](colmap::point2D_t point2D_idx, colmap::point3D_t point3D_id,
                 bool observed_by_image) {
    const int support = num_trusted_observers.at(point3D_id) -
                        (observed_by_image && !image_is_suspect ? 1 : 0);
    if (support >= options.min_point_support) {
      correspondences.push_back({point2D_idx, point3D_id});
    }
  };
  for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
    const colmap::Point2D& point2D = image.Point2D(idx);
    if (point2D.HasPoint3D()) add(idx, point2D.Point3DId(), true);
  }
  for (const ImagePair* pair : pairs) {
    const bool is_first = pair->image_id1 == image_id;
    const colmap::Image& other =
        model.Image(is_first ? pair->image_id2 : pair->image_id1);
    for (const colmap::FeatureMatch& match : pair->matches) {
      const colmap::point2D_t own_idx =
          is_first ? match.point2D_idx1 : match.point2D_idx2;
      const colmap::point2D_t other_idx =
          is_first ? match.point2D_idx2 : match.point2D_idx1;
      if (own_idx >= image.NumPoints2D() || other_idx >= other.NumPoints2D()) {
        continue;
      }
      const colmap::Point2D& other_point2D = other.Point2D(other_idx);
      if (!other_point2D.HasPoint3D()) continue;
      const colmap::point3D_t point3D_id = other_point2D.Point3DId();
      const colmap::Point2D& own_point2D = image.Point2D(own_idx);
      if (own_point2D.HasPoint3D() && own_point2D.Point3DId() == point3D_id) {
        continue;  // Already an own observation.
      }
      add(own_idx, point3D_id, Observes(model, point3D_id, image_id));
    }
  }
  std::sort(correspondences.begin(), correspondences.end());
  correspondences.erase(
      std::unique(correspondences.begin(), correspondences.end()),
      correspondences.end());
  return correspondences;
}

// Inliers of the current pose, and the best pose RANSAC finds (refined on
// its inliers, intrinsics fixed) with its inliers.
void CheckImage(const PoseVerificationOptions& options,
                const colmap::Reconstruction& model, double scene_size,
                Check* check) {
  const colmap::image_t image_id = check->result.image_id;
  const colmap::Image& image = model.Image(image_id);
  const colmap::Camera& camera = model.Camera(image.CameraId());
  PoseVerificationResult& result = check->result;
  result.num_correspondences = check->correspondences.size();
  std::vector<Eigen::Vector2d> points2D;
  std::vector<Eigen::Vector3d> points3D;
  points2D.reserve(check->correspondences.size());
  points3D.reserve(check->correspondences.size());
  for (const Correspondence& c : check->correspondences) {
    points2D.push_back(image.Point2D(c.point2D_idx).XY());
    points3D.push_back(model.Point3D(c.point3D_id).XYZ());
  }
  std::vector<char> current_inliers;
  result.num_current_inliers =
      CountInliers(camera, image.ProjectionMatrix(), points2D, points3D,
                   options.max_reproj_error_px, &current_inliers);
  if (points2D.size() <
      static_cast<size_t>(colmap::P3PEstimator::kMinNumSamples)) {
    return;
  }
  std::vector<Eigen::Vector2d> normalized(points2D.size());
  for (size_t i = 0; i < points2D.size(); ++i) {
    normalized[i] = camera.ImageToWorld(points2D[i]);
  }
  // COLMAP's RANSAC samples from a thread-local PRNG: seeding it per image
  // makes the result independent of the thread that checks the image.
  colmap::SetPRNGSeed(static_cast<unsigned>(options.random_seed) ^
                      static_cast<unsigned>(image_id * 2654435761u));
  colmap::RANSACOptions ransac_options;
  ransac_options.max_error =
      camera.ImageToWorldThreshold(options.max_reproj_error_px);
  ransac_options.confidence = options.ransac_confidence;
  ransac_options.max_num_trials = options.ransac_max_num_trials;
  ransac_options.min_inlier_ratio = 0.1;
  colmap::LORANSAC<colmap::P3PEstimator, colmap::EPNPEstimator> ransac(
      ransac_options);
  const auto report = ransac.Estimate(normalized, points3D);
  if (!report.success || !report.model.allFinite()) return;

  check->qvec = colmap::RotationMatrixToQuaternion(report.model.leftCols<3>());
  check->tvec = report.model.col(3);
  colmap::AbsolutePoseRefinementOptions refinement;
  refinement.refine_focal_length = false;
  refinement.refine_extra_params = false;
  refinement.print_summary = false;
  colmap::Camera camera_copy = camera;
  Eigen::Vector4d qvec = check->qvec;
  Eigen::Vector3d tvec = check->tvec;
  if (colmap::RefineAbsolutePose(refinement, report.inlier_mask, points2D,
                                 points3D, &qvec, &tvec, &camera_copy) &&
      qvec.allFinite() && tvec.allFinite()) {
    check->qvec = qvec.normalized();
    check->tvec = tvec;
  }
  const Eigen::Matrix3x4d estimate =
      colmap::ComposeProjectionMatrix(check->qvec, check->tvec);
  result.num_estimate_inliers =
      CountInliers(camera, estimate, points2D, points3D,
                   options.max_reproj_error_px, &check->estimate_inliers);
  const Eigen::Matrix3d current_rotation = image.RotationMatrix();
  const Eigen::Matrix3d estimate_rotation =
      colmap::QuaternionToRotationMatrix(check->qvec);
  const Eigen::AngleAxisd difference(estimate_rotation *
                                     current_rotation.transpose());
  result.rotation_difference_deg = colmap::RadToDeg(difference.angle());
  const Eigen::Vector3d estimate_center =
      -estimate_rotation.transpose() * check->tvec;
  result.center_distance_ratio =
      (estimate_center - image.ProjectionCenter()).norm() / scene_size;
}

std::vector<Check> CheckImages(
    const PoseVerificationOptions& options, const colmap::Reconstruction& model,
    const std::vector<colmap::image_t>& image_ids,
    const std::unordered_map<colmap::image_t, std::vector<const ImagePair*>>&
        pairs_of_image,
    const std::unordered_map<colmap::point3D_t, int>& num_trusted_observers,
    const std::unordered_map<colmap::image_t, char>& suspect_by_id,
    double scene_size) {
  static const std::vector<const ImagePair*> kNoPairs;
  std::vector<Check> checks(image_ids.size());
  ParallelFor(options.num_threads, image_ids.size(), [&](size_t k) {
    const colmap::image_t image_id = image_ids[k];
    const auto it = pairs_of_image.find(image_id);
    Check& check = checks[k];
    check.result.image_id = image_id;
    check.correspondences = FindCorrespondences(
        options, model, image_id, suspect_by_id.at(image_id),
        it == pairs_of_image.end() ? kNoPairs : it->second,
        num_trusted_observers);
    CheckImage(options, model, scene_size, &check);
  });
  return checks;
}

// Gives the image the checked estimate: observations that disagree with it
// are deleted (they would pull it back in bundle adjustment), and the
// inlier points it does not observe yet become observations.
void Replace(const PoseVerificationOptions& options, const Check& check,
             colmap::Reconstruction* reconstruction) {
  const colmap::image_t image_id = check.result.image_id;
  colmap::Image& image = reconstruction->Image(image_id);
  image.SetQvec(check.qvec);
  image.SetTvec(check.tvec);
  const colmap::Camera& camera = reconstruction->Camera(image.CameraId());
  const Eigen::Matrix3x4d pose = image.ProjectionMatrix();
  for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
    const colmap::Point2D& point2D = image.Point2D(idx);
    if (!point2D.HasPoint3D()) continue;
    const Eigen::Vector3d& xyz =
        reconstruction->Point3D(point2D.Point3DId()).XYZ();
    if (!IsInlier(camera, pose, point2D.XY(), xyz,
                  options.max_reproj_error_px)) {
      reconstruction->DeleteObservation(image_id, idx);
    }
  }
  for (size_t i = 0; i < check.correspondences.size(); ++i) {
    if (!check.estimate_inliers[i]) continue;
    const Correspondence& c = check.correspondences[i];
    if (image.Point2D(c.point2D_idx).HasPoint3D() ||
        !reconstruction->ExistsPoint3D(c.point3D_id) ||
        Observes(*reconstruction, c.point3D_id, image_id)) {
      continue;
    }
    reconstruction->AddObservation(
        c.point3D_id, colmap::TrackElement(image_id, c.point2D_idx));
  }
}

}  // namespace

bool PoseVerificationOptions::Check() const {
  return max_reproj_error_px > 0 && positioning_max_reproj_error_px > 0 &&
         min_point_support >= 1 && min_num_inliers >= 4 &&
         min_inlier_ratio >= 0 && min_inlier_ratio <= 1 &&
         min_inlier_fraction_of_estimate >= 0 &&
         min_inlier_fraction_of_estimate <= 1 && ransac_confidence > 0 &&
         ransac_confidence < 1 && ransac_max_num_trials > 0 &&
         max_rotation_difference_deg >= 0 && max_center_distance_ratio >= 0 &&
         max_num_rounds >= 1 && (num_threads == -1 || num_threads > 0);
}

Status VerifyPoses(const PoseVerificationOptions& options,
                   const ViewGraph& view_graph,
                   colmap::Reconstruction* reconstruction,
                   PoseVerificationSummary* summary,
                   const Interrupt& interrupt) {
  *summary = PoseVerificationSummary();
  if (!options.Check()) {
    return Status::Error("Invalid pose verification options.");
  }
  std::vector<colmap::image_t> image_ids = reconstruction->RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  const double scene_size = SceneSize(*reconstruction, image_ids);

  // Pairs between registered images, per image.
  std::unordered_map<colmap::image_t, std::vector<const ImagePair*>>
      pairs_of_image;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if ((!pair.is_valid && !options.use_all_pairs) ||
        !reconstruction->IsImageRegistered(pair.image_id1) ||
        !reconstruction->IsImageRegistered(pair.image_id2)) {
      continue;
    }
    pairs_of_image[pair.image_id1].push_back(&pair);
    pairs_of_image[pair.image_id2].push_back(&pair);
  }

  auto supported = [&options](size_t num_inliers, size_t num_correspondences) {
    return num_inliers >= static_cast<size_t>(options.min_num_inliers) &&
           num_inliers >= options.min_inlier_ratio * num_correspondences;
  };
  auto passes = [&](const PoseVerificationResult& result) {
    if (!supported(result.num_current_inliers, result.num_correspondences)) {
      return false;
    }
    const bool explains_enough =
        result.num_current_inliers >=
        options.min_inlier_fraction_of_estimate * result.num_estimate_inliers;
    const bool agrees =
        result.rotation_difference_deg <= options.max_rotation_difference_deg &&
        result.center_distance_ratio <= options.max_center_distance_ratio;
    return explains_enough || agrees;
  };

  // Images that fail are suspects; a point is evidence only through the
  // images that are not. Without this, a wrongly placed group of images
  // would pull its correctly placed neighbours along: their keypoints match
  // the group's points, which sit consistently in the group's wrong frame.
  // Repeated until the suspects no longer change (in practice one or two
  // rounds; the first has no suspect on a sound model).
  std::vector<char> is_suspect(image_ids.size(), 0);
  std::vector<Check> checks;
  for (int round = 0; round < options.max_num_rounds; ++round) {
    std::unordered_map<colmap::image_t, char> suspect_by_id;
    for (size_t k = 0; k < image_ids.size(); ++k) {
      suspect_by_id[image_ids[k]] = is_suspect[k];
    }
    const std::unordered_map<colmap::point3D_t, int> num_trusted_observers =
        CountTrustedObservers(*reconstruction, suspect_by_id);
    checks = CheckImages(options, *reconstruction, image_ids, pairs_of_image,
                         num_trusted_observers, suspect_by_id, scene_size);
    if (interrupt.IsStopped()) return Status::Cancelled();
    std::vector<char> fails(image_ids.size(), 0);
    for (size_t k = 0; k < checks.size(); ++k) {
      fails[k] = !passes(checks[k].result);
    }
    if (fails == is_suspect) break;
    is_suspect = fails;
  }

  for (Check& check : checks) {
    PoseVerificationResult& result = check.result;
    ++summary->num_checked;
    if (passes(result)) {
      ++summary->num_kept;
      continue;
    }
    const colmap::image_t image_id = result.image_id;
    const std::string& name = reconstruction->Image(image_id).Name();
    if (supported(result.num_estimate_inliers, result.num_correspondences) &&
        result.num_estimate_inliers > result.num_current_inliers) {
      result.outcome = Outcome::kReplaced;
      result.reason = DescribeChange(result, options);
      LOG(WARNING) << "Pose verification: image " << name
                   << " re-placed: " << result.reason << ".";
      Replace(options, check, reconstruction);
      ++summary->num_replaced;
    } else {
      result.outcome = Outcome::kDeregistered;
      result.reason = DescribeChange(result, options);
      LOG(WARNING) << "Pose verification: image " << name
                   << " left unregistered: " << result.reason << ".";
      reconstruction->DeRegisterImage(image_id);
      ++summary->num_deregistered;
    }
    summary->changed.push_back(result);
  }
  return Status::Ok();
}

}  // namespace glomap
