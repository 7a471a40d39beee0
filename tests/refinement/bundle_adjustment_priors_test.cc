// Bundle adjustment with pose priors: robust, covariance-weighted position
// terms that hold the gauge, gravity terms on the rotations.

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/util/random.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MaxUnalignedCenterError;

SyntheticScene Scene() {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.num_points = 600;
  options.visibility = 0.7;
  options.noise_px = 0.5;
  return GenerateSyntheticScene(options);
}

// Priors at the true centres (+ `std` noise), image 4's 50 m off; gravity
// exact when asked.
PosePriors Priors(const Reconstruction& truth, double std, bool gravity) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, std);
  PosePriors priors;
  for (const auto& [image_id, image] : truth.images) {
    PosePrior& prior = priors[image_id];
    prior.position = image.ProjectionCenter() + RandomVector<3>(normal, rng);
    if (image_id == 4) prior.position += Eigen::Vector3d(0, 50, 0);
    prior.position_covariance = std * std * Eigen::Matrix3d::Identity();
    if (gravity) {
      prior.gravity = image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
    }
  }
  return priors;
}

// Moves the whole model by a rotation about x and a shift.
void MoveModel(double angle_deg, const Eigen::Vector3d& shift,
               Reconstruction* model) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(DegToRad(angle_deg), Eigen::Vector3d::UnitX())
          .toRotationMatrix();
  const Eigen::Quaterniond q(R);
  for (auto& [image_id, image] : model->images) {
    const Eigen::Vector3d center = R * image.ProjectionCenter() + shift;
    image.cam_from_world.rotation = image.cam_from_world.rotation * q.inverse();
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  for (auto& [point3D_id, point] : model->points3D) {
    point.xyz = R * point.xyz + shift;
  }
}

// The largest angle between a camera's down (0, 0, -1 of the world) in `a`
// and in `b`.
double MaxTiltErrorDeg(const Reconstruction& a, const Reconstruction& b) {
  double error = 0;
  const Eigen::Vector3d down(0, 0, -1);
  for (const auto& [image_id, image] : a.images) {
    const double cosine =
        (image.cam_from_world.rotation * down)
            .dot(b.images.at(image_id).cam_from_world.rotation * down);
    error = std::max(error, RadToDeg(std::acos(std::min(1.0, cosine))));
  }
  return error;
}

BundleAdjustmentOptions Options() {
  BundleAdjustmentOptions options;
  options.refine_extra_params = false;  // PINHOLE
  return options;
}

TEST(BundleAdjustmentPriors, PriorsPullAShiftedModelBackAndIgnoreAnOutlier) {
  const SyntheticScene scene = Scene();
  const PosePriors priors = Priors(scene.truth, 0.02, false);
  Reconstruction model = scene.truth;
  MoveModel(0.0, Eigen::Vector3d(0.3, -0.2, 0.1), &model);
  BundleAdjustmentSummary summary;
  ASSERT_TRUE(RunBundleAdjustment(Options(), &model, &summary, &priors));
  // The outlier, 2,500 std off, is beyond the gate even on the shifted model
  // (the gate widens with the priors' spread, 15-19 std here): left out.
  EXPECT_EQ(summary.num_position_priors, 11);
  EXPECT_EQ(summary.rejected_position_priors, std::vector<image_t>({4}));
  // Back in the priors' frame (radius 10, priors 2 cm): the outlier, 50 m
  // off, neither moved its camera nor the model.
  EXPECT_LT(MaxUnalignedCenterError(model, scene.truth), 0.03);
  EXPECT_LT((model.images.at(4).ProjectionCenter() -
             scene.truth.images.at(4).ProjectionCenter())
                .norm(),
            0.03);

  // Without priors the gauge holds the first image: the shift stays.
  Reconstruction without = scene.truth;
  MoveModel(0.0, Eigen::Vector3d(0.3, -0.2, 0.1), &without);
  ASSERT_TRUE(RunBundleAdjustment(Options(), &without));
  EXPECT_GT(MaxUnalignedCenterError(without, scene.truth), 0.3);

  // Least squares on the priors (and no gate): the outlier drags the model.
  BundleAdjustmentOptions least_squares = Options();
  least_squares.pose_priors.loss_scale = 1e6;
  least_squares.pose_priors.gate_std = 0;
  Reconstruction dragged = scene.truth;
  ASSERT_TRUE(RunBundleAdjustment(least_squares, &dragged, nullptr, &priors));
  EXPECT_GT(MaxUnalignedCenterError(dragged, scene.truth), 1.0);
}

// Valid priors (all within 4 std) place the model where their
// least-squares similarity does: with the shape held by the images, the
// frame is the least-squares fit of the true centres onto the priors (equal
// isotropic covariances: Umeyama's is the weighted one). Measured: 4 mm off
// that frame (the shape's own error); with a Cauchy throughout
// (quadratic_std 0), which weighs a prior 2 std off a third less, 0.23 m;
// before the final similarity fit (FitPriorFrame) the adjustment stopped
// 0.25 m (least squares) and 0.37 m (Cauchy) off it.
TEST(BundleAdjustmentPriors, ValidPriorsPlaceTheModelByLeastSquares) {
  const SyntheticScene scene = Scene();
  const double std = 1.0;
  PosePriors priors = Priors(scene.truth, std, false);
  priors.at(4).position -= Eigen::Vector3d(0, 50, 0);  // no outlier here
  std::vector<Eigen::Vector3d> centers, positions;
  double max_whitened = 0;
  for (const auto& [image_id, image] : scene.truth.images) {
    centers.push_back(image.ProjectionCenter());
    positions.push_back(priors.at(image_id).position);
  }
  Sim3d least_squares;
  ASSERT_TRUE(EstimateSimilarity(centers, positions, &least_squares));
  Reconstruction reference = scene.truth;
  for (auto& [image_id, image] : reference.images) {
    const Eigen::Vector3d center = least_squares * image.ProjectionCenter();
    max_whitened = std::max(
        max_whitened, (center - priors.at(image_id).position).norm() / std);
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  // Priors up to 2.5 std off the fit: a Cauchy of 3 weighs them 0.6.
  ASSERT_LT(max_whitened, 4.0);
  ASSERT_GT(max_whitened, 2.0);
  double errors[2];
  for (const double quadratic_std : {4.0, 0.0}) {
    BundleAdjustmentOptions options = Options();
    options.pose_priors.quadratic_std = quadratic_std;
    Reconstruction model = scene.truth;
    ASSERT_TRUE(RunBundleAdjustment(options, &model, nullptr, &priors));
    errors[quadratic_std > 0 ? 0 : 1] =
        MaxUnalignedCenterError(model, reference);
  }
  EXPECT_LT(errors[0], 0.01);
  EXPECT_GT(errors[1], 0.03);
}

// Priors far off the model as it is handed in (beyond gate_std, 6 std) are
// left out: the adjustment is then exactly the one without them, where the
// Cauchy tail alone left each a small pull. Valid priors (1 m noise, the
// widest 2.9 std off) are all kept, on either backend.
TEST(BundleAdjustmentPriors, PriorsBeyondTheGateAreLeftOut) {
  const SyntheticScene scene = Scene();
  const double std = 1.0;
  // Image 4 50 m off (Priors), 7 and 10 too, in other directions.
  PosePriors priors = Priors(scene.truth, std, false);
  priors.at(7).position += Eigen::Vector3d(50, 0, 0);
  priors.at(10).position += Eigen::Vector3d(0, -30, 40);
  PosePriors inliers = priors;
  for (const image_t image_id : {4, 7, 10}) inliers.erase(image_id);
  PosePriors valid = Priors(scene.truth, std, false);
  valid.at(4).position -= Eigen::Vector3d(0, 50, 0);
  for (const auto backend : {BundleAdjustmentSolverBackend::kCeres,
                             BundleAdjustmentSolverBackend::kSchur}) {
    SCOPED_TRACE(EnumName(backend));
    BundleAdjustmentOptions options = Options();
    options.solver_backend = backend;
    Reconstruction model = scene.truth;
    BundleAdjustmentSummary summary;
    ASSERT_TRUE(RunBundleAdjustment(options, &model, &summary, &priors));
    EXPECT_EQ(summary.rejected_position_priors,
              std::vector<image_t>({4, 7, 10}));
    EXPECT_TRUE(summary.rejected_gravity_priors.empty());
    EXPECT_EQ(summary.num_position_priors, 9);

    Reconstruction reference = scene.truth;
    BundleAdjustmentSummary reference_summary;
    ASSERT_TRUE(
        RunBundleAdjustment(options, &reference, &reference_summary, &inliers));
    EXPECT_TRUE(reference_summary.rejected_position_priors.empty());
    EXPECT_LT(MaxUnalignedCenterError(model, reference), 1e-9);

    // Without the gate the outliers' Cauchy tails move the model.
    BundleAdjustmentOptions no_gate = options;
    no_gate.pose_priors.gate_std = 0;
    Reconstruction pulled = scene.truth;
    BundleAdjustmentSummary pulled_summary;
    ASSERT_TRUE(
        RunBundleAdjustment(no_gate, &pulled, &pulled_summary, &priors));
    EXPECT_TRUE(pulled_summary.rejected_position_priors.empty());
    EXPECT_EQ(pulled_summary.num_position_priors, 12);
    EXPECT_GT(MaxUnalignedCenterError(pulled, reference), 0.01);

    // No valid prior is left out.
    Reconstruction clean = scene.truth;
    BundleAdjustmentSummary clean_summary;
    ASSERT_TRUE(RunBundleAdjustment(options, &clean, &clean_summary, &valid));
    EXPECT_TRUE(clean_summary.rejected_position_priors.empty());
    EXPECT_EQ(clean_summary.num_position_priors, 12);
  }
}

// The gate is in units of the priors' own spread when that is wider than
// their covariance: a model not yet in the priors' frame (shifted 0.3 m
// against 2 cm priors: every prior 15 std off) keeps its valid priors and
// still leaves out the outlier; a gravity direction 30 deg off (15 std of 2
// deg) is left out, the exact ones kept.
TEST(BundleAdjustmentPriors, GateWidensWithTheSpreadAndChecksGravity) {
  const SyntheticScene scene = Scene();
  PosePriors priors = Priors(scene.truth, 0.02, true);
  const Eigen::Vector3d down = priors.at(9).gravity;
  priors.at(9).gravity =
      Eigen::AngleAxisd(DegToRad(30.0), down.unitOrthogonal()) * down;
  PosePriorOptions options;
  const PosePriorGate in_frame = GatePosePriors(scene.truth, priors, options);
  EXPECT_EQ(in_frame.rejected_positions, std::vector<image_t>({4}));
  EXPECT_EQ(in_frame.rejected_gravity, std::vector<image_t>({9}));
  EXPECT_LT(in_frame.position_spread, 1.5);
  EXPECT_FALSE(in_frame.kept.at(4).HasPosition());
  EXPECT_TRUE(in_frame.kept.at(4).HasGravity());
  EXPECT_FALSE(in_frame.kept.at(9).HasGravity());
  EXPECT_TRUE(in_frame.kept.at(9).HasPosition());

  Reconstruction shifted = scene.truth;
  MoveModel(0.0, Eigen::Vector3d(0.3, -0.2, 0.1), &shifted);
  const PosePriorGate off_frame = GatePosePriors(shifted, priors, options);
  EXPECT_GT(off_frame.position_spread, 5.0);
  EXPECT_EQ(off_frame.rejected_positions, std::vector<image_t>({4}));

  // A gate in covariance units alone would have left out every prior.
  double min_whitened = 1e9;
  for (const auto& [image_id, image] : shifted.images) {
    min_whitened = std::min(
        min_whitened,
        (image.ProjectionCenter() - priors.at(image_id).position).norm() /
            0.02);
  }
  EXPECT_GT(min_whitened, options.gate_std);
  options.gate_std = 0;
  EXPECT_TRUE(
      GatePosePriors(scene.truth, priors, options).rejected_positions.empty());
}

TEST(BundleAdjustmentPriors, GravityCorrectsATilt) {
  const SyntheticScene scene = Scene();
  // Loose positions (1 m): they alone cannot tell a 2 degree tilt.
  for (const bool gravity : {false, true}) {
    const PosePriors priors = Priors(scene.truth, 1.0, gravity);
    Reconstruction model = scene.truth;
    MoveModel(2.0, Eigen::Vector3d::Zero(), &model);
    BundleAdjustmentSummary summary;
    ASSERT_TRUE(RunBundleAdjustment(Options(), &model, &summary, &priors));
    EXPECT_EQ(summary.num_gravity_priors, gravity ? 12 : 0);
    // The heading stays as loose as the positions make it; the tilt is
    // gravity's.
    if (gravity) {
      EXPECT_LT(MaxTiltErrorDeg(model, scene.truth), 0.1);
    } else {
      EXPECT_GT(MaxTiltErrorDeg(model, scene.truth), 0.5);
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
