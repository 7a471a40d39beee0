// Global positioning with pose priors: the model placed in their frame,
// robust to an outlier prior.

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/random.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MaxUnalignedCenterError;

constexpr image_t kOutlierImage = 7;

struct PriorScene {
  SyntheticScene scene;
  Reconstruction reconstruction;  // rotations exact, no translations
  PosePriors priors;              // the truth's frame, one outlier
};

// 15 images on an arc of radius 10; priors with `std` noise, image 7's
// displaced by `outlier_offset`; exact gravity if `gravity`.
PriorScene MakeSetup(double std, const Eigen::Vector3d& outlier_offset,
                     bool gravity) {
  SyntheticSceneOptions options;
  options.num_images = 15;
  options.num_points = 800;
  options.visibility = 0.6;
  options.noise_px = 0.5;
  PriorScene setup;
  setup.scene = GenerateSyntheticScene(options);
  setup.reconstruction = StripPoints(setup.scene.truth);
  for (auto& [image_id, image] : setup.reconstruction.images) {
    image.cam_from_world.translation.setZero();
  }
  AddTracksToReconstruction(
      BuildTracks(TrackBuilderOptions(), setup.scene.matches,
                  setup.reconstruction.images),
      &setup.reconstruction);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, std);
  for (const auto& [image_id, image] : setup.scene.truth.images) {
    PosePrior& prior = setup.priors[image_id];
    prior.position = image.ProjectionCenter() + RandomVector<3>(normal, rng);
    if (image_id == kOutlierImage) prior.position += outlier_offset;
    prior.position_covariance = std * std * Eigen::Matrix3d::Identity();
    if (gravity) {
      prior.gravity = image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
    }
  }
  return setup;
}

// How well the priors themselves know the frame: the rotation of the
// similarity that best maps the true centres onto the priors, the outlier
// left out. A placement from the priors cannot do better.
double PriorsFrameRotationError(const PriorScene& setup) {
  std::vector<Eigen::Vector3d> src, dst;
  for (const auto& [image_id, image] : setup.scene.truth.images) {
    if (image_id == kOutlierImage) continue;
    src.push_back(image.ProjectionCenter());
    dst.push_back(setup.priors.at(image_id).position);
  }
  Sim3d best;
  EXPECT_TRUE(EstimateSimilarity(src, dst, &best));
  return Eigen::AngleAxisd(best.R).angle();
}

TEST(GlobalPositioningPriors, PlacesTheModelInThePriorFrameDespiteAnOutlier) {
  PriorScene setup = MakeSetup(0.05, Eigen::Vector3d(30, -20, 40), false);
  GlobalPositionerSummary summary;
  const double priors_error = PriorsFrameRotationError(setup);
  ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(),
                                   &setup.reconstruction, &summary,
                                   &setup.priors));
  EXPECT_TRUE(summary.in_prior_frame) << summary.prior_problem;
  EXPECT_EQ(summary.num_position_priors, 15);
  EXPECT_EQ(summary.num_position_prior_inliers, 14);
  EXPECT_FALSE(summary.priors_disagree);
  // No alignment: the model is in the truth's (the priors') frame, and the
  // outlier's camera stays where its observations put it, 54 m from its
  // prior (radius 10: positioning, before bundle adjustment, is within
  // ~2% of it).
  EXPECT_LT(MaxUnalignedCenterError(setup.reconstruction, setup.scene.truth),
            0.3);
  for (const auto& [image_id, image] : setup.reconstruction.images) {
    EXPECT_LT(
        image.cam_from_world.rotation.angularDistance(
            setup.scene.truth.images.at(image_id).cam_from_world.rotation),
        priors_error + DegToRad(0.05))
        << "the priors' own best frame is " << RadToDeg(priors_error)
        << " deg off";
  }

  // Least squares on the priors instead (a huge loss scale): the outlier
  // drags the model by metres.
  PriorScene least_squares =
      MakeSetup(0.05, Eigen::Vector3d(30, -20, 40), false);
  GlobalPositionerOptions options;
  options.pose_priors.loss_scale = 1e6;
  ASSERT_TRUE(RunGlobalPositioning(options, &least_squares.reconstruction,
                                   &summary, &least_squares.priors));
  EXPECT_GT(MaxUnalignedCenterError(least_squares.reconstruction,
                                    least_squares.scene.truth),
            1.0);
}

TEST(GlobalPositioningPriors, ManyPriorsOffTheModelAreReported) {
  // 6 of 15 priors 30-60 m off, in different directions: the model is still
  // placed by the 9 others, and the disagreement is reported.
  PriorScene setup = MakeSetup(0.05, Eigen::Vector3d::Zero(), false);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> distance(30.0, 60.0);
  for (const image_t image_id : {2, 5, 8, 10, 12, 14}) {
    setup.priors.at(image_id).position +=
        distance(rng) * RandomVector<3>(normal, rng).normalized();
  }
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(),
                                   &setup.reconstruction, &summary,
                                   &setup.priors));
  EXPECT_TRUE(summary.in_prior_frame) << summary.prior_problem;
  EXPECT_EQ(summary.num_position_prior_inliers, 9);
  EXPECT_TRUE(summary.priors_disagree);
}

TEST(GlobalPositioningPriors, GravitySetsTheTiltWhenPositionsCannot) {
  // The cameras lie nearly in a plane: with 2 m noise on the priors the
  // similarity's tilt is poorly known; exact gravity fixes it.
  for (const bool gravity : {false, true}) {
    PriorScene setup = MakeSetup(2.0, Eigen::Vector3d::Zero(), gravity);
    GlobalPositionerSummary summary;
    ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(),
                                     &setup.reconstruction, &summary,
                                     &setup.priors));
    ASSERT_TRUE(summary.in_prior_frame);
    double max_tilt_deg = 0;
    for (const auto& [image_id, image] : setup.reconstruction.images) {
      const Eigen::Vector3d down =
          image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
      const Eigen::Vector3d true_down =
          setup.scene.truth.images.at(image_id).cam_from_world.rotation *
          Eigen::Vector3d(0, 0, -1);
      max_tilt_deg =
          std::max(max_tilt_deg,
                   RadToDeg(std::acos(std::min(1.0, down.dot(true_down)))));
    }
    if (gravity) {
      EXPECT_LT(max_tilt_deg, 0.05);
      EXPECT_EQ(summary.num_gravity_priors, 15);
    } else {
      EXPECT_GT(max_tilt_deg, 0.5);
    }
  }
}

TEST(GlobalPositioningPriors, TooFewPriorsLeaveTheModelAsWithout) {
  PriorScene setup = MakeSetup(0.05, Eigen::Vector3d::Zero(), false);
  PosePriors two;
  two[1] = setup.priors.at(1);
  two[2] = setup.priors.at(2);
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(),
                                   &setup.reconstruction, &summary, &two));
  EXPECT_FALSE(summary.in_prior_frame);
  EXPECT_NE(summary.prior_problem.find("2 images with a position prior"),
            std::string::npos);
  // The first image at the origin, as without priors.
  EXPECT_LT(
      setup.reconstruction.images.begin()->second.ProjectionCenter().norm(),
      1e-9);
}

}  // namespace
}  // namespace colmap_irav4
