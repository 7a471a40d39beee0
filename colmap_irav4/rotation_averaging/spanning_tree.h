#pragma once

#include <string>
#include <vector>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Maximum spanning tree of the graph's largest connected component by edge
// weight (inlier count), ties broken by edge index so that the result is
// deterministic. Returns the tree's edge indices and its root: the vertex of
// largest weighted degree (the best-supported camera anchors the chaining).
struct SpanningTree {
  int root = -1;
  std::vector<int> edges;
  // parent[v] / parent_edge[v]: the tree parent of v (-1 for the root and for
  // vertices outside the component).
  std::vector<int> parent;
  std::vector<int> parent_edge;
  // Vertices in BFS order from the root.
  std::vector<int> order;
};
SpanningTree MaximumSpanningTree(const RotationGraph& graph);

// Rotations chained along the tree from the root (R_root = I):
// R_child = R_{parent,child} R_parent. Vertices outside the largest component
// are left unestimated (identity).
RotationAveragingResult ChainRotationsAlongTree(const RotationGraph& graph,
                                                const SpanningTree& tree);

// The plain spanning-tree chaining baseline.
class SpanningTreeAverager : public RotationAverager {
 public:
  std::string Name() const override { return "spanning_tree"; }
  RotationAveragingResult Estimate(const RotationGraph& graph) override;
};

}  // namespace colmap_irav4
