#include "colmap_irav4/refinement/triangulation.h"

#include <random>
#include <set>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {
namespace {

TEST(Triangulation, MidpointAndDLTAreExactOnExactRays) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d X =
        RandomVector<3>(uniform, rng) + Eigen::Vector3d(0, 0, 5);
    std::vector<Eigen::Vector3d> centers, directions;
    std::vector<Eigen::Matrix<double, 3, 4>> cams;
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d c = RandomVector<3>(uniform, rng);
      centers.push_back(c);
      directions.push_back(3.0 * (X - c));
      Eigen::Matrix<double, 3, 4> P;
      P << Eigen::Matrix3d::Identity(), -c;
      cams.push_back(P);
      points.push_back((X - c).hnormalized());
    }
    Eigen::Vector3d midpoint, dlt;
    ASSERT_TRUE(TriangulateMidpoint(centers, directions, &midpoint));
    ASSERT_TRUE(TriangulateDLT(cams, points, &dlt));
    EXPECT_LT((midpoint - X).norm(), 1e-9);
    EXPECT_LT((dlt - X).norm(), 1e-9);
  }
  Eigen::Vector3d xyz;
  EXPECT_FALSE(TriangulateMidpoint(
      {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()},
      {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX()}, &xyz));
}

SyntheticScene Scene(double noise_px) {
  SyntheticSceneOptions options;
  options.num_images = 8;
  options.num_points = 300;
  options.visibility = 0.7;
  options.noise_px = noise_px;
  options.camera_model_id = CameraModelNameToId("SIMPLE_RADIAL");
  options.extra_param = 0.02;
  return GenerateSyntheticScene(options);
}

TEST(Triangulation, TriangulatesEveryTrackOfKnownPoses) {
  const SyntheticScene scene = Scene(0.5);
  Reconstruction reconstruction = StripPoints(scene.truth);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  const TriangulationSummary summary =
      TriangulateTracks(TriangulationOptions(), tracks, &reconstruction);
  EXPECT_EQ(summary.num_points_added, tracks.size());
  EXPECT_EQ(NumObservations(reconstruction), NumObservations(scene.truth));
  EXPECT_LT(UpdateReprojectionErrors(&reconstruction), 1.0);
  double max_error = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    const TrackElement& e = point.track[0];
    const point3D_t true_id =
        scene.truth.images.at(e.image_id).points2D[e.point2D_idx].point3D_id;
    max_error = std::max(
        max_error, (point.xyz - scene.truth.points3D.at(true_id).xyz).norm());
  }
  EXPECT_LT(max_error, 0.1);  // cameras 10 away, 0.5 px noise
}

TEST(Triangulation, RejectsWrongObservationsAndSplitsMergedTracks) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction reconstruction = StripPoints(scene.truth);
  std::vector<Track> tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  // Merge pairs of tracks: images 1-4 of one with images 5-8 of the next.
  std::vector<Track> merged;
  for (size_t t = 0; t + 1 < tracks.size(); t += 2) {
    Track track;
    for (const auto& e : tracks[t])
      if (e.image_id <= 4) track.push_back(e);
    const size_t num_first = track.size();
    for (const auto& e : tracks[t + 1])
      if (e.image_id > 4) track.push_back(e);
    if (num_first >= 2 && track.size() - num_first >= 2)
      merged.push_back(track);
  }
  const size_t num_merged = merged.size();
  ASSERT_GT(num_merged, 5u);
  const TriangulationSummary summary =
      TriangulateTracks(TriangulationOptions(), merged, &reconstruction);
  EXPECT_EQ(summary.num_points_added, 2 * num_merged);
  EXPECT_LT(UpdateReprojectionErrors(&reconstruction), 1e-6);
  // One wrong observation per track: excluded.
  Reconstruction reconstruction2 = StripPoints(scene.truth);
  std::vector<Track> corrupted = tracks;
  std::mt19937_64 rng(4);
  size_t num_corrupted = 0;
  for (Track& track : corrupted) {
    if (track.size() < 3) continue;
    const Image& image = reconstruction2.images.at(track[1].image_id);
    std::uniform_int_distribution<point2D_t> dist(0, image.points2D.size() - 1);
    const point2D_t idx = dist(rng);
    if ((image.points2D[idx].xy - image.points2D[track[1].point2D_idx].xy)
            .norm() < 20)
      continue;
    track[1].point2D_idx = idx;
    ++num_corrupted;
  }
  ASSERT_GT(num_corrupted, 50u);
  TriangulateTracks(TriangulationOptions(), corrupted, &reconstruction2);
  EXPECT_LT(UpdateReprojectionErrors(&reconstruction2), 1e-6);
  EXPECT_GE(NumObservations(reconstruction2),
            NumObservations(scene.truth) - 2 * num_corrupted);
}

// With a noise model, an observation is an inlier up to max_reproj_error
// times its scale bin's factor: a coarse keypoint moved by 12 px is kept at
// factor 4 (16 px) and dropped without the model (4 px).
TEST(Triangulation, InlierThresholdScalesWithTheKeypointNoise) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction reconstruction = StripPoints(scene.truth);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  // Image 2's keypoints of tracks of 4 or more observations: a move of one
  // of them cannot be absorbed by the point's depth.
  std::set<point2D_t> moved;
  for (const Track& track : tracks) {
    if (track.size() < 4) continue;
    for (const TrackElement& e : track) {
      if (e.image_id == 2 && moved.size() < 40) moved.insert(e.point2D_idx);
    }
  }
  ASSERT_EQ(moved.size(), 40u);
  std::vector<Point2D>& points2D = reconstruction.images.at(2).points2D;
  for (point2D_t idx = 0; idx < points2D.size(); ++idx) {
    points2D[idx].scale = moved.count(idx) ? 10.0f : 4.0f;
    if (moved.count(idx)) points2D[idx].xy.x() += 12.0;
  }
  KeypointScaleNoise noise;
  noise.edges = {8.0f};
  noise.factors = {1.0, 4.0};
  Reconstruction without = reconstruction;
  TriangulateTracks(TriangulationOptions(), tracks, &without);
  TriangulateTracks(TriangulationOptions(), tracks, &reconstruction, &noise);
  size_t num_kept_without = 0, num_kept_with = 0;
  for (const point2D_t idx : moved) {
    num_kept_without +=
        without.images.at(2).points2D[idx].point3D_id != kInvalidPoint3DId;
    num_kept_with += points2D[idx].point3D_id != kInvalidPoint3DId;
  }
  EXPECT_EQ(num_kept_without, 0u);
  EXPECT_EQ(num_kept_with, moved.size());
  EXPECT_EQ(NumObservations(reconstruction), NumObservations(scene.truth));
}

TEST(Triangulation, RetriangulatesOnlyWhatIsMissing) {
  const SyntheticScene scene = Scene(0.5);
  Reconstruction reconstruction = scene.truth;
  const size_t num_points = reconstruction.points3D.size();
  const size_t num_observations = NumObservations(reconstruction);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  // Delete every third point.
  std::vector<point3D_t> deleted;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    if (point3D_id % 3 == 0) deleted.push_back(point3D_id);
  }
  for (point3D_t id : deleted) DeletePoint3D(id, &reconstruction);
  const TriangulationSummary summary =
      TriangulateTracks(TriangulationOptions(), tracks, &reconstruction);
  EXPECT_EQ(summary.num_points_added, deleted.size());
  EXPECT_EQ(reconstruction.points3D.size(), num_points);
  EXPECT_EQ(NumObservations(reconstruction), num_observations);
}

TEST(Triangulation, RespectsMinimumAngle) {
  SyntheticSceneOptions options;
  options.num_images = 2;
  options.num_points = 100;
  options.arc_angle_deg = 1.0;  // baseline: 1 deg seen from the centre
  options.height_jitter = 0.0;
  const SyntheticScene scene = GenerateSyntheticScene(options);
  Reconstruction reconstruction = StripPoints(scene.truth);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  ASSERT_GT(tracks.size(), 50u);
  TriangulationOptions triangulation_options;
  EXPECT_EQ(TriangulateTracks(triangulation_options, tracks, &reconstruction)
                .num_points_added,
            0u);
  triangulation_options.min_tri_angle = 0.1;
  EXPECT_GT(TriangulateTracks(triangulation_options, tracks, &reconstruction)
                .num_points_added,
            50u);
}

TEST(Triangulation, IgnoresTwoViewTracksWhenAsked) {
  // Low visibility: many points are seen by two images only.
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 8;
  scene_options.num_points = 300;
  scene_options.visibility = 0.3;
  scene_options.noise_px = 0.5;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  const Reconstruction stripped = StripPoints(scene.truth);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, stripped.images);
  size_t num_two_view = 0;
  for (const Track& track : tracks) num_two_view += track.size() == 2;
  ASSERT_GT(num_two_view, 20u);  // the scene has many
  Reconstruction all = stripped;
  EXPECT_EQ(
      TriangulateTracks(TriangulationOptions(), tracks, &all).num_points_added,
      tracks.size());
  TriangulationOptions options;
  options.ignore_two_view_tracks = true;
  Reconstruction ignored = stripped;
  EXPECT_EQ(TriangulateTracks(options, tracks, &ignored).num_points_added,
            tracks.size() - num_two_view);
  for (const auto& [point3D_id, point] : ignored.points3D) {
    EXPECT_GE(point.track.size(), 3u);
  }
}

// Observations filtered off a point come back to it: one alone (which no
// new point could use) and two (which would otherwise form a second point
// of the same track).
TEST(Triangulation, CompletesTracksOntoTheirExistingPoint) {
  const SyntheticScene scene = Scene(0.5);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, scene.truth.images);
  Reconstruction unlinked = scene.truth;
  size_t num_unlinked = 0;
  size_t num_points_with_two = 0;
  for (auto& [point3D_id, point] : unlinked.points3D) {
    if (point.track.size() < 5) continue;
    const size_t num = point3D_id % 2 == 0 ? 1 : 2;
    num_points_with_two += num == 2;
    for (size_t k = 0; k < num; ++k) {
      const TrackElement element = point.track.back();
      UnlinkObservation(element.image_id, element.point2D_idx, &unlinked);
      ++num_unlinked;
    }
  }
  ASSERT_GT(num_points_with_two, 20u);
  const size_t num_points = unlinked.points3D.size();
  const size_t num_observations = NumObservations(scene.truth);

  Reconstruction completed = unlinked;
  const TriangulationSummary summary =
      TriangulateTracks(TriangulationOptions(), tracks, &completed);
  EXPECT_EQ(summary.num_observations_completed, num_unlinked);
  EXPECT_EQ(summary.num_points_added, 0u);
  EXPECT_EQ(completed.points3D.size(), num_points);
  EXPECT_EQ(NumObservations(completed), num_observations);
  for (const auto& [point3D_id, point] : completed.points3D) {
    for (const TrackElement& element : point.track) {
      EXPECT_EQ(scene.truth.images.at(element.image_id)
                    .points2D[element.point2D_idx]
                    .point3D_id,
                point3D_id);
    }
  }

  // Without completion: the pairs become second points, the singles lost.
  TriangulationOptions no_completion;
  no_completion.complete_tracks = false;
  Reconstruction split = unlinked;
  const TriangulationSummary split_summary =
      TriangulateTracks(no_completion, tracks, &split);
  EXPECT_EQ(split_summary.num_observations_completed, 0u);
  EXPECT_EQ(split_summary.num_points_added, num_points_with_two);
  EXPECT_EQ(split.points3D.size(), num_points + num_points_with_two);
  EXPECT_EQ(NumObservations(split),
            num_observations - (num_unlinked - 2 * num_points_with_two));
}

// An observation that does not reproject onto the track's point (a wrong
// match) is not added to it.
TEST(Triangulation, CompletionRejectsObservationsOffThePoint) {
  const SyntheticScene scene = Scene(0.0);
  Reconstruction moved = scene.truth;
  std::vector<Track> tracks;
  size_t num_moved = 0;
  for (auto& [point3D_id, point] : moved.points3D) {
    if (point.track.size() < 4) continue;
    const TrackElement element = point.track.back();
    tracks.push_back(point.track);
    UnlinkObservation(element.image_id, element.point2D_idx, &moved);
    // 10 px off: beyond the 4 px threshold.
    moved.images.at(element.image_id).points2D[element.point2D_idx].xy +=
        Eigen::Vector2d(6, 8);
    ++num_moved;
  }
  ASSERT_GT(num_moved, 50u);
  const size_t num_observations = NumObservations(moved);
  const TriangulationSummary summary =
      TriangulateTracks(TriangulationOptions(), tracks, &moved);
  EXPECT_EQ(summary.num_observations_completed, 0u);
  EXPECT_EQ(summary.num_points_added, 0u);
  EXPECT_EQ(NumObservations(moved), num_observations);
}

}  // namespace
}  // namespace colmap_irav4
