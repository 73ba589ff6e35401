#include "glomap/scene/view_graph.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <unordered_map>
#include <unordered_set>

#include "base/database.h"
#include "base/pose.h"
#include "glomap/util/union_find.h"

namespace glomap {
namespace {

// Image ids that take part in at least one pair for which `is_edge` holds,
// sorted.
std::vector<colmap::image_t> ImagesOfPairs(
    const std::map<colmap::image_pair_t, ImagePair>& pairs,
    const std::function<bool(const ImagePair&)>& is_edge) {
  std::vector<colmap::image_t> image_ids;
  for (const auto& [pair_id, pair] : pairs) {
    if (!is_edge(pair)) continue;
    image_ids.push_back(pair.image_id1);
    image_ids.push_back(pair.image_id2);
  }
  std::sort(image_ids.begin(), image_ids.end());
  image_ids.erase(std::unique(image_ids.begin(), image_ids.end()),
                  image_ids.end());
  return image_ids;
}

}  // namespace

colmap::Image KeypointImage(const colmap::Image& source) {
  colmap::Image image;
  image.SetImageId(source.ImageId());
  image.SetName(source.Name());
  image.SetCameraId(source.CameraId());
  std::vector<Eigen::Vector2d> points2D;
  points2D.reserve(source.NumPoints2D());
  for (const colmap::Point2D& point2D : source.Points2D()) {
    points2D.push_back(point2D.XY());
  }
  image.SetPoints2D(points2D);
  return image;
}

colmap::CorrespondenceGraph& MutableCorrespondenceGraph(
    colmap::DatabaseCache* cache) {
  return const_cast<colmap::CorrespondenceGraph&>(cache->CorrespondenceGraph());
}

colmap::FeatureMatches CleanMatches(const colmap::FeatureMatches& matches,
                                    size_t num_points1, size_t num_points2) {
  colmap::FeatureMatches clean;
  clean.reserve(matches.size());
  std::unordered_set<colmap::point2D_t> used1, used2;
  for (const colmap::FeatureMatch& match : matches) {
    if (match.point2D_idx1 >= num_points1 ||
        match.point2D_idx2 >= num_points2) {
      continue;
    }
    if (!used1.insert(match.point2D_idx1).second) continue;
    if (!used2.insert(match.point2D_idx2).second) continue;
    clean.push_back(match);
  }
  return clean;
}

ImagePair& ViewGraph::AddPair(ImagePair pair) {
  if (pair.image_id1 > pair.image_id2) {
    std::swap(pair.image_id1, pair.image_id2);
    for (auto& match : pair.matches) {
      std::swap(match.point2D_idx1, match.point2D_idx2);
    }
    pair.F.transposeInPlace();
    pair.E.transposeInPlace();
    if (pair.H.determinant() != 0) pair.H = pair.H.inverse().eval();
    // Invert the relative pose: cam1_from_cam2.
    const Eigen::Vector4d q = pair.qvec2_from_1;
    pair.qvec2_from_1 = colmap::InvertQuaternion(q);
    // -R^T t. Eigen's matrix, not colmap::QuaternionToRotationMatrix: that
    // one normalizes q again, which changes the last bits of a third of the
    // stored unit quaternions.
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(q(0), q(1), q(2), q(3)).toRotationMatrix();
    pair.tvec2_from_1 = -R.transpose() * pair.tvec2_from_1;
  }
  const colmap::image_pair_t pair_id =
      colmap::Database::ImagePairToPairId(pair.image_id1, pair.image_id2);
  ImagePair& stored = pairs_[pair_id];
  stored = std::move(pair);
  return stored;
}

size_t ViewGraph::NumValidPairs() const {
  size_t num_valid = 0;
  for (const auto& [pair_id, pair] : pairs_) num_valid += pair.is_valid;
  return num_valid;
}

std::vector<colmap::image_t> ViewGraph::ImagesWithValidPairs() const {
  return ImagesOfPairs(pairs_, IsValid);
}

std::vector<std::vector<colmap::image_t>> ViewGraph::ConnectedComponents(
    const std::function<bool(const ImagePair&)>& is_edge) const {
  const std::vector<colmap::image_t> image_ids = ImagesOfPairs(pairs_, is_edge);
  std::unordered_map<colmap::image_t, size_t> index;
  for (size_t i = 0; i < image_ids.size(); ++i) index[image_ids[i]] = i;

  UnionFind<size_t> union_find(image_ids.size());
  for (const auto& [pair_id, pair] : pairs_) {
    if (!is_edge(pair)) continue;
    union_find.Union(index.at(pair.image_id1), index.at(pair.image_id2));
  }

  std::map<size_t, std::vector<colmap::image_t>> by_root;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    by_root[union_find.Find(i)].push_back(image_ids[i]);
  }
  std::vector<std::vector<colmap::image_t>> components;
  for (auto& [root, members] : by_root) components.push_back(members);
  // Largest first; equal sizes keep the order of their smallest image id.
  std::stable_sort(
      components.begin(), components.end(),
      [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return components;
}

std::vector<colmap::image_t> ViewGraph::LargestConnectedComponent(
    const std::function<bool(const ImagePair&)>& is_edge) const {
  auto components = ConnectedComponents(is_edge);
  if (components.empty()) return {};
  return components.front();
}

size_t ViewGraph::InvalidatePairsOutside(
    const std::unordered_set<colmap::image_t>& image_ids) {
  size_t num_invalidated = 0;
  for (auto& [pair_id, pair] : pairs_) {
    if (!pair.is_valid) continue;
    if (image_ids.count(pair.image_id1) == 0 ||
        image_ids.count(pair.image_id2) == 0) {
      pair.is_valid = false;
      ++num_invalidated;
    }
  }
  return num_invalidated;
}

void ViewGraph::ReleaseInlierIdxs() {
  for (auto& [pair_id, pair] : pairs_) {
    std::vector<int>().swap(pair.inlier_idxs);
  }
}

}  // namespace glomap
