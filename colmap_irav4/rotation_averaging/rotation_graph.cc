#include "colmap_irav4/rotation_averaging/rotation_graph.h"

#include <algorithm>

#include <glog/logging.h>

#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {

RotationGraph::RotationGraph(int num_vertices)
    : names_(num_vertices), adjacency_(num_vertices) {}

int RotationGraph::AddVertex(const std::string& name) {
  names_.push_back(name);
  adjacency_.emplace_back();
  return NumVertices() - 1;
}

int RotationGraph::AddEdge(int i, int j, const Eigen::Matrix3d& R_ij,
                           double weight) {
  CHECK_NE(i, j);
  CHECK(i >= 0 && i < NumVertices()) << i;
  CHECK(j >= 0 && j < NumVertices()) << j;
  RelativeRotation edge;
  edge.i = i;
  edge.j = j;
  edge.R_ij = R_ij;
  edge.weight = weight;
  edges_.push_back(edge);
  const int edge_idx = NumEdges() - 1;
  adjacency_[i].emplace_back(j, edge_idx);
  adjacency_[j].emplace_back(i, edge_idx);
  return edge_idx;
}

Eigen::Matrix3d RotationGraph::RotationFrom(int edge_idx, int from) const {
  const RelativeRotation& e = edges_[edge_idx];
  return e.i == from ? e.R_ij : Eigen::Matrix3d(e.R_ij.transpose());
}

std::vector<std::vector<int>> RotationGraph::ConnectedComponents() const {
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(edges_.size());
  for (const RelativeRotation& e : edges_) pairs.emplace_back(e.i, e.j);
  return colmap_irav4::ConnectedComponents(NumVertices(), pairs);
}

RotationGraph RotationGraph::InducedSubgraph(
    const std::vector<int>& vertices) const {
  RotationGraph subgraph;
  std::vector<int> new_index(NumVertices(), -1);
  for (int v : vertices) {
    new_index[v] = subgraph.AddVertex(names_[v]);
  }
  for (const RelativeRotation& e : edges_) {
    if (new_index[e.i] >= 0 && new_index[e.j] >= 0) {
      subgraph.AddEdge(new_index[e.i], new_index[e.j], e.R_ij, e.weight);
    }
  }
  return subgraph;
}

int RotationAveragingResult::NumEstimated() const {
  return static_cast<int>(std::count(estimated.begin(), estimated.end(), true));
}

}  // namespace colmap_irav4
