#include "colmap_irav4/eval/model_alignment.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

Sim3d RandomSim(std::mt19937_64* rng) {
  Sim3d sim;
  sim.scale = 3.7;
  sim.R = RandomRotation(rng);
  sim.t = Eigen::Vector3d(1.0, -2.0, 0.5);
  return sim;
}

TEST(ModelAlignment, SimilarityExactFromPoints) {
  std::mt19937_64 rng(3);
  const Sim3d truth = RandomSim(&rng);
  std::vector<Eigen::Vector3d> src, dst;
  for (int k = 0; k < 10; ++k) {
    src.push_back(Eigen::Vector3d::Random());
    dst.push_back(truth * src.back());
  }
  Sim3d sim;
  ASSERT_TRUE(EstimateSimilarity(src, dst, &sim));
  EXPECT_NEAR(sim.scale, truth.scale, 1e-9);
  EXPECT_LT(AngularDistanceDeg(sim.R, truth.R), 1e-6);
  EXPECT_LT((sim.t - truth.t).norm(), 1e-9);
}

TEST(ModelAlignment, CollinearPointsAreDegenerate) {
  std::vector<Eigen::Vector3d> src, dst;
  for (int k = 0; k < 5; ++k) {
    src.push_back(Eigen::Vector3d(k, 2.0 * k, 0));
    dst.push_back(src.back());
  }
  Sim3d sim;
  EXPECT_FALSE(EstimateSimilarity(src, dst, &sim));
}

TEST(ModelAlignment, RansacIgnoresOutliers) {
  std::mt19937_64 rng(4);
  const Sim3d truth = RandomSim(&rng);
  std::vector<Eigen::Vector3d> src, dst;
  for (int k = 0; k < 40; ++k) {
    src.push_back(Eigen::Vector3d::Random());
    dst.push_back(truth * src.back());
    if (k % 4 == 0) dst.back() += Eigen::Vector3d(5, 5, 5);  // 25% outliers
  }
  Sim3d sim;
  std::vector<bool> inliers;
  ASSERT_TRUE(EstimateSimilarityRansac(src, dst, SimilarityRansacOptions(),
                                       &sim, &inliers));
  EXPECT_NEAR(sim.scale, truth.scale, 1e-6);
  EXPECT_LT(AngularDistanceDeg(sim.R, truth.R), 1e-4);
  for (int k = 0; k < 40; ++k) EXPECT_EQ(inliers[k], k % 4 != 0) << k;
}

TEST(ModelAlignment, ComparePosesRecoversKnownErrors) {
  std::mt19937_64 rng(5);
  const Sim3d truth = RandomSim(&rng);
  std::map<std::string, Rigid3d> reference, estimate;
  for (int k = 0; k < 8; ++k) {
    // Estimate in its own frame; reference = truth * estimate.
    Rigid3d est;
    est.rotation = Eigen::Quaterniond(RandomRotation(&rng));
    const Eigen::Vector3d center = 2.0 * Eigen::Vector3d::Random();
    est.translation = -(est.rotation * center);
    Rigid3d ref;
    ref.rotation = Eigen::Quaterniond(est.rotation.toRotationMatrix() *
                                      truth.R.transpose());
    ref.translation = -(ref.rotation * (truth * center));
    const std::string name = "img" + std::to_string(k);
    estimate[name] = est;
    reference[name] = ref;
  }
  // Perturb one estimate's rotation by 2 degrees about its own centre: its
  // rotation error must be 2 deg and every centre error ~0.
  Rigid3d& perturbed = estimate["img3"];
  const Eigen::Vector3d center = perturbed.Inverse().translation;
  perturbed.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(
                           DegToRad(2.0), Eigen::Vector3d::UnitX())) *
                       perturbed.rotation;
  perturbed.translation = -(perturbed.rotation * center);
  reference["only_in_reference"] = Rigid3d();
  PoseComparison comparison;
  ASSERT_TRUE(ComparePoses(estimate, reference, SimilarityRansacOptions(),
                           &comparison));
  EXPECT_EQ(comparison.num_common, 8);
  EXPECT_EQ(comparison.num_reference, 9);
  EXPECT_NEAR(comparison.rotation_error_max_deg, 2.0, 1e-6);
  EXPECT_LT(comparison.rotation_error_median_deg, 1e-6);
  EXPECT_LT(comparison.center_error_median, 1e-6);
}

}  // namespace
}  // namespace colmap_irav4
