#include "colmap_irav4/rotation_averaging/cluster_alignment.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// Cosine threshold: d(A, B) < theta  <=>  tr(A B^T) > 1 + 2 cos(theta), which
// avoids an arccos per comparison in the voting loops.
bool Within(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b,
            double trace_threshold) {
  return (a.cwiseProduct(b)).sum() > trace_threshold;
}

int CountSupport(const Eigen::Matrix3d& candidate,
                 const std::vector<Eigen::Matrix3d>& estimates,
                 double trace_threshold) {
  int count = 0;
  for (const auto& estimate : estimates) {
    if (Within(candidate, estimate, trace_threshold)) ++count;
  }
  return count;
}

}  // namespace

void ClusterAlignmentOptions::Check() const {
  if (!(theta_deg > 0 && theta_deg < 180)) {
    throw OptionError(&theta_deg, "ClusterAlignmentOptions::theta_deg",
                      "must be in (0, 180)");
  }
  if (num_refinements < 0) {
    throw OptionError(&num_refinements,
                      "ClusterAlignmentOptions::num_refinements",
                      "must be >= 0");
  }
  if (max_vote_candidates < 1) {
    throw OptionError(&max_vote_candidates,
                      "ClusterAlignmentOptions::max_vote_candidates",
                      "must be >= 1");
  }
}

Eigen::Matrix3d GeodesicMean(const std::vector<Eigen::Matrix3d>& rotations,
                             const Eigen::Matrix3d& initial,
                             int max_iterations) {
  Eigen::Matrix3d mean = initial;
  if (rotations.empty()) return mean;
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (const auto& R : rotations) {
      step += RotationToAngleAxis(mean.transpose() * R);
    }
    step /= static_cast<double>(rotations.size());
    mean = mean * AngleAxisToRotation(step);
    if (step.norm() < 1e-12) break;
  }
  return mean;
}

ClusterAlignment AlignClusterToReference(
    const RotationGraph& graph,
    const std::vector<Eigen::Matrix3d>& cluster_rotations,
    const std::vector<bool>& in_cluster,
    const std::vector<Eigen::Matrix3d>& reference_rotations,
    const std::vector<bool>& in_reference,
    const ClusterAlignmentOptions& options) {
  options.Check();
  const int n = graph.NumVertices();
  CHECK_EQ(static_cast<int>(cluster_rotations.size()), n);
  CHECK_EQ(static_cast<int>(reference_rotations.size()), n);
  const double trace_threshold =
      1.0 + 2.0 * std::cos(DegToRad(options.theta_deg));

  std::vector<Eigen::Matrix3d> vertex_estimates, edge_estimates;
  for (int v = 0; v < n; ++v) {
    if (in_cluster[v] && in_reference[v]) {
      vertex_estimates.push_back(cluster_rotations[v].transpose() *
                                 reference_rotations[v]);
    }
  }
  for (int e = 0; e < graph.NumEdges(); ++e) {
    const RelativeRotation& edge = graph.Edge(e);
    // Both orientations: a in the cluster, b in the reference.
    for (int side = 0; side < 2; ++side) {
      const int a = side == 0 ? edge.i : edge.j;
      const int b = side == 0 ? edge.j : edge.i;
      if (!in_cluster[a] || !in_reference[b]) continue;
      const Eigen::Matrix3d R_ab = graph.RotationFrom(e, a);
      edge_estimates.push_back(cluster_rotations[a].transpose() *
                               R_ab.transpose() * reference_rotations[b]);
    }
  }

  ClusterAlignment result;
  result.num_common_vertices = static_cast<int>(vertex_estimates.size());
  result.num_edges = static_cast<int>(edge_estimates.size());
  if (vertex_estimates.empty() && edge_estimates.empty()) return result;

  // Candidates: the vertex-induced estimates (more reliable: averaged
  // absolute rotations) or, without common vertices, the edge-induced ones.
  // Score: edge-induced supporters; ties broken by vertex-induced agreement.
  result.used_vertex_guidance = !vertex_estimates.empty();
  std::vector<const Eigen::Matrix3d*> candidates;
  if (result.used_vertex_guidance) {
    for (const auto& estimate : vertex_estimates) {
      candidates.push_back(&estimate);
    }
  } else {
    const size_t stride = std::max<size_t>(
        1, edge_estimates.size() / options.max_vote_candidates);
    for (size_t k = 0; k < edge_estimates.size(); k += stride) {
      candidates.push_back(&edge_estimates[k]);
    }
  }
  int best_edge_support = -1, best_vertex_support = -1;
  Eigen::Matrix3d A = *candidates.front();
  for (const Eigen::Matrix3d* candidate : candidates) {
    const int edge_support =
        CountSupport(*candidate, edge_estimates, trace_threshold);
    const int vertex_support =
        CountSupport(*candidate, vertex_estimates, trace_threshold);
    if (edge_support > best_edge_support ||
        (edge_support == best_edge_support &&
         vertex_support > best_vertex_support)) {
      best_edge_support = edge_support;
      best_vertex_support = vertex_support;
      A = *candidate;
    }
  }

  // Refine on the supporters (edge- and vertex-induced within theta).
  std::vector<Eigen::Matrix3d> supporters;
  for (int round = 0; round <= options.num_refinements; ++round) {
    supporters.clear();
    for (const auto& estimate : edge_estimates) {
      if (Within(A, estimate, trace_threshold)) supporters.push_back(estimate);
    }
    for (const auto& estimate : vertex_estimates) {
      if (Within(A, estimate, trace_threshold)) supporters.push_back(estimate);
    }
    if (supporters.empty() || round == options.num_refinements) break;
    A = GeodesicMean(supporters, A);
  }
  result.A = A;
  result.num_supporters = static_cast<int>(supporters.size());
  result.success = true;
  return result;
}

}  // namespace colmap_irav4
