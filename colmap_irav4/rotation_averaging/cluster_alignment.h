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

// Geodesic (Karcher) L2 mean of rotations, initialised at `initial`.
Eigen::Matrix3d GeodesicMean(const std::vector<Eigen::Matrix3d>& rotations,
                             const Eigen::Matrix3d& initial,
                             int max_iterations = 20);

}  // namespace colmap_irav4
