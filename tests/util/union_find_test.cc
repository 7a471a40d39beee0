#include "colmap_irav4/util/union_find.h"

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(UnionFind, MergesAndReportsCycles) {
  UnionFind sets(5);
  EXPECT_EQ(sets.Size(), 5u);
  EXPECT_TRUE(sets.Union(0, 1));
  EXPECT_TRUE(sets.Union(3, 4));
  EXPECT_FALSE(sets.Union(1, 0));
  EXPECT_EQ(sets.Find(0), sets.Find(1));
  EXPECT_NE(sets.Find(0), sets.Find(3));
  EXPECT_NE(sets.Find(2), sets.Find(0));
  const size_t added = sets.Add();
  EXPECT_EQ(added, 5u);
  EXPECT_TRUE(sets.Union(added, 2));
  EXPECT_TRUE(sets.Union(2, 4));
  EXPECT_EQ(sets.Find(5), sets.Find(3));
  EXPECT_EQ(sets.SetSize(4), 4u);  // {2, 3, 4, 5}
  EXPECT_EQ(sets.SetSize(0), 2u);
}

TEST(ConnectedComponents, LargestFirstThenSmallestVertex) {
  // {0, 5}, {1, 2, 6}, {3}, {4, 7}: sizes 2, 3, 1, 2.
  const std::vector<std::vector<int>> components =
      ConnectedComponents(8, {{5, 0}, {6, 2}, {2, 1}, {7, 4}});
  const std::vector<std::vector<int>> expected = {
      {1, 2, 6}, {0, 5}, {4, 7}, {3}};
  EXPECT_EQ(components, expected);
  EXPECT_TRUE(ConnectedComponents(0, {}).empty());
}

TEST(ConnectedComponents, LongChainIsOneComponent) {
  std::vector<std::pair<int, int>> edges;
  for (int v = 999; v > 0; --v) edges.emplace_back(v, v - 1);
  const std::vector<std::vector<int>> components =
      ConnectedComponents(1000, edges);
  ASSERT_EQ(components.size(), 1u);
  EXPECT_EQ(components[0].size(), 1000u);
  EXPECT_EQ(components[0].front(), 0);
  EXPECT_EQ(components[0].back(), 999);
}

}  // namespace
}  // namespace colmap_irav4
