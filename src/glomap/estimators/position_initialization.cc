#include "glomap/estimators/position_initialization.h"

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <algorithm>
#include <deque>
#include <memory>
#include <unordered_map>
#include <vector>

#include "base/pose.h"
#include "glomap/estimators/cost_functions/ray_residual.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/options_check.h"
#include "glomap/util/union_find.h"
#include "util/timer.h"

namespace glomap {
namespace {

// A usable pair as an edge between problem indices, with the direction from
// the first camera's centre to the second's in world coordinates.
struct DirectionEdge {
  size_t node1 = 0;
  size_t node2 = 0;
  Eigen::Vector3d direction_in_world = Eigen::Vector3d::Zero();
  size_t num_matches = 0;
};

bool IsUsable(const ImagePair& pair) {
  return pair.is_valid && pair.has_relative_pose &&
         pair.image_id1 != pair.image_id2 && pair.tvec2_from_1.allFinite() &&
         pair.tvec2_from_1.norm() > 0 && pair.qvec2_from_1.allFinite() &&
         pair.qvec2_from_1.norm() > 0;
}

// The problem's images (the registered ones in a usable pair, in id order)
// and one direction edge per usable pair between them.
struct DirectionGraph {
  std::vector<colmap::image_t> image_ids;
  std::vector<DirectionEdge> edges;
};

DirectionGraph CollectDirections(const ViewGraph& view_graph,
                                 const colmap::Reconstruction& reconstruction) {
  DirectionGraph graph;
  std::vector<colmap::image_t>& image_ids = graph.image_ids;
  std::vector<DirectionEdge>& edges = graph.edges;
  std::unordered_map<colmap::image_t, size_t> node_of_image;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (!IsUsable(pair) || !reconstruction.ExistsImage(pair.image_id1) ||
        !reconstruction.ExistsImage(pair.image_id2) ||
        !reconstruction.IsImageRegistered(pair.image_id1) ||
        !reconstruction.IsImageRegistered(pair.image_id2)) {
      continue;
    }
    // x2 = R x1 + t (cam2_from_cam1, |t| = 1): the second centre is -R^T t
    // in the first camera, the first is t in the second. Both give the
    // direction c2 - c1 in the world through the global rotations; their
    // mean spreads a disagreement between the relative and global rotations
    // over both cameras.
    const Eigen::Matrix3d rotation2_from_1 = colmap::QuaternionToRotationMatrix(
        colmap::NormalizeQuaternion(pair.qvec2_from_1));
    const Eigen::Vector3d t = pair.tvec2_from_1.normalized();
    const Eigen::Matrix3d world_from_cam1 =
        reconstruction.Image(pair.image_id1).RotationMatrix().transpose();
    const Eigen::Matrix3d world_from_cam2 =
        reconstruction.Image(pair.image_id2).RotationMatrix().transpose();
    const Eigen::Vector3d direction =
        -world_from_cam1 * rotation2_from_1.transpose() * t -
        world_from_cam2 * t;
    if (!(direction.norm() > 1e-6)) continue;  // Contradicting rotations.
    DirectionEdge edge;
    for (const colmap::image_t image_id : {pair.image_id1, pair.image_id2}) {
      if (node_of_image.emplace(image_id, image_ids.size()).second) {
        image_ids.push_back(image_id);
      }
    }
    edge.node1 = node_of_image.at(pair.image_id1);
    edge.node2 = node_of_image.at(pair.image_id2);
    edge.direction_in_world = direction.normalized();
    edge.num_matches = pair.matches.size();
    edges.push_back(edge);
  }
  // Nodes in image-id order, whatever the pairs' order.
  {
    std::vector<colmap::image_t> sorted_ids = image_ids;
    std::sort(sorted_ids.begin(), sorted_ids.end());
    std::vector<size_t> new_node(image_ids.size());
    for (size_t i = 0; i < sorted_ids.size(); ++i) {
      new_node[node_of_image.at(sorted_ids[i])] = i;
    }
    for (DirectionEdge& edge : edges) {
      edge.node1 = new_node[edge.node1];
      edge.node2 = new_node[edge.node2];
    }
    image_ids = std::move(sorted_ids);
  }
  return graph;
}

// The maximum spanning tree's layout (Kruskal; most matches first, then
// pair order, so the same input gives the same tree), walked breadth-first
// from the smallest image id of each component with unit steps.
struct TreeLayout {
  std::vector<Eigen::Vector3d> centers;
  std::vector<size_t> roots;  // One node per component.
  // Per component, the tree edge whose scale fixes the component's size.
  std::vector<size_t> gauge_edges;
};

TreeLayout LayOutSpanningTree(const std::vector<DirectionEdge>& edges,
                              size_t num_nodes) {
  std::vector<size_t> edge_order(edges.size());
  for (size_t i = 0; i < edge_order.size(); ++i) edge_order[i] = i;
  std::stable_sort(edge_order.begin(), edge_order.end(),
                   [&edges](size_t a, size_t b) {
                     return edges[a].num_matches > edges[b].num_matches;
                   });
  UnionFind<size_t> components(num_nodes);
  std::vector<std::vector<size_t>> tree_edges_of_node(num_nodes);
  for (const size_t e : edge_order) {
    if (components.Union(edges[e].node1, edges[e].node2)) {
      tree_edges_of_node[edges[e].node1].push_back(e);
      tree_edges_of_node[edges[e].node2].push_back(e);
    }
  }
  TreeLayout layout;
  std::vector<Eigen::Vector3d>& centers = layout.centers;
  centers.assign(num_nodes, Eigen::Vector3d::Zero());
  std::vector<bool> placed(num_nodes, false);
  std::vector<size_t>& roots = layout.roots;
  std::vector<size_t>& gauge_edges = layout.gauge_edges;
  for (size_t root = 0; root < num_nodes; ++root) {
    if (placed[root]) continue;
    roots.push_back(root);
    placed[root] = true;
    std::deque<size_t> queue = {root};
    while (!queue.empty()) {
      const size_t node = queue.front();
      queue.pop_front();
      for (const size_t e : tree_edges_of_node[node]) {
        const DirectionEdge& edge = edges[e];
        const bool forward = edge.node1 == node;
        const size_t next = forward ? edge.node2 : edge.node1;
        if (placed[next]) continue;
        if (node == root && gauge_edges.size() < roots.size()) {
          gauge_edges.push_back(e);
        }
        placed[next] = true;
        centers[next] =
            centers[node] + (forward ? 1.0 : -1.0) * edge.direction_in_world;
        queue.push_back(next);
      }
    }
  }

  return layout;
}

// Every pair's direction, robustly, from the tree's layout (the centres in
// `layout`, refined in place). Gauge: each component's root fixed, and the
// scale of one tree pair at its root.
Status RefineCenters(const PositionInitializationOptions& options,
                     const std::vector<DirectionEdge>& edges,
                     const Interrupt& interrupt, TreeLayout* layout,
                     ceres::Solver::Summary* summary) {
  std::vector<Eigen::Vector3d>& centers = layout->centers;
  std::vector<double> scales(edges.size());
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss loss(options.loss_scale);
  for (size_t e = 0; e < edges.size(); ++e) {
    const DirectionEdge& edge = edges[e];
    scales[e] = BestRayScale(edge.direction_in_world,
                             centers[edge.node2] - centers[edge.node1],
                             options.min_scale);
    problem.AddResidualBlock(new RayResidual(edge.direction_in_world), &loss,
                             centers[edge.node1].data(),
                             centers[edge.node2].data(), &scales[e]);
    problem.SetParameterLowerBound(&scales[e], 0, options.min_scale);
  }
  for (const size_t root : layout->roots) {
    problem.SetParameterBlockConstant(centers[root].data());
  }
  for (const size_t e : layout->gauge_edges) {
    problem.SetParameterBlockConstant(&scales[e]);
  }
  // Schur elimination of the scales (each in one residual): the reduced
  // system holds only the centres.
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (double& scale : scales) ordering->AddElementToGroup(&scale, 0);
  for (Eigen::Vector3d& center : centers) {
    ordering->AddElementToGroup(center.data(), 1);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.linear_solver_ordering = ordering;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads =
      CeresNumThreads(options.num_threads, problem.NumResidualBlocks(),
                      options.min_residuals_per_ceres_thread);
  solver_options.logging_type = ceres::SILENT;
  InterruptCallback interrupt_callback(interrupt);
  solver_options.callbacks.push_back(&interrupt_callback);
  ceres::Solve(solver_options, &problem, summary);
  if (interrupt.IsStopped()) return Status::Cancelled();
  if (!summary->IsSolutionUsable()) {
    return Status::Error("Position initialization: solver failed: " +
                         summary->message);
  }
  for (const Eigen::Vector3d& center : centers) {
    if (!center.allFinite()) {
      return Status::Error("Position initialization: non-finite solution.");
    }
  }

  return Status::Ok();
}

}  // namespace

Status PositionInitializationOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("loss_scale", loss_scale, 0);
  check.AtLeast("max_num_iterations", max_num_iterations, 0);
  check.AtLeast("function_tolerance", function_tolerance, 0);
  check.GreaterThan("min_scale", min_scale, 0);
  check.MinusOneOrAtLeast("num_threads", num_threads, 1);
  check.AtLeast("min_residuals_per_ceres_thread",
                min_residuals_per_ceres_thread, 1);
  return check.status();
}

Status InitializeCameraCenters(const PositionInitializationOptions& options,
                               const ViewGraph& view_graph,
                               colmap::Reconstruction* reconstruction,
                               const Interrupt& interrupt,
                               size_t* num_placed_images) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid position initialization options: " +
                         check.message());
  }
  if (num_placed_images != nullptr) *num_placed_images = 0;
  colmap::Timer timer;
  timer.Start();
  const DirectionGraph graph = CollectDirections(view_graph, *reconstruction);
  if (graph.edges.empty()) {
    return Status::Error(
        "Position initialization: no image pair with a relative pose between "
        "registered images.");
  }
  const size_t num_nodes = graph.image_ids.size();
  TreeLayout layout = LayOutSpanningTree(graph.edges, num_nodes);
  ceres::Solver::Summary summary;
  if (const Status status =
          RefineCenters(options, graph.edges, interrupt, &layout, &summary);
      !status.ok()) {
    return status;
  }
  for (size_t i = 0; i < num_nodes; ++i) {
    colmap::Image& image = reconstruction->Image(graph.image_ids[i]);
    image.SetTvec(-(image.RotationMatrix() * layout.centers[i]));
  }
  if (num_placed_images != nullptr) *num_placed_images = num_nodes;
  VLOG(3) << "Position initialization: " << num_nodes << " images, "
          << graph.edges.size() << " pairs, " << layout.roots.size()
          << " component(s); " << summary.iterations.size() << " iterations ("
          << ceres::TerminationTypeToString(summary.termination_type)
          << "), cost " << summary.initial_cost << " -> " << summary.final_cost
          << "; " << timer.ElapsedSeconds() << " s";
  return Status::Ok();
}

}  // namespace glomap
