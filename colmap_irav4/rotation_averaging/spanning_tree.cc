#include "colmap_irav4/rotation_averaging/spanning_tree.h"

#include <algorithm>
#include <numeric>

#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {
SpanningTree MaximumSpanningTree(const RotationGraph& graph) {
  const int num_vertices = graph.NumVertices();
  SpanningTree tree;
  tree.parent.assign(num_vertices, -1);
  tree.parent_edge.assign(num_vertices, -1);
  if (num_vertices == 0) return tree;

  const std::vector<std::vector<int>> components = graph.ConnectedComponents();
  const std::vector<int>& component = components.front();
  std::vector<bool> in_component(num_vertices, false);
  for (int v : component) in_component[v] = true;

  // Root: largest weighted degree inside the component.
  double best_degree = -1.0;
  for (int v : component) {
    double degree = 0.0;
    for (const auto& [neighbor, edge_idx] : graph.Neighbors(v)) {
      degree += graph.Edge(edge_idx).weight;
    }
    if (degree > best_degree) {
      best_degree = degree;
      tree.root = v;
    }
  }

  // Kruskal on the component's edges, heaviest first.
  std::vector<int> edge_order;
  edge_order.reserve(graph.NumEdges());
  for (int e = 0; e < graph.NumEdges(); ++e) {
    if (in_component[graph.Edge(e).i]) edge_order.push_back(e);
  }
  std::stable_sort(edge_order.begin(), edge_order.end(), [&](int a, int b) {
    return graph.Edge(a).weight > graph.Edge(b).weight;
  });
  UnionFind union_find(num_vertices);
  std::vector<std::vector<std::pair<int, int>>> tree_adjacency(num_vertices);
  for (int e : edge_order) {
    const RelativeRotation& edge = graph.Edge(e);
    if (!union_find.Union(edge.i, edge.j)) continue;  // would close a cycle
    tree.edges.push_back(e);
    tree_adjacency[edge.i].emplace_back(edge.j, e);
    tree_adjacency[edge.j].emplace_back(edge.i, e);
    if (tree.edges.size() + 1 == component.size()) break;
  }

  // BFS from the root fixes parents and the chaining order.
  std::vector<bool> visited(num_vertices, false);
  visited[tree.root] = true;
  tree.order.push_back(tree.root);
  for (size_t k = 0; k < tree.order.size(); ++k) {
    const int v = tree.order[k];
    for (const auto& [child, edge_idx] : tree_adjacency[v]) {
      if (visited[child]) continue;
      visited[child] = true;
      tree.parent[child] = v;
      tree.parent_edge[child] = edge_idx;
      tree.order.push_back(child);
    }
  }
  return tree;
}

RotationAveragingResult ChainRotationsAlongTree(const RotationGraph& graph,
                                                const SpanningTree& tree) {
  RotationAveragingResult result;
  result.rotations.assign(graph.NumVertices(), Eigen::Matrix3d::Identity());
  result.estimated.assign(graph.NumVertices(), false);
  for (int v : tree.order) {
    if (v != tree.root) {
      const int parent = tree.parent[v];
      result.rotations[v] = graph.RotationFrom(tree.parent_edge[v], parent) *
                            result.rotations[parent];
    }
    result.estimated[v] = true;
  }
  return result;
}

RotationAveragingResult SpanningTreeAverager::Estimate(
    const RotationGraph& graph) {
  Timer timer;
  const SpanningTree tree = MaximumSpanningTree(graph);
  RotationAveragingResult result = ChainRotationsAlongTree(graph, tree);
  result.stage_seconds.emplace_back("spanning_tree", timer.ElapsedSeconds());
  return result;
}

}  // namespace colmap_irav4
