#include "colmap_irav4/refinement/point_merging.h"

#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

SyntheticScene Scene(double noise_px) {
  SyntheticSceneOptions options;
  options.num_images = 10;
  options.num_points = 400;
  options.visibility = 0.8;
  options.noise_px = noise_px;
  options.camera_model_id = CameraModelNameToId("SIMPLE_RADIAL");
  options.extra_param = 0.02;
  return GenerateSyntheticScene(options);
}

// The truth with each point of 4+ observations split in two (its first half
// of images, its second half), each at the true position moved by `offset`
// (the two halves in opposite directions), the second half's keypoints
// moved by `shift` px (0: the halves agree, one point). Returns the number
// split.
size_t SplitPoints(const Reconstruction& truth, const Eigen::Vector3d& offset,
                   Reconstruction* split, double shift = 0) {
  *split = truth;
  size_t num_split = 0;
  std::vector<point3D_t> ids;
  for (const auto& [point3D_id, point] : truth.points3D) {
    if (point.track.size() >= 4) ids.push_back(point3D_id);
  }
  for (const point3D_t point3D_id : ids) {
    const Point3D point = split->points3D.at(point3D_id);
    const size_t half = point.track.size() / 2;
    const std::vector<TrackElement> second(point.track.begin() + half,
                                           point.track.end());
    for (const TrackElement& element : second) {
      UnlinkObservation(element.image_id, element.point2D_idx, split);
      split->images.at(element.image_id).points2D[element.point2D_idx].xy +=
          Eigen::Vector2d(0, shift);
    }
    split->points3D.at(point3D_id).xyz = point.xyz + offset;
    AddPoint3D(point.xyz - offset, second, split);
    ++num_split;
  }
  return num_split;
}

// The true point of each of the model's points (all observations agree).
void ExpectPure(const Reconstruction& model, const Reconstruction& truth) {
  for (const auto& [point3D_id, point] : model.points3D) {
    std::map<point3D_t, int> truths;
    for (const TrackElement& element : point.track) {
      ++truths[truth.images.at(element.image_id)
                   .points2D[element.point2D_idx]
                   .point3D_id];
    }
    EXPECT_EQ(truths.size(), 1u) << "point " << point3D_id;
  }
}

TEST(PointMerging, MergesPointsSplitAcrossTracks) {
  const SyntheticScene scene = Scene(0.5);
  Reconstruction split;
  const size_t num_split =
      SplitPoints(scene.truth, Eigen::Vector3d(0.002, 0.001, -0.001), &split);
  ASSERT_GT(num_split, 200u);
  const size_t num_observations = NumObservations(scene.truth);
  ASSERT_EQ(split.points3D.size(), scene.truth.points3D.size() + num_split);

  const PointMergingSummary summary =
      MergePoints(PointMergingOptions(), &split);
  EXPECT_EQ(summary.num_merges, num_split);
  EXPECT_EQ(split.points3D.size(), scene.truth.points3D.size());
  EXPECT_EQ(NumObservations(split), num_observations);
  ExpectPure(split, scene.truth);
  // The merged points moved to the least-squares position of all their
  // observations: within 0.5 px noise of the truth, not the split offsets.
  EXPECT_LT(UpdateReprojectionErrors(&split), 1.0);
}

TEST(PointMerging, LeavesDistinctPointsAlone) {
  const SyntheticScene scene = Scene(0.5);
  Reconstruction model = scene.truth;
  const PointMergingSummary summary =
      MergePoints(PointMergingOptions(), &model);
  EXPECT_EQ(summary.num_merges, 0u);
  EXPECT_EQ(model.points3D.size(), scene.truth.points3D.size());
  EXPECT_EQ(NumObservations(model), NumObservations(scene.truth));
}

// Halves whose keypoints disagree by 40 px (beyond the threshold wherever
// the merged point lies) are two points, not one.
TEST(PointMerging, DoesNotMergeHalvesThatDisagree) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction split;
  const size_t num_split =
      SplitPoints(scene.truth, Eigen::Vector3d::Zero(), &split, 40);
  ASSERT_GT(num_split, 200u);
  const size_t num_points = split.points3D.size();
  PointMergingOptions options;
  options.search_radius = 100;  // every half a candidate of the other
  const PointMergingSummary summary = MergePoints(options, &split);
  EXPECT_GT(summary.num_candidates, num_split / 2);
  // A search this wide finds the odd chance coincidence of two points that
  // are not one (400 points, 4 px): at most 2%.
  EXPECT_LE(summary.num_merges, num_split / 50);
  EXPECT_EQ(split.points3D.size(), num_points - summary.num_merges);
}

// With a keypoint noise model the threshold is in noise units: halves whose
// keypoints disagree by 14 px (the merged point 5.6-8.4 px from each, as the
// halves have 2-3 of 4-5 observations or more) merge only when every
// keypoint's factor is 4 (16 px).
TEST(PointMerging, ThresholdScalesWithTheKeypointNoise) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction split;
  const size_t num_split =
      SplitPoints(scene.truth, Eigen::Vector3d::Zero(), &split, 14);
  PointMergingOptions options;
  options.search_radius = 30;
  Reconstruction without = split;
  EXPECT_LE(MergePoints(options, &without).num_merges, num_split / 50);
  KeypointScaleNoise noise;
  noise.factors = {4.0};
  Reconstruction with = split;
  EXPECT_GT(MergePoints(options, &with, &noise).num_merges, num_split / 2);
}

TEST(PointMerging, ChecksOptions) {
  PointMergingOptions options;
  options.search_radius = 0;
  EXPECT_THROW(options.Check(), InputError);
  options = PointMergingOptions();
  options.max_reproj_error = -1;
  EXPECT_THROW(options.Check(), InputError);
  options = PointMergingOptions();
  options.max_passes = 0;
  EXPECT_THROW(options.Check(), InputError);
  Reconstruction empty;
  EXPECT_EQ(MergePoints(PointMergingOptions(), &empty).num_merges, 0u);
}

}  // namespace
}  // namespace colmap_irav4
