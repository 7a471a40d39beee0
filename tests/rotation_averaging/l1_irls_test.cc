#include "colmap_irav4/rotation_averaging/l1_irls.h"

#include <algorithm>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/spanning_tree.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

// The paper's synthetic protocol on a connected random graph.
struct Scene {
  RotationGraph graph;
  std::vector<Eigen::Matrix3d> truth;
};

Scene MakeScene(int num_vertices, int num_chords, double noise_deg,
                double outlier_ratio, int seed) {
  SyntheticOptions options;
  options.noise_sigma_deg = noise_deg;
  options.outlier_ratio = outlier_ratio;
  options.seed = seed;
  SyntheticProblem problem = MakeSyntheticProblem(
      num_vertices,
      RandomConnectedGraph(num_vertices, num_vertices + num_chords, seed),
      options);
  return {std::move(problem.graph), std::move(problem.ground_truth)};
}

std::vector<double> Errors(const std::vector<Eigen::Matrix3d>& estimate,
                           const std::vector<Eigen::Matrix3d>& truth) {
  return EvaluateRotations(estimate, {}, truth).errors_deg;
}

TEST(SpanningTree, NoiseFreeExactRecovery) {
  const Scene scene = MakeScene(60, 200, 0.0, 0.0, 1);
  SpanningTreeAverager averager;
  const RotationAveragingResult result = averager.Estimate(scene.graph);
  ASSERT_EQ(result.NumEstimated(), 60);
  for (double error : Errors(result.rotations, scene.truth)) {
    EXPECT_LT(error, 1e-6);
  }
}

TEST(SpanningTree, PicksHeaviestEdges) {
  // Triangle: the lightest edge must be left out of the tree.
  RotationGraph graph(3);
  graph.AddEdge(0, 1, Eigen::Matrix3d::Identity(), 100);
  graph.AddEdge(1, 2, Eigen::Matrix3d::Identity(), 5);
  graph.AddEdge(0, 2, Eigen::Matrix3d::Identity(), 50);
  const SpanningTree tree = MaximumSpanningTree(graph);
  ASSERT_EQ(tree.edges.size(), 2u);
  EXPECT_EQ(std::count(tree.edges.begin(), tree.edges.end(), 1), 0);
  EXPECT_EQ(tree.root, 0);  // weighted degree 150
}

TEST(SpanningTree, EstimatesLargestComponentOnly) {
  RotationGraph graph(5);
  graph.AddEdge(0, 1, Eigen::Matrix3d::Identity());
  graph.AddEdge(2, 3, Eigen::Matrix3d::Identity());
  graph.AddEdge(3, 4, Eigen::Matrix3d::Identity());
  const RotationAveragingResult result = SpanningTreeAverager().Estimate(graph);
  EXPECT_EQ(result.estimated,
            std::vector<bool>({false, false, true, true, true}));
}

TEST(L1Irls, NoiseFreeExactRecovery) {
  for (const std::string solver : {"cholesky", "cg"}) {
    const Scene scene = MakeScene(80, 300, 0.0, 0.0, 2);
    L1IrlsOptions options;
    ASSERT_TRUE(ParseEnum(solver, &options.linear_solver)) << solver;
    const RotationAveragingResult result =
        L1IrlsAverager(options).Estimate(scene.graph);
    ASSERT_EQ(result.NumEstimated(), 80);
    for (double error : Errors(result.rotations, scene.truth)) {
      EXPECT_LT(error, 1e-6) << solver;
    }
  }
}

TEST(L1Irls, ExactRecoveryWithOutliersWithoutNoise) {
  // Exact inliers, 20% random outliers: the spanning tree chains through
  // outliers, the robust refinement must recover the truth exactly.
  const Scene scene = MakeScene(100, 900, 0.0, 0.2, 5);
  const std::vector<double> tree_errors = Errors(
      SpanningTreeAverager().Estimate(scene.graph).rotations, scene.truth);
  EXPECT_GT(*std::max_element(tree_errors.begin(), tree_errors.end()), 10.0);
  const std::vector<double> errors =
      Errors(L1IrlsAverager().Estimate(scene.graph).rotations, scene.truth);
  // Not 0: Geman-McClure leaves the outliers a weight ~1e-5, a bias of
  // ~1e-3 deg at the fixed point.
  EXPECT_LT(*std::max_element(errors.begin(), errors.end()), 1e-2);
}

TEST(L1Irls, FarBetterThanSpanningTreeWithNoiseAndOutliers) {
  const Scene scene = MakeScene(150, 2500, 5.0, 0.3, 3);
  const double tree_median = Median(Errors(
      SpanningTreeAverager().Estimate(scene.graph).rotations, scene.truth));
  const double l1_median = Median(
      Errors(L1IrlsAverager().Estimate(scene.graph).rotations, scene.truth));
  // 2500 edges on 150 vertices: averaging reduces the 5 deg edge noise well
  // below one edge's noise, while chaining accumulates noise and outliers.
  COLMAP_IRAV4_FIGURES << "median error: spanning tree " << tree_median
                       << " deg, L1-IRLS " << l1_median << " deg" << std::endl;
  EXPECT_LT(l1_median, 2.0);
  EXPECT_LT(l1_median * 5, tree_median);
}

TEST(L1Irls, MadridStructureWithNoiseAndOutliers) {
  COLMAP_IRAV4_REQUIRE_DATA("1dsfm/Madrid_Metropolis");
  // The paper's protocol on the real Madrid graph: sigma 5 deg, 30% outliers.
  SyntheticOptions options;
  options.noise_sigma_deg = 5.0;
  options.outlier_ratio = 0.3;
  options.seed = 8;
  const SyntheticProblem problem = MakeSyntheticProblem(
      ReadOneDsfmScene(DataDir() + "/1dsfm/Madrid_Metropolis").graph, options);
  const RotationErrors tree = EvaluateRotations(
      SpanningTreeAverager().Estimate(problem.graph), problem.ground_truth);
  const RotationErrors l1 = EvaluateRotations(
      L1IrlsAverager().Estimate(problem.graph), problem.ground_truth);
  COLMAP_IRAV4_FIGURES
      << "Madrid, sigma 5, 30% outliers: median error spanning tree "
      << tree.median_deg << " deg, L1-IRLS " << l1.median_deg << " deg"
      << std::endl;
  EXPECT_EQ(l1.num_compared, 394);
  EXPECT_LT(l1.median_deg, 1.0);
  EXPECT_LT(10 * l1.median_deg, tree.median_deg);
}

TEST(L1Irls, CholeskyAndCgAgree) {
  const Scene scene = MakeScene(100, 1000, 5.0, 0.2, 4);
  L1IrlsOptions cholesky_options, cg_options;
  cholesky_options.linear_solver = L1IrlsLinearSolver::kCholesky;
  cg_options.linear_solver = L1IrlsLinearSolver::kCg;
  const RotationAveragingResult a =
      L1IrlsAverager(cholesky_options).Estimate(scene.graph);
  const RotationAveragingResult b =
      L1IrlsAverager(cg_options).Estimate(scene.graph);
  for (int v = 0; v < 100; ++v) {
    EXPECT_LT(AngularDistanceDeg(a.rotations[v], b.rotations[v]), 1e-3);
  }
}

TEST(L1Irls, OptionsCheck) {
  L1IrlsOptions options;
  EXPECT_NO_THROW(options.Check());
  EXPECT_FALSE(ParseEnum("qr", &options.linear_solver));
  options = L1IrlsOptions();
  options.gm_sigma_deg = 0;
  EXPECT_THROW(options.Check(), InputError);
}

// The shared IRLS stage from given rotations: two separate parts (one gauge
// each, kept fixed), a non-estimated vertex left alone, outliers without
// noise recovered exactly from a 2 deg perturbation of the truth.
TEST(L1Irls, RefineRotationsIrlsFromGivenRotations) {
  const Scene first = MakeScene(40, 150, 0.0, 0.2, 3);
  const Scene second = MakeScene(30, 100, 0.0, 0.2, 4);
  RotationGraph graph(71);
  std::vector<Eigen::Matrix3d> truth(71, Eigen::Matrix3d::Identity());
  for (int e = 0; e < first.graph.NumEdges(); ++e) {
    const RelativeRotation& r = first.graph.Edge(e);
    graph.AddEdge(r.i, r.j, r.R_ij);
  }
  for (int e = 0; e < second.graph.NumEdges(); ++e) {
    const RelativeRotation& r = second.graph.Edge(e);
    graph.AddEdge(40 + r.i, 40 + r.j, r.R_ij);
  }
  graph.AddEdge(0, 70, Eigen::Matrix3d::Identity());
  for (int v = 0; v < 40; ++v) truth[v] = first.truth[v];
  for (int v = 0; v < 30; ++v) truth[40 + v] = second.truth[v];
  std::mt19937_64 rng(9);
  std::vector<Eigen::Matrix3d> rotations(71, Eigen::Matrix3d::Identity());
  std::vector<bool> estimated(71, true);
  estimated[70] = false;
  for (int v = 0; v < 70; ++v) {
    rotations[v] = truth[v];
    // The gauges (5: given root; 40: first of the second part) stay exact.
    if (v != 5 && v != 40) {
      rotations[v] = RandomRotationWithAngle(DegToRad(2.0), &rng) * truth[v];
    }
  }
  const std::vector<Eigen::Matrix3d> initial = rotations;
  const int iterations =
      RefineRotationsIrls(graph, L1IrlsOptions(), estimated, 5, &rotations);
  EXPECT_GT(iterations, 0);
  for (int v : {5, 40, 70}) {
    EXPECT_TRUE((rotations[v].array() == initial[v].array()).all()) << v;
  }
  for (int v = 0; v < 70; ++v) {
    EXPECT_LT(RadToDeg(RotationAngle(rotations[v] * truth[v].transpose())),
              0.01)
        << v;
  }
}

}  // namespace
}  // namespace colmap_irav4
