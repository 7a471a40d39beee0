#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace colmap_irav4 {

// The coarse level of a two-level preconditioner for the reduced camera
// system (SchurBundleAdjuster's conjugate gradients): the images are grouped
// into clusters of images that share many points, and each cluster may move
// as one rigid body with a scale (7 values: an infinitesimal similarity
// transform of the world applied to its images' poses). The Schur-Jacobi
// preconditioner (one image at a time) leaves those motions of whole
// clusters to the conjugate gradients, which take many iterations to carry
// them across a large scene; the coarse correction solves them exactly,
// z += P (P^T S P)^-1 P^T r (additive two-level Schwarz), with P the
// clusters' motions as columns. On a 1,000-image photo scene's reduced
// system, clusters of 10 took the conjugate gradients from 200 iterations to
// 60 (docs/notes/2026-12-06-coarse-preconditioner.md).

// The values of a coarse column per cluster: rotation (3), translation (3),
// scale (1).
inline constexpr int kNumCoarseModes = 7;

using CoarseMotion = Eigen::Matrix<double, 6, kNumCoarseModes>;

// How a pose's tangent (rotation steps left-multiplied in the camera frame,
// as ceres::EigenQuaternionManifold's; then the position) moves when the
// world moves by the infinitesimal similarity (omega, d, sigma): X -> X +
// omega x X + d + sigma X. `rotation`: quaternion x, y, z, w (world to
// camera); `position`: the projection centre (`center`) or the translation.
CoarseMotion SimilarityMotion(const double* rotation, const double* position,
                              bool center);

// Accumulates the coupling between the nodes of a graph (images): weights
// of unordered pairs.
class CouplingGraph {
 public:
  explicit CouplingGraph(int num_nodes) : num_nodes_(num_nodes) {}
  void Add(int a, int b, double weight);
  int NumNodes() const { return num_nodes_; }
  const std::unordered_map<uint64_t, double>& Pairs() const { return pairs_; }

 private:
  int num_nodes_;
  std::unordered_map<uint64_t, double> pairs_;  // min << 32 | max
};

// Groups the graph's nodes into clusters of at most `size` (aggregation): a
// seed (the node of the largest total weight not yet taken) takes the
// untaken nodes most strongly tied to any of its cluster's members until the
// cluster holds `size` or none is left; a seed left alone then joins the
// cluster of its strongest neighbour (one image's 6 pose values cannot carry
// 7 motions). Returns each node's cluster (0 .. *num_clusters - 1); a node
// without edges is in none (-1: alone, its motions would be singular).
std::vector<int> AggregateClusters(const CouplingGraph& graph, int size,
                                   int* num_clusters);

// The coarse system P^T S P (dense, kNumCoarseModes per cluster) and its
// Cholesky factor. Assembled into the upper triangle of its blocks, a row of
// blocks contiguous and each block contiguous: one point's updates, its
// clusters in increasing order, then walk forward through memory (at 10,000
// images and 502 clusters the scattered blocks of the dense matrix made the
// assembly wait on memory, 8-16 CPU s an iteration).
class CoarseSystem {
 public:
  using Block = Eigen::Matrix<double, kNumCoarseModes, kNumCoarseModes>;

  // Zeros for `num_clusters` clusters.
  void Reset(int num_clusters);
  int Size() const { return kNumCoarseModes * num_clusters_; }
  // Adds m to the block of clusters (a, b) and m^T to (b, a) (m + m^T to
  // the block when a == b).
  void AddPair(int a, int b, const Block& m) {
    if (a < b) {
      UpperBlock(a, b) += m;
    } else if (a > b) {
      UpperBlock(b, a) += m.transpose();
    } else {
      UpperBlock(a, a) += m + m.transpose();
    }
  }
  // Adds the symmetric m to the block of cluster a with itself.
  void AddDiagonal(int a, const Block& m) { UpperBlock(a, a) += m; }
  // The whole symmetric matrix as assembled (not the factor).
  Eigen::MatrixXd Matrix() const;
  // False when the matrix is not positive definite (then no correction).
  bool Factorize();
  bool Factorized() const { return factorized_; }
  // w := (P^T S P)^-1 w.
  void Solve(Eigen::VectorXd* w) const;

 private:
  size_t UpperIndex(int a, int b) const {
    const size_t row = static_cast<size_t>(a);
    return row * num_clusters_ - row * (row - 1) / 2 + (b - a);
  }
  Eigen::Map<Block> UpperBlock(int a, int b) {
    return Eigen::Map<Block>(
        &blocks_[Block::SizeAtCompileTime * UpperIndex(a, b)]);
  }
  Eigen::Map<const Block> UpperBlock(int a, int b) const {
    return Eigen::Map<const Block>(
        &blocks_[Block::SizeAtCompileTime * UpperIndex(a, b)]);
  }

  int num_clusters_ = 0;
  std::vector<double> blocks_;  // the upper triangle's blocks, by rows
  Eigen::MatrixXd factor_;      // lower triangle
  std::unique_ptr<Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>>> llt_;
  bool factorized_ = false;
};

}  // namespace colmap_irav4
