#pragma once

#include <vector>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Community detection on the epipolar graph, weighted by the edges' weights
// (inlier counts): Louvain modularity maximisation, then size control so that
// every community can seed a cluster (IRAv3's cluster seed construction).
struct CommunityDetectionOptions {
  // Modularity resolution (1 = standard modularity; larger = smaller
  // communities).
  double resolution = 1.0;
  // Communities larger than this are re-partitioned by Louvain on their
  // induced subgraph (and, if that does not split them, cut into connected
  // BFS chunks). 0 = no limit.
  int max_community_size = 0;
  // Communities smaller than this, or without a triangle (no seed triplet),
  // are merged into the neighbouring community they share most edge weight
  // with.
  int min_community_size = 10;
  // Cap on Louvain local-moving passes per level (each pass visits every
  // vertex once in index order: deterministic).
  int max_passes = 50;
  // Minimum modularity gain of a level to go on aggregating.
  double min_modularity_gain = 1e-7;

  void Check() const;
};

// Louvain on the whole graph: one label per vertex (0..k-1, numbered by their
// smallest vertex), deterministic. Vertices without edges form singletons.
std::vector<int> LouvainCommunities(const RotationGraph& graph,
                                    double resolution = 1.0,
                                    int max_passes = 50,
                                    double min_modularity_gain = 1e-7);

// Weighted modularity of a labelling (for tests and reports).
double Modularity(const RotationGraph& graph, const std::vector<int>& labels,
                  double resolution = 1.0);

// Louvain plus size control; returns the communities (each sorted ascending),
// ordered by their smallest vertex.
std::vector<std::vector<int>> DetectCommunities(
    const RotationGraph& graph, const CommunityDetectionOptions& options);

// Whether the subgraph induced by `vertices` contains a triangle.
bool ContainsTriangle(const RotationGraph& graph,
                      const std::vector<int>& vertices);

}  // namespace colmap_irav4
