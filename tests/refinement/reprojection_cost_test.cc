// LinearizeReprojection (the chain rule, Jets through the projection alone)
// against Ceres' automatic differentiation of ReprojectionCost times the
// quaternion manifold's PlusJacobian, on every camera model, both pose
// parameterisations (translation, centre).

#include "colmap_irav4/refinement/reprojection_cost.h"

#include <random>

#include <ceres/autodiff_cost_function.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>

#include "colmap_irav4/scene/camera_models.h"

namespace colmap_irav4 {
namespace {

template <int kNumParams>
void ExpectSameAsAutomatic(int model_id, bool center, std::mt19937* rng) {
  std::uniform_real_distribution<double> unit(-1, 1);
  Eigen::Quaterniond q(
      Eigen::Vector4d(unit(*rng), unit(*rng), unit(*rng), unit(*rng)));
  q.normalize();
  Eigen::Vector3d position(unit(*rng), unit(*rng), unit(*rng));
  // A point in front of the camera: its camera coordinates drawn first.
  const Eigen::Vector3d in_cam(0.5 * unit(*rng), 0.5 * unit(*rng),
                               3 + unit(*rng));
  Eigen::Vector3d point;
  if (center) {
    point = q.inverse() * in_cam + position;  // R (X - C) = in_cam
  } else {
    point = q.inverse() * (in_cam - position);  // R X + t = in_cam
  }
  double params[kNumParams];
  for (int i = 0; i < kNumParams; ++i) params[i] = 0.02 * unit(*rng);
  for (const int i : CameraModelFocalLengthIdxs(model_id)) {
    params[i] = 500 + 100 * unit(*rng);
  }
  const std::vector<int> principal = CameraModelPrincipalPointIdxs(model_id);
  params[principal[0]] = 320 + 10 * unit(*rng);
  params[principal[1]] = 240 + 10 * unit(*rng);
  const Eigen::Vector2d xy(300, 250);

  ReprojectionJacobians<kNumParams> linear;
  double residual[2];
  ASSERT_TRUE(LinearizeReprojection<kNumParams>(
      model_id, xy, center, q.coeffs().data(), position.data(), point.data(),
      params, residual, &linear));

  auto* cost = new ReprojectionCost<kNumParams>(model_id, xy, nullptr, center);
  ceres::AutoDiffCostFunction<ReprojectionCost<kNumParams>, 2, 4, 3, 3,
                              kNumParams>
      automatic(cost);
  const double* parameters[4] = {q.coeffs().data(), position.data(),
                                 point.data(), params};
  Eigen::Matrix<double, 2, 4, Eigen::RowMajor> dq;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> dp, dx;
  Eigen::Matrix<double, 2, kNumParams, Eigen::RowMajor> dc;
  double* jacobians[4] = {dq.data(), dp.data(), dx.data(), dc.data()};
  double expected[2];
  ASSERT_TRUE(automatic.Evaluate(parameters, expected, jacobians));
  Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus;
  ceres::EigenQuaternionManifold().PlusJacobian(q.coeffs().data(), plus.data());
  const Eigen::Matrix<double, 2, 3> drotation = dq * plus;

  EXPECT_NEAR(residual[0], expected[0], 1e-9);
  EXPECT_NEAR(residual[1], expected[1], 1e-9);
  // The rotation's Jacobian is hundreds of px per radian: relative 1e-9.
  const double scale = 1 + drotation.norm() + dx.norm() + dc.norm();
  EXPECT_LT((linear.rotation - drotation).norm(), 1e-9 * scale);
  EXPECT_LT((linear.position - Eigen::Matrix<double, 2, 3>(dp)).norm(),
            1e-9 * scale);
  EXPECT_LT((linear.point - Eigen::Matrix<double, 2, 3>(dx)).norm(),
            1e-9 * scale);
  EXPECT_LT((linear.params - Eigen::Matrix<double, 2, kNumParams>(dc)).norm(),
            1e-9 * scale);
  // Not a trivially small Jacobian: the comparison can fail.
  EXPECT_GT(linear.rotation.norm(), 10.0);
}

TEST(LinearizeReprojection, SameAsAutomaticDifferentiationOnEveryModel) {
  std::mt19937 rng(7);
  for (int model_id = 0; model_id < kNumCameraModels; ++model_id) {
    for (const bool center : {false, true}) {
      for (int trial = 0; trial < 5; ++trial) {
        SCOPED_TRACE(CameraModelIdToName(model_id) +
                     (center ? " centre" : " translation"));
        ASSERT_TRUE(
            WithNumCameraParams(CameraModelNumParams(model_id), [&](auto n) {
              ExpectSameAsAutomatic<decltype(n)::value>(model_id, center, &rng);
            }));
      }
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
