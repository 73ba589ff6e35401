// Camera clustering (paper Sec. 3, "Camera Clustering"; glomap.md §2.9):
// internet photo collections can contain wrongly matched, non-overlapping
// scenes that collapse into one reconstruction. Clustering the covisibility
// graph into strongly connected groups separates them so that each group can
// be written as its own model.
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {

struct CameraClusteringOptions {
  // Image pairs sharing fewer 3D points are not edges of the covisibility
  // graph (the paper: a relative pose is unreliable below 5 points).
  int min_covisible_points = 5;

  // Floor of the strong-edge threshold tau = max(median - MAD, this), in
  // shared points.
  double min_edge_weight = 20;

  // Two clusters merge if at least `min_num_merge_edges` edges between them
  // have a weight of at least `merge_weight_ratio` * tau.
  double merge_weight_ratio = 0.75;
  int min_num_merge_edges = 2;

  // Merging repeats until nothing merges, at most this many rounds.
  int max_merge_rounds = 10;

  // Clusters with fewer images are dropped (not returned). The reference
  // ignores its equivalent argument (glomap.md Appendix A.10); we honour it.
  int min_cluster_size = 2;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Clusters the registered images of `reconstruction` by covisibility (number
// of 3D points two images share). Strong components are the connected
// components of edges with weight >= tau, tau = max(median - MAD,
// min_edge_weight) over all edge weights; then clusters joined by enough
// edges of weight >= merge_weight_ratio * tau are merged, repeatedly.
// Returns the clusters as sorted image id lists, largest first (ties: the
// cluster with the smallest image id first). Registered images in no kept
// cluster appear in no list. Invalid options give an empty result (the error
// is logged; the global mapper checks its options first).
//
// The paper connects pairs with "more than tau" points; we use ">= tau" so
// that when at least half of the weights tie at the median (MAD = 0) those
// pairs still count as strong; otherwise a uniformly covisible group would
// fall apart into single images, which can never be merged back because two
// single images share only one edge.
std::vector<std::vector<colmap::image_t>> ClusterCameras(
    const CameraClusteringOptions& options,
    const colmap::Reconstruction& reconstruction);

// The model of one cluster, copied from `reconstruction`: the cluster's
// images (all registered, with their keypoints and poses) and their cameras,
// and each point with its observations in cluster images (xyz, colour,
// error and the order of the observations kept), or none if fewer than two
// remain. Nothing else is copied: the memory is that of the cluster. Point
// ids are new, in the order of the old ones. Image ids not registered in
// `reconstruction` are ignored.
colmap::Reconstruction ExtractCluster(
    const colmap::Reconstruction& reconstruction,
    const std::vector<colmap::image_t>& cluster_image_ids);

}  // namespace glomap
