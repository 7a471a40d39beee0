#include "colmap_irav4/rotation_averaging/rotation_graph.h"

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

TEST(RotationGraph, EdgesOrientationAndComponents) {
  std::mt19937_64 rng(1);
  RotationGraph graph(5);
  const Eigen::Matrix3d R01 = RandomRotation(&rng);
  graph.AddEdge(0, 1, R01);
  graph.AddEdge(1, 2, RandomRotation(&rng));
  graph.AddEdge(3, 4, RandomRotation(&rng));
  EXPECT_EQ(graph.NumEdges(), 3);
  EXPECT_EQ(graph.Degree(1), 2);
  EXPECT_LT(AngularDistanceDeg(graph.RotationFrom(0, 1), R01.transpose()),
            1e-9);
  EXPECT_EQ(graph.OtherEnd(0, 1), 0);
  const auto components = graph.ConnectedComponents();
  ASSERT_EQ(components.size(), 2u);
  EXPECT_EQ(components[0], (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(components[1], (std::vector<int>{3, 4}));
  const RotationGraph sub = graph.InducedSubgraph({1, 2});
  EXPECT_EQ(sub.NumVertices(), 2);
  EXPECT_EQ(sub.NumEdges(), 1);
}

}  // namespace
}  // namespace colmap_irav4
