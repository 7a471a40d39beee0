#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace colmap_irav4 {

// An edge of the rotation averaging problem: R_ij = cam_j_from_cam_i =
// R_j R_i^T between dense vertex indices i and j.
struct RelativeRotation {
  int i = -1;
  int j = -1;
  Eigen::Matrix3d R_ij = Eigen::Matrix3d::Identity();
  double weight = 1.0;  // e.g. the pair's inlier count
};

// The input of every rotation averager: vertices 0..n-1 (optionally named),
// edges with relative rotations, and an adjacency list. Vertices are dense
// indices so that the averagers work on plain vectors.
class RotationGraph {
 public:
  RotationGraph() = default;
  explicit RotationGraph(int num_vertices);

  // Adds a vertex and returns its index.
  int AddVertex(const std::string& name = "");
  // Adds edge i -> j with R_ij = R_j R_i^T; returns its index. i != j, both
  // valid vertices (CHECKed: programmer error).
  int AddEdge(int i, int j, const Eigen::Matrix3d& R_ij, double weight = 1.0);

  int NumVertices() const { return static_cast<int>(names_.size()); }
  int NumEdges() const { return static_cast<int>(edges_.size()); }
  const RelativeRotation& Edge(int edge_idx) const { return edges_[edge_idx]; }
  const std::vector<RelativeRotation>& Edges() const { return edges_; }
  const std::string& Name(int vertex) const { return names_[vertex]; }
  const std::vector<std::string>& Names() const { return names_; }

  // (neighbour, edge index) pairs of a vertex.
  const std::vector<std::pair<int, int>>& Neighbors(int vertex) const {
    return adjacency_[vertex];
  }
  int Degree(int vertex) const {
    return static_cast<int>(adjacency_[vertex].size());
  }
  // The edge's rotation oriented from `from` to its other end:
  // R_{from,to} = R_to R_from^T.
  Eigen::Matrix3d RotationFrom(int edge_idx, int from) const;
  // The edge's other end.
  int OtherEnd(int edge_idx, int vertex) const {
    const RelativeRotation& e = edges_[edge_idx];
    return e.i == vertex ? e.j : e.i;
  }

  // Connected components, largest first; each sorted ascending.
  std::vector<std::vector<int>> ConnectedComponents() const;
  // The subgraph induced by `vertices` (new index k = vertices[k]).
  RotationGraph InducedSubgraph(const std::vector<int>& vertices) const;

 private:
  std::vector<std::string> names_;
  std::vector<RelativeRotation> edges_;
  std::vector<std::vector<std::pair<int, int>>> adjacency_;
};

// The output of every rotation averager: one cam_from_world rotation per
// vertex of the input graph (identity where not estimated), in an arbitrary
// global frame (the gauge).
struct RotationAveragingResult {
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<bool> estimated;
  // Named stage timings in seconds, in order, for the per-stage report.
  std::vector<std::pair<std::string, double>> stage_seconds;

  int NumEstimated() const;
};

// The interface shared by IRAv4, IRA and the baselines, so that every
// comparison runs side by side on the same input.
class RotationAverager {
 public:
  virtual ~RotationAverager() = default;
  virtual std::string Name() const = 0;
  virtual RotationAveragingResult Estimate(const RotationGraph& graph) = 0;
};

}  // namespace colmap_irav4
