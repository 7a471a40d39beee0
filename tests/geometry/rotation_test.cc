#include "colmap_irav4/geometry/rotation.h"

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(Rotation, AngularDistanceOfKnownRotation) {
  const Eigen::Matrix3d R1 = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d R2 =
      Eigen::AngleAxisd(DegToRad(30.0), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  EXPECT_NEAR(AngularDistanceDeg(R1, R2), 30.0, 1e-9);
  EXPECT_NEAR(AngularDistanceDeg(R2, R1), 30.0, 1e-9);
  EXPECT_NEAR(AngularDistanceDeg(R2, R2), 0.0, 1e-6);
}

TEST(Rotation, SmallAnglesAreAccurate) {
  // arccos of the trace loses small angles; the implementation must not.
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(1e-7, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_NEAR(RotationAngle(R), 1e-7, 1e-12);
}

TEST(Rotation, QuaternionRoundTrip) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 100; ++k) {
    const Eigen::Matrix3d R = RandomRotation(&rng);
    const Eigen::Vector4d q = RotationToQuaternion(R);
    EXPECT_GE(q(0), 0.0);
    EXPECT_NEAR(q.norm(), 1.0, 1e-12);
    EXPECT_LT(AngularDistanceDeg(R, QuaternionToRotation(q)), 1e-6);
  }
}

TEST(Rotation, AngleAxisRoundTrip) {
  std::mt19937_64 rng(8);
  for (int k = 0; k < 100; ++k) {
    const Eigen::Matrix3d R = RandomRotation(&rng);
    EXPECT_LT(
        AngularDistanceDeg(R, AngleAxisToRotation(RotationToAngleAxis(R))),
        1e-6);
  }
}

TEST(Rotation, RandomRotationWithAngleHasThatAngle) {
  std::mt19937_64 rng(9);
  for (double deg : {0.5, 5.0, 90.0, 179.0}) {
    EXPECT_NEAR(
        RadToDeg(RotationAngle(RandomRotationWithAngle(DegToRad(deg), &rng))),
        deg, 1e-6);
  }
}

TEST(Rotation, ProjectToRotation) {
  std::mt19937_64 rng(10);
  const Eigen::Matrix3d R = RandomRotation(&rng);
  const Eigen::Matrix3d noisy = R + 1e-3 * Eigen::Matrix3d::Random();
  EXPECT_FALSE(IsRotation(noisy));
  const Eigen::Matrix3d projected = ProjectToRotation(noisy);
  EXPECT_TRUE(IsRotation(projected));
  EXPECT_LT(AngularDistanceDeg(R, projected), 0.5);
  EXPECT_FALSE(IsRotation(-Eigen::Matrix3d::Identity()));
}

}  // namespace
}  // namespace colmap_irav4
