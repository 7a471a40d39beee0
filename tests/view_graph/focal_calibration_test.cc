// Focal self-calibration from fundamental matrices: synthetic scenes with
// known K and a wrong focal guess, and the Strecha fountain database with its
// focal perturbed (copied to a temporary directory).

#include "colmap_irav4/view_graph/focal_calibration.h"
#include "colmap_irav4/util/random.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "colmap_irav4/eval/relative_pose_eval.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

Camera MakePinhole(camera_t id, double f, bool prior) {
  Camera camera;
  camera.camera_id = id;
  camera.model_id = CameraModelNameToId("PINHOLE");
  camera.width = 1600;
  camera.height = 1200;
  camera.params = {f, f, 790, 610};
  camera.has_prior_focal_length = prior;
  return camera;
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
  return S;
}

// Normalised eight-point F (rank 2) from pixel correspondences.
Eigen::Matrix3d EightPointF(const std::vector<Eigen::Vector2d>& x1,
                            const std::vector<Eigen::Vector2d>& x2) {
  auto normaliser = [](const std::vector<Eigen::Vector2d>& x) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : x) mean += p;
    mean /= x.size();
    double spread = 0;
    for (const auto& p : x) spread += (p - mean).norm();
    const double s = std::sqrt(2.0) * x.size() / spread;
    Eigen::Matrix3d T;
    T << s, 0, -s * mean(0), 0, s, -s * mean(1), 0, 0, 1;
    return T;
  };
  const Eigen::Matrix3d T1 = normaliser(x1);
  const Eigen::Matrix3d T2 = normaliser(x2);
  Eigen::MatrixXd A(x1.size(), 9);
  for (size_t i = 0; i < x1.size(); ++i) {
    const Eigen::Vector3d a = T1 * x1[i].homogeneous();
    const Eigen::Vector3d b = T2 * x2[i].homogeneous();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) A(i, 3 * r + c) = b(r) * a(c);
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd f = svd.matrixV().col(8);
  Eigen::Matrix3d F;
  F << f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7), f(8);
  Eigen::JacobiSVD<Eigen::Matrix3d> rank2(
      F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = rank2.singularValues();
  s(2) = 0;
  F = rank2.matrixU() * s.asDiagonal() * rank2.matrixV().transpose();
  return T2.transpose() * F * T1;
}

// Images on an arc looking at a point cloud around the origin; image i uses
// camera camera_of[i] (true K in true_cameras). Every pair gets F estimated
// from noisy projections (0.5 px).
std::vector<FocalCalibrationPair> SyntheticPairs(
    const std::map<camera_t, Camera>& true_cameras,
    const std::vector<camera_t>& camera_of, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::Vector3d> points(300);
  for (auto& p : points) p = RandomVector<3>(uniform, *rng) * 2.0;
  const int n = static_cast<int>(camera_of.size());
  std::vector<Eigen::Matrix3d> R(n);
  std::vector<Eigen::Vector3d> t(n);
  for (int i = 0; i < n; ++i) {
    // Centre on an arc of 60 degrees at distance 8, jittered; looking at the
    // origin with a random roll.
    const double angle = (-30.0 + 60.0 * i / std::max(1, n - 1)) * M_PI / 180;
    const Eigen::Vector3d centre(8 * std::sin(angle), uniform(*rng),
                                 -8 * std::cos(angle));
    // Aims spread over the scene: optical axes through one common point are
    // a degenerate configuration for focal self-calibration.
    const Eigen::Vector3d target = 2 * RandomVector<3>(uniform, *rng);
    const Eigen::Vector3d z = (target - centre).normalized();
    Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d world_from_cam;
    world_from_cam << x, y, z;
    const Eigen::Matrix3d roll =
        Eigen::AngleAxisd(0.1 * uniform(*rng), Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    R[i] = roll * world_from_cam.transpose();
    t[i] = -R[i] * centre;
  }
  std::vector<FocalCalibrationPair> pairs;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const Eigen::Matrix3d K1 =
          CameraCalibrationMatrix(true_cameras.at(camera_of[i]));
      const Eigen::Matrix3d K2 =
          CameraCalibrationMatrix(true_cameras.at(camera_of[j]));
      std::vector<Eigen::Vector2d> x1, x2;
      for (const auto& p : points) {
        const Eigen::Vector3d a = K1 * (R[i] * p + t[i]);
        const Eigen::Vector3d b = K2 * (R[j] * p + t[j]);
        x1.push_back(a.hnormalized() + RandomVector<2>(noise, *rng));
        x2.push_back(b.hnormalized() + RandomVector<2>(noise, *rng));
      }
      FocalCalibrationPair pair;
      pair.camera_id1 = camera_of[i];
      pair.camera_id2 = camera_of[j];
      pair.F = EightPointF(x1, x2);
      pair.weight = 100;
      pairs.push_back(pair);
    }
  }
  return pairs;
}

TEST(FocalCalibration, CostIsZeroForTrueFocalOnly) {
  const Eigen::Matrix3d K =
      CameraCalibrationMatrix(MakePinhole(1, 1500, false));
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized())
          .toRotationMatrix();
  const Eigen::Vector3d t(1, 0.2, 0.1);
  const Eigen::Matrix3d F = K.inverse().transpose() * Skew(t) * R * K.inverse();
  EXPECT_LT(EssentialSingularValueCost(F, K, K), 1e-9);
  const Eigen::Matrix3d K_wrong =
      CameraCalibrationMatrix(MakePinhole(1, 1950, false));
  EXPECT_GT(EssentialSingularValueCost(F, K_wrong, K_wrong), 0.01);
}

// The closed form against the singular values of an SVD, on random rank-2
// fundamental matrices and calibrations near and far from the true ones.
TEST(FocalCalibration, EssentialCostIsThatOfTheSingularValues) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  int num_small = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(
            unit(rng) * M_PI,
            Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized())
            .toRotationMatrix();
    const Eigen::Vector3d t(unit(rng), unit(rng), unit(rng));
    const Eigen::Matrix3d K1 =
        CameraCalibrationMatrix(MakePinhole(1, 1000 + 500 * unit(rng), false));
    const Eigen::Matrix3d K2 =
        CameraCalibrationMatrix(MakePinhole(2, 1000 + 500 * unit(rng), false));
    const Eigen::Matrix3d F =
        K2.inverse().transpose() * Skew(t) * R * K1.inverse();
    // The true calibration (cost ~0) half the time, else one off by up to 2x.
    const double off = trial % 2 == 0 ? 1.0 : std::exp(0.7 * unit(rng));
    Eigen::Matrix3d K1_tried = K1;
    K1_tried(0, 0) *= off;
    K1_tried(1, 1) *= off;
    const Eigen::Matrix3d E = K2.transpose() * F * K1_tried;
    const Eigen::Vector3d s =
        Eigen::JacobiSVD<Eigen::Matrix3d>(E).singularValues();
    const double expected = (s(0) - s(1)) / (s(0) + s(1));
    const double cost = EssentialSingularValueCost(F, K1_tried, K2);
    EXPECT_NEAR(cost, expected, 1e-12) << "trial " << trial;
    if (expected < 1e-9) ++num_small;
  }
  EXPECT_GE(num_small, 200);  // the true calibrations were tried
  // Rank below 2: the largest cost.
  EXPECT_EQ(EssentialSingularValueCost(Eigen::Matrix3d::Zero(),
                                       Eigen::Matrix3d::Identity(),
                                       Eigen::Matrix3d::Identity()),
            1.0);
  Eigen::Matrix3d rank1 =
      Eigen::Vector3d(1, 2, 3) * Eigen::Vector3d(0.5, -1, 2).transpose();
  EXPECT_EQ(EssentialSingularValueCost(rank1, Eigen::Matrix3d::Identity(),
                                       Eigen::Matrix3d::Identity()),
            1.0);
}

TEST(FocalCalibration, SharedCameraGuessOff30Percent) {
  for (const double factor : {1.3, 1.0 / 1.3}) {
    std::mt19937 rng(7);
    const std::map<camera_t, Camera> truth{{1, MakePinhole(1, 1500, false)}};
    std::vector<FocalCalibrationPair> pairs =
        SyntheticPairs(truth, {1, 1, 1, 1, 1, 1}, &rng);
    // One outlier pair (a wrong F) must not pull the estimate.
    pairs[3].F =
        Skew(Eigen::Vector3d(0.3, -1, 0.5)) *
        Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    std::map<camera_t, Camera> cameras{
        {1, MakePinhole(1, 1500 * factor, false)}};
    const std::vector<FocalCalibrationResult> results =
        CalibrateFocalLengths(pairs, FocalCalibrationOptions(), &cameras);
    ASSERT_EQ(results.size(), 1u);
    EXPECT_TRUE(results[0].calibrated) << results[0].reason;
    EXPECT_EQ(results[0].num_pairs, 15);
    EXPECT_NEAR(results[0].guess_focal, 1500 * factor, 1e-9);
    ::colmap_irav4::test::RecordFiguresF("guess %.1f -> %.2f (true 1500)\n",
                                         1500 * factor,
                                         cameras.at(1).params[0]);
    EXPECT_NEAR(cameras.at(1).params[0] / 1500, 1.0, 0.02);
    EXPECT_NEAR(cameras.at(1).params[1] / 1500, 1.0, 0.02);
    // Principal point untouched.
    EXPECT_EQ(cameras.at(1).params[2], 790);
    EXPECT_EQ(cameras.at(1).params[3], 610);
  }
}

TEST(FocalCalibration, TwoCamerasCoordinateDescent) {
  std::mt19937 rng(11);
  const std::map<camera_t, Camera> truth{{1, MakePinhole(1, 1500, false)},
                                         {2, MakePinhole(2, 2200, false)}};
  const std::vector<FocalCalibrationPair> pairs =
      SyntheticPairs(truth, {1, 2, 1, 2, 1, 2, 1, 2}, &rng);
  std::map<camera_t, Camera> cameras{{1, MakePinhole(1, 1950, false)},
                                     {2, MakePinhole(2, 1700, false)}};
  const std::vector<FocalCalibrationResult> results =
      CalibrateFocalLengths(pairs, FocalCalibrationOptions(), &cameras);
  ASSERT_EQ(results.size(), 2u);
  for (const FocalCalibrationResult& result : results) {
    EXPECT_TRUE(result.calibrated) << result.reason;
  }
  ::colmap_irav4::test::RecordFiguresF(
      "camera 1: 1950 -> %.2f (true 1500); camera 2: 1700 -> %.2f (true "
      "2200)\n",
      cameras.at(1).params[0], cameras.at(2).params[0]);
  EXPECT_NEAR(cameras.at(1).params[0] / 1500, 1.0, 0.02);
  EXPECT_NEAR(cameras.at(2).params[0] / 2200, 1.0, 0.02);
}

TEST(FocalCalibration, PriorCameraUntouchedAndConstrainsTheOther) {
  std::mt19937 rng(5);
  const std::map<camera_t, Camera> truth{{1, MakePinhole(1, 1500, false)},
                                         {2, MakePinhole(2, 2200, false)}};
  const std::vector<FocalCalibrationPair> pairs =
      SyntheticPairs(truth, {1, 2, 1, 2, 1, 2}, &rng);
  // Camera 1 has a (deliberately wrong) prior: it must stay as it is.
  std::map<camera_t, Camera> cameras{{1, MakePinhole(1, 1500, true)},
                                     {2, MakePinhole(2, 1700, false)}};
  const std::vector<FocalCalibrationResult> results =
      CalibrateFocalLengths(pairs, FocalCalibrationOptions(), &cameras);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].camera_id, 2u);
  EXPECT_EQ(cameras.at(1).params, MakePinhole(1, 1500, true).params);
  EXPECT_NEAR(cameras.at(2).params[0] / 2200, 1.0, 0.02);

  std::map<camera_t, Camera> all_prior{{1, MakePinhole(1, 1900, true)},
                                       {2, MakePinhole(2, 1700, true)}};
  EXPECT_TRUE(
      CalibrateFocalLengths(pairs, FocalCalibrationOptions(), &all_prior)
          .empty());
  EXPECT_EQ(all_prior.at(1).params[0], 1900);
  EXPECT_EQ(all_prior.at(2).params[0], 1700);
}

// With prior_max_ratio > 1, cameras with a prior focal a few percent off are
// calibrated within that ratio of it; a prior too far off for the range keeps
// its value.
TEST(FocalCalibration, PriorCamerasCalibratedWithinTheirRatio) {
  std::mt19937 rng(5);
  const std::map<camera_t, Camera> truth{{1, MakePinhole(1, 1500, false)},
                                         {2, MakePinhole(2, 2200, false)},
                                         {3, MakePinhole(3, 1800, false)}};
  const std::vector<FocalCalibrationPair> pairs =
      SyntheticPairs(truth, {1, 2, 3, 1, 2, 3, 1, 2, 3}, &rng);
  FocalCalibrationOptions options;
  options.prior_max_ratio = 1.1;
  // Priors 4% over, 3.6% under and 30% over.
  std::map<camera_t, Camera> cameras{{1, MakePinhole(1, 1560, true)},
                                     {2, MakePinhole(2, 2120, true)},
                                     {3, MakePinhole(3, 2340, true)}};
  const std::vector<FocalCalibrationResult> results =
      CalibrateFocalLengths(pairs, options, &cameras);
  ASSERT_EQ(results.size(), 3u);
  std::map<camera_t, FocalCalibrationResult> by_camera;
  for (const FocalCalibrationResult& result : results) {
    by_camera[result.camera_id] = result;
  }
  ::colmap_irav4::test::RecordFiguresF(
      "camera 1: 1560 -> %.2f (true 1500); camera 2: 2120 -> %.2f (true "
      "2200); camera 3: 2340 -> %.2f (true 1800, out of range)\n",
      cameras.at(1).params[0], cameras.at(2).params[0],
      cameras.at(3).params[0]);
  EXPECT_TRUE(by_camera[1].calibrated) << by_camera[1].reason;
  EXPECT_TRUE(by_camera[2].calibrated) << by_camera[2].reason;
  EXPECT_NEAR(cameras.at(1).params[0] / 1500, 1.0, 0.01);
  EXPECT_NEAR(cameras.at(2).params[0] / 2200, 1.0, 0.01);
  EXPECT_FALSE(by_camera[3].calibrated);
  EXPECT_NE(by_camera[3].reason.find("prior kept"), std::string::npos)
      << by_camera[3].reason;
  EXPECT_EQ(cameras.at(3).params[0], 2340);
  // Principal points untouched.
  EXPECT_EQ(cameras.at(1).params[2], 790);
  EXPECT_EQ(cameras.at(2).params[3], 610);

  // The default (1) keeps every prior.
  std::map<camera_t, Camera> fixed{{1, MakePinhole(1, 1560, true)},
                                   {2, MakePinhole(2, 2120, true)},
                                   {3, MakePinhole(3, 2340, true)}};
  EXPECT_TRUE(
      CalibrateFocalLengths(pairs, FocalCalibrationOptions(), &fixed).empty());
  EXPECT_EQ(fixed.at(1).params[0], 1560);
}

TEST(FocalCalibration, GuardsKeepTheGuess) {
  std::mt19937 rng(3);
  const std::map<camera_t, Camera> truth{{1, MakePinhole(1, 1500, false)}};
  const std::vector<FocalCalibrationPair> pairs =
      SyntheticPairs(truth, {1, 1, 1}, &rng);
  // Three pairs, four needed.
  FocalCalibrationOptions options;
  options.min_num_pairs = 4;
  std::map<camera_t, Camera> cameras{{1, MakePinhole(1, 1950, false)}};
  std::vector<FocalCalibrationResult> results =
      CalibrateFocalLengths(pairs, options, &cameras);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_FALSE(results[0].calibrated);
  EXPECT_NE(results[0].reason.find("too few pairs"), std::string::npos);
  EXPECT_EQ(cameras.at(1).params[0], 1950);

  // F of a pure translation along the optical axis, K = identity-like: every
  // focal gives a valid essential matrix (flat cost).
  const Eigen::Matrix3d K =
      CameraCalibrationMatrix(MakePinhole(1, 1500, false));
  std::vector<FocalCalibrationPair> flat(3);
  for (FocalCalibrationPair& pair : flat) {
    pair.camera_id1 = pair.camera_id2 = 1;
    pair.F =
        K.inverse().transpose() * Skew(Eigen::Vector3d(0, 0, 1)) * K.inverse();
  }
  results = CalibrateFocalLengths(flat, FocalCalibrationOptions(), &cameras);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_FALSE(results[0].calibrated);
  EXPECT_EQ(cameras.at(1).params[0], 1950);

  // Disabled: nothing changes.
  options = FocalCalibrationOptions();
  options.calibrate_focal = false;
  EXPECT_TRUE(CalibrateFocalLengths(pairs, options, &cameras).empty());
  EXPECT_EQ(cameras.at(1).params[0], 1950);
}

TEST(FocalCalibration, OptionsCheck) {
  FocalCalibrationOptions options;
  EXPECT_NO_THROW(options.Check());
  options.min_focal_ratio = 1.5;
  EXPECT_THROW(options.Check(), InputError);
  options = FocalCalibrationOptions();
  options.min_num_pairs = 0;
  EXPECT_THROW(options.Check(), InputError);
  options = FocalCalibrationOptions();
  options.prior_max_ratio = 0.9;
  EXPECT_THROW(options.Check(), InputError);
  options.prior_max_ratio = options.max_focal_ratio;
  EXPECT_THROW(options.Check(), InputError);
}

// The fountain database with its focal x factor and no prior, as COLMAP would
// leave it without EXIF focal: the view graph calibrates the focal back and
// derives accurate relative rotations.
void CheckPerturbedFountain(double factor) {
  const std::string scene = DataDir() + "/strecha/fountain-P11";
  const std::string shared = scene + "/database.db";
  const uint64_t hash = test::HashFile(shared);
  test::TempDir dir;
  const std::string path = dir.File("database.db");
  std::filesystem::copy_file(shared, path);
  const DatabaseContents original = ReadDatabase(path);
  ASSERT_EQ(original.cameras.size(), 1u);
  const Camera& camera = original.cameras.begin()->second;
  ASSERT_EQ(CameraModelIdToName(camera.model_id), "PINHOLE");
  ASSERT_TRUE(camera.has_prior_focal_length);
  std::vector<double> params = camera.params;
  params[0] *= factor;
  params[1] *= factor;
  {
    test::SqliteWriter writer(path);
    writer.Run(
        "UPDATE cameras SET params = ?, prior_focal_length = 0 WHERE camera_id "
        "= ?",
        {test::ToBlob(params), static_cast<int64_t>(camera.camera_id)});
    // Without a prior focal COLMAP's matcher estimates no E: the pairs are
    // UNCALIBRATED with F (and H) only.
    writer.Run(
        "UPDATE two_view_geometries SET config = 3, E = ? WHERE config = 2",
        {test::ToBlob(std::vector<double>(9, 0.0))});
  }
  const DatabaseContents database = ReadDatabase(path);
  ASSERT_FALSE(database.cameras.begin()->second.has_prior_focal_length);
  ASSERT_NEAR(database.cameras.begin()->second.params[0],
              factor * camera.params[0], 1e-6);

  std::map<std::string, Rigid3d> gt;
  for (const auto& [name, gt_camera] :
       ReadStrechaGroundTruth(scene + "/gt_cameras")) {
    gt[name] = gt_camera.cam_from_world;
  }
  ViewGraphBuilderOptions options;
  ViewGraphSummary summary;
  const ViewGraph view_graph = BuildViewGraph(database, options, &summary);
  ASSERT_EQ(summary.focal_calibration.size(), 1u);
  EXPECT_TRUE(summary.focal_calibration[0].calibrated)
      << summary.focal_calibration[0].reason;
  const Camera& calibrated = view_graph.cameras.at(camera.camera_id);
  const RelativePoseErrors e = EvaluateRelativePoses(view_graph, gt);

  options.focal_calibration.calibrate_focal = false;
  ViewGraphSummary summary_off;
  const ViewGraph uncalibrated =
      BuildViewGraph(database, options, &summary_off);
  const RelativePoseErrors e_off = EvaluateRelativePoses(uncalibrated, gt);
  ::colmap_irav4::test::RecordFiguresF(
      "fountain focal x%.3f (%.1f): calibrated fx %.1f fy %.1f (K.txt 2759.48 "
      "2764.16) from %d pairs; %zu pairs kept, rotation median %.5f max %.3f "
      "deg; without calibration %zu pairs, rotation median %.3f max %.3f deg\n",
      factor, params[0], calibrated.params[0], calibrated.params[1],
      summary.focal_calibration[0].num_pairs, view_graph.pairs.size(),
      e.rotation_median_deg, e.rotation_max_deg, uncalibrated.pairs.size(),
      e_off.rotation_median_deg, e_off.rotation_max_deg);
  EXPECT_NEAR(calibrated.params[0] / 2759.48, 1.0, 0.03);
  EXPECT_NEAR(calibrated.params[1] / 2764.16, 1.0, 0.03);
  EXPECT_EQ(calibrated.params[2], params[2]);
  EXPECT_EQ(calibrated.params[3], params[3]);
  EXPECT_EQ(static_cast<int>(view_graph.pairs.size()), 55);
  EXPECT_LT(e.rotation_median_deg, 0.5);
  EXPECT_EQ(e.num_rotation_over_5deg, 0);
  // The shared database was only read.
  EXPECT_EQ(test::HashFile(shared), hash);

  // The original database (with its prior) is left as it is.
  ViewGraphSummary summary_prior;
  const ViewGraph with_prior =
      BuildViewGraph(original, ViewGraphBuilderOptions(), &summary_prior);
  EXPECT_TRUE(summary_prior.focal_calibration.empty());
  EXPECT_EQ(with_prior.cameras.at(camera.camera_id).params, camera.params);
}

TEST(FocalCalibration, StrechaFountainFocalTooLong) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  CheckPerturbedFountain(1.3);
}

TEST(FocalCalibration, StrechaFountainFocalTooShort) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  CheckPerturbedFountain(1 / 1.3);
}

}  // namespace
}  // namespace colmap_irav4
