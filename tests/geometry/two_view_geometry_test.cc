#include "colmap_irav4/geometry/two_view_geometry.h"

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/record.h"
#include "tests/test_utils/synthetic_two_view.h"

namespace colmap_irav4 {
namespace {

using test::MakeCamera;
using test::MakeSyntheticPair;
using test::SyntheticPair;

double TranslationErrorDeg(const Eigen::Vector3d& t1,
                           const Eigen::Vector3d& t2) {
  return RadToDeg(
      std::acos(std::clamp(t1.normalized().dot(t2.normalized()), -1.0, 1.0)));
}

TEST(TwoViewGeometry, EssentialDecompositionContainsTruePose) {
  std::mt19937_64 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d R = RandomRotation(&rng);
    const Eigen::Vector3d t = Eigen::Vector3d::Random().normalized();
    std::vector<Eigen::Matrix3d> Rs;
    std::vector<Eigen::Vector3d> ts;
    DecomposeEssentialMatrix(3.7 * EssentialFromPose(R, t), &Rs, &ts);
    ASSERT_EQ(Rs.size(), 4u);
    int found = 0;
    for (size_t i = 0; i < Rs.size(); ++i) {
      EXPECT_TRUE(IsRotation(Rs[i], 1e-9));
      if (AngularDistanceDeg(Rs[i], R) < 1e-6 && (ts[i] - t).norm() < 1e-9)
        ++found;
    }
    EXPECT_EQ(found, 1);
  }
}

TEST(TwoViewGeometry, HomographyDecompositionContainsTruePose) {
  std::mt19937_64 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(20), &rng);
    const Eigen::Vector3d t = Eigen::Vector3d::Random();
    const Eigen::Vector3d n =
        (Eigen::Vector3d::Random() * 0.3 + Eigen::Vector3d(0, 0, 1))
            .normalized() /
        4.0;
    // x2 ~ (R + t n^T) x1 for points with n^T X1 = 1; any positive scale.
    const Eigen::Matrix3d H = 2.5 * (R + t * n.transpose());
    std::vector<Eigen::Matrix3d> Rs;
    std::vector<Eigen::Vector3d> ts, ns;
    DecomposeHomographyMatrix(H, &Rs, &ts, &ns);
    ASSERT_EQ(Rs.size(), 4u);
    int found = 0;
    for (size_t i = 0; i < Rs.size(); ++i) {
      EXPECT_TRUE(IsRotation(Rs[i], 1e-6));
      // Each solution reproduces H.
      EXPECT_LT((Rs[i] + ts[i] * ns[i].transpose() - H / 2.5).norm(), 1e-6);
      // (t, n) are defined up to t n^T: the decomposition's n is unit.
      if (AngularDistanceDeg(Rs[i], R) < 1e-5 &&
          (ts[i] - t * n.norm()).norm() < 1e-6 &&
          (ns[i] - n.normalized()).norm() < 1e-6) {
        ++found;
      }
    }
    EXPECT_EQ(found, 1);
  }
  // A pure rotation has a single solution without translation.
  const Eigen::Matrix3d R = RandomRotation(&rng);
  std::vector<Eigen::Matrix3d> Rs;
  std::vector<Eigen::Vector3d> ts, ns;
  DecomposeHomographyMatrix(0.5 * R, &Rs, &ts, &ns);
  ASSERT_EQ(Rs.size(), 1u);
  EXPECT_LT(AngularDistanceDeg(Rs[0], R), 1e-6);
  EXPECT_EQ(ts[0].norm(), 0);
}

TEST(TwoViewGeometry, EightPointRecoversEssentialMatrix) {
  std::mt19937_64 rng(3);
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(10), &rng);
  const Eigen::Vector3d t(1, 0.2, 0.1);
  const SyntheticPair pair =
      MakeSyntheticPair(camera, camera, R, t, 50, 0, false, &rng);
  std::vector<Eigen::Vector2d> x1, x2;
  for (const FeatureMatch& m : pair.geometry.inlier_matches) {
    x1.push_back(CameraImageToCamera(
        camera, pair.keypoints1[m.point2D_idx1].cast<double>()));
    x2.push_back(CameraImageToCamera(
        camera, pair.keypoints2[m.point2D_idx2].cast<double>()));
  }
  Eigen::Matrix3d E;
  ASSERT_TRUE(EstimateEssentialEightPoint(x1, x2, &E));
  Eigen::Matrix3d E_true = EssentialFromPose(R, t.normalized());
  E_true /= E_true.norm();
  E /= E.norm();
  EXPECT_LT(std::min((E - E_true).norm(), (E + E_true).norm()), 1e-4);
  EXPECT_FALSE(EstimateEssentialEightPoint({x1.begin(), x1.begin() + 7},
                                           {x2.begin(), x2.begin() + 7}, &E));
}

TEST(TwoViewGeometry, EightPointRecoversFundamentalMatrix) {
  std::mt19937_64 rng(5);
  const Camera camera1 = MakeCamera(CameraModelNameToId("PINHOLE"), 1);
  Camera camera2 = MakeCamera(CameraModelNameToId("SIMPLE_PINHOLE"), 2);
  camera2.params = {1100, 790, 610};
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(15), &rng);
  const Eigen::Vector3d t(-1, 0.3, 0.2);
  const SyntheticPair pair =
      MakeSyntheticPair(camera1, camera2, R, t, 60, 0, false, &rng);
  std::vector<Eigen::Vector2d> x1, x2;
  for (const FeatureMatch& m : pair.geometry.inlier_matches) {
    x1.push_back(pair.keypoints1[m.point2D_idx1].cast<double>());
    x2.push_back(pair.keypoints2[m.point2D_idx2].cast<double>());
  }
  Eigen::Matrix3d F;
  ASSERT_TRUE(EstimateFundamentalEightPoint(x1, x2, &F));
  Eigen::Matrix3d F_true =
      CameraCalibrationMatrix(camera2).inverse().transpose() *
      EssentialFromPose(R, t.normalized()) *
      CameraCalibrationMatrix(camera1).inverse();
  F_true /= F_true.norm();
  EXPECT_NEAR(F.norm(), 1.0, 1e-12);
  EXPECT_LT(std::min((F - F_true).norm(), (F + F_true).norm()), 1e-4);
  // Rank 2, and the matches on its epipolar lines (pixels).
  EXPECT_LT(std::abs(F.determinant()), 1e-12);
  for (size_t i = 0; i < x1.size(); ++i)
    EXPECT_LT(SampsonErrorSquared(F, x1[i], x2[i]), 1e-8);
  EXPECT_FALSE(EstimateFundamentalEightPoint({x1.begin(), x1.begin() + 7},
                                             {x2.begin(), x2.begin() + 7}, &F));
}

TEST(TwoViewGeometry, DltRecoversHomography) {
  // x2 ~ H x1 for the points of a plane: H = K2 (R + t n^T) K1^-1 with
  // n^T X1 = 1 on the plane.
  std::mt19937_64 rng(6);
  const Eigen::Matrix3d K1 =
      CameraCalibrationMatrix(MakeCamera(CameraModelNameToId("PINHOLE")));
  Eigen::Matrix3d K2 = K1;
  K2(0, 0) = K2(1, 1) = 1100;
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(12), &rng);
  const Eigen::Vector3d t(0.4, -0.1, 0.05);
  const Eigen::Vector3d n(0.1, 0.05, 0.2);  // the plane z ~ 5
  Eigen::Matrix3d H_true = K2 * (R + t * n.transpose()) * K1.inverse();
  H_true /= H_true.norm();
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<Eigen::Vector2d> x1, x2;
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector2d xy(unit(rng), unit(rng));
    const Eigen::Vector3d ray = xy.homogeneous();
    const Eigen::Vector3d X1 = ray / n.dot(ray);
    x1.push_back((K1 * X1).hnormalized());
    x2.push_back((K2 * (R * X1 + t)).hnormalized());
  }
  Eigen::Matrix3d H;
  ASSERT_TRUE(EstimateHomographyDLT(x1, x2, &H));
  EXPECT_NEAR(H.norm(), 1.0, 1e-12);
  EXPECT_LT(std::min((H - H_true).norm(), (H + H_true).norm()), 1e-8);
  for (size_t i = 0; i < x1.size(); ++i)
    EXPECT_LT(HomographyTransferErrorSquared(H, x1[i], x2[i]), 1e-12);
  EXPECT_FALSE(EstimateHomographyDLT({x1.begin(), x1.begin() + 3},
                                     {x2.begin(), x2.begin() + 3}, &H));
}

TEST(TwoViewGeometry, InverseSwapsEverything) {
  std::mt19937_64 rng(4);
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  SyntheticPair pair =
      MakeSyntheticPair(camera, camera, RandomRotationWithAngle(0.2, &rng),
                        Eigen::Vector3d(1, 0, 0.3), 30, 0, false, &rng);
  pair.geometry.has_pose = true;
  pair.geometry.qvec = RotationToQuaternion(pair.R);
  pair.geometry.tvec = Eigen::Vector3d(1, 0, 0.3);
  const TwoViewGeometry inverse = pair.geometry.Inverse();
  EXPECT_EQ(inverse.image_id1, 2u);
  EXPECT_EQ(inverse.image_id2, 1u);
  EXPECT_EQ(inverse.inlier_matches[3].point2D_idx1,
            pair.geometry.inlier_matches[3].point2D_idx2);
  EXPECT_EQ(inverse.inlier_matches[3].point2D_idx2,
            pair.geometry.inlier_matches[3].point2D_idx1);
  EXPECT_LT((inverse.F - pair.geometry.F.transpose()).norm(), 1e-15);
  EXPECT_LT((inverse.H * pair.geometry.H - Eigen::Matrix3d::Identity()).norm(),
            1e-9);
  EXPECT_LT(AngularDistanceDeg(QuaternionToRotation(inverse.qvec),
                               pair.R.transpose()),
            1e-9);
  // x1 = R^T x2 - R^T t.
  EXPECT_LT((inverse.tvec + pair.R.transpose() * pair.geometry.tvec).norm(),
            1e-12);
  const TwoViewGeometry twice = inverse.Inverse();
  EXPECT_LT((twice.H / twice.H(2, 2) - pair.geometry.H / pair.geometry.H(2, 2))
                .norm(),
            1e-9);
  EXPECT_LT((twice.tvec - pair.geometry.tvec).norm(), 1e-12);
}

struct Case {
  std::string model;
  int config;
  bool keep_E, keep_F, keep_H;
  bool planar;
  bool pure_rotation;
};

void ExpectRecovered(const Case& c, double noise_px, double max_rotation_deg,
                     double max_translation_deg,
                     RelativePoseSource expected_source, uint64_t seed) {
  SCOPED_TRACE(c.model + " config " + TwoViewConfigName(c.config));
  std::mt19937_64 rng(seed);
  const Camera camera1 = MakeCamera(CameraModelNameToId(c.model), 1);
  const Camera camera2 = MakeCamera(CameraModelNameToId(c.model), 2);
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(15), &rng);
  const Eigen::Vector3d t = c.pure_rotation ? Eigen::Vector3d::Zero()
                                            : Eigen::Vector3d(-1.2, 0.3, 0.4);
  SyntheticPair pair =
      MakeSyntheticPair(camera1, camera2, R, t, 300, noise_px, c.planar, &rng);
  pair.geometry.config = c.config;
  if (!c.keep_E) pair.geometry.E.setZero();
  if (!c.keep_F) pair.geometry.F.setZero();
  if (!c.keep_H) pair.geometry.H.setZero();
  RelativePoseOptions options;
  const RelativePose pose =
      EstimateRelativePose(pair.geometry, camera1, camera2, pair.keypoints1,
                           pair.keypoints2, options);
  ASSERT_TRUE(pose.success) << pose.failure;
  EXPECT_LT(AngularDistanceDeg(pose.R, R), max_rotation_deg);
  EXPECT_EQ(pose.has_translation, !c.pure_rotation);
  if (!c.pure_rotation) {
    EXPECT_LT(TranslationErrorDeg(pose.t, t), max_translation_deg);
  } else {
    EXPECT_EQ(pose.t.norm(), 0);
  }
  if (noise_px == 0) {
    EXPECT_EQ(pose.source, expected_source);
  }
  EXPECT_GT(pose.num_supporting, 280);
  // The reversed pair gives the inverse pose.
  const RelativePose reverse =
      EstimateRelativePose(pair.geometry.Inverse(), camera2, camera1,
                           pair.keypoints2, pair.keypoints1, options);
  ASSERT_TRUE(reverse.success);
  EXPECT_LT(AngularDistanceDeg(reverse.R, R.transpose()), max_rotation_deg);
  if (!c.pure_rotation) {
    EXPECT_LT(TranslationErrorDeg(reverse.t, -(R.transpose() * t)),
              max_translation_deg);
  }
}

TEST(TwoViewGeometry, RelativePoseFromEachGeometryExact) {
  const int kCal = TwoViewGeometry::CALIBRATED;
  const int kUncal = TwoViewGeometry::UNCALIBRATED;
  const int kPlanar = TwoViewGeometry::PLANAR;
  const int kPano = TwoViewGeometry::PANORAMIC;
  const int kPop = TwoViewGeometry::PLANAR_OR_PANORAMIC;
  // Exact data: the first candidate source that fits wins and is exact.
  ExpectRecovered({"PINHOLE", kCal, true, false, false, false, false}, 0, 1e-4,
                  1e-3, RelativePoseSource::kEssential, 10);
  ExpectRecovered({"PINHOLE", kUncal, false, true, false, false, false}, 0,
                  1e-4, 1e-3, RelativePoseSource::kFundamental, 11);
  ExpectRecovered({"SIMPLE_PINHOLE", kPlanar, false, false, true, true, false},
                  0, 1e-4, 1e-3, RelativePoseSource::kHomography, 12);
  ExpectRecovered({"PINHOLE", kPop, true, true, true, true, false}, 0, 1e-4,
                  1e-3, RelativePoseSource::kEssential, 13);
  ExpectRecovered({"PINHOLE", kPano, false, false, true, false, true}, 0, 1e-4,
                  0, RelativePoseSource::kRotation, 14);
  // Nothing stored: re-estimated from the matches.
  ExpectRecovered({"PINHOLE", kCal, false, false, false, false, false}, 0, 1e-4,
                  1e-3, RelativePoseSource::kEightPoint, 15);
}

TEST(TwoViewGeometry, RelativePoseWithDistortionAndNoise) {
  const int kCal = TwoViewGeometry::CALIBRATED;
  const int kPop = TwoViewGeometry::PLANAR_OR_PANORAMIC;
  const int kPano = TwoViewGeometry::PANORAMIC;
  for (const std::string model :
       {"SIMPLE_RADIAL", "OPENCV", "OPENCV_FISHEYE"}) {
    // E on undistorted points, as COLMAP estimates it for calibrated pairs.
    ExpectRecovered({model, kCal, true, false, false, false, false}, 0.5, 0.3,
                    3, RelativePoseSource::kNone, 20);
    ExpectRecovered({model, kPop, true, false, true, true, false}, 0.5, 0.3, 3,
                    RelativePoseSource::kNone, 21);
    ExpectRecovered({model, kPano, false, false, true, false, true}, 0.5, 0.3,
                    0, RelativePoseSource::kNone, 22);
  }
}

TEST(TwoViewGeometry, RefinementImprovesNoisyPoses) {
  // Noisy keypoints, E from the eight-point estimate only: refinement on the
  // Sampson error must reduce the mean rotation error.
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  double error_plain = 0, error_refined = 0;
  for (int trial = 0; trial < 20; ++trial) {
    std::mt19937_64 rng(100 + trial);
    const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(10), &rng);
    SyntheticPair pair = MakeSyntheticPair(
        camera, camera, R, Eigen::Vector3d(1, 0.1, 0.2), 200, 1.0, false, &rng);
    pair.geometry.E.setZero();
    pair.geometry.F.setZero();
    pair.geometry.H.setZero();
    RelativePoseOptions options;
    options.refine = false;
    const RelativePose plain =
        EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                             pair.keypoints2, options);
    options.refine = true;
    const RelativePose refined =
        EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                             pair.keypoints2, options);
    ASSERT_TRUE(plain.success && refined.success);
    EXPECT_TRUE(refined.refined);
    error_plain += AngularDistanceDeg(plain.R, R);
    error_refined += AngularDistanceDeg(refined.R, R);
  }
  ::colmap_irav4::test::RecordFiguresF(
      "mean rotation error over 20 noisy pairs: eight-point %.4f deg, refined "
      "%.4f deg\n",
      error_plain / 20, error_refined / 20);
  EXPECT_LT(error_refined, 0.8 * error_plain);
}

TEST(TwoViewGeometry, RefinementConvergesToOneOptimumInFewPasses) {
  // The same noisy matches refined from the exact E and from an E a third of
  // the noise away: both must reach the same optimum of the robust cost (the
  // stopping rule must not stop short), in few passes (the loss's curvature
  // in the Hessian: reweighted least squares alone took about 8).
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  int max_passes = 0;
  double max_rotation_gap_deg = 0, max_translation_gap_deg = 0;
  for (int trial = 0; trial < 10; ++trial) {
    std::mt19937_64 rng(200 + trial);
    const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(10), &rng);
    const Eigen::Vector3d t(1, 0.1, 0.2);
    SyntheticPair pair =
        MakeSyntheticPair(camera, camera, R, t, 300, 1.0, false, &rng);
    pair.geometry.F.setZero();
    pair.geometry.H.setZero();
    RelativePoseOptions options;
    options.skip_eight_point_min_support = 0;  // start from the stored E
    const RelativePose from_exact =
        EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                             pair.keypoints2, options);
    pair.geometry.E = EssentialFromPose(
        RandomRotationWithAngle(DegToRad(0.013), &rng) * R,
        (t.normalized() + Eigen::Vector3d(0, 2e-4, -2e-4)).normalized());
    const RelativePose from_off =
        EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                             pair.keypoints2, options);
    ASSERT_TRUE(from_exact.success && from_off.success);
    ASSERT_TRUE(from_exact.refined && from_off.refined);
    EXPECT_EQ(from_exact.source, RelativePoseSource::kEssential);
    EXPECT_EQ(from_off.source, RelativePoseSource::kEssential);
    // The start moved the pose: the refinement did something.
    EXPECT_GT(AngularDistanceDeg(from_exact.R, R), 1e-4);
    max_rotation_gap_deg = std::max(
        max_rotation_gap_deg, AngularDistanceDeg(from_exact.R, from_off.R));
    max_translation_gap_deg = std::max(
        max_translation_gap_deg, TranslationErrorDeg(from_exact.t, from_off.t));
    max_passes = std::max(
        {max_passes, from_exact.num_refine_passes, from_off.num_refine_passes});
  }
  ::colmap_irav4::test::RecordFiguresF(
      "refined from the exact E and from one 0.013 deg off, 10 noisy pairs: "
      "largest gap %.2e deg (R), %.2e deg (t); at most %d passes\n",
      max_rotation_gap_deg, max_translation_gap_deg, max_passes);
  EXPECT_LT(max_rotation_gap_deg, 2e-3);
  EXPECT_LT(max_translation_gap_deg, 1e-2);
  EXPECT_GE(max_passes, 2);
  EXPECT_LE(max_passes, 5);
}

TEST(TwoViewGeometry, EightPointOnlyWhereTheStoredGeometryFallsShort) {
  std::mt19937_64 rng(50);
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(12), &rng);
  const Eigen::Vector3d t(1, 0.2, -0.1);
  SyntheticPair pair =
      MakeSyntheticPair(camera, camera, R, t, 300, 0.5, false, &rng);
  pair.geometry.F.setZero();
  pair.geometry.H.setZero();
  // A stored E that every match supports: the eight-point estimate is
  // skipped, and the refined pose is the one with it to rounding.
  RelativePoseOptions options;
  const RelativePose skipped = EstimateRelativePose(
      pair.geometry, camera, camera, pair.keypoints1, pair.keypoints2, options);
  options.skip_eight_point_min_support = 2;  // never skipped
  const RelativePose full = EstimateRelativePose(
      pair.geometry, camera, camera, pair.keypoints1, pair.keypoints2, options);
  ASSERT_TRUE(skipped.success && full.success);
  EXPECT_EQ(skipped.source, RelativePoseSource::kEssential);
  EXPECT_LT(AngularDistanceDeg(skipped.R, full.R), 2e-3);
  EXPECT_LT(TranslationErrorDeg(skipped.t, full.t), 1e-2);
  EXPECT_LT(AngularDistanceDeg(skipped.R, R), 0.1);
  // A stored E 3 deg off explains few matches: the eight-point estimate is
  // made and wins, unless it is always skipped.
  pair.geometry.E = EssentialFromPose(
      RandomRotationWithAngle(DegToRad(3), &rng) * R, t.normalized());
  options = RelativePoseOptions();
  const RelativePose recovered = EstimateRelativePose(
      pair.geometry, camera, camera, pair.keypoints1, pair.keypoints2, options);
  ASSERT_TRUE(recovered.success);
  EXPECT_EQ(recovered.source, RelativePoseSource::kEightPoint);
  EXPECT_LT(AngularDistanceDeg(recovered.R, R), 0.1);
  options.skip_eight_point_min_support = 0;
  const RelativePose stuck = EstimateRelativePose(
      pair.geometry, camera, camera, pair.keypoints1, pair.keypoints2, options);
  EXPECT_FALSE(stuck.success &&
               stuck.source == RelativePoseSource::kEightPoint);
}

TEST(TwoViewGeometry, StoredPoseUsedOnlyWhenConsistent) {
  std::mt19937_64 rng(30);
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(12), &rng);
  const Eigen::Vector3d t(1, 0.2, -0.1);
  SyntheticPair pair =
      MakeSyntheticPair(camera, camera, R, t, 200, 0.3, false, &rng);
  pair.geometry.has_pose = true;
  pair.geometry.qvec = RotationToQuaternion(R);
  pair.geometry.tvec = 2.0 * t;
  RelativePoseOptions options;
  RelativePose pose = EstimateRelativePose(
      pair.geometry, camera, camera, pair.keypoints1, pair.keypoints2, options);
  ASSERT_TRUE(pose.success);
  EXPECT_EQ(pose.source, RelativePoseSource::kStored);
  EXPECT_LT(AngularDistanceDeg(pose.R, R), 0.2);  // refined on noisy matches
  // Without refinement the stored pose is returned as is.
  options.refine = false;
  pose = EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                              pair.keypoints2, options);
  EXPECT_EQ(pose.source, RelativePoseSource::kStored);
  EXPECT_LT(AngularDistanceDeg(pose.R, R), 1e-9);
  EXPECT_LT((pose.t - t.normalized()).norm(), 1e-12);
  options.refine = true;
  // A stored pose that contradicts the matches (transposed R) is ignored.
  pair.geometry.qvec = RotationToQuaternion(R.transpose());
  pose = EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                              pair.keypoints2, options);
  ASSERT_TRUE(pose.success);
  EXPECT_NE(pose.source, RelativePoseSource::kStored);
  EXPECT_LT(AngularDistanceDeg(pose.R, R), 0.2);
}

TEST(TwoViewGeometry, FailsWithoutEnoughMatches) {
  std::mt19937_64 rng(40);
  const Camera camera = MakeCamera(CameraModelNameToId("PINHOLE"));
  SyntheticPair pair =
      MakeSyntheticPair(camera, camera, Eigen::Matrix3d::Identity(),
                        Eigen::Vector3d(1, 0, 0), 4, 0, false, &rng);
  const RelativePose pose =
      EstimateRelativePose(pair.geometry, camera, camera, pair.keypoints1,
                           pair.keypoints2, RelativePoseOptions());
  EXPECT_FALSE(pose.success);
  EXPECT_FALSE(pose.failure.empty());
}

TEST(TwoViewGeometry, RetriedWithinTheLooserThresholdWhereNonePasses) {
  // A photo collection's pair: the matcher fitted E with the true
  // intrinsics (radial distortion -0.09), the database holds a focal prior
  // 3% off and no distortion. No candidate, the eight-point re-estimate
  // included, then has 5 matches within 4 px (nor 8); within 16 px the
  // stored E's pose is supported and kept.
  std::mt19937_64 rng(60);
  Camera truth = MakeCamera(CameraModelNameToId("SIMPLE_RADIAL"));
  truth.params[3] = -0.09;
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(20), &rng);
  const Eigen::Vector3d t(1, 0.1, -0.2);
  SyntheticPair pair =
      MakeSyntheticPair(truth, truth, R, t, 300, 0.5, false, &rng);
  pair.geometry.F.setZero();
  pair.geometry.H.setZero();
  Camera prior = truth;
  prior.params = {1.03 * truth.params[0], truth.params[1], truth.params[2], 0};
  RelativePoseOptions options;
  const RelativePose dropped = EstimateRelativePose(
      pair.geometry, prior, prior, pair.keypoints1, pair.keypoints2, options);
  ASSERT_FALSE(dropped.success);
  EXPECT_FALSE(dropped.failure.empty());
  options.retry_max_error_px = 8;
  EXPECT_FALSE(EstimateRelativePose(pair.geometry, prior, prior,
                                    pair.keypoints1, pair.keypoints2, options)
                   .success);
  options.retry_max_error_px = 16;
  const RelativePose retried = EstimateRelativePose(
      pair.geometry, prior, prior, pair.keypoints1, pair.keypoints2, options);
  ASSERT_TRUE(retried.success);
  EXPECT_TRUE(retried.retried);
  EXPECT_LT(AngularDistanceDeg(retried.R, R), 1.0);
  // With the true intrinsics nothing is retried.
  const RelativePose exact = EstimateRelativePose(
      pair.geometry, truth, truth, pair.keypoints1, pair.keypoints2, options);
  ASSERT_TRUE(exact.success);
  EXPECT_FALSE(exact.retried);
  EXPECT_LT(AngularDistanceDeg(exact.R, R), 0.1);
}

TEST(TwoViewGeometry, OptionsCheck) {
  RelativePoseOptions options;
  EXPECT_NO_THROW(options.Check());
  options.max_error_px = 0;
  EXPECT_THROW(options.Check(), InputError);
  options = RelativePoseOptions();
  options.min_stored_pose_support = 1.5;
  EXPECT_THROW(options.Check(), InputError);
  options = RelativePoseOptions();
  options.skip_eight_point_min_support = -0.1;
  EXPECT_THROW(options.Check(), InputError);
  options.skip_eight_point_min_support = 1.5;  // never skipped
  EXPECT_NO_THROW(options.Check());
  options = RelativePoseOptions();
  options.retry_max_error_px = -1;
  EXPECT_THROW(options.Check(), InputError);
}

TEST(TwoViewGeometry, ConfigNames) {
  EXPECT_EQ(TwoViewConfigName(TwoViewGeometry::PLANAR_OR_PANORAMIC),
            "PLANAR_OR_PANORAMIC");
  EXPECT_EQ(TwoViewConfigFromName("WATERMARK"), 7);
  EXPECT_EQ(TwoViewConfigFromName("nope"), -1);
  EXPECT_EQ(TwoViewConfigName(42), "UNKNOWN(42)");
}

}  // namespace
}  // namespace colmap_irav4
