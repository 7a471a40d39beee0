#include "colmap_irav4/refinement/coarse_space.h"

#include <algorithm>
#include <numeric>
#include <queue>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Geometry>

namespace colmap_irav4 {

CoarseMotion SimilarityMotion(const double* rotation, const double* position,
                              bool center) {
  const Eigen::Matrix3d r =
      Eigen::Quaterniond(rotation[3], rotation[0], rotation[1], rotation[2])
          .normalized()
          .toRotationMatrix();
  const Eigen::Vector3d p(position[0], position[1], position[2]);
  CoarseMotion m = CoarseMotion::Zero();
  // The camera keeps seeing the moved world as before: R' = R (I -
  // [omega]x), i.e. a left step of -R omega.
  m.block<3, 3>(0, 0) = -r;
  if (center) {
    // C' = C + omega x C + d + sigma C.
    m.block<3, 3>(3, 0) << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;
    m.block<3, 3>(3, 3).setIdentity();
    m.block<3, 1>(3, 6) = p;
  } else {
    // t' = t + sigma t - R d (R X + t scaled by 1 + sigma).
    m.block<3, 3>(3, 3) = -r;
    m.block<3, 1>(3, 6) = p;
  }
  return m;
}

void CouplingGraph::Add(int a, int b, double weight) {
  if (a == b) return;
  const uint64_t key = static_cast<uint64_t>(std::min(a, b)) << 32 |
                       static_cast<uint32_t>(std::max(a, b));
  pairs_[key] += weight;
}

std::vector<int> AggregateClusters(const CouplingGraph& graph, int size,
                                   int* num_clusters) {
  CHECK_GE(size, 1);
  const int n = graph.NumNodes();
  // Adjacency (CSR) and each node's total weight.
  std::vector<int> begin(n + 1, 0);
  for (const auto& [key, weight] : graph.Pairs()) {
    ++begin[(key >> 32) + 1];
    ++begin[(key & 0xffffffffu) + 1];
  }
  std::partial_sum(begin.begin(), begin.end(), begin.begin());
  std::vector<std::pair<int, double>> edges(begin[n]);
  std::vector<int> fill(begin.begin(), begin.end() - 1);
  std::vector<double> total(n, 0.0);
  for (const auto& [key, weight] : graph.Pairs()) {
    const int a = static_cast<int>(key >> 32);
    const int b = static_cast<int>(key & 0xffffffffu);
    edges[fill[a]++] = {b, weight};
    edges[fill[b]++] = {a, weight};
    total[a] += weight;
    total[b] += weight;
  }
  // The pairs come in the hash table's order: sorted, the clusters do not
  // depend on it.
  for (int i = 0; i < n; ++i) {
    std::sort(edges.begin() + begin[i], edges.begin() + begin[i + 1]);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return total[a] > total[b]; });
  std::vector<int> cluster(n, -1), cluster_size;
  std::priority_queue<std::pair<double, int>> ties;  // (weight, -node)
  for (const int seed : order) {
    if (cluster[seed] >= 0 || begin[seed] == begin[seed + 1]) continue;
    const int c = static_cast<int>(cluster_size.size());
    cluster_size.push_back(0);
    ties = {};
    ties.push({0.0, -seed});
    while (!ties.empty() && cluster_size[c] < size) {
      const int node = -ties.top().second;
      ties.pop();
      if (cluster[node] >= 0) continue;
      cluster[node] = c;
      ++cluster_size[c];
      for (int e = begin[node]; e < begin[node + 1]; ++e) {
        if (cluster[edges[e].first] < 0) {
          ties.push({edges[e].second, -edges[e].first});
        }
      }
    }
  }
  // A lone seed joins its strongest neighbour's cluster.
  for (int i = 0; i < n; ++i) {
    if (cluster[i] < 0 || cluster_size[cluster[i]] != 1) continue;
    const auto strongest = std::max_element(
        edges.begin() + begin[i], edges.begin() + begin[i + 1],
        [](const auto& x, const auto& y) { return x.second < y.second; });
    --cluster_size[cluster[i]];
    cluster[i] = cluster[strongest->first];
    ++cluster_size[cluster[i]];
  }
  // Numbered without the emptied clusters.
  std::vector<int> number(cluster_size.size(), -1);
  int count = 0;
  for (size_t c = 0; c < cluster_size.size(); ++c) {
    if (cluster_size[c] > 0) number[c] = count++;
  }
  for (int& c : cluster) c = c >= 0 ? number[c] : -1;
  *num_clusters = count;
  return cluster;
}

void CoarseSystem::Reset(int num_clusters) {
  llt_.reset();
  factorized_ = false;
  num_clusters_ = num_clusters;
  const size_t num_blocks = static_cast<size_t>(num_clusters) *
                            (static_cast<size_t>(num_clusters) + 1) / 2;
  blocks_.assign(Block::SizeAtCompileTime * num_blocks, 0.0);
}

Eigen::MatrixXd CoarseSystem::Matrix() const {
  Eigen::MatrixXd matrix(Size(), Size());
  for (int a = 0; a < num_clusters_; ++a) {
    for (int b = a; b < num_clusters_; ++b) {
      matrix.block<kNumCoarseModes, kNumCoarseModes>(
          kNumCoarseModes * a, kNumCoarseModes * b) = UpperBlock(a, b);
      matrix.block<kNumCoarseModes, kNumCoarseModes>(kNumCoarseModes * b,
                                                     kNumCoarseModes * a) =
          UpperBlock(a, b).transpose();
    }
  }
  return matrix;
}

bool CoarseSystem::Factorize() {
  // The lower triangle (all the factorisation reads), column by column.
  factor_.resize(Size(), Size());
  for (int a = 0; a < num_clusters_; ++a) {
    for (int b = a; b < num_clusters_; ++b) {
      factor_.block<kNumCoarseModes, kNumCoarseModes>(kNumCoarseModes * b,
                                                      kNumCoarseModes * a) =
          UpperBlock(a, b).transpose();
    }
  }
  llt_ = std::make_unique<Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>>>(factor_);
  factorized_ = llt_->info() == Eigen::Success;
  return factorized_;
}

void CoarseSystem::Solve(Eigen::VectorXd* w) const {
  CHECK(factorized_);
  llt_->solveInPlace(*w);
}

}  // namespace colmap_irav4
