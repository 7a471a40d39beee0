#include "colmap_irav4/rotation_averaging/cds.h"

#include <random>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

RotationGraph RandomGraph(int n, double p, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  RotationGraph graph(n);
  for (int i = 0; i < n; ++i) {
    // A path backbone keeps it connected.
    if (i > 0) graph.AddEdge(i - 1, i, Eigen::Matrix3d::Identity(), 30);
    for (int j = i + 2; j < n; ++j) {
      if (uniform(rng) < p) {
        graph.AddEdge(i, j, Eigen::Matrix3d::Identity(),
                      1 + static_cast<int>(uniform(rng) * 300));
      }
    }
  }
  return graph;
}

TEST(Cds, KnownAnswersOnPathAndStar) {
  RotationGraph path(5);
  for (int i = 0; i + 1 < 5; ++i) {
    path.AddEdge(i, i + 1, Eigen::Matrix3d::Identity());
  }
  EXPECT_EQ(GreedyCds(path), (std::vector<int>{1, 2, 3}));
  RotationGraph star(6);
  for (int i = 1; i < 6; ++i) star.AddEdge(0, i, Eigen::Matrix3d::Identity());
  EXPECT_EQ(GreedyCds(star), (std::vector<int>{0}));
  EXPECT_EQ(RandomCds(star, 3).size() <= 2, true);
  EXPECT_TRUE(IsConnectedDominatingSet(star, RandomCds(star, 3)));
}

TEST(Cds, WeightedGreedyFollowsInlierCounts) {
  // 0 and 4 both see 1, 2, 3; 4's edges are heavy. Unweighted starts at 0
  // (tie, smallest index), weighted at 4.
  RotationGraph graph(5);
  for (int v : {1, 2, 3}) {
    graph.AddEdge(0, v, Eigen::Matrix3d::Identity(), 1);
    graph.AddEdge(4, v, Eigen::Matrix3d::Identity(), 100);
  }
  EXPECT_EQ(GreedyCds(graph, false), (std::vector<int>{0, 1}));
  EXPECT_EQ(GreedyCds(graph, true), (std::vector<int>{1, 4}));
}

TEST(Cds, GreedyAndRandomAreConnectedDominatingSets) {
  for (uint64_t seed : {1, 2, 3}) {
    const RotationGraph graph = RandomGraph(300, 0.03, seed);
    const std::vector<int> greedy = GreedyCds(graph);
    EXPECT_TRUE(IsConnectedDominatingSet(graph, greedy));
    EXPECT_TRUE(IsConnectedDominatingSet(graph, GreedyCds(graph, true)));
    const std::vector<int> r1 = RandomCds(graph, 10 + seed);
    const std::vector<int> r2 = RandomCds(graph, 10 + seed);
    const std::vector<int> r3 = RandomCds(graph, 20 + seed);
    EXPECT_EQ(r1, r2);
    EXPECT_NE(r1, r3);
    EXPECT_TRUE(IsConnectedDominatingSet(graph, r1));
    EXPECT_TRUE(IsConnectedDominatingSet(graph, r3));
    // The greedy rule covers fastest: no larger than a random draw here.
    EXPECT_LE(greedy.size(), r1.size());
    const std::vector<int> un = UnionOfRandomCds(graph, 3, seed);
    EXPECT_TRUE(IsConnectedDominatingSet(graph, un));
    EXPECT_GE(un.size(), r1.size() / 2);
  }
}

TEST(Cds, Checks) {
  RotationGraph graph(5);
  graph.AddEdge(0, 1, Eigen::Matrix3d::Identity());
  graph.AddEdge(1, 2, Eigen::Matrix3d::Identity());
  graph.AddEdge(2, 3, Eigen::Matrix3d::Identity());
  graph.AddEdge(3, 4, Eigen::Matrix3d::Identity());
  EXPECT_TRUE(IsDominatingSet(graph, {1, 3}));
  EXPECT_FALSE(IsConnectedSet(graph, {1, 3}));
  EXPECT_FALSE(IsConnectedDominatingSet(graph, {1, 3}));
  EXPECT_FALSE(IsDominatingSet(graph, {1, 2}));
  EXPECT_TRUE(IsConnectedDominatingSet(graph, {1, 2, 3}));
}

}  // namespace
}  // namespace colmap_irav4
