#pragma once

#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// The paper's synthetic protocol (its section 5.2.1, after HARA and CReTA):
// ground-truth rotations drawn uniformly, every edge R_ij = N_ij R_j R_i^T with
// N_ij a rotation about a uniformly random axis by an angle ~ normal(0, sigma),
// then a fraction p of the edges (chosen at random, exactly round(p |E|))
// replaced by uniformly random rotations.
struct SyntheticOptions {
  // Standard deviation of the noise angle, degrees (the paper: 5 or 10).
  double noise_sigma_deg = 5.0;
  // Fraction of edges replaced by random rotations, in [0, 1] (paper: 0-0.5).
  double outlier_ratio = 0.0;
  // Seed of the std::mt19937_64 that draws everything.
  uint64_t seed = 0;
  // The structured-outlier protocol (symmetric scenes, e.g. opposite walls
  // that look alike), used when > 0: cameras are upright (heading uniform,
  // pitch and roll ~ normal(0, upright_sigma_deg) about a random axis), and
  // this fraction of the "twin pairs" (edges (i, j) where camera i's viewing
  // direction is within twin_overlap_deg of that of j's mirrored twin R_j M,
  // M = 180 deg about the vertical y axis) carry R_j M^T R_i^T (with noise)
  // instead of R_j R_i^T. Such false edges agree with each other around
  // cycles (they are consistent with R_i M for camera i). outlier_ratio then
  // applies to the other edges (random outliers on top). 0 = the paper's
  // protocol, bit-identical to before.
  double structured_outlier_ratio = 0.0;
  double twin_overlap_deg = 60.0;
  double upright_sigma_deg = 5.0;
  void Check() const;  // throws InputError
};

struct SyntheticProblem {
  RotationGraph graph;                        // structure + noisy measurements
  std::vector<Eigen::Matrix3d> ground_truth;  // cam_from_world per vertex
  std::vector<bool> edge_is_outlier;          // per edge index of `graph`
  // Per edge: a structured (mirrored twin) outlier; also in edge_is_outlier.
  std::vector<bool> edge_is_structured_outlier;
  int num_twin_pairs = 0;  // edges eligible for a structured outlier
};

// 180 deg about the vertical (y) axis: the mirrored twin of a camera R is
// R M (the structured-outlier protocol).
Eigen::Matrix3d MirrorRotation();

// Measurements on the structure of `structure` (its vertices, names, edge
// endpoints and weights are kept; its rotations are ignored).
SyntheticProblem MakeSyntheticProblem(const RotationGraph& structure,
                                      const SyntheticOptions& options);
// Measurements on an edge list over vertices 0..num_vertices-1 (weights 1).
SyntheticProblem MakeSyntheticProblem(
    int num_vertices, const std::vector<std::pair<int, int>>& edges,
    const SyntheticOptions& options);

// A connected random graph: a random spanning tree (each vertex, in a random
// order, attached to a uniformly chosen earlier one) plus uniformly random
// distinct pairs (Erdos-Renyi G(n, m) style) until `num_edges` edges.
// Requires n-1 <= num_edges <= n(n-1)/2 (throws InputError). Edges (i < j) in
// generation order; O(num_edges) time and memory, so 5,000 vertices and
// 700,000 edges take well under a second.
std::vector<std::pair<int, int>> RandomConnectedGraph(int num_vertices,
                                                      int64_t num_edges,
                                                      uint64_t seed);

}  // namespace colmap_irav4
