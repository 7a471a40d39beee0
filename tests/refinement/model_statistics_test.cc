#include "colmap_irav4/refinement/model_statistics.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

SyntheticScene Scene(double noise_px) {
  SyntheticSceneOptions options;
  options.num_images = 8;
  options.num_points = 300;
  options.visibility = 0.5;  // tracks of different lengths, some of two
  options.noise_px = noise_px;
  return GenerateSyntheticScene(options);
}

Sim3d SomeSimilarity() {
  Sim3d sim;
  sim.scale = 0.37;
  sim.R = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())
              .toRotationMatrix();
  sim.t = Eigen::Vector3d(4, -5, 6);
  return sim;
}

double MaxCenterDistance(const Reconstruction& a, const Reconstruction& b) {
  double max_distance = 0;
  for (const auto& [image_id, image] : a.images) {
    max_distance = std::max(
        max_distance,
        (image.ProjectionCenter() - b.images.at(image_id).ProjectionCenter())
            .norm());
  }
  return max_distance;
}

TEST(ObservationStatistics, CountsAHandBuiltModel) {
  Reconstruction model;
  model.cameras[1].model_id = 1;  // PINHOLE
  model.cameras[1].width = 100;
  model.cameras[1].height = 100;
  model.cameras[1].params = {100, 100, 50, 50};
  for (image_t id = 1; id <= 3; ++id) {
    Image& image = model.images[id];
    image.image_id = id;
    image.camera_id = 1;
    image.cam_from_world.translation = Eigen::Vector3d(-1.0 * id, 0, 0);
    image.points2D.resize(4);
  }
  // A point seen by the three images, one by images 1 and 2; keypoints at
  // its exact projections, so the reprojection error is 0.
  const Eigen::Vector3d xyz1(2, 0, 10);
  const Eigen::Vector3d xyz2(2, -3, 10);
  for (image_t id = 1; id <= 3; ++id) {
    Image& image = model.images.at(id);
    const Eigen::Vector3d p1 = image.cam_from_world * xyz1;
    image.points2D[0].xy =
        Eigen::Vector2d(100 * p1.x() / p1.z() + 50, 100 * p1.y() / p1.z() + 50);
    const Eigen::Vector3d p2 = image.cam_from_world * xyz2;
    image.points2D[1].xy =
        Eigen::Vector2d(100 * p2.x() / p2.z() + 50, 100 * p2.y() / p2.z() + 50);
  }
  AddPoint3D(xyz1, {{1, 0}, {2, 0}, {3, 0}}, &model);
  AddPoint3D(xyz2, {{1, 1}, {2, 1}}, &model);
  const ObservationStatistics stats = ComputeObservationStatistics(model, 2);
  EXPECT_EQ(stats.num_images, 3);
  EXPECT_EQ(stats.num_points, 2u);
  EXPECT_EQ(stats.num_observations, 5u);
  EXPECT_DOUBLE_EQ(stats.mean_track_length, 2.5);
  EXPECT_DOUBLE_EQ(stats.two_view_point_fraction, 0.5);
  EXPECT_EQ(stats.min_observations_per_image, 1);
  EXPECT_DOUBLE_EQ(stats.median_observations_per_image, 2);
  EXPECT_NEAR(stats.mean_reproj_error, 0, 1e-9);
  // Image 1 sees xyz1 right of the centre, xyz2 up and right: two of the
  // four cells; images 2 and 3 likewise at most two.
  EXPECT_GT(stats.mean_grid_coverage, 0.25);
  EXPECT_LE(stats.mean_grid_coverage, 0.5);
  EXPECT_GT(stats.median_tri_angle_deg, 0);
}

TEST(TransferPoses, TakesThePosesOfAModelInAnotherFrame) {
  const SyntheticScene scene = Scene(0.0);
  // Source: the truth in another frame; target: the truth with its poses
  // spoiled. After the transfer the target's poses are the truth's again
  // (the similarity maps the source back onto the target's points' frame).
  Reconstruction source = scene.truth;
  TransformReconstruction(SomeSimilarity(), &source);
  // Rotations spoiled by 2 deg about the same centres.
  Reconstruction target = scene.truth;
  std::mt19937_64 rng(3);
  for (auto& [image_id, image] : target.images) {
    const Eigen::Vector3d center = image.ProjectionCenter();
    image.cam_from_world.rotation =
        Eigen::Quaterniond(RandomRotationWithAngle(DegToRad(2.0), &rng)) *
        image.cam_from_world.rotation;
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  EXPECT_EQ(TransferPoses(source, false, &target), 8);
  for (const auto& [image_id, image] : target.images) {
    const Image& truth = scene.truth.images.at(image_id);
    EXPECT_LT((image.ProjectionCenter() - truth.ProjectionCenter()).norm(),
              1e-9);
    EXPECT_LT(
        AngularDistanceDeg(image.cam_from_world.rotation.toRotationMatrix(),
                           truth.cam_from_world.rotation.toRotationMatrix()),
        1e-6);
  }
  // The points are the target's, untouched.
  EXPECT_EQ(target.points3D.begin()->second.xyz,
            scene.truth.points3D.begin()->second.xyz);
}

TEST(TransferPoses, CopiesIntrinsicsOnlyWhenAsked) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction source = scene.truth;
  for (auto& [camera_id, camera] : source.cameras) camera.params[0] += 7;
  Reconstruction target = scene.truth;
  TransferPoses(source, false, &target);
  EXPECT_EQ(target.cameras.begin()->second.params,
            scene.truth.cameras.begin()->second.params);
  TransferPoses(source, true, &target);
  EXPECT_EQ(target.cameras.begin()->second.params,
            source.cameras.begin()->second.params);
  source.cameras.begin()->second.model_id = 0;
  EXPECT_THROW(TransferPoses(source, true, &target), InputError);
}

TEST(TransferPoses, NeedsThreeCommonImages) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction source = scene.truth;
  int k = 0;
  for (auto& [image_id, image] : source.images) {
    if (k++ >= 2) image.name = "other" + std::to_string(image_id);
  }
  Reconstruction target = scene.truth;
  EXPECT_THROW(TransferPoses(source, false, &target), InputError);
}

// The basis of the swap experiment (refinement_benchmark final_ba): the
// bundle adjustment's result depends on the observation set, not on the
// poses it starts from.
TEST(TransferPoses, BundleAdjustmentEndsAtTheSameOptimumFromOtherPoses) {
  const SyntheticScene scene = Scene(1.0);
  BundleAdjustmentOptions options;
  options.loss_function = BundleAdjustmentLoss::kTrivial;
  options.num_rounds = 1;
  options.solver.ceres.function_tolerance = 0;
  options.solver.ceres.parameter_tolerance = 0;
  options.solver.ceres.gradient_tolerance = 0;
  options.solver.ceres.max_num_iterations = 200;
  Reconstruction from_truth = scene.truth;
  // Other poses: the truth's, perturbed by 1 deg and 5 cm, in another frame.
  Reconstruction other = scene.truth;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (auto& [image_id, image] : other.images) {
    const Eigen::Vector3d center =
        image.ProjectionCenter() +
        Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    image.cam_from_world.rotation =
        Eigen::Quaterniond(RandomRotationWithAngle(DegToRad(1.0), &rng)) *
        image.cam_from_world.rotation;
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  TransformReconstruction(SomeSimilarity(), &other);
  Reconstruction from_other = scene.truth;
  TransferPoses(other, false, &from_other);
  ASSERT_GT(MaxCenterDistance(from_other, from_truth), 0.01);
  BundleAdjustmentSummary summary_truth, summary_other;
  ASSERT_TRUE(RunBundleAdjustment(options, &from_truth, &summary_truth));
  ASSERT_TRUE(RunBundleAdjustment(options, &from_other, &summary_other));
  EXPECT_NEAR(summary_other.final_mean_reproj_error,
              summary_truth.final_mean_reproj_error, 1e-6);
  // The optima coincide up to the gauge (a similarity).
  Reconstruction aligned = from_truth;
  TransferPoses(from_other, false, &aligned);
  EXPECT_LT(MaxCenterDistance(aligned, from_truth), 1e-5);
}

TEST(CompareTracksWithTruth, FindsWrongAndMissingObservations) {
  const SyntheticScene scene = Scene(0.5);
  Reconstruction model = scene.truth;
  TrackCorrectness check = CompareTracksWithTruth(model, scene.truth);
  EXPECT_EQ(check.num_wrong, 0u);
  EXPECT_EQ(check.num_truth_missing, 0u);
  EXPECT_EQ(check.num_observations, NumObservations(scene.truth));
  // A point of three or more observations: move one of its observations
  // to a keypoint of another point of the same image (a wrong match).
  point3D_t long_point = kInvalidPoint3DId;
  for (const auto& [id, point] : model.points3D) {
    if (point.track.size() >= 3) {
      long_point = id;
      break;
    }
  }
  ASSERT_NE(long_point, kInvalidPoint3DId);
  const TrackElement moved = model.points3D.at(long_point).track.back();
  const Image& image = model.images.at(moved.image_id);
  point2D_t other_idx = 0;
  while (image.points2D[other_idx].point3D_id == long_point ||
         image.points2D[other_idx].point3D_id == kInvalidPoint3DId) {
    ++other_idx;
  }
  const point3D_t other_point = image.points2D[other_idx].point3D_id;
  DeleteObservation(moved.image_id, moved.point2D_idx, &model);
  // The other point loses that keypoint, the long point takes it.
  DeleteObservation(moved.image_id, other_idx, &model);
  Point3D& point = model.points3D.at(long_point);
  point.track.push_back({moved.image_id, other_idx});
  model.images.at(moved.image_id).points2D[other_idx].point3D_id = long_point;
  check = CompareTracksWithTruth(model, scene.truth);
  EXPECT_EQ(check.num_wrong, 1u);
  EXPECT_EQ(check.num_points_with_wrong, 1u);
  // Missing: the moved observation of the long point, the keypoint lost by
  // the other point (plus its whole track if that fell below two).
  EXPECT_GE(check.num_truth_missing, 2u);
  if (model.points3D.count(other_point)) {
    EXPECT_EQ(check.num_truth_missing, 2u);
  }
}

TEST(DeleteShortTracks, DeletesExactlyTheShortTracks) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction model = scene.truth;
  size_t num_two_view = 0;
  for (const auto& [id, point] : model.points3D) {
    if (point.track.size() == 2) ++num_two_view;
  }
  ASSERT_GT(num_two_view, 0u);
  const size_t num_points = model.points3D.size();
  EXPECT_EQ(DeleteShortTracks(3, &model), num_two_view);
  EXPECT_EQ(model.points3D.size(), num_points - num_two_view);
  for (const auto& [id, point] : model.points3D) {
    EXPECT_GE(point.track.size(), 3u);
  }
  EXPECT_EQ(DeleteShortTracks(3, &model), 0u);
}

}  // namespace
}  // namespace colmap_irav4
