#include "colmap_irav4/rotation_averaging/incremental_engine.h"

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "tests/test_utils/rotation_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MakeRandomProblem;

// Eq. 5-8 from scratch with the engine's current rotations.
IncrementalEngine::Candidate BruteForceBest(const IncrementalEngine& engine,
                                            double theta_deg) {
  const RotationGraph& graph = engine.Graph();
  IncrementalEngine::Candidate best;
  best.reward = -1;
  for (int p = 0; p < graph.NumVertices(); ++p) {
    if (engine.IsSelected(p) || !engine.IsAllowed(p) || engine.IsExcluded(p)) {
      continue;
    }
    std::vector<std::pair<int, Eigen::Matrix3d>> pre;
    for (const auto& [m, e] : engine.Adjacency(p)) {
      if (engine.IsSelected(m)) {
        pre.emplace_back(m, graph.RotationFrom(e, m) * engine.Rotation(m));
      }
    }
    for (const auto& [m, P_m] : pre) {
      double reward = 0;
      for (const auto& [n, P_n] : pre) {
        const double d = AngularDistanceDeg(P_m, P_n);
        if (d < theta_deg) reward += std::cos(DegToRad(d));
      }
      if (reward > best.reward + 1e-9) {
        best.vertex = p;
        best.via = m;
        best.reward = reward;
        best.R_init = P_m;
      }
    }
  }
  return best;
}

TEST(IncrementalEngine, RewardsMatchBruteForceAndAreAtLeastOne) {
  const SyntheticProblem problem = MakeRandomProblem(120, 1500, 5.0, 0.3, 21);
  IncrementalOptions options;
  options.lazy_reward_recomputation = false;  // the exact Eq. 8 argmax
  IncrementalEngine engine(problem.graph, options);
  ASSERT_TRUE(engine.InitializeFromBestTriplet());
  EXPECT_EQ(engine.NumSelected(), 3);
  int num_checked = 0;
  while (true) {
    const IncrementalEngine::Candidate candidate = engine.BestCandidate();
    if (candidate.vertex < 0) break;
    // The edge e_mp supports its own pre-computation.
    EXPECT_GE(candidate.reward, 1.0);
    const IncrementalEngine::Candidate brute =
        BruteForceBest(engine, options.theta_deg);
    EXPECT_NEAR(candidate.reward, brute.reward, 1e-9);
    EXPECT_EQ(candidate.vertex, brute.vertex);
    EXPECT_EQ(candidate.via, brute.via);
    EXPECT_TRUE(IsRotation(candidate.R_init, 1e-9));
    engine.AddVertex(candidate);
    EXPECT_EQ(engine.LastAdded(), candidate.vertex);
    ++num_checked;
  }
  EXPECT_EQ(num_checked, 117);
  EXPECT_EQ(engine.NumSelected(), 120);
  EXPECT_GT(engine.Stats().num_global_optimizations, 10);
  EXPECT_GT(engine.Stats().num_incremental_reward_updates, 0);
}

// Lazy recomputation (the default): the chosen candidate's reward is always
// computed from the current rotations (fresh), and close to the exact best.
TEST(IncrementalEngine, LazyRewardsAreFreshForTheChosenCandidate) {
  const SyntheticProblem problem = MakeRandomProblem(120, 1500, 5.0, 0.3, 21);
  IncrementalOptions options;
  IncrementalEngine engine(problem.graph, options);
  ASSERT_TRUE(engine.InitializeFromBestTriplet());
  int num_checked = 0, num_exact = 0;
  while (true) {
    const IncrementalEngine::Candidate candidate = engine.BestCandidate();
    if (candidate.vertex < 0) break;
    // Eq. 7 for the chosen (vertex, via) from scratch.
    const RotationGraph& graph = engine.Graph();
    std::vector<Eigen::Matrix3d> pre;
    Eigen::Matrix3d P_via = Eigen::Matrix3d::Identity();
    for (const auto& [m, e] : engine.Adjacency(candidate.vertex)) {
      if (!engine.IsSelected(m)) continue;
      pre.push_back(graph.RotationFrom(e, m) * engine.Rotation(m));
      if (m == candidate.via) P_via = pre.back();
    }
    double reward = 0;
    for (const Eigen::Matrix3d& P : pre) {
      const double d = AngularDistanceDeg(P_via, P);
      if (d < options.theta_deg) reward += std::cos(DegToRad(d));
    }
    EXPECT_NEAR(candidate.reward, reward, 1e-9);
    const IncrementalEngine::Candidate brute =
        BruteForceBest(engine, options.theta_deg);
    EXPECT_GE(candidate.reward, 0.7 * brute.reward);
    num_exact += candidate.vertex == brute.vertex;
    engine.AddVertex(candidate);
    ++num_checked;
  }
  EXPECT_EQ(num_checked, 117);
  EXPECT_GT(num_exact, num_checked / 2);
}

TEST(IncrementalEngine, BoundedRecomputationStillPicksSupportedVertices) {
  // With a tiny bound the rewards are approximate but still >= 1 and growth
  // completes.
  const SyntheticProblem problem = MakeRandomProblem(80, 1200, 5.0, 0.2, 4);
  IncrementalOptions options;
  options.max_precomputations = 2;
  IncrementalEngine engine(problem.graph, options);
  ASSERT_TRUE(engine.InitializeFromBestTriplet());
  while (true) {
    const auto candidate = engine.BestCandidate();
    if (candidate.vertex < 0) break;
    EXPECT_GE(candidate.reward, 1.0);
    engine.AddVertex(candidate);
  }
  EXPECT_EQ(engine.NumSelected(), 80);
}

TEST(IncrementalEngine, StopRuleAllowedAndExcluded) {
  const SyntheticProblem problem = MakeRandomProblem(100, 800, 5.0, 0.1, 8);
  std::vector<bool> allowed(100, true);
  for (int v = 0; v < 100; v += 3) allowed[v] = false;
  IncrementalEngine engine(problem.graph, IncrementalOptions(), allowed);
  ASSERT_TRUE(engine.InitializeFromBestTriplet());
  for (int v : engine.Selected()) EXPECT_TRUE(allowed[v]);
  const int added = engine.Grow([&]() { return engine.NumSelected() >= 10; });
  EXPECT_EQ(added, 7);
  EXPECT_EQ(engine.NumSelected(), 10);
  // Exclude the next best vertex: it must never be selected.
  const int excluded = engine.BestCandidate().vertex;
  ASSERT_GE(excluded, 0);
  engine.Exclude(excluded);
  EXPECT_NE(engine.BestCandidate().vertex, excluded);
  engine.Grow([]() { return false; });
  EXPECT_FALSE(engine.IsSelected(excluded));
  for (int v = 0; v < 100; ++v) {
    EXPECT_EQ(engine.IsSelected(v), allowed[v] && v != excluded) << v;
  }
  EXPECT_EQ(engine.BestCandidate().vertex, -1);
}

TEST(IncrementalEngine, SeedIsTheMostConsistentTriangle) {
  // Four vertices, two triangles sharing edge 0-1: one exact, one with a
  // 2 deg cycle error (passes Eq. 2) and one with 10 deg (fails).
  std::mt19937_64 rng(2);
  std::vector<Eigen::Matrix3d> R(5);
  for (auto& r : R) r = RandomRotation(&rng);
  const auto rel = [&](int i, int j) {
    return Eigen::Matrix3d(R[j] * R[i].transpose());
  };
  const auto tilt = [&](double deg) {
    return Eigen::Matrix3d(
        Eigen::AngleAxisd(DegToRad(deg), Eigen::Vector3d::UnitX()));
  };
  RotationGraph graph(5);
  graph.AddEdge(0, 1, rel(0, 1));
  graph.AddEdge(1, 2, tilt(2.0) * rel(1, 2));
  graph.AddEdge(0, 2, rel(0, 2));
  graph.AddEdge(1, 3, rel(1, 3));
  graph.AddEdge(3, 0, rel(3, 0));
  graph.AddEdge(3, 4, tilt(10.0) * rel(3, 4));
  graph.AddEdge(4, 0, rel(4, 0));
  IncrementalEngine engine(graph, IncrementalOptions());
  ASSERT_TRUE(engine.InitializeFromBestTriplet());
  EXPECT_EQ(engine.Stats().num_triangles, 3);
  EXPECT_EQ(engine.Stats().num_triangles_passed, 2);
  std::vector<int> seed = engine.Selected();
  std::sort(seed.begin(), seed.end());
  EXPECT_EQ(seed, (std::vector<int>{0, 1, 3}));
  // Exact triangle: relative rotations reproduced.
  EXPECT_LT(AngularDistanceDeg(
                engine.Rotation(3) * engine.Rotation(1).transpose(), rel(1, 3)),
            1e-6);

  IncrementalEngine forced(graph, IncrementalOptions());
  EXPECT_FALSE(forced.InitializeFromTriplet(0, 3, 4));  // fails Eq. 2
  EXPECT_FALSE(forced.InitializeFromTriplet(1, 2, 3));  // not a triangle
  ASSERT_TRUE(forced.InitializeFromTriplet(0, 1, 2));
  // Eq. 3 spreads the 2 deg cycle error evenly over the three edges.
  for (int e = 0; e < 3; ++e) {
    const RelativeRotation& edge = graph.Edge(e);
    const double d = AngularDistanceDeg(
        forced.Rotation(edge.j) * forced.Rotation(edge.i).transpose(),
        edge.R_ij);
    EXPECT_NEAR(d, 2.0 / 3.0, 0.01) << e;
  }
}

TEST(IncrementalEngine, Deterministic) {
  const SyntheticProblem problem = MakeRandomProblem(150, 2000, 10.0, 0.4, 5);
  std::vector<Eigen::Matrix3d> first;
  std::vector<int> first_order;
  // The second run shares a separately built adjacency: same output.
  const auto shared = IncrementalEngine::BuildAdjacency(problem.graph);
  for (int run = 0; run < 2; ++run) {
    IncrementalEngine engine(problem.graph, IncrementalOptions(), {},
                             run == 0 ? nullptr : shared);
    ASSERT_TRUE(engine.InitializeFromBestTriplet());
    engine.Grow([]() { return false; });
    engine.GlobalOptimize();
    std::vector<Eigen::Matrix3d> rotations;
    for (int v = 0; v < 150; ++v) rotations.push_back(engine.Rotation(v));
    if (run == 0) {
      first = rotations;
      first_order = engine.Selected();
    } else {
      EXPECT_EQ(engine.Selected(), first_order);
      for (int v = 0; v < 150; ++v) {
        EXPECT_TRUE((rotations[v].array() == first[v].array()).all()) << v;
      }
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
