#include "colmap_irav4/rotation_averaging/synthetic.h"

#include <set>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

TEST(Synthetic, RandomGraphIsConnectedSimpleAndSized) {
  const auto edges = RandomConnectedGraph(300, 3000, 1);
  ASSERT_EQ(edges.size(), 3000u);
  std::set<std::pair<int, int>> unique;
  RotationGraph graph(300);
  for (const auto& [i, j] : edges) {
    ASSERT_LT(i, j);
    ASSERT_GE(i, 0);
    ASSERT_LT(j, 300);
    unique.insert({i, j});
    graph.AddEdge(i, j, Eigen::Matrix3d::Identity());
  }
  EXPECT_EQ(unique.size(), edges.size());
  EXPECT_EQ(graph.ConnectedComponents().size(), 1u);
  // A tree and a complete graph are both reachable.
  EXPECT_EQ(RandomConnectedGraph(50, 49, 2).size(), 49u);
  EXPECT_EQ(RandomConnectedGraph(20, 190, 2).size(), 190u);
  EXPECT_THROW(RandomConnectedGraph(20, 191, 2), InputError);
  EXPECT_THROW(RandomConnectedGraph(20, 18, 2), InputError);
}

TEST(Synthetic, SeedReproducesAndChanges) {
  EXPECT_EQ(RandomConnectedGraph(100, 500, 7),
            RandomConnectedGraph(100, 500, 7));
  EXPECT_NE(RandomConnectedGraph(100, 500, 7),
            RandomConnectedGraph(100, 500, 8));
  const auto edges = RandomConnectedGraph(100, 500, 7);
  SyntheticOptions options;
  options.outlier_ratio = 0.2;
  options.seed = 9;
  const SyntheticProblem a = MakeSyntheticProblem(100, edges, options);
  const SyntheticProblem b = MakeSyntheticProblem(100, edges, options);
  ASSERT_EQ(a.graph.NumEdges(), b.graph.NumEdges());
  for (int e = 0; e < a.graph.NumEdges(); ++e) {
    EXPECT_EQ(a.graph.Edge(e).R_ij, b.graph.Edge(e).R_ij);
  }
  EXPECT_EQ(a.edge_is_outlier, b.edge_is_outlier);
  options.seed = 10;
  const SyntheticProblem c = MakeSyntheticProblem(100, edges, options);
  EXPECT_NE(a.edge_is_outlier, c.edge_is_outlier);
}

TEST(Synthetic, NoiseFreeEdgesAreExact) {
  const auto edges = RandomConnectedGraph(50, 200, 3);
  SyntheticOptions options;
  options.noise_sigma_deg = 0.0;
  const SyntheticProblem problem = MakeSyntheticProblem(50, edges, options);
  for (const RelativeRotation& e : problem.graph.Edges()) {
    EXPECT_LT(
        AngularDistanceDeg(e.R_ij, problem.ground_truth[e.j] *
                                       problem.ground_truth[e.i].transpose()),
        1e-6);
  }
}

TEST(Synthetic, NoiseAndOutliersFollowTheProtocol) {
  const auto edges = RandomConnectedGraph(400, 20000, 4);
  for (double sigma : {5.0, 10.0}) {
    SyntheticOptions options;
    options.noise_sigma_deg = sigma;
    options.outlier_ratio = 0.3;
    options.seed = 5;
    const SyntheticProblem problem = MakeSyntheticProblem(400, edges, options);
    int num_outliers = 0;
    double sum_sq = 0.0;
    int num_inliers = 0;
    int num_far_outliers = 0;
    for (int e = 0; e < problem.graph.NumEdges(); ++e) {
      const RelativeRotation& edge = problem.graph.Edge(e);
      const double err = AngularDistanceDeg(
          edge.R_ij, problem.ground_truth[edge.j] *
                         problem.ground_truth[edge.i].transpose());
      if (problem.edge_is_outlier[e]) {
        ++num_outliers;
        if (err > 3 * sigma) ++num_far_outliers;
      } else {
        sum_sq += err * err;
        ++num_inliers;
      }
    }
    EXPECT_EQ(num_outliers, 6000);
    // |angle| of a normal(0, sigma) angle: RMS = sigma.
    EXPECT_NEAR(std::sqrt(sum_sq / num_inliers), sigma, 0.05 * sigma);
    // Uniform rotations are almost never within 3 sigma of the truth.
    EXPECT_GT(num_far_outliers, 0.95 * num_outliers);
  }
}

TEST(Synthetic, StructureGraphKeepsNamesAndWeights) {
  RotationGraph structure;
  structure.AddVertex("a");
  structure.AddVertex("b");
  structure.AddVertex("c");
  structure.AddEdge(0, 1, Eigen::Matrix3d::Identity(), 10);
  structure.AddEdge(2, 1, Eigen::Matrix3d::Identity(), 20);
  SyntheticOptions options;
  options.noise_sigma_deg = 0.0;
  const SyntheticProblem problem = MakeSyntheticProblem(structure, options);
  EXPECT_EQ(problem.graph.Name(2), "c");
  EXPECT_EQ(problem.graph.Edge(1).i, 2);
  EXPECT_EQ(problem.graph.Edge(1).weight, 20);
  EXPECT_LT(AngularDistanceDeg(
                problem.graph.Edge(1).R_ij,
                problem.ground_truth[1] * problem.ground_truth[2].transpose()),
            1e-6);
  options.outlier_ratio = 1.5;
  EXPECT_THROW(MakeSyntheticProblem(structure, options), InputError);
}

}  // namespace
}  // namespace colmap_irav4

namespace colmap_irav4 {
namespace {

// The structured protocol: upright cameras; the chosen twin pairs carry the
// mirrored twin's relative rotation R_j M^T R_i^T (noise-free here), exactly
// round(ratio x twin pairs) of them; random outliers on the other edges.
TEST(Synthetic, StructuredOutliersAreMirroredTwinPairs) {
  SyntheticOptions options;
  options.noise_sigma_deg = 0.0;
  options.outlier_ratio = 0.1;
  options.structured_outlier_ratio = 0.5;
  options.seed = 3;
  const auto edges = RandomConnectedGraph(200, 3000, 3);
  const SyntheticProblem problem = MakeSyntheticProblem(200, edges, options);
  const Eigen::Matrix3d M = MirrorRotation();
  EXPECT_NEAR(RadToDeg(RotationAngle(M)), 180.0, 1e-9);
  ASSERT_GT(problem.num_twin_pairs, 300);
  int num_structured = 0, num_random = 0;
  for (int e = 0; e < problem.graph.NumEdges(); ++e) {
    const RelativeRotation& edge = problem.graph.Edge(e);
    const Eigen::Matrix3d& R_i = problem.ground_truth[edge.i];
    const Eigen::Matrix3d& R_j = problem.ground_truth[edge.j];
    // Upright: the camera's y axis is the world's, up to the small tilt.
    EXPECT_GT(R_i(1, 1), std::cos(DegToRad(40.0)));
    if (problem.edge_is_structured_outlier[e]) {
      ++num_structured;
      EXPECT_TRUE(problem.edge_is_outlier[e]);
      EXPECT_LT((edge.R_ij - R_j * M.transpose() * R_i.transpose()).norm(),
                1e-9);
      // A twin pair: i looks where j's twin looks.
      const Eigen::Vector3d d_i = R_i.row(2).transpose();
      const Eigen::Vector3d d_j = R_j.row(2).transpose();
      EXPECT_GT(d_i.dot(M * d_j), std::cos(DegToRad(60.0)) - 1e-12);
    } else if (problem.edge_is_outlier[e]) {
      ++num_random;
    } else {
      EXPECT_LT((edge.R_ij - R_j * R_i.transpose()).norm(), 1e-9);
    }
  }
  EXPECT_EQ(num_structured,
            static_cast<int>(std::llround(0.5 * problem.num_twin_pairs)));
  EXPECT_EQ(num_random,
            static_cast<int>(std::llround(
                0.1 * (problem.graph.NumEdges() - num_structured))));
  options.structured_outlier_ratio = 2.0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
