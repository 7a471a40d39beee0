#pragma once

#include <cstdint>
#include <vector>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Task-independent connected dominating sets (CDS) of the epipolar graph, the
// reference baselines that IRAv4's task-specific reference is compared with.

// Guha-Khuller greedy CDS (as used by WCDS): start from the vertex with most
// neighbours; then repeatedly turn black the gray vertex with most white
// neighbours, its white neighbours gray, until no vertex is white.
// `weighted`: neighbours counted by edge weight (inlier count) instead of one
// each. Ties go to the smallest vertex index. On a disconnected graph only
// the component of the start vertex is dominated. Returns the sorted set.
std::vector<int> GreedyCds(const RotationGraph& graph, bool weighted = false);

// A randomised greedy CDS (IRAv3+-style): a uniformly random start vertex,
// then at each step a gray vertex drawn with probability proportional to its
// number of white neighbours. Same seed, same set.
std::vector<int> RandomCds(const RotationGraph& graph, uint64_t seed);

// The union of `num_cds` random CDSs drawn with seeds derived from `seed`
// (IRAv3+'s reference: several random CDSs estimated together).
std::vector<int> UnionOfRandomCds(const RotationGraph& graph, int num_cds,
                                  uint64_t seed);

// Whether `vertices` induce a connected subgraph.
bool IsConnectedSet(const RotationGraph& graph,
                    const std::vector<int>& vertices);
// Whether every vertex of the graph is in `vertices` or adjacent to one.
bool IsDominatingSet(const RotationGraph& graph,
                     const std::vector<int>& vertices);
inline bool IsConnectedDominatingSet(const RotationGraph& graph,
                                     const std::vector<int>& vertices) {
  return !vertices.empty() && IsConnectedSet(graph, vertices) &&
         IsDominatingSet(graph, vertices);
}

}  // namespace colmap_irav4
