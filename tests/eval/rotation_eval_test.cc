#include "colmap_irav4/eval/rotation_eval.h"

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

TEST(RotationEval, ExactEstimateInAnotherFrameHasZeroError) {
  std::mt19937_64 rng(3);
  const Eigen::Matrix3d A = RandomRotation(&rng);
  std::vector<Eigen::Matrix3d> gt, est;
  for (int i = 0; i < 50; ++i) {
    gt.push_back(RandomRotation(&rng));
    est.push_back(gt.back() * A.transpose());  // est A = gt
  }
  const RotationErrors errors = EvaluateRotations(est, {}, gt);
  EXPECT_EQ(errors.num_compared, 50);
  EXPECT_LT(errors.max_deg, 1e-6);
  EXPECT_LT(AngularDistanceDeg(errors.alignment, A), 1e-6);
}

TEST(RotationEval, KnownPerturbationsGiveKnownStatistics) {
  // Camera i perturbed by angle_i about a random axis, 40% of cameras far off:
  // the L1 alignment must ignore them and the statistics must be exact.
  std::mt19937_64 rng(5);
  const Eigen::Matrix3d A = RandomRotation(&rng);
  std::vector<Eigen::Matrix3d> gt, est;
  std::vector<double> angles;
  for (int i = 0; i < 101; ++i) {
    gt.push_back(RandomRotation(&rng));
    const double angle = i < 60 ? 0.0 : 20.0 + i;  // deg
    angles.push_back(angle);
    est.push_back(RandomRotationWithAngle(DegToRad(angle), &rng) * gt.back() *
                  A.transpose());
  }
  const RotationErrors errors = EvaluateRotations(est, {}, gt);
  EXPECT_EQ(errors.num_compared, 101);
  EXPECT_LT(AngularDistanceDeg(errors.alignment, A), 1e-6);
  EXPECT_NEAR(errors.median_deg, 0.0, 1e-6);
  EXPECT_NEAR(errors.max_deg, 120.0, 1e-6);
  double mean = 0;
  for (double a : angles) mean += a;
  EXPECT_NEAR(errors.mean_deg, mean / 101, 1e-6);
  double max_deviation = 0.0;
  for (int i = 0; i < 101; ++i) {
    max_deviation =
        std::max(max_deviation, std::abs(errors.errors_deg[i] - angles[i]));
  }
  EXPECT_LT(max_deviation, 1e-6);
}

TEST(RotationEval, NoisyMedianMatchesNoiseLevel) {
  // Small noise on every camera: the L1 alignment costs little, the median
  // error stays close to the median noise angle.
  std::mt19937_64 rng(11);
  std::vector<Eigen::Matrix3d> gt, est;
  for (int i = 0; i < 2000; ++i) {
    gt.push_back(RandomRotation(&rng));
    est.push_back(RandomRotationWithAngle(DegToRad(2.0), &rng) * gt.back());
  }
  const RotationErrors errors = EvaluateRotations(est, {}, gt);
  EXPECT_NEAR(errors.median_deg, 2.0, 0.2);
  EXPECT_LT(RadToDeg(RotationAngle(errors.alignment)), 0.3);
}

TEST(RotationEval, MasksAndNamesSelectCommonCameras) {
  std::mt19937_64 rng(13);
  RotationAveragingResult result;
  std::vector<Eigen::Matrix3d> gt;
  for (int i = 0; i < 6; ++i) {
    gt.push_back(RandomRotation(&rng));
    result.rotations.push_back(gt.back());
    result.estimated.push_back(i != 2);
  }
  result.rotations[2] = RandomRotation(&rng);  // not estimated: ignored
  RotationErrors errors = EvaluateRotations(result, gt);
  EXPECT_EQ(errors.num_compared, 5);
  EXPECT_LT(errors.max_deg, 1e-6);
  errors = EvaluateRotations(result, gt, {true, true, true, false, true, true});
  EXPECT_EQ(errors.num_compared, 4);

  std::map<std::string, Eigen::Matrix3d> est_map{
      {"a", gt[0]}, {"b", gt[1]}, {"c", gt[2]}};
  std::map<std::string, Eigen::Matrix3d> gt_map{
      {"b", gt[1]}, {"c", gt[2]}, {"d", gt[3]}};
  errors = EvaluateRotations(est_map, gt_map);
  EXPECT_EQ(errors.num_compared, 2);
  EXPECT_LT(errors.max_deg, 1e-6);
  errors = EvaluateRotations(std::map<std::string, Eigen::Matrix3d>{}, gt_map);
  EXPECT_EQ(errors.num_compared, 0);
}

}  // namespace
}  // namespace colmap_irav4
