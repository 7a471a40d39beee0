#include "colmap_irav4/rotation_averaging/community_detection.h"

#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

// Planted partition: `groups` groups of `size` vertices, edges inside with
// probability p_in, between with p_out, weights (inlier counts) 20..200.
RotationGraph PlantedPartition(int groups, int size, double p_in, double p_out,
                               uint64_t seed, std::vector<int>* truth) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  RotationGraph graph(groups * size);
  truth->assign(groups * size, 0);
  for (int v = 0; v < groups * size; ++v) (*truth)[v] = v / size;
  for (int i = 0; i < groups * size; ++i) {
    for (int j = i + 1; j < groups * size; ++j) {
      const double p = (*truth)[i] == (*truth)[j] ? p_in : p_out;
      if (uniform(rng) < p) {
        graph.AddEdge(i, j, Eigen::Matrix3d::Identity(),
                      20 + static_cast<int>(uniform(rng) * 180));
      }
    }
  }
  return graph;
}

// Whether two labellings are equal up to renaming the labels.
bool SamePartition(const std::vector<int>& a, const std::vector<int>& b) {
  std::map<int, int> ab, ba;
  for (size_t k = 0; k < a.size(); ++k) {
    if (ab.emplace(a[k], b[k]).first->second != b[k]) return false;
    if (ba.emplace(b[k], a[k]).first->second != a[k]) return false;
  }
  return true;
}

std::vector<int> LabelsOf(const std::vector<std::vector<int>>& communities,
                          int n) {
  std::vector<int> labels(n, -1);
  for (size_t c = 0; c < communities.size(); ++c) {
    for (int v : communities[c]) labels[v] = static_cast<int>(c);
  }
  return labels;
}

TEST(CommunityDetection, LouvainRecoversPlantedPartitions) {
  for (uint64_t seed : {1, 2, 3, 4, 5}) {
    std::vector<int> truth;
    const RotationGraph graph =
        PlantedPartition(5, 40, 0.4, 0.01, seed, &truth);
    const std::vector<int> labels = LouvainCommunities(graph);
    EXPECT_TRUE(SamePartition(labels, truth)) << "seed " << seed;
    EXPECT_GE(Modularity(graph, labels), Modularity(graph, truth) - 1e-12);
  }
}

TEST(CommunityDetection, DeterministicAndNumberedBySmallestVertex) {
  std::vector<int> truth;
  const RotationGraph graph = PlantedPartition(4, 30, 0.3, 0.03, 7, &truth);
  const std::vector<int> a = LouvainCommunities(graph);
  const std::vector<int> b = LouvainCommunities(graph);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a[0], 0);
  CommunityDetectionOptions options;
  const auto c1 = DetectCommunities(graph, options);
  const auto c2 = DetectCommunities(graph, options);
  EXPECT_EQ(c1, c2);
}

TEST(CommunityDetection, WeightsDecideBetweenEquallyDenseGroupings) {
  // Two cliques of 10 joined by many light edges vs. heavy inner edges: the
  // weighted modularity keeps the cliques apart although the unweighted
  // bipartite links are dense.
  RotationGraph graph(20);
  for (int i = 0; i < 20; ++i) {
    for (int j = i + 1; j < 20; ++j) {
      const bool same = (i < 10) == (j < 10);
      if (same) {
        graph.AddEdge(i, j, Eigen::Matrix3d::Identity(), 500);
      } else if ((i + j) % 2 == 0) {
        graph.AddEdge(i, j, Eigen::Matrix3d::Identity(), 1);
      }
    }
  }
  const std::vector<int> labels = LouvainCommunities(graph);
  std::vector<int> truth(20);
  for (int v = 0; v < 20; ++v) truth[v] = v < 10 ? 0 : 1;
  EXPECT_TRUE(SamePartition(labels, truth));
}

TEST(CommunityDetection, MaxSizeSplitsAndMinSizeMerges) {
  std::vector<int> truth;
  const RotationGraph graph = PlantedPartition(3, 60, 0.3, 0.005, 11, &truth);
  CommunityDetectionOptions options;
  options.min_community_size = 5;
  options.max_community_size = 25;
  const auto small = DetectCommunities(graph, options);
  int covered = 0;
  for (const auto& community : small) {
    EXPECT_LE(community.size(), 25u);
    EXPECT_GE(community.size(), 5u);
    EXPECT_TRUE(ContainsTriangle(graph, community));
    covered += community.size();
  }
  EXPECT_EQ(covered, graph.NumVertices());
  EXPECT_GE(small.size(), 8u);  // 180 vertices, at most 25 each
  // Each split piece stays inside one planted group.
  for (const auto& community : small) {
    std::set<int> groups;
    for (int v : community) groups.insert(truth[v]);
    EXPECT_EQ(groups.size(), 1u);
  }

  options.max_community_size = 0;
  options.min_community_size = 61;  // every planted group is too small
  const auto merged = DetectCommunities(graph, options);
  EXPECT_EQ(merged.size(), 1u);
  EXPECT_EQ(static_cast<int>(merged[0].size()), graph.NumVertices());
}

TEST(CommunityDetection, CommunityWithoutTriangleIsMerged) {
  // A triangle-rich group plus a pendant path 10-11-12-13 hanging off it
  // with heavy weights (Louvain may keep the path apart; it cannot seed).
  RotationGraph graph(14);
  for (int i = 0; i < 10; ++i) {
    for (int j = i + 1; j < 10; ++j) {
      graph.AddEdge(i, j, Eigen::Matrix3d::Identity(), 10);
    }
  }
  graph.AddEdge(9, 10, Eigen::Matrix3d::Identity(), 1);
  graph.AddEdge(10, 11, Eigen::Matrix3d::Identity(), 1000);
  graph.AddEdge(11, 12, Eigen::Matrix3d::Identity(), 1000);
  graph.AddEdge(12, 13, Eigen::Matrix3d::Identity(), 1000);
  CommunityDetectionOptions options;
  options.min_community_size = 1;
  const auto communities = DetectCommunities(graph, options);
  for (const auto& community : communities) {
    EXPECT_TRUE(ContainsTriangle(graph, community));
  }
  EXPECT_EQ(LabelsOf(communities, 14)[13], LabelsOf(communities, 14)[0]);
}

TEST(CommunityDetection, ContainsTriangle) {
  RotationGraph graph(4);
  graph.AddEdge(0, 1, Eigen::Matrix3d::Identity());
  graph.AddEdge(1, 2, Eigen::Matrix3d::Identity());
  graph.AddEdge(2, 3, Eigen::Matrix3d::Identity());
  EXPECT_FALSE(ContainsTriangle(graph, {0, 1, 2, 3}));
  graph.AddEdge(0, 2, Eigen::Matrix3d::Identity());
  EXPECT_TRUE(ContainsTriangle(graph, {0, 1, 2}));
  EXPECT_FALSE(ContainsTriangle(graph, {0, 1, 3}));
}

}  // namespace
}  // namespace colmap_irav4
