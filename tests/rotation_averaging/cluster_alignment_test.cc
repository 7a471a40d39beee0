#include "colmap_irav4/rotation_averaging/cluster_alignment.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

struct Scene {
  RotationGraph graph;
  std::vector<Eigen::Matrix3d> truth;
};

// Random graph over true rotations; relative rotations with `noise_deg`
// noise and a fraction of outliers (uniformly random rotations).
Scene MakeScene(int n, double p, double noise_deg, double outliers,
                uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::normal_distribution<double> normal(0, 1);
  Scene scene;
  scene.graph = RotationGraph(n);
  for (int v = 0; v < n; ++v) scene.truth.push_back(RandomRotation(&rng));
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (uniform(rng) >= p) continue;
      Eigen::Matrix3d R_ij = scene.truth[j] * scene.truth[i].transpose();
      if (uniform(rng) < outliers) {
        R_ij = RandomRotation(&rng);
      } else {
        R_ij = RandomRotationWithAngle(
                   DegToRad(std::abs(noise_deg * normal(rng))), &rng) *
               R_ij;
      }
      scene.graph.AddEdge(i, j, R_ij);
    }
  }
  return scene;
}

// Rotations of `truth` expressed in another frame: R_v^F = R_v F, with
// small noise.
std::vector<Eigen::Matrix3d> InFrame(const std::vector<Eigen::Matrix3d>& truth,
                                     const Eigen::Matrix3d& F, double noise_deg,
                                     std::mt19937_64* rng) {
  std::vector<Eigen::Matrix3d> out;
  for (const auto& R : truth) {
    out.push_back(RandomRotationWithAngle(DegToRad(noise_deg), rng) * R * F);
  }
  return out;
}

std::vector<bool> Range(int n, int begin, int end) {
  std::vector<bool> in(n, false);
  for (int v = begin; v < end; ++v) in[v] = true;
  return in;
}

TEST(ClusterAlignment, ExactWithoutNoiseFromVerticesAndFromEdges) {
  const Scene scene = MakeScene(40, 0.3, 0.0, 0.0, 1);
  std::mt19937_64 rng(2);
  const Eigen::Matrix3d C = RandomRotation(&rng), B = RandomRotation(&rng);
  const auto cluster = InFrame(scene.truth, C, 0.0, &rng);
  const auto reference = InFrame(scene.truth, B, 0.0, &rng);
  // R^ref = R B, R^c = R C, R^ref = R^c A  =>  A = C^T B.
  const Eigen::Matrix3d A_true = C.transpose() * B;
  ClusterAlignmentOptions options;
  // Overlapping: vertex guidance.
  ClusterAlignment a =
      AlignClusterToReference(scene.graph, cluster, Range(40, 0, 25), reference,
                              Range(40, 20, 40), options);
  ASSERT_TRUE(a.success);
  EXPECT_TRUE(a.used_vertex_guidance);
  EXPECT_EQ(a.num_common_vertices, 5);
  EXPECT_LT(AngularDistanceDeg(a.A, A_true), 1e-6);
  // Disjoint: edge voting only; the edge formula must hold exactly.
  ClusterAlignment b =
      AlignClusterToReference(scene.graph, cluster, Range(40, 0, 20), reference,
                              Range(40, 20, 40), options);
  ASSERT_TRUE(b.success);
  EXPECT_FALSE(b.used_vertex_guidance);
  EXPECT_GT(b.num_edges, 0);
  EXPECT_EQ(b.num_supporters, b.num_edges);
  EXPECT_LT(AngularDistanceDeg(b.A, A_true), 1e-6);
}

TEST(ClusterAlignment, RobustToOutlierEdgesAndBadCommonVertices) {
  for (uint64_t seed : {3, 4, 5}) {
    const Scene scene = MakeScene(120, 0.2, 1.0, 0.4, seed);
    std::mt19937_64 rng(seed + 100);
    const Eigen::Matrix3d C = RandomRotation(&rng), B = RandomRotation(&rng);
    auto cluster = InFrame(scene.truth, C, 0.3, &rng);
    const auto reference = InFrame(scene.truth, B, 0.3, &rng);
    const Eigen::Matrix3d A_true = C.transpose() * B;
    // Two of the four common vertices (60..63) are badly estimated in the
    // cluster: their vertex-induced candidates have little edge support.
    cluster[60] = RandomRotation(&rng);
    cluster[61] = RandomRotation(&rng);
    ClusterAlignmentOptions options;
    const ClusterAlignment a =
        AlignClusterToReference(scene.graph, cluster, Range(120, 0, 64),
                                reference, Range(120, 60, 120), options);
    ASSERT_TRUE(a.success);
    EXPECT_TRUE(a.used_vertex_guidance);
    EXPECT_LT(AngularDistanceDeg(a.A, A_true), 0.5) << "seed " << seed;
    // Disjoint sets with 40% outlier edges: voting still finds it.
    const ClusterAlignment b =
        AlignClusterToReference(scene.graph, cluster, Range(120, 0, 60),
                                reference, Range(120, 60, 120), options);
    ASSERT_TRUE(b.success);
    EXPECT_FALSE(b.used_vertex_guidance);
    EXPECT_LT(AngularDistanceDeg(b.A, A_true), 0.5) << "seed " << seed;
  }
}

TEST(ClusterAlignment, NothingSharedFails) {
  RotationGraph graph(4);
  graph.AddEdge(0, 1, Eigen::Matrix3d::Identity());
  graph.AddEdge(2, 3, Eigen::Matrix3d::Identity());
  std::vector<Eigen::Matrix3d> R(4, Eigen::Matrix3d::Identity());
  const ClusterAlignment a = AlignClusterToReference(
      graph, R, Range(4, 0, 2), R, Range(4, 2, 4), ClusterAlignmentOptions());
  EXPECT_FALSE(a.success);
}

TEST(ClusterAlignment, GeodesicMeanOfSymmetricPerturbations) {
  std::mt19937_64 rng(9);
  const Eigen::Matrix3d center = RandomRotation(&rng);
  std::vector<Eigen::Matrix3d> rotations;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    w[k] = 0.1;
    rotations.push_back(center * AngleAxisToRotation(w));
    rotations.push_back(center * AngleAxisToRotation(-w));
  }
  const Eigen::Matrix3d mean =
      GeodesicMean(rotations, Eigen::Matrix3d::Identity(), 50);
  EXPECT_LT(AngularDistanceDeg(mean, center), 1e-6);
}

// Three clusters of 10 (0-9, 10-19, 20-29), each complete inside, joined by
// true edges 0-10 and 5-15 (clusters 0-1) and `num_true_12` true edges
// 10+k - 20+k (clusters 1-2), plus a false edge 3-23 that holds for
// cluster 2 turned by W. Cluster 2 is aligned as if it had followed the
// false edge (R_v W), the others rightly: the weak join of V2 100 seed 2.
struct WeakJoin {
  RotationGraph graph;
  std::vector<Eigen::Matrix3d> truth;
  std::vector<Eigen::Matrix3d> aligned;
  std::vector<int> cluster_of;
};

WeakJoin MakeWeakJoin(int num_true_12) {
  std::mt19937_64 rng(7);
  WeakJoin scene;
  scene.graph = RotationGraph(30);
  for (int v = 0; v < 30; ++v) scene.truth.push_back(RandomRotation(&rng));
  const Eigen::Matrix3d W = RandomRotationWithAngle(DegToRad(117.0), &rng);
  auto add_true = [&](int i, int j) {
    scene.graph.AddEdge(i, j, scene.truth[j] * scene.truth[i].transpose());
  };
  for (int c = 0; c < 3; ++c) {
    for (int i = 10 * c; i < 10 * c + 10; ++i) {
      for (int j = i + 1; j < 10 * c + 10; ++j) add_true(i, j);
    }
  }
  add_true(0, 10);
  add_true(5, 15);
  for (int k = 0; k < num_true_12; ++k) add_true(10 + k, 20 + k);
  scene.graph.AddEdge(3, 23, scene.truth[23] * W * scene.truth[3].transpose());
  for (int v = 0; v < 30; ++v) {
    scene.aligned.push_back(v < 20 ? scene.truth[v] : scene.truth[v] * W);
    scene.cluster_of.push_back(v / 10);
  }
  return scene;
}

// The check with theta 3 deg and 500 candidates per pair.
ClusterConsensusCheck RunCheck(const WeakJoin& scene, int min_support,
                               std::vector<Eigen::Matrix3d>* rotations) {
  return CheckAlignmentByClusterConsensus(scene.graph, scene.cluster_of, 3, 3.0,
                                          min_support, 500, rotations);
}

TEST(ClusterConsensus, CorrectsAClusterThatFollowedAFalseEdge) {
  WeakJoin scene = MakeWeakJoin(3);
  std::vector<Eigen::Matrix3d> rotations = scene.aligned;
  const ClusterConsensusCheck check = RunCheck(scene, 2, &rotations);
  EXPECT_EQ(check.num_relations, 3);
  EXPECT_EQ(check.num_contradicted, 1);  // 1-2: 3 edges against the false one
  EXPECT_EQ(check.num_moved_clusters, 1);
  EXPECT_TRUE(check.applied);
  EXPECT_EQ(check.inliers_after, check.inliers_before + 3 - 1);
  // The two right clusters are untouched; the third is back in their frame.
  for (int v = 0; v < 20; ++v) {
    EXPECT_TRUE(rotations[v] == scene.aligned[v]) << v;
  }
  for (int v = 20; v < 30; ++v) {
    EXPECT_LT(AngularDistanceDeg(rotations[v], scene.truth[v]), 1e-6) << v;
  }
}

TEST(ClusterConsensus, OneEdgeDoesNotOverruleTheReference) {
  // One true edge across against one false edge: no corroborated relation
  // contradicts the alignment, nothing moves.
  WeakJoin scene = MakeWeakJoin(1);
  std::vector<Eigen::Matrix3d> rotations = scene.aligned;
  const ClusterConsensusCheck check = RunCheck(scene, 2, &rotations);
  EXPECT_EQ(check.num_contradicted, 0);
  EXPECT_EQ(check.num_moved_clusters, 0);
  EXPECT_FALSE(check.applied);
  for (int v = 0; v < 30; ++v) {
    EXPECT_TRUE(rotations[v] == scene.aligned[v]) << v;
  }
  // With min_support 1 the one true edge contradicts the alignment of 1-2,
  // but the spanning tree takes the equally supported relation 0-2 (the
  // false edge, which the alignment keeps) first: ties keep the alignment.
  const ClusterConsensusCheck loose = RunCheck(scene, 1, &rotations);
  EXPECT_EQ(loose.num_contradicted, 1);
  EXPECT_EQ(loose.num_moved_clusters, 0);
}

TEST(ClusterConsensus, RightAlignmentUnchanged) {
  WeakJoin scene = MakeWeakJoin(3);
  std::vector<Eigen::Matrix3d> rotations = scene.truth;
  const ClusterConsensusCheck check = RunCheck(scene, 2, &rotations);
  EXPECT_EQ(check.num_contradicted, 0);  // the false edge alone: support 1
  EXPECT_FALSE(check.applied);
  for (int v = 0; v < 30; ++v) EXPECT_TRUE(rotations[v] == scene.truth[v]);
}

TEST(ClusterConsensus, NotAppliedUnlessItAddsInlierEdges) {
  // The right alignment; clusters 1-2 joined by one true edge (10-20) and
  // two false edges that agree on turning cluster 2 by V (a corroborated
  // contradiction the tree follows), clusters 0-2 by the false 3-23 and a
  // true 4-24. Turning cluster 2 gains the two false edges and loses the
  // two true ones: no more inliers, not applied.
  WeakJoin scene = MakeWeakJoin(1);
  std::mt19937_64 rng(11);
  const Eigen::Matrix3d V = RandomRotationWithAngle(DegToRad(90.0), &rng);
  const auto& R = scene.truth;
  scene.graph.AddEdge(4, 24, R[24] * R[4].transpose());
  scene.graph.AddEdge(11, 25, R[25] * V * R[11].transpose());
  scene.graph.AddEdge(12, 26, R[26] * V * R[12].transpose());
  std::vector<Eigen::Matrix3d> rotations = scene.truth;
  const ClusterConsensusCheck check = RunCheck(scene, 2, &rotations);
  EXPECT_EQ(check.num_contradicted, 1);
  EXPECT_EQ(check.num_moved_clusters, 1);
  EXPECT_EQ(check.inliers_after, check.inliers_before);
  EXPECT_FALSE(check.applied);
  for (int v = 0; v < 30; ++v) EXPECT_TRUE(rotations[v] == scene.truth[v]);
}

}  // namespace
}  // namespace colmap_irav4
