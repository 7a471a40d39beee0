#pragma once

#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Common-vertex-guided alignment of a cluster to the reference (IRAv3+, kept
// by IRAv4). Rotations in a cluster's frame relate to the reference frame by
// one rotation A_c: R_v = R_v^c A_c (A_c = cluster_world_from_world). Then
//   a common vertex u gives            A_u  = (R_u^c)^T R_u^ref,
//   an edge a (cluster) - b (reference) A_ab = (R_a^c)^T R_ab^T R_b^ref,
// the latter because R_b = R_ab R_a = R_ab R_a^c A_c.
struct ClusterAlignmentOptions {
  // Two estimates of A agree (support each other) within this angle.
  double theta_deg = 3.0;
  // Refinement rounds: re-collect supporters around the current estimate and
  // take their geodesic mean.
  int num_refinements = 3;
  // Without common vertices, the edge-induced estimates vote among
  // themselves; at most this many of them are tried as candidates (evenly
  // spread, deterministic) to bound the quadratic cost.
  int max_vote_candidates = 500;

  void Check() const;
};

struct ClusterAlignment {
  bool success = false;
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  int num_common_vertices = 0;
  int num_edges = 0;       // cluster-to-reference edges used
  int num_supporters = 0;  // estimates within theta of the final A
  bool used_vertex_guidance = false;
};

// `cluster_rotations` / `reference_rotations`: one entry per graph vertex,
// meaningful where `in_cluster` / `in_reference` is true.
ClusterAlignment AlignClusterToReference(
    const RotationGraph& graph,
    const std::vector<Eigen::Matrix3d>& cluster_rotations,
    const std::vector<bool>& in_cluster,
    const std::vector<Eigen::Matrix3d>& reference_rotations,
    const std::vector<bool>& in_reference,
    const ClusterAlignmentOptions& options);

// What CheckAlignmentByClusterConsensus found and did.
struct ClusterConsensusCheck {
  int num_relations = 0;     // cluster pairs joined by at least one edge
  int num_contradicted = 0;  // corroborated relations the alignment breaks
  int num_moved_clusters = 0;
  int inliers_before = 0;  // edges within theta, all estimated vertices
  int inliers_after = 0;   // of the corrected alignment (if one was tried)
  bool applied = false;
};

// A check of the reference-based alignment by the consensus of ALL edges
// between each pair of clusters (IRA++'s inter-cluster voting, used here as
// a check): `cluster_of[v]` is v's aligned cluster (-1: none, e.g. placed
// one by one), `rotations` the aligned rotations. The reference can be
// wrong where the graph is thin: it takes a vertex on the word of a single
// edge, and a whole part of the reference then follows a false pair (V2 100
// seed 2, docs/notes/2026-12-03-irav4-weak-joins.md); every cluster aligned
// to that part follows it, whatever the true pairs across say. Each cluster
// pair's relation is the edge-induced estimate with the most supporters
// within theta (ties, and estimates within 2 theta of the current
// alignment, which differ from it by noise only: the current alignment;
// the final optimisation refines those). A maximum-support spanning
// tree of the cluster graph keeps the current relation of each tree pair
// unless `min_support` or more edges agree on another one (a single edge
// never overrules the reference). The corrected alignment is kept only if
// it has more inlier edges (within theta) over the whole graph than the
// current one; else `rotations` is unchanged. Per pair at most
// `max_candidates` edge estimates are tried as the relation (evenly spread),
// each scored against all: O(max_candidates E) at worst.
ClusterConsensusCheck CheckAlignmentByClusterConsensus(
    const RotationGraph& graph, const std::vector<int>& cluster_of,
    int num_clusters, double theta_deg, int min_support, int max_candidates,
    std::vector<Eigen::Matrix3d>* rotations);

// Geodesic (Karcher) L2 mean of rotations, initialised at `initial`.
Eigen::Matrix3d GeodesicMean(const std::vector<Eigen::Matrix3d>& rotations,
                             const Eigen::Matrix3d& initial,
                             int max_iterations = 20);

}  // namespace colmap_irav4
