// The view graph: verified image pairs read from a COLMAP database, refined
// stage by stage (focal lengths, relative poses, rotation consistency).
// Pairs are kept in an ordered map keyed by COLMAP's pair id so that every
// stage iterates them in the same order on every run (determinism).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <map>
#include <unordered_set>
#include <vector>

#include "base/database_cache.h"
#include "base/image.h"
#include "feature/types.h"
#include "util/types.h"

namespace glomap {

// One image pair of the database, in COLMAP's canonical orientation
// (image_id1 < image_id2; matches hold point2D indices of image 1, image 2).
struct ImagePair {
  colmap::image_t image_id1 = colmap::kInvalidImageId;
  colmap::image_t image_id2 = colmap::kInvalidImageId;

  // Two-view configuration stored by the matcher
  // (colmap::TwoViewGeometry::ConfigurationType).
  int config = 0;

  // Two-view geometry from the database, column-major Eigen:
  // x2^T F x1 = 0 in pixels, x2^T E x1 = 0 in normalized image coordinates
  // (E is zero when a camera had no focal prior), x2 ~ H x1 in pixels.
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();

  // Number of raw (putative) matches in the database's `matches` table.
  int num_raw_matches = 0;

  // Geometrically verified matches (the database's two-view-geometry inliers).
  colmap::FeatureMatches matches;

  // Indices into `matches` that agree with the relative pose below, filled by
  // the relative-pose stage. Tracks are built from these only; the global
  // mapper frees them after that (ViewGraph::ReleaseInlierIdxs).
  std::vector<int> inlier_idxs;

  // Relative pose cam2_from_cam1: x_cam2 = R(qvec) x_cam1 + tvec, |tvec| = 1.
  // qvec is (w, x, y, z), COLMAP's order.
  Eigen::Vector4d qvec2_from_1 = Eigen::Vector4d(1, 0, 0, 0);
  Eigen::Vector3d tvec2_from_1 = Eigen::Vector3d::Zero();
  bool has_relative_pose = false;

  // False once a stage rejects the pair; invalid pairs are ignored by every
  // later stage but kept for retriangulation with the database matches.
  bool is_valid = true;
};

// The matches of one pair without out-of-range indices and without a second
// match of an already matched keypoint, as COLMAP's correspondence graph
// wants them (it would drop those too, printing one warning per match).
colmap::FeatureMatches CleanMatches(const colmap::FeatureMatches& matches,
                                    size_t num_points1, size_t num_points2);

// A copy of `source` as COLMAP's DatabaseCache holds images read from a
// database: id, name, camera and keypoints (no pose, no 3D points), for the
// in-memory caches that retriangulation and calibration build from the view
// graph instead of opening the database.
colmap::Image KeypointImage(const colmap::Image& source);

// The correspondence graph of a DatabaseCache that we fill ourselves. COLMAP
// only exposes it as const; the cache is our own non-const object, so
// writing to it through const_cast is well defined.
colmap::CorrespondenceGraph& MutableCorrespondenceGraph(
    colmap::DatabaseCache* cache);

class ViewGraph {
 public:
  static bool IsValid(const ImagePair& pair) { return pair.is_valid; }

  std::map<colmap::image_pair_t, ImagePair>& Pairs() { return pairs_; }
  const std::map<colmap::image_pair_t, ImagePair>& Pairs() const {
    return pairs_;
  }

  // Adds a pair (swapped into canonical orientation if needed) and returns it.
  ImagePair& AddPair(ImagePair pair);

  size_t NumPairs() const { return pairs_.size(); }
  size_t NumValidPairs() const;

  // Image ids that take part in at least one valid pair, sorted.
  std::vector<colmap::image_t> ImagesWithValidPairs() const;

  // The largest connected component of the graph of the pairs for which
  // `is_edge` holds (by default the valid pairs), as sorted image ids. Ties
  // are broken towards the component with the smallest id.
  std::vector<colmap::image_t> LargestConnectedComponent(
      const std::function<bool(const ImagePair&)>& is_edge = IsValid) const;

  // All connected components of the same graph, largest first, each sorted;
  // equal sizes keep the order of their smallest image id.
  std::vector<std::vector<colmap::image_t>> ConnectedComponents(
      const std::function<bool(const ImagePair&)>& is_edge = IsValid) const;

  // Marks every pair with an image outside `image_ids` as invalid; returns
  // the number of pairs newly invalidated.
  size_t InvalidatePairsOutside(
      const std::unordered_set<colmap::image_t>& image_ids);

  // Frees the inlier indices of every pair (ImagePair::inlier_idxs), once
  // the last stage that reads them (track establishment) is done.
  void ReleaseInlierIdxs();

 private:
  std::map<colmap::image_pair_t, ImagePair> pairs_;
};

}  // namespace glomap
