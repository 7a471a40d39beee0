#include "colmap_irav4/positioning/global_positioning.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MaxRelativeCenterError;

Reconstruction PrepareFromTracks(const SyntheticScene& scene) {
  Reconstruction reconstruction = StripPoints(scene.truth);
  for (auto& [image_id, image] : reconstruction.images) {
    image.cam_from_world.translation.setZero();  // unknown
  }
  AddTracksToReconstruction(
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images),
      &reconstruction);
  return reconstruction;
}

// 15 images, 500 points each seen by ~60% of them.
SyntheticSceneOptions SceneOptions() {
  SyntheticSceneOptions options;
  options.num_images = 15;
  options.num_points = 500;
  options.visibility = 0.6;
  return options;
}

TEST(GlobalPositioning, RecoversCentersOfExactScene) {
  const SyntheticSceneOptions scene_options = SceneOptions();
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  GlobalPositionerOptions options;
  // Exact data: solved to tight tolerances the cost's minimum is the truth.
  options.solver.ceres.function_tolerance = 1e-10;
  options.solver.ceres.parameter_tolerance = 1e-10;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &reconstruction, &summary));
  EXPECT_EQ(summary.num_images, 15);
  EXPECT_EQ(reconstruction.images.size(), 15u);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth,
                                   scene_options.arc_radius),
            1e-4);
  // Rotations are untouched.
  for (const auto& [image_id, image] : reconstruction.images) {
    EXPECT_LT(image.cam_from_world.rotation.angularDistance(
                  scene.truth.images.at(image_id).cam_from_world.rotation),
              1e-12);
  }
}

TEST(GlobalPositioning, RobustToNoiseAndWrongMatches) {
  SyntheticSceneOptions scene_options = SceneOptions();
  scene_options.num_points = 800;
  scene_options.noise_px = 1.0;
  scene_options.outlier_match_ratio = 0.002;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  // Add 10% wrong observations to the kept tracks: a random keypoint of
  // another image that is not yet in the track.
  std::mt19937_64 rng(3);
  int num_added = 0;
  const size_t num_points = reconstruction.points3D.size();
  for (auto& [point3D_id, point] : reconstruction.points3D) {
    if (num_added >= static_cast<int>(0.1 * NumObservations(reconstruction)))
      break;
    std::uniform_int_distribution<image_t> image_dist(1, 15);
    const image_t image_id = image_dist(rng);
    bool present = false;
    for (const auto& element : point.track)
      present |= element.image_id == image_id;
    if (present) continue;
    Image& image = reconstruction.images.at(image_id);
    std::uniform_int_distribution<point2D_t> idx_dist(
        0, image.points2D.size() - 1);
    const point2D_t idx = idx_dist(rng);
    if (image.points2D[idx].point3D_id != kInvalidPoint3DId) continue;
    image.points2D[idx].point3D_id = point3D_id;
    point.track.push_back({image_id, idx});
    ++num_added;
  }
  ASSERT_GT(num_added, static_cast<int>(0.05 * num_points));
  ASSERT_GT(num_points, 300u);
  GlobalPositionerOptions options;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &reconstruction, &summary));
  EXPECT_EQ(reconstruction.images.size(), 15u);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth,
                                   scene_options.arc_radius),
            0.005);
  EXPECT_GT(summary.num_observations_filtered, num_added / 2);
}

TEST(GlobalPositioning, DropsShortTracksAndUnobservedImages) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 5;
  scene_options.num_points = 200;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  // Image 5 keeps only 2-view observations: unlink all others.
  for (point2D_t idx = 0; idx < reconstruction.images.at(5).points2D.size();
       ++idx) {
    DeleteObservation(5, idx, &reconstruction);
  }
  Image extra;
  extra.image_id = 6;
  extra.camera_id = 1;
  reconstruction.images[6] = extra;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(), &reconstruction,
                                   &summary));
  EXPECT_EQ(summary.num_images_dropped, 2);
  EXPECT_EQ(reconstruction.images.size(), 4u);
}

TEST(GlobalPositioning, SameBitsWhereverTheModelIsOnTheHeap) {
  // Ceres orders the blocks of an elimination group by address: solved in
  // place, a copy laid out otherwise would differ in the last bits.
  SyntheticSceneOptions scene_options = SceneOptions();
  scene_options.noise_px = 1.0;
  Reconstruction a = PrepareFromTracks(GenerateSyntheticScene(scene_options));
  Reconstruction b = test::CopyInReverseOrder(a);
  GlobalPositionerOptions options;
  options.solver.ceres.num_threads = 1;
  ASSERT_TRUE(RunGlobalPositioning(options, &a));
  ASSERT_TRUE(RunGlobalPositioning(options, &b));
  test::ExpectSameBits(a, b);
}

TEST(GlobalPositioning, OptionsCheck) {
  GlobalPositionerOptions options;
  EXPECT_NO_THROW(options.Check());
  EXPECT_FALSE(ParseEnum("l7", &options.loss_function));
  options = GlobalPositionerOptions();
  options.min_track_length = 1;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
