#include "colmap_irav4/positioning/direction_cost.h"

#include <memory>
#include <random>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

// The analytic cost function must give positioning's solve the very values
// automatic differentiation gave it (the model must not change with it):
// residuals and both Jacobians equal, on both sides of the scale's lower
// bound.
TEST(ProjectedDirectionCostFunction, SameValuesAsAutoDiff) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-3.0, 3.0);
  int num_clamped = 0, num_free = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d direction =
        Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).normalized();
    double a[3], b[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = uniform(rng);
      b[k] = uniform(rng);
    }
    const std::unique_ptr<ceres::CostFunction> autodiff(
        ProjectedDirectionCost::Create(direction));
    const ProjectedDirectionCostFunction analytic(direction);
    const double* parameters[2] = {a, b};
    double r_auto[3], r_analytic[3], ja_auto[9], jb_auto[9], ja_analytic[9],
        jb_analytic[9];
    double* j_auto[2] = {ja_auto, jb_auto};
    double* j_analytic[2] = {ja_analytic, jb_analytic};
    ASSERT_TRUE(autodiff->Evaluate(parameters, r_auto, j_auto));
    ASSERT_TRUE(analytic.Evaluate(parameters, r_analytic, j_analytic));
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r_analytic[k], r_auto[k]);
    for (int i = 0; i < 9; ++i) {
      EXPECT_EQ(ja_analytic[i], ja_auto[i]) << "trial " << trial << " " << i;
      EXPECT_EQ(jb_analytic[i], jb_auto[i]) << "trial " << trial << " " << i;
    }
    // Residuals alone, and one Jacobian asked for.
    double r_only[3];
    ASSERT_TRUE(analytic.Evaluate(parameters, r_only, nullptr));
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r_only[k], r_auto[k]);
    double jb_only[9];
    double* j_b_only[2] = {nullptr, jb_only};
    ASSERT_TRUE(analytic.Evaluate(parameters, r_only, j_b_only));
    for (int i = 0; i < 9; ++i) EXPECT_EQ(jb_only[i], jb_auto[i]);
    const Eigen::Vector3d u(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    (u.dot(direction) < 1.0 ? num_clamped : num_free) += 1;
  }
  // Both branches were compared.
  EXPECT_GT(num_clamped, 100);
  EXPECT_GT(num_free, 100);
}

TEST(ProjectedDirectionCostFunction, KeepsItsDirection) {
  const Eigen::Vector3d direction = Eigen::Vector3d(1, -2, 0.5).normalized();
  EXPECT_EQ(ProjectedDirectionCostFunction(direction).direction(), direction);
}

}  // namespace
}  // namespace colmap_irav4
