#include "colmap_irav4/refinement/filtering.h"

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

SyntheticScene Scene() {
  SyntheticSceneOptions options;
  options.num_images = 6;
  options.num_points = 200;
  options.noise_px = 0.5;
  return GenerateSyntheticScene(options);
}

// Whether every link points both ways.
void ExpectConsistent(const Reconstruction& reconstruction) {
  size_t num_linked = 0;
  for (const auto& [image_id, image] : reconstruction.images) {
    for (point2D_t idx = 0; idx < image.points2D.size(); ++idx) {
      const point3D_t point3D_id = image.points2D[idx].point3D_id;
      if (point3D_id == kInvalidPoint3DId) continue;
      ++num_linked;
      const auto& track = reconstruction.points3D.at(point3D_id).track;
      EXPECT_EQ(std::count_if(track.begin(), track.end(),
                              // Captured by name: clang (C++17) cannot
                              // capture a structured binding.
                              [&, image_id = image_id](const TrackElement& e) {
                                return e.image_id == image_id &&
                                       e.point2D_idx == idx;
                              }),
                1);
    }
  }
  EXPECT_EQ(num_linked, NumObservations(reconstruction));
  for (const auto& [point3D_id, point] : reconstruction.points3D)
    EXPECT_GE(point.track.size(), 2u);
}

TEST(Filtering, RemovesExactlyTheObservationsOverTheThreshold) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  const size_t num_before = NumObservations(reconstruction);
  // Move 20 keypoints of image 3 by 10 px.
  int num_moved = 0;
  for (Point2D& point2D : reconstruction.images.at(3).points2D) {
    if (num_moved == 20) break;
    point2D.xy.x() += 10.0;
    ++num_moved;
  }
  EXPECT_EQ(FilterObservationsWithLargeReprojectionError(4.0, &reconstruction),
            20u);
  EXPECT_EQ(NumObservations(reconstruction), num_before - 20);
  ExpectConsistent(reconstruction);
  EXPECT_EQ(FilterObservationsWithLargeReprojectionError(4.0, &reconstruction),
            0u);
}

// With a noise model the threshold is in noise units: 4 px at factor 1,
// 8 px for a keypoint of a bin twice as noisy, 2 px for one half as noisy.
TEST(Filtering, ThresholdScalesWithTheNoiseOfTheKeypointScale) {
  SyntheticSceneOptions options;
  options.num_images = 6;
  options.num_points = 200;
  options.noise_px = 0.0;
  SyntheticScene scene = GenerateSyntheticScene(options);
  Reconstruction& reconstruction = scene.truth;
  KeypointScaleNoise noise;
  noise.edges = {2.0f, 8.0f};
  noise.factors = {0.5, 1.0, 2.0};
  // Image 3's observed keypoints: 10 fine ones moved by 3 px, 10 coarse ones
  // by 6 px, 10 coarse ones by 10 px; the others of a middle scale.
  int num_moved = 0;
  for (Point2D& point2D : reconstruction.images.at(3).points2D) {
    point2D.scale = 4.0f;
    if (point2D.point3D_id == kInvalidPoint3DId || num_moved == 30) continue;
    point2D.scale = num_moved < 10 ? 1.0f : 10.0f;
    point2D.xy.x() += num_moved < 10 ? 3.0 : (num_moved < 20 ? 6.0 : 10.0);
    ++num_moved;
  }
  ASSERT_EQ(num_moved, 30);
  // In pixels: the 6 and 10 px ones.
  EXPECT_EQ(
      FindObservationsWithLargeReprojectionError(4.0, reconstruction).size(),
      20u);
  // In noise units: the fine 3 px ones (over 2) and the coarse 10 px ones
  // (over 8); the coarse 6 px ones are within 8.
  EXPECT_EQ(FilterObservationsWithLargeReprojectionError(4.0, &reconstruction,
                                                         &noise),
            20u);
  ExpectConsistent(reconstruction);
  int num_coarse_left = 0;
  for (const Point2D& point2D : reconstruction.images.at(3).points2D) {
    if (point2D.point3D_id == kInvalidPoint3DId) continue;
    EXPECT_NE(point2D.scale, 1.0f);  // every fine moved one is gone
    num_coarse_left += point2D.scale == 10.0f;
  }
  EXPECT_EQ(num_coarse_left, 10);
}

TEST(Filtering, RemovesPointsBehindTheCamera) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  Point3D& point = reconstruction.points3D.begin()->second;
  const size_t track_length = point.track.size();
  // Mirror the point through the first camera's centre: behind that camera.
  const Eigen::Vector3d center =
      reconstruction.images.at(point.track[0].image_id).ProjectionCenter();
  point.xyz = 2 * center - point.xyz;
  EXPECT_GE(FilterObservationsWithLargeReprojectionError(4.0, &reconstruction),
            track_length - 1);
  ExpectConsistent(reconstruction);
}

TEST(Filtering, TriangulationAngle) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  // Images 1 and 2 are 90/5 = 18 deg apart on the arc, the points near the
  // centre: every point sees angles well above 1.5 deg.
  EXPECT_EQ(FilterPointsWithSmallTriangulationAngle(1.5, &reconstruction), 0u);
  // A point 1000 radii away is seen under ~0.09 deg at most.
  const point3D_t far_id = reconstruction.points3D.begin()->first;
  reconstruction.points3D.at(far_id).xyz = Eigen::Vector3d(0, 0, 10000.0);
  EXPECT_LT(RadToDeg(MaxTriangulationAngle(reconstruction,
                                           reconstruction.points3D.at(far_id))),
            0.2);
  EXPECT_EQ(FilterPointsWithSmallTriangulationAngle(1.5, &reconstruction), 1u);
  EXPECT_FALSE(reconstruction.points3D.count(far_id));
  ExpectConsistent(reconstruction);
}

TEST(Filtering, NormalizationCentresAndScalesWithoutChangingProjections) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  const double error_before = UpdateReprojectionErrors(&reconstruction);
  Sim3d offset;
  offset.scale = 3.7;
  offset.R = AngleAxisToRotation(Eigen::Vector3d(0.3, -0.2, 0.5));
  offset.t = Eigen::Vector3d(100, -50, 7);
  TransformReconstruction(offset, &reconstruction);
  EXPECT_NEAR(UpdateReprojectionErrors(&reconstruction), error_before, 1e-6);
  NormalizationOptions options;
  const Sim3d applied = NormalizeReconstruction(options, &reconstruction);
  EXPECT_GT(applied.scale, 0);
  EXPECT_NEAR(UpdateReprojectionErrors(&reconstruction), error_before, 1e-6);
  std::vector<double> xs, ys, zs;
  double spread = 0;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    for (const auto& [image_id, image] : reconstruction.images)
      values.push_back(image.ProjectionCenter()[axis]);
    std::sort(values.begin(), values.end());
    const auto at = [&](double f) {
      return values[static_cast<size_t>(std::round(f * (values.size() - 1)))];
    };
    EXPECT_NEAR(at(0.5), 0.0, 1e-9);
    spread = std::max(spread, at(0.9) - at(0.1));
  }
  EXPECT_NEAR(spread, 10.0, 1e-9);
  options.max_percentile = 0.05;
  EXPECT_THROW(options.Check(), InputError);
}

TEST(Filtering, RunFilteringDropsImagesWithFewObservations) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  for (point2D_t idx = 10; idx < reconstruction.images.at(2).points2D.size();
       ++idx) {
    DeleteObservation(2, idx, &reconstruction);
  }
  FilterOptions options;
  options.min_num_observations_per_image = 20;
  const FilterSummary summary = RunFiltering(options, &reconstruction);
  EXPECT_EQ(summary.num_images_filtered, 1u);
  EXPECT_FALSE(reconstruction.images.count(2));
  ExpectConsistent(reconstruction);
}

// By default (as COLMAP's FilterImages) an image no point is seen in leaves
// the model; one seen in a single point stays.
TEST(Filtering, RunFilteringDropsImagesWithoutObservationsByDefault) {
  SyntheticScene scene = Scene();
  Reconstruction& reconstruction = scene.truth;
  for (image_t image_id : {2, 3}) {
    const point2D_t first_deleted = image_id == 2 ? 0 : 1;
    for (point2D_t idx = first_deleted;
         idx < reconstruction.images.at(image_id).points2D.size(); ++idx) {
      DeleteObservation(image_id, idx, &reconstruction);
    }
  }
  const size_t num_images = reconstruction.images.size();
  const FilterSummary summary = RunFiltering(FilterOptions(), &reconstruction);
  EXPECT_EQ(summary.num_images_filtered, 1u);
  EXPECT_EQ(summary.filtered_images, std::vector<image_t>{2});
  EXPECT_FALSE(reconstruction.images.count(2));
  EXPECT_EQ(reconstruction.images.size(), num_images - 1);
  ExpectConsistent(reconstruction);
}

// An image whose camera bundle adjustment drove to a focal length near zero
// (or below it) leaves the model with its observations, as COLMAP's
// incremental mapper filters images; the others (their own cameras, all
// plausible) stay, whatever their reprojection errors.
TEST(Filtering, RunFilteringDropsImagesWithBogusCameras) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 6;
  scene_options.num_points = 200;
  scene_options.camera_model_id = 2;  // SIMPLE_RADIAL
  scene_options.shared_camera = false;
  SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction& reconstruction = scene.truth;
  ASSERT_NE(reconstruction.images.at(2).camera_id,
            reconstruction.images.at(4).camera_id);
  const auto num_seen = [&](image_t image_id) {
    size_t n = 0;
    for (const Point2D& point2D : reconstruction.images.at(image_id).points2D) {
      n += point2D.point3D_id != kInvalidPoint3DId;
    }
    return n;
  };
  const size_t num_expected = num_seen(2) + num_seen(4);
  const size_t num_before = NumObservations(reconstruction);
  // 44 px on a 1600 px side (r300 seed 1's camera collapsed to 44 px on a
  // 1920 px side) and a negative focal length (as seed 2's).
  reconstruction.cameras.at(reconstruction.images.at(2).camera_id).params[0] =
      44;
  reconstruction.cameras.at(reconstruction.images.at(4).camera_id).params[0] =
      -189;
  // A threshold no reprojection error reaches: only the camera check can
  // remove the two images (the reprojection filter would remove their
  // observations, and the image filter then the images).
  FilterOptions options;
  options.max_reproj_error = 1e9;
  const FilterSummary summary = RunFiltering(options, &reconstruction);
  EXPECT_EQ(summary.bogus_camera_images, (std::vector<image_t>{2, 4}));
  EXPECT_EQ(summary.num_bogus_camera_observations, num_expected);
  EXPECT_EQ(summary.num_images_filtered, 0u);
  EXPECT_FALSE(reconstruction.images.count(2));
  EXPECT_FALSE(reconstruction.images.count(4));
  EXPECT_EQ(reconstruction.images.size(), 4u);
  // Only their observations went (the scene is noise free).
  EXPECT_EQ(summary.num_observations_filtered, 0u);
  EXPECT_LE(NumObservations(reconstruction), num_before - num_expected);
  ExpectConsistent(reconstruction);

  // Nothing bogus left: a second filtering removes no image.
  EXPECT_TRUE(
      RunFiltering(options, &reconstruction).bogus_camera_images.empty());
}

TEST(Filtering, BogusCameraLimitsAreChecked) {
  const auto check = [](double min_ratio, double max_ratio, double max_extra) {
    FilterOptions options;
    options.min_focal_length_ratio = min_ratio;
    options.max_focal_length_ratio = max_ratio;
    options.max_extra_param = max_extra;
    options.Check();
  };
  EXPECT_NO_THROW(check(0.1, 10, 1));
  EXPECT_NO_THROW(check(0, 10, 0));
  EXPECT_THROW(check(10, 10, 1), InputError);
  EXPECT_THROW(check(-0.1, 10, 1), InputError);
  EXPECT_THROW(check(0.1, 10, -1), InputError);
}

}  // namespace
}  // namespace colmap_irav4
