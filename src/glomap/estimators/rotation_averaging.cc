#include "glomap/estimators/rotation_averaging.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <queue>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>
#ifdef GLOMAP_HAS_CHOLMOD
#include <Eigen/CholmodSupport>
#else
#include <Eigen/SparseCholesky>
#endif

#include "glomap/util/options_check.h"
#include "glomap/util/union_find.h"
#include "util/logging.h"

namespace glomap {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kRadToDeg = 180.0 / M_PI;

Eigen::Quaterniond QuaternionFromQvec(const Eigen::Vector4d& qvec) {
  return Eigen::Quaterniond(qvec(0), qvec(1), qvec(2), qvec(3)).normalized();
}

// Rotation vector (angle * axis) of a unit quaternion, angle in [0, pi].
// Below the 1e-15 guard, the first-order form avoids dividing by a vanishing
// vector norm (numerical guards here and in ExpMap, not options).
Eigen::Vector3d LogMap(const Eigen::Quaterniond& q) {
  const double sign = q.w() < 0 ? -1.0 : 1.0;
  const Eigen::Vector3d v = sign * q.vec();
  const double w = sign * q.w();
  const double v_norm = v.norm();
  if (v_norm < 1e-15) return 2.0 * v / std::max(w, 1e-15);
  return (2.0 * std::atan2(v_norm, w) / v_norm) * v;
}

Eigen::Quaterniond ExpMap(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  const double half = 0.5 * angle;
  // sin(x/2)/x -> 1/2 as x -> 0; the series keeps small steps exact.
  const double scale =
      angle < 1e-8 ? 0.5 - angle * angle / 48.0 : std::sin(half) / angle;
  const Eigen::Vector3d v = scale * rotation_vector;
  return Eigen::Quaterniond(std::cos(half), v.x(), v.y(), v.z());
}

double AngleDeg(const Eigen::Quaterniond& q) {
  return LogMap(q.normalized()).norm() * kRadToDeg;
}

// One relative-rotation measurement between dense image indices.
struct Edge {
  int node1 = 0;
  int node2 = 0;
  // Measured R2 * R1^T (cam2_from_cam1).
  Eigen::Quaterniond rotation2_from_1;
  // Preference in the spanning-tree initialization (number of inliers).
  double tree_weight = 0;
};

// The problem of one round: images as dense indices in increasing image id
// order, so node 0 (the smallest id) carries the gauge.
struct Problem {
  std::vector<colmap::image_t> image_ids;
  std::vector<Edge> edges;
};

// Residual of an edge as a rotation vector in the world frame,
// Log(R2^T * R21 * R1); zero when the rotations agree with the measurement.
// With the world-frame update R_i <- R_i * Exp(x_i) it is, to first order,
// x2 - x1 = residual: each pair contributes rows [-I, +I] (Sec. 3 of
// Chatterjee & Govindu, cited in paper Sec. 3).
Eigen::Vector3d EdgeResidual(const Edge& edge,
                             const std::vector<Eigen::Quaterniond>& rotations) {
  return LogMap(rotations[edge.node2].conjugate() * edge.rotation2_from_1 *
                rotations[edge.node1]);
}

// Because every pair's rows are [-I, +I] times one scalar weight, the normal
// equations of the 3n-dimensional problem are (weighted graph Laplacian) x I3.
// We therefore factor the n x n Laplacian once per weighting and solve for
// the three coordinates as three right-hand sides: 27x fewer flops in the
// factorization than factoring the 3n x 3n system. The gauge node 0 is
// removed from the system (its update is zero), which makes the reduced
// Laplacian positive definite on a connected graph.
class LaplacianSolver {
 public:
  LaplacianSolver(int num_nodes, const std::vector<Edge>& edges)
      : num_nodes_(num_nodes), edges_(edges) {
    const int size = num_nodes_ - 1;
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(3 * edges_.size() + size);
    for (int k = 0; k < size; ++k) triplets.emplace_back(k, k, 1.0);
    for (const Edge& edge : edges_) {
      const int a = std::max(edge.node1, edge.node2) - 1;
      const int b = std::min(edge.node1, edge.node2) - 1;
      if (b >= 0) triplets.emplace_back(a, b, 1.0);
    }
    // Lower triangle only; both solvers read just that part.
    matrix_.resize(size, size);
    matrix_.setFromTriplets(triplets.begin(), triplets.end());
    matrix_.makeCompressed();

    // Offsets into the value array, so that reweighting is a linear pass.
    diagonal_offsets_.resize(size);
    for (int k = 0; k < size; ++k) {
      diagonal_offsets_[k] = &matrix_.coeffRef(k, k) - matrix_.valuePtr();
    }
    off_diagonal_offsets_.resize(edges_.size(), -1);
    for (size_t e = 0; e < edges_.size(); ++e) {
      const int a = std::max(edges_[e].node1, edges_[e].node2) - 1;
      const int b = std::min(edges_[e].node1, edges_[e].node2) - 1;
      if (b >= 0) {
        off_diagonal_offsets_[e] = &matrix_.coeffRef(a, b) - matrix_.valuePtr();
      }
    }
  }

  // Factors the Laplacian with the given per-edge weights (all > 0).
  bool Factorize(const Eigen::VectorXd& edge_weights) {
    if (num_nodes_ < 2) return false;
    double* values = matrix_.valuePtr();
    std::fill(values, values + matrix_.nonZeros(), 0.0);
    for (size_t e = 0; e < edges_.size(); ++e) {
      const double w = edge_weights(e);
      if (edges_[e].node1 > 0)
        values[diagonal_offsets_[edges_[e].node1 - 1]] += w;
      if (edges_[e].node2 > 0)
        values[diagonal_offsets_[edges_[e].node2 - 1]] += w;
      if (off_diagonal_offsets_[e] >= 0) values[off_diagonal_offsets_[e]] -= w;
    }
    if (!analyzed_) {
      solver_.analyzePattern(matrix_);
      analyzed_ = true;
    }
    solver_.factorize(matrix_);
    return solver_.info() == Eigen::Success;
  }

  // Solves L x = rhs for every node except the gauge; row 0 of the result
  // (the gauge node) is zero. rhs has one row per node.
  bool Solve(const Eigen::MatrixX3d& rhs, Eigen::MatrixX3d* solution) {
    const int size = num_nodes_ - 1;
    const Eigen::MatrixX3d reduced = solver_.solve(rhs.bottomRows(size));
    if (solver_.info() != Eigen::Success || !reduced.allFinite()) return false;
    solution->resize(num_nodes_, 3);
    solution->row(0).setZero();
    solution->bottomRows(size) = reduced;
    return true;
  }

 private:
  const int num_nodes_;
  const std::vector<Edge>& edges_;
  Eigen::SparseMatrix<double> matrix_;
  std::vector<Eigen::Index> diagonal_offsets_;
  std::vector<Eigen::Index> off_diagonal_offsets_;
  bool analyzed_ = false;
#ifdef GLOMAP_HAS_CHOLMOD
  // Supernodal CHOLMOD uses BLAS on dense blocks, which matters once the
  // view graph is dense (many pairs per image).
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower>
      solver_;
#else
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> solver_;
#endif
};

// A^T * (per-edge 3-vectors), where A has rows [-I on node1, +I on node2].
void AccumulateTranspose(const std::vector<Edge>& edges,
                         const Eigen::MatrixX3d& edge_values, int num_nodes,
                         Eigen::MatrixX3d* result) {
  result->setZero(num_nodes, 3);
  for (size_t e = 0; e < edges.size(); ++e) {
    result->row(edges[e].node2) += edge_values.row(e);
    result->row(edges[e].node1) -= edge_values.row(e);
  }
}

// A * x: per edge, x(node2) - x(node1).
void ApplyIncidence(const std::vector<Edge>& edges, const Eigen::MatrixX3d& x,
                    Eigen::MatrixX3d* result) {
  result->resize(edges.size(), 3);
  for (size_t e = 0; e < edges.size(); ++e) {
    result->row(e) = x.row(edges[e].node2) - x.row(edges[e].node1);
  }
}

// Applies the world-frame updates and returns the mean update angle (rad).
double ApplyUpdate(const Eigen::MatrixX3d& update,
                   std::vector<Eigen::Quaterniond>* rotations) {
  double sum_norm = 0;
  for (size_t i = 0; i < rotations->size(); ++i) {
    const Eigen::Vector3d step = update.row(i).transpose();
    (*rotations)[i] = ((*rotations)[i] * ExpMap(step)).normalized();
    sum_norm += step.norm();
  }
  return sum_norm / rotations->size();
}

// For every edge, the number of triangles it closes whose loop rotation
// (composed around the cycle) is within max_loop_error_rad of the
// identity. A wrong measurement rarely closes consistent loops with correct
// ones, so this separates outliers that an inlier count cannot (e.g. wrong
// pairs from repeated structure, which often have many inliers).
std::vector<int> CountConsistentTriangles(const Problem& problem,
                                          double max_loop_error_rad) {
  const int num_nodes = static_cast<int>(problem.image_ids.size());
  // Per node: (neighbor, edge index), sorted by neighbor for merging.
  std::vector<std::vector<std::pair<int, int>>> adjacency(num_nodes);
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    adjacency[problem.edges[e].node1].emplace_back(problem.edges[e].node2, e);
    adjacency[problem.edges[e].node2].emplace_back(problem.edges[e].node1, e);
  }
  for (auto& neighbors : adjacency)
    std::sort(neighbors.begin(), neighbors.end());
  // Measured rotation from node `from` to the other node of edge e.
  auto relative = [&problem](int e, int from) {
    const Edge& edge = problem.edges[e];
    return edge.node1 == from ? edge.rotation2_from_1
                              : edge.rotation2_from_1.conjugate();
  };
  std::vector<int> support(problem.edges.size(), 0);
  for (size_t e = 0; e < problem.edges.size(); ++e) {
    const int i = problem.edges[e].node1, j = problem.edges[e].node2;
    const Eigen::Quaterniond j_from_i = problem.edges[e].rotation2_from_1;
    const auto& ni = adjacency[i];
    const auto& nj = adjacency[j];
    for (size_t a = 0, b = 0; a < ni.size() && b < nj.size();) {
      if (ni[a].first < nj[b].first) {
        ++a;
      } else if (nj[b].first < ni[a].first) {
        ++b;
      } else {
        // i -> j -> k -> i should compose to the identity.
        const Eigen::Quaterniond loop = relative(ni[a].second, ni[a].first) *
                                        relative(nj[b].second, j) * j_from_i;
        if (LogMap(loop.normalized()).norm() < max_loop_error_rad) {
          ++support[e];
        }
        ++a;
        ++b;
      }
    }
  }
  return support;
}

// Kruskal's maximum spanning tree, then rotations chained outwards from node
// 0 (identity) in breadth-first order. Edges are preferred by the number of
// consistent triangles they close (if given), then by inlier count; ties go
// to the edge that comes first (pair-id order), so the tree is deterministic.
std::vector<Eigen::Quaterniond> InitializeFromSpanningTree(
    const Problem& problem, const std::vector<int>& triangle_support) {
  const int num_nodes = static_cast<int>(problem.image_ids.size());
  std::vector<size_t> order(problem.edges.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (!triangle_support.empty() &&
        triangle_support[a] != triangle_support[b]) {
      return triangle_support[a] > triangle_support[b];
    }
    return problem.edges[a].tree_weight > problem.edges[b].tree_weight;
  });

  UnionFind<int> forest(num_nodes);
  std::vector<std::vector<size_t>> tree_edges(num_nodes);
  for (const size_t e : order) {
    const Edge& edge = problem.edges[e];
    if (!forest.Union(edge.node1, edge.node2)) continue;
    tree_edges[edge.node1].push_back(e);
    tree_edges[edge.node2].push_back(e);
  }

  std::vector<Eigen::Quaterniond> rotations(num_nodes,
                                            Eigen::Quaterniond::Identity());
  std::vector<bool> visited(num_nodes, false);
  std::queue<int> queue;
  queue.push(0);
  visited[0] = true;
  while (!queue.empty()) {
    const int node = queue.front();
    queue.pop();
    for (const size_t e : tree_edges[node]) {
      const Edge& edge = problem.edges[e];
      // R2 = R21 * R1, R1 = R21^T * R2.
      if (edge.node1 == node && !visited[edge.node2]) {
        rotations[edge.node2] = edge.rotation2_from_1 * rotations[node];
        visited[edge.node2] = true;
        queue.push(edge.node2);
      } else if (edge.node2 == node && !visited[edge.node1]) {
        rotations[edge.node1] =
            edge.rotation2_from_1.conjugate() * rotations[node];
        visited[edge.node1] = true;
        queue.push(edge.node1);
      }
    }
  }
  return rotations;
}

// Minimizes sum_e ||x(node2) - x(node1) - b_e||_2 (a group L1 norm: to first
// order the sum of residual angles, independent of the world frame) with
// ADMM (Boyd et al., "Distributed optimization ...", Sec. 6.1), reusing one
// factorization of the unweighted Laplacian. rho is adapted by residual
// balancing (ibid. Sec. 3.4.1), which leaves the factorization unchanged;
// its start (1), its trigger (a residual 10 times the other) and its factor
// (2) are the values given there and are not options: rho adapts itself, so
// they change how fast the solve converges, not what it converges to.
bool SolveGroupL1(const RotationAveragingOptions& options,
                  const std::vector<Edge>& edges, const Eigen::MatrixX3d& b,
                  int num_nodes, int max_num_iterations,
                  LaplacianSolver* solver, Eigen::MatrixX3d* x,
                  int* num_iterations) {
  const double absolute_tolerance = options.admm_absolute_tolerance_rad;
  const double relative_tolerance = options.admm_relative_tolerance;
  const double num_edges = static_cast<double>(edges.size());

  // Start from x = 0, with z consistent with it and no dual.
  x->setZero(num_nodes, 3);
  Eigen::MatrixX3d z = -b;
  Eigen::MatrixX3d u = Eigen::MatrixX3d::Zero(edges.size(), 3);
  Eigen::MatrixX3d z_old, rhs, ax, dual;
  double rho = 1.0;
  *num_iterations = 0;
  for (int iteration = 0; iteration < max_num_iterations; ++iteration) {
    ++*num_iterations;
    AccumulateTranspose(edges, b + z - u, num_nodes, &rhs);
    if (!solver->Solve(rhs, x)) return false;
    ApplyIncidence(edges, *x, &ax);

    z_old = z;
    const Eigen::MatrixX3d v = ax - b + u;
    const double threshold = 1.0 / rho;
    for (Eigen::Index e = 0; e < v.rows(); ++e) {
      const double norm = v.row(e).norm();
      z.row(e) = norm > threshold ? ((1.0 - threshold / norm) * v.row(e)).eval()
                                  : Eigen::RowVector3d::Zero().eval();
    }
    u += ax - z - b;

    const double primal_norm = (ax - z - b).norm();
    AccumulateTranspose(edges, z - z_old, num_nodes, &dual);
    const double dual_norm = rho * dual.norm();
    const double primal_tolerance =
        std::sqrt(3.0 * num_edges) * absolute_tolerance +
        relative_tolerance * std::max({ax.norm(), z.norm(), b.norm()});
    AccumulateTranspose(edges, u, num_nodes, &dual);
    const double dual_tolerance =
        std::sqrt(3.0 * num_nodes) * absolute_tolerance +
        relative_tolerance * rho * dual.norm();
    if (primal_norm < primal_tolerance && dual_norm < dual_tolerance) break;

    if (primal_norm > 10 * dual_norm) {
      rho *= 2;
      u /= 2;
    } else if (dual_norm > 10 * primal_norm) {
      rho /= 2;
      u *= 2;
    }
  }
  return x->allFinite();
}

// Chatterjee & Govindu's scheme (paper Sec. 3): L1 to get into the basin of
// the inliers, then Geman-McClure IRLS for accuracy.
Status SolveRotations(const RotationAveragingOptions& options,
                      const Problem& problem,
                      std::vector<Eigen::Quaterniond>* rotations,
                      const Interrupt& interrupt) {
  const int num_nodes = static_cast<int>(problem.image_ids.size());
  const std::vector<Edge>& edges = problem.edges;
  LaplacianSolver solver(num_nodes, edges);
  Eigen::MatrixX3d residuals(edges.size(), 3);
  auto compute_residuals = [&]() {
    for (size_t e = 0; e < edges.size(); ++e) {
      residuals.row(e) = EdgeResidual(edges[e], *rotations).transpose();
    }
  };

  Eigen::MatrixX3d update;
  if (options.max_num_l1_iterations > 0) {
    if (!solver.Factorize(Eigen::VectorXd::Ones(edges.size()))) {
      return Status::Error("Rotation averaging: factorization failed (L1).");
    }
    // ADMM iterations of the next L1 solve: they start low and double
    // (see l1_initial_num_admm_iterations).
    int max_inner = std::min(options.l1_initial_num_admm_iterations,
                             options.l1_max_num_admm_iterations);
    for (int iteration = 0; iteration < options.max_num_l1_iterations;
         ++iteration) {
      if (interrupt.IsStopped()) return Status::Cancelled();
      compute_residuals();
      int num_inner = 0;
      if (!SolveGroupL1(options, edges, residuals, num_nodes, max_inner,
                        &solver, &update, &num_inner)) {
        return Status::Error("Rotation averaging: L1 solve failed.");
      }
      max_inner = static_cast<int>(
          std::min<int64_t>(2 * static_cast<int64_t>(max_inner),
                            options.l1_max_num_admm_iterations));
      const double mean_step = ApplyUpdate(update, rotations);
      VLOG(3) << "Rotation averaging L1 iteration " << iteration
              << ": mean step " << mean_step * kRadToDeg << " deg, "
              << num_inner << " ADMM iterations";
      if (mean_step < options.l1_step_convergence_threshold_rad) break;
    }
  }

  const double sigma = options.irls_loss_parameter_sigma_deg * kDegToRad;
  const double sigma_sq = sigma * sigma;
  Eigen::VectorXd weights(edges.size());
  Eigen::MatrixX3d weighted(edges.size(), 3);
  Eigen::MatrixX3d rhs;
  for (int iteration = 0; iteration < options.max_num_irls_iterations;
       ++iteration) {
    if (interrupt.IsStopped()) return Status::Cancelled();
    compute_residuals();
    for (size_t e = 0; e < edges.size(); ++e) {
      // Geman-McClure IRLS weight, scaled to 1 at zero residual so that the
      // Laplacian stays well scaled.
      const double ratio =
          sigma_sq / (residuals.row(e).squaredNorm() + sigma_sq);
      weights(e) = ratio * ratio;
      weighted.row(e) = weights(e) * residuals.row(e);
    }
    if (!solver.Factorize(weights)) {
      return Status::Error("Rotation averaging: factorization failed (IRLS).");
    }
    AccumulateTranspose(edges, weighted, num_nodes, &rhs);
    if (!solver.Solve(rhs, &update)) {
      return Status::Error("Rotation averaging: IRLS solve failed.");
    }
    const double mean_step = ApplyUpdate(update, rotations);
    VLOG(3) << "Rotation averaging IRLS iteration " << iteration
            << ": mean step " << mean_step * kRadToDeg << " deg";
    if (mean_step < options.irls_step_convergence_threshold_rad) break;
  }
  return Status::Ok();
}

bool IsUsable(const ImagePair& pair) {
  return pair.is_valid && pair.has_relative_pose &&
         pair.image_id1 != pair.image_id2;
}

Problem BuildProblem(const ViewGraph& view_graph,
                     const std::vector<colmap::image_t>& component) {
  Problem problem;
  problem.image_ids = component;
  std::unordered_map<colmap::image_t, int> index;
  for (size_t i = 0; i < component.size(); ++i) index[component[i]] = i;
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (!IsUsable(pair)) continue;
    const auto it1 = index.find(pair.image_id1);
    const auto it2 = index.find(pair.image_id2);
    if (it1 == index.end() || it2 == index.end()) continue;
    Edge edge;
    edge.node1 = it1->second;
    edge.node2 = it2->second;
    edge.rotation2_from_1 = QuaternionFromQvec(pair.qvec2_from_1);
    edge.tree_weight = !pair.inlier_idxs.empty()
                           ? static_cast<double>(pair.inlier_idxs.size())
                           : static_cast<double>(pair.matches.size());
    problem.edges.push_back(edge);
  }
  return problem;
}

}  // namespace

Status RotationAveragingOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("max_num_l1_iterations", max_num_l1_iterations, 0);
  check.AtLeast("l1_step_convergence_threshold_rad",
                l1_step_convergence_threshold_rad, 0);
  check.AtLeast("l1_initial_num_admm_iterations",
                l1_initial_num_admm_iterations, 1);
  check.AtLeast("l1_max_num_admm_iterations", l1_max_num_admm_iterations, 1);
  check.AtLeast("admm_absolute_tolerance_rad", admm_absolute_tolerance_rad, 0);
  check.AtLeast("admm_relative_tolerance", admm_relative_tolerance, 0);
  check.AtLeast("max_num_irls_iterations", max_num_irls_iterations, 0);
  check.AtLeast("irls_step_convergence_threshold_rad",
                irls_step_convergence_threshold_rad, 0);
  check.GreaterThan("irls_loss_parameter_sigma_deg",
                    irls_loss_parameter_sigma_deg, 0);
  check.GreaterThan("max_rotation_error_deg", max_rotation_error_deg, 0);
  check.AtLeast("num_rounds", num_rounds, 1);
  return check.status();
}

double RelativeRotationErrorDeg(const ImagePair& pair,
                                const colmap::Reconstruction& reconstruction) {
  const Eigen::Quaterniond rotation1 =
      QuaternionFromQvec(reconstruction.Image(pair.image_id1).Qvec());
  const Eigen::Quaterniond rotation2 =
      QuaternionFromQvec(reconstruction.Image(pair.image_id2).Qvec());
  return AngleDeg(rotation2 * rotation1.conjugate() *
                  QuaternionFromQvec(pair.qvec2_from_1).conjugate());
}

Status AverageRotations(const RotationAveragingOptions& options,
                        ViewGraph* view_graph,
                        colmap::Reconstruction* reconstruction,
                        size_t* num_rejected_pairs,
                        const Interrupt& interrupt) {
  CHECK_NOTNULL(view_graph);
  CHECK_NOTNULL(reconstruction);
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Rotation averaging: invalid options: " +
                         check.message());
  }
  size_t num_rejected = 0;
  if (num_rejected_pairs != nullptr) *num_rejected_pairs = 0;

  // Validate the input before COLMAP's accessors could abort on it.
  for (auto& [pair_id, pair] : view_graph->Pairs()) {
    if (!IsUsable(pair)) continue;
    if (!reconstruction->ExistsImage(pair.image_id1) ||
        !reconstruction->ExistsImage(pair.image_id2)) {
      return Status::Error("Rotation averaging: pair (" +
                           std::to_string(pair.image_id1) + ", " +
                           std::to_string(pair.image_id2) +
                           ") names an image missing from the reconstruction.");
    }
    // A (near) zero quaternion is no rotation (a numerical guard).
    if (!pair.qvec2_from_1.allFinite() || pair.qvec2_from_1.norm() < 1e-12) {
      pair.is_valid = false;
      ++num_rejected;
    }
  }

  const double max_error_rad = options.max_rotation_error_deg * kDegToRad;
  std::vector<colmap::image_t> component;
  std::vector<Eigen::Quaterniond> rotations;
  Problem problem;
  // Rotations of the last solved round, by image id.
  std::unordered_map<colmap::image_t, Eigen::Quaterniond> previous_by_id;
  for (int round = 0; round < options.num_rounds; ++round) {
    component = view_graph->LargestConnectedComponent(IsUsable);
    if (component.size() < 2) {
      return Status::Error(
          "Rotation averaging: fewer than two images are connected by valid "
          "relative rotations.");
    }
    problem = BuildProblem(*view_graph, component);
    // Later rounds start from the previous solution rather than from a new
    // spanning tree (the reference re-initializes): it is already in the
    // inliers' basin and closer than any chain of noisy measurements.
    if (round == 0) {
      rotations = InitializeFromSpanningTree(
          problem, options.use_triangle_support_in_tree
                       ? CountConsistentTriangles(problem, max_error_rad)
                       : std::vector<int>());
    } else {
      rotations.clear();
      for (const colmap::image_t image_id : component) {
        rotations.push_back(previous_by_id.at(image_id));
      }
    }
    const Status status =
        SolveRotations(options, problem, &rotations, interrupt);
    if (!status.ok()) return status;

    // Reject the pairs that disagree with the solution; the next round (and
    // the final component) only sees the consistent ones.
    size_t e = 0;
    size_t num_rejected_in_round = 0;
    for (auto& [pair_id, pair] : view_graph->Pairs()) {
      if (!IsUsable(pair)) continue;
      if (!std::binary_search(component.begin(), component.end(),
                              pair.image_id1) ||
          !std::binary_search(component.begin(), component.end(),
                              pair.image_id2)) {
        continue;
      }
      // Same filter and order as BuildProblem, so edge e is this pair.
      const double error = EdgeResidual(problem.edges[e++], rotations).norm();
      if (error > max_error_rad) {
        pair.is_valid = false;
        ++num_rejected_in_round;
      }
    }
    CHECK_EQ(e, problem.edges.size());
    // Rejection may split this component below the size of another one that
    // was never solved. Pairs outside the solved images are dropped now, so
    // that the next round and the final component only hold images with a
    // rotation from this round (they would be dropped at the end anyway).
    num_rejected +=
        view_graph->InvalidatePairsOutside(std::unordered_set<colmap::image_t>(
            component.begin(), component.end()));
    previous_by_id.clear();
    for (size_t i = 0; i < component.size(); ++i) {
      previous_by_id.emplace(component[i], rotations[i]);
    }
    num_rejected += num_rejected_in_round;
    VLOG(3) << "Rotation averaging round " << round << ": " << component.size()
            << " images, " << problem.edges.size() << " pairs, "
            << num_rejected_in_round << " rejected";
  }

  // Rejection may have split off images; keep the largest consistent part.
  const std::vector<colmap::image_t> final_component =
      view_graph->LargestConnectedComponent(IsUsable);
  if (final_component.size() < 2) {
    return Status::Error(
        "Rotation averaging: fewer than two images remain after rejecting "
        "inconsistent pairs.");
  }
  // Re-anchor the gauge at the smallest id of the final component (only
  // changes anything if the previous gauge image was split off).
  const Eigen::Quaterniond world_correction =
      previous_by_id.at(final_component.front()).conjugate();
  std::unordered_set<colmap::image_t> final_set(final_component.begin(),
                                                final_component.end());

  std::vector<colmap::image_t> all_image_ids;
  all_image_ids.reserve(reconstruction->NumImages());
  for (const auto& [image_id, image] : reconstruction->Images()) {
    all_image_ids.push_back(image_id);
  }
  std::sort(all_image_ids.begin(), all_image_ids.end());
  for (const colmap::image_t image_id : all_image_ids) {
    if (final_set.count(image_id) == 0) {
      if (reconstruction->IsImageRegistered(image_id)) {
        reconstruction->DeRegisterImage(image_id);
      }
      continue;
    }
    const Eigen::Quaterniond rotation =
        (previous_by_id.at(image_id) * world_correction).normalized();
    colmap::Image& image = reconstruction->Image(image_id);
    image.SetQvec(Eigen::Vector4d(rotation.w(), rotation.x(), rotation.y(),
                                  rotation.z()));
    image.SetTvec(Eigen::Vector3d::Zero());
    reconstruction->RegisterImage(image_id);
  }

  num_rejected += view_graph->InvalidatePairsOutside(final_set);
  if (num_rejected_pairs != nullptr) *num_rejected_pairs = num_rejected;
  return Status::Ok();
}

}  // namespace glomap
