#include "glomap/processors/camera_clustering.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "glomap/util/options_check.h"
#include "glomap/util/union_find.h"
#include "util/logging.h"

namespace glomap {
namespace {

struct Edge {
  size_t idx1;  // Dense indices into the sorted registered image ids.
  size_t idx2;
  double weight;  // Number of shared 3D points.
};

double Median(std::vector<double> values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double median = values[mid];
  if (values.size() % 2 == 0) {
    median = 0.5 *
             (median + *std::max_element(values.begin(), values.begin() + mid));
  }
  return median;
}

}  // namespace

Status CameraClusteringOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("min_covisible_points", min_covisible_points, 1);
  check.AtLeast("min_edge_weight", min_edge_weight, 0);
  check.GreaterThan("merge_weight_ratio", merge_weight_ratio, 0);
  check.AtLeast("min_num_merge_edges", min_num_merge_edges, 1);
  check.AtLeast("max_merge_rounds", max_merge_rounds, 0);
  check.AtLeast("min_cluster_size", min_cluster_size, 1);
  return check.status();
}

std::vector<std::vector<colmap::image_t>> ClusterCameras(
    const CameraClusteringOptions& options,
    const colmap::Reconstruction& reconstruction) {
  if (const Status check = options.Check(); !check.ok()) {
    LOG(ERROR) << "Invalid camera clustering options: " << check.message();
    return {};
  }
  std::vector<colmap::image_t> image_ids = reconstruction.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  std::unordered_map<colmap::image_t, size_t> image_idxs;
  for (size_t i = 0; i < image_ids.size(); ++i) image_idxs[image_ids[i]] = i;

  // Covisibility: each point counts once for every pair of distinct
  // registered images that observe it.
  std::unordered_map<uint64_t, int> covisibility;
  std::vector<size_t> track_idxs;
  for (const auto& point3D : reconstruction.Points3D()) {
    track_idxs.clear();
    for (const colmap::TrackElement& el : point3D.second.Track().Elements()) {
      const auto it = image_idxs.find(el.image_id);
      if (it != image_idxs.end()) track_idxs.push_back(it->second);
    }
    std::sort(track_idxs.begin(), track_idxs.end());
    track_idxs.erase(std::unique(track_idxs.begin(), track_idxs.end()),
                     track_idxs.end());
    for (size_t i = 0; i < track_idxs.size(); ++i) {
      for (size_t j = i + 1; j < track_idxs.size(); ++j) {
        ++covisibility[(static_cast<uint64_t>(track_idxs[i]) << 32) |
                       track_idxs[j]];
      }
    }
  }
  std::vector<Edge> edges;
  for (const auto& [key, count] : covisibility) {
    if (count >= options.min_covisible_points) {
      edges.push_back({static_cast<size_t>(key >> 32),
                       static_cast<size_t>(key & 0xFFFFFFFFu),
                       static_cast<double>(count)});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
    return std::make_pair(a.idx1, a.idx2) < std::make_pair(b.idx1, b.idx2);
  });

  UnionFind<size_t> clusters(image_ids.size());
  if (!edges.empty()) {
    std::vector<double> weights;
    weights.reserve(edges.size());
    for (const Edge& edge : edges) weights.push_back(edge.weight);
    const double median = Median(weights);
    for (double& weight : weights) weight = std::abs(weight - median);
    const double mad = Median(weights);
    const double tau = std::max(median - mad, options.min_edge_weight);

    // Strong components.
    for (const Edge& edge : edges) {
      if (edge.weight >= tau) clusters.Union(edge.idx1, edge.idx2);
    }

    // Merge clusters joined by several moderately strong edges; a single
    // edge is not enough, since one wrongly matched pair can be strong.
    const double merge_weight = options.merge_weight_ratio * tau;
    for (int round = 0; round < options.max_merge_rounds; ++round) {
      std::map<std::pair<size_t, size_t>, int> num_links;
      for (const Edge& edge : edges) {
        if (edge.weight < merge_weight) continue;
        size_t root1 = clusters.Find(edge.idx1);
        size_t root2 = clusters.Find(edge.idx2);
        if (root1 == root2) continue;
        if (root1 > root2) std::swap(root1, root2);
        ++num_links[{root1, root2}];
      }
      bool merged = false;
      for (const auto& [roots, count] : num_links) {
        if (count >= options.min_num_merge_edges) {
          clusters.Union(roots.first, roots.second);
          merged = true;
        }
      }
      if (!merged) break;
    }
  }

  std::map<size_t, std::vector<colmap::image_t>> members;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    members[clusters.Find(i)].push_back(image_ids[i]);  // Stays sorted.
  }
  std::vector<std::vector<colmap::image_t>> result;
  for (auto& [root, cluster] : members) {
    if (static_cast<int>(cluster.size()) >= options.min_cluster_size) {
      result.push_back(std::move(cluster));
    }
  }
  std::sort(result.begin(), result.end(),
            [](const std::vector<colmap::image_t>& a,
               const std::vector<colmap::image_t>& b) {
              if (a.size() != b.size()) return a.size() > b.size();
              return a.front() < b.front();
            });
  return result;
}

colmap::Reconstruction ExtractCluster(
    const colmap::Reconstruction& reconstruction,
    const std::vector<colmap::image_t>& cluster_image_ids) {
  std::vector<colmap::image_t> image_ids;
  for (const colmap::image_t image_id : cluster_image_ids) {
    if (reconstruction.ExistsImage(image_id) &&
        reconstruction.IsImageRegistered(image_id)) {
      image_ids.push_back(image_id);
    }
  }
  std::sort(image_ids.begin(), image_ids.end());
  image_ids.erase(std::unique(image_ids.begin(), image_ids.end()),
                  image_ids.end());
  const std::unordered_set<colmap::image_t> in_cluster(image_ids.begin(),
                                                       image_ids.end());

  // The cluster's images and their cameras, copied one by one; the images'
  // links to points are set again as the points are added.
  colmap::Reconstruction cluster;
  for (const colmap::image_t image_id : image_ids) {
    const colmap::Image& source = reconstruction.Image(image_id);
    if (!cluster.ExistsCamera(source.CameraId())) {
      cluster.AddCamera(reconstruction.Camera(source.CameraId()));
    }
    colmap::Image image = source;
    for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
      if (image.Point2D(idx).HasPoint3D()) image.ResetPoint3DForPoint2D(idx);
    }
    // RegisterImage lists only images that are not registered yet.
    image.SetRegistered(false);
    cluster.AddImage(std::move(image));
    cluster.RegisterImage(image_id);
  }

  // Each point with at least two observations in the cluster, with those
  // observations in their order, in ascending order of the old ids.
  std::vector<colmap::point3D_t> point3D_ids;
  point3D_ids.reserve(reconstruction.NumPoints3D());
  for (const auto& point3D : reconstruction.Points3D()) {
    point3D_ids.push_back(point3D.first);
  }
  std::sort(point3D_ids.begin(), point3D_ids.end());
  for (const colmap::point3D_t point3D_id : point3D_ids) {
    const colmap::Point3D& point3D = reconstruction.Point3D(point3D_id);
    colmap::Track track;
    for (const colmap::TrackElement& el : point3D.Track().Elements()) {
      if (in_cluster.count(el.image_id) > 0) track.AddElement(el);
    }
    if (track.Length() < 2) continue;
    const colmap::point3D_t new_id =
        cluster.AddPoint3D(point3D.XYZ(), std::move(track), point3D.Color());
    cluster.Point3D(new_id).SetError(point3D.Error());
  }
  return cluster;
}

}  // namespace glomap
