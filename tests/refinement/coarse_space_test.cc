#include "colmap_irav4/refinement/coarse_space.h"

#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace colmap_irav4 {
namespace {

// A pose moved by a finite similarity of the world X -> s Q X + d, as its
// tangent step from the original (rotation left-multiplied, position
// added).
Eigen::Matrix<double, 6, 1> FiniteStep(const Eigen::Quaterniond& q,
                                       const Eigen::Vector3d& position,
                                       bool center,
                                       const Eigen::Vector3d& omega,
                                       const Eigen::Vector3d& d, double sigma) {
  const Eigen::Matrix3d world =
      Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  const double s = 1 + sigma;
  const Eigen::Matrix3d r = q.toRotationMatrix();
  // The camera sees the moved world as the old one: R' = R Q^T, centre
  // C' = s Q C + d (translation t' = -R' C' with C = -R^T t).
  const Eigen::Matrix3d r_moved = r * world.transpose();
  const Eigen::Vector3d c =
      center ? position : Eigen::Vector3d(-r.transpose() * position);
  const Eigen::Vector3d c_moved = s * world * c + d;
  Eigen::Matrix<double, 6, 1> step;
  const Eigen::AngleAxisd left(r_moved * r.transpose());
  step.head<3>() = left.angle() * left.axis();
  step.tail<3>() = center ? Eigen::Vector3d(c_moved - c)
                          : Eigen::Vector3d(-r_moved * c_moved - position);
  return step;
}

TEST(CoarseSpace, SimilarityMotionIsTheFirstOrderOfAWorldSimilarity) {
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(0.3, -0.5, 0.7, 0.2).normalized();
  const double rotation[4] = {q.x(), q.y(), q.z(), q.w()};
  const Eigen::Vector3d position(2.0, -1.0, 4.0);
  for (const bool center : {true, false}) {
    const CoarseMotion m = SimilarityMotion(rotation, position.data(), center);
    for (int mode = 0; mode < kNumCoarseModes; ++mode) {
      constexpr double kEpsilon = 1e-6;
      Eigen::Matrix<double, kNumCoarseModes, 1> v =
          Eigen::Matrix<double, kNumCoarseModes, 1>::Zero();
      v[mode] = kEpsilon;
      const Eigen::Matrix<double, 6, 1> step =
          FiniteStep(q, position, center, v.head<3>(), v.segment<3>(3), v[6]);
      EXPECT_GT(step.norm(), 0.5 * kEpsilon);
      // First order: the difference is second order in epsilon.
      EXPECT_LT((m * v - step).norm(), 1e-3 * step.norm())
          << "mode " << mode << ", center " << center << "\n"
          << (m * v).transpose() << "\n"
          << step.transpose();
    }
  }
}

// Two groups of five nodes tied strongly within, weakly between: clusters of
// five are the groups. A node without ties is in no cluster.
TEST(CoarseSpace, ClustersFollowTheStrongTies) {
  CouplingGraph graph(11);
  for (int group = 0; group < 2; ++group) {
    for (int a = 0; a < 5; ++a) {
      for (int b = 0; b < a; ++b) graph.Add(5 * group + a, 5 * group + b, 10);
    }
  }
  graph.Add(4, 5, 1);
  graph.Add(0, 9, 1);
  int num_clusters = 0;
  const std::vector<int> cluster = AggregateClusters(graph, 5, &num_clusters);
  ASSERT_EQ(cluster.size(), 11u);
  EXPECT_EQ(num_clusters, 2);
  for (int a = 1; a < 5; ++a) {
    EXPECT_EQ(cluster[a], cluster[0]);
    EXPECT_EQ(cluster[5 + a], cluster[5]);
  }
  EXPECT_NE(cluster[0], cluster[5]);
  EXPECT_EQ(cluster[10], -1);
  const std::set<int> numbers(cluster.begin(), cluster.end());
  EXPECT_EQ(numbers, (std::set<int>{-1, 0, 1}));
}

// A seed whose neighbours were all taken joins its strongest neighbour's
// cluster rather than standing alone (one image cannot carry 7 motions).
TEST(CoarseSpace, LoneSeedJoinsItsStrongestNeighbour) {
  // A star: the centre (0) takes two leaves at size 3, the others are left
  // as seeds with no untaken neighbour.
  CouplingGraph graph(5);
  graph.Add(0, 1, 5);
  graph.Add(0, 2, 4);
  graph.Add(0, 3, 3);
  graph.Add(0, 4, 2);
  int num_clusters = 0;
  const std::vector<int> cluster = AggregateClusters(graph, 3, &num_clusters);
  EXPECT_EQ(num_clusters, 1);
  for (int a = 1; a < 5; ++a) EXPECT_EQ(cluster[a], cluster[0]);
}

TEST(CoarseSpace, SystemSolvesAndRefusesAnIndefiniteMatrix) {
  CoarseSystem system;
  system.Reset(2);
  ASSERT_EQ(system.Size(), 2 * kNumCoarseModes);
  const Eigen::MatrixXd m = Eigen::MatrixXd::Random(14, 14);
  const Eigen::MatrixXd spd =
      m * m.transpose() + Eigen::MatrixXd::Identity(14, 14);
  system.AddDiagonal(0, spd.block<7, 7>(0, 0));
  system.AddDiagonal(1, spd.block<7, 7>(7, 7));
  system.AddPair(1, 0, spd.block<7, 7>(7, 0));
  EXPECT_LT((system.Matrix() - spd).norm(), 1e-12 * spd.norm());
  ASSERT_TRUE(system.Factorize());
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(14, -1, 1);
  Eigen::VectorXd w = spd * x;
  system.Solve(&w);
  EXPECT_LT((w - x).norm(), 1e-10);
  system.Reset(2);
  system.AddDiagonal(0, -CoarseSystem::Block::Identity());
  system.AddDiagonal(1, CoarseSystem::Block::Identity());
  EXPECT_FALSE(system.Factorize());
  EXPECT_FALSE(system.Factorized());
}

}  // namespace
}  // namespace colmap_irav4
