#include "glomap/view_graph.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include "base/database.h"

namespace glomap {

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
    pair.qvec2_from_1 = Eigen::Vector4d(q(0), -q(1), -q(2), -q(3));
    // R^T * -t without pulling pose helpers into this header-level type.
    const double w = q(0), x = q(1), y = q(2), z = q(3);
    Eigen::Matrix3d R;
    R << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
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
  std::vector<colmap::image_t> image_ids;
  for (const auto& [pair_id, pair] : pairs_) {
    if (!pair.is_valid) continue;
    image_ids.push_back(pair.image_id1);
    image_ids.push_back(pair.image_id2);
  }
  std::sort(image_ids.begin(), image_ids.end());
  image_ids.erase(std::unique(image_ids.begin(), image_ids.end()),
                  image_ids.end());
  return image_ids;
}

std::vector<std::vector<colmap::image_t>> ViewGraph::ConnectedComponents()
    const {
  const std::vector<colmap::image_t> image_ids = ImagesWithValidPairs();
  std::unordered_map<colmap::image_t, size_t> index;
  for (size_t i = 0; i < image_ids.size(); ++i) index[image_ids[i]] = i;

  // Union-find over dense indices, with path halving.
  std::vector<size_t> parent(image_ids.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&parent](size_t i) {
    while (parent[i] != i) {
      parent[i] = parent[parent[i]];
      i = parent[i];
    }
    return i;
  };
  for (const auto& [pair_id, pair] : pairs_) {
    if (!pair.is_valid) continue;
    const size_t a = find(index.at(pair.image_id1));
    const size_t b = find(index.at(pair.image_id2));
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }

  std::map<size_t, std::vector<colmap::image_t>> by_root;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    by_root[find(i)].push_back(image_ids[i]);
  }
  std::vector<std::vector<colmap::image_t>> components;
  for (auto& [root, members] : by_root) components.push_back(members);
  // Largest first; equal sizes keep the order of their smallest image id.
  std::stable_sort(
      components.begin(), components.end(),
      [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return components;
}

std::vector<colmap::image_t> ViewGraph::LargestConnectedComponent() const {
  auto components = ConnectedComponents();
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

}  // namespace glomap
