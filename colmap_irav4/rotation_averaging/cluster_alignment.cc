#include "colmap_irav4/rotation_averaging/cluster_alignment.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>
#include <utility>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/union_find.h"

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

ClusterConsensusCheck CheckAlignmentByClusterConsensus(
    const RotationGraph& graph, const std::vector<int>& cluster_of,
    int num_clusters, double theta_deg, int min_support, int max_candidates,
    std::vector<Eigen::Matrix3d>* rotations) {
  const int n = graph.NumVertices();
  CHECK_EQ(static_cast<int>(cluster_of.size()), n);
  CHECK_EQ(static_cast<int>(rotations->size()), n);
  CHECK_GE(min_support, 1);
  CHECK_GE(max_candidates, 1);
  const double trace_threshold = 1.0 + 2.0 * std::cos(DegToRad(theta_deg));
  const double noise_trace_threshold =
      1.0 + 2.0 * std::cos(DegToRad(std::min(2.0 * theta_deg, 180.0)));
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  ClusterConsensusCheck check;
  auto count_inliers = [&](const std::vector<Eigen::Matrix3d>& R) {
    int count = 0;
    for (const RelativeRotation& edge : graph.Edges()) {
      // Edges touching no cluster, or a vertex placed one by one, keep
      // their residual under any correction or are not the clusters' to
      // decide.
      if (cluster_of[edge.i] < 0 || cluster_of[edge.j] < 0) continue;
      count += Within(R[edge.j], edge.R_ij * R[edge.i], trace_threshold);
    }
    return count;
  };

  // A correction G_c of cluster c turns its rotations into R_v G_c. Edge
  // a (cluster c) - b (cluster d) holds if R_b G_d = R_ab R_a G_c, i.e.
  // G_d = M G_c with M = R_b^T R_ab R_a: the identity where the current
  // alignment satisfies the edge. Per pair c < d, the M's mapping c to d.
  std::map<std::pair<int, int>, std::vector<Eigen::Matrix3d>> estimates;
  for (int e = 0; e < graph.NumEdges(); ++e) {
    const RelativeRotation& edge = graph.Edge(e);
    const int ci = cluster_of[edge.i], cj = cluster_of[edge.j];
    if (ci < 0 || cj < 0 || ci == cj) continue;
    const Eigen::Matrix3d M =
        (*rotations)[edge.j].transpose() * edge.R_ij * (*rotations)[edge.i];
    if (ci < cj) {
      estimates[{ci, cj}].push_back(M);
    } else {
      estimates[{cj, ci}].push_back(M.transpose());
    }
  }
  struct Relation {
    int c, d;
    int support;        // of the chosen relation
    bool keeps;         // the chosen relation is the current alignment
    Eigen::Matrix3d M;  // G_d = M G_c
  };
  std::vector<Relation> relations;
  for (const auto& [pair, pair_estimates] : estimates) {
    Relation relation{pair.first, pair.second, 0, true, identity};
    relation.support = CountSupport(identity, pair_estimates, trace_threshold);
    // At most max_candidates candidates, evenly spread (deterministic):
    // dense graphs join two clusters by thousands of edges, of which a
    // relation held by many is sampled many times.
    const size_t stride = std::max<size_t>(
        1, pair_estimates.size() / static_cast<size_t>(max_candidates));
    for (size_t k = 0; k < pair_estimates.size(); k += stride) {
      const Eigen::Matrix3d& candidate = pair_estimates[k];
      const int support =
          CountSupport(candidate, pair_estimates, trace_threshold);
      if (support > relation.support) {
        relation.support = support;
        relation.keeps = false;
        relation.M = candidate;
      }
    }
    if (!relation.keeps) {
      std::vector<Eigen::Matrix3d> supporters;
      for (const Eigen::Matrix3d& estimate : pair_estimates) {
        if (Within(relation.M, estimate, trace_threshold)) {
          supporters.push_back(estimate);
        }
      }
      relation.M = GeodesicMean(supporters, relation.M);
      // A relation within 2 theta of the current one is the same up to
      // noise (their supporters overlap): the final optimisation refines
      // it, the check is for gross errors (90-170 deg on the V2 scenes).
      if (Within(relation.M, identity, noise_trace_threshold)) {
        relation.keeps = true;
        relation.M = identity;
      } else {
        check.num_contradicted += relation.support >= min_support;
      }
    }
    relations.push_back(relation);
  }
  check.num_relations = static_cast<int>(relations.size());
  check.inliers_before = count_inliers(*rotations);
  if (check.num_contradicted == 0) return check;

  // Maximum-support spanning tree (Kruskal; ties: relations that keep the
  // current alignment, then cluster order).
  std::stable_sort(relations.begin(), relations.end(),
                   [](const Relation& a, const Relation& b) {
                     return std::make_tuple(-a.support, !a.keeps, a.c, a.d) <
                            std::make_tuple(-b.support, !b.keeps, b.c, b.d);
                   });
  UnionFind forest(num_clusters);
  // tree[c]: (neighbour, G_neighbour = M G_c).
  std::vector<std::vector<std::pair<int, Eigen::Matrix3d>>> tree(num_clusters);
  for (const Relation& relation : relations) {
    if (!forest.Union(relation.c, relation.d)) continue;
    const Eigen::Matrix3d M = relation.keeps || relation.support < min_support
                                  ? identity
                                  : relation.M;
    tree[relation.c].emplace_back(relation.d, M);
    tree[relation.d].emplace_back(relation.c, M.transpose());
  }
  // Propagate from the largest cluster of each tree (its correction: none).
  std::vector<int> size(num_clusters, 0);
  for (int v = 0; v < n; ++v) {
    if (cluster_of[v] >= 0) ++size[cluster_of[v]];
  }
  std::vector<int> order(num_clusters);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return size[a] > size[b]; });
  std::vector<Eigen::Matrix3d> correction(num_clusters, identity);
  std::vector<bool> done(num_clusters, false);
  std::vector<bool> moved(num_clusters, false);
  for (int root : order) {
    if (done[root]) continue;
    done[root] = true;
    std::vector<int> stack = {root};
    while (!stack.empty()) {
      const int c = stack.back();
      stack.pop_back();
      for (const auto& [d, M] : tree[c]) {
        if (done[d]) continue;
        done[d] = true;
        moved[d] = moved[c] || !M.isIdentity(0.0);
        correction[d] =
            moved[d] ? Eigen::Matrix3d(M * correction[c]) : identity;
        stack.push_back(d);
      }
    }
  }
  check.num_moved_clusters =
      static_cast<int>(std::count(moved.begin(), moved.end(), true));
  if (check.num_moved_clusters == 0) return check;
  std::vector<Eigen::Matrix3d> corrected = *rotations;
  for (int v = 0; v < n; ++v) {
    if (cluster_of[v] >= 0 && moved[cluster_of[v]]) {
      corrected[v] = (*rotations)[v] * correction[cluster_of[v]];
    }
  }
  check.inliers_after = count_inliers(corrected);
  if (check.inliers_after > check.inliers_before) {
    rotations->swap(corrected);
    check.applied = true;
  }
  return check;
}

}  // namespace colmap_irav4
