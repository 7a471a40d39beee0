#include "colmap_irav4/positioning/track_builder.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// Images 1..n, each with the given keypoint positions.
std::map<image_t, Image> MakeImages(
    const std::vector<std::vector<Eigen::Vector2d>>& keypoints) {
  std::map<image_t, Image> images;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    Image& image = images[i + 1];
    image.image_id = i + 1;
    for (const auto& xy : keypoints[i]) {
      Point2D point2D;
      point2D.xy = xy;
      image.points2D.push_back(point2D);
    }
  }
  return images;
}

// Element by element.
void ExpectSameTracks(const std::vector<Track>& tracks,
                      const std::vector<Track>& expected) {
  ASSERT_EQ(tracks.size(), expected.size());
  for (size_t t = 0; t < expected.size(); ++t) {
    ASSERT_EQ(tracks[t].size(), expected[t].size());
    for (size_t e = 0; e < expected[t].size(); ++e) {
      EXPECT_EQ(tracks[t][e].image_id, expected[t][e].image_id);
      EXPECT_EQ(tracks[t][e].point2D_idx, expected[t][e].point2D_idx);
    }
  }
}

// Six images, 400 points, 2% wrong matches.
SyntheticScene SceneWithWrongMatches() {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 6;
  scene_options.num_points = 400;
  scene_options.outlier_match_ratio = 0.02;
  return GenerateSyntheticScene(scene_options);
}

TEST(TrackBuilder, ChainsMatchesTransitively) {
  const auto images =
      MakeImages({{{0, 0}, {10, 10}}, {{1, 1}, {20, 20}}, {{2, 2}}});
  // 1:0 - 2:0 - 3:0 is one track; 1:1 - 2:1 another.
  std::vector<ImagePairMatches> pairs = {{1, 2, {{0, 0}, {1, 1}}},
                                         {2, 3, {{0, 0}}}};
  TrackBuilderStats stats;
  const auto tracks = BuildTracks(TrackBuilderOptions(), pairs, images, &stats);
  ASSERT_EQ(tracks.size(), 2u);
  ASSERT_EQ(tracks[0].size(), 3u);
  EXPECT_EQ(tracks[0][0].image_id, 1u);
  EXPECT_EQ(tracks[0][1].image_id, 2u);
  EXPECT_EQ(tracks[0][2].image_id, 3u);
  ASSERT_EQ(tracks[1].size(), 2u);
  EXPECT_EQ(tracks[1][0].point2D_idx, 1u);
  EXPECT_EQ(stats.num_observations, 5u);
  EXPECT_EQ(stats.num_tracks, 2u);
}

TEST(TrackBuilder, DropsTracksSeeingOneImageAtDistantPixels) {
  // 1:0 - 2:0 and 2:0 - 1:1 put 1:0 and 1:1 (100 px apart) in one track.
  const auto images = MakeImages({{{0, 0}, {100, 0}}, {{5, 5}}, {{7, 7}}});
  std::vector<ImagePairMatches> pairs = {{1, 2, {{0, 0}}}, {2, 1, {{0, 1}}}};
  TrackBuilderStats stats;
  EXPECT_TRUE(
      BuildTracks(TrackBuilderOptions(), pairs, images, &stats).empty());
  EXPECT_EQ(stats.num_inconsistent, 1u);
}

TEST(TrackBuilder, MergesNearDuplicateObservations) {
  // 1:0 and 1:1 are 1 px apart: the same feature detected twice.
  const auto images = MakeImages({{{0, 0}, {1, 0}}, {{5, 5}}, {{7, 7}}});
  std::vector<ImagePairMatches> pairs = {
      {1, 2, {{0, 0}}}, {2, 1, {{0, 1}}}, {2, 3, {{0, 0}}}};
  TrackBuilderStats stats;
  const auto tracks = BuildTracks(TrackBuilderOptions(), pairs, images, &stats);
  ASSERT_EQ(tracks.size(), 1u);
  ASSERT_EQ(tracks[0].size(), 3u);
  EXPECT_EQ(tracks[0][0].image_id, 1u);
  EXPECT_EQ(tracks[0][0].point2D_idx, 0u);
  EXPECT_EQ(stats.num_merged_duplicates, 1u);
}

TEST(TrackBuilder, LengthLimits) {
  const auto images =
      MakeImages({{{0, 0}, {50, 50}}, {{1, 1}, {60, 60}}, {{2, 2}}, {{3, 3}}});
  std::vector<ImagePairMatches> pairs = {
      {1, 2, {{0, 0}, {1, 1}}}, {2, 3, {{0, 0}}}, {3, 4, {{0, 0}}}};
  TrackBuilderOptions options;
  options.min_track_length = 3;
  EXPECT_EQ(BuildTracks(options, pairs, images).size(), 1u);  // the 4-view one
  options.max_track_length = 3;
  TrackBuilderStats stats;
  EXPECT_TRUE(BuildTracks(options, pairs, images, &stats).empty());
  EXPECT_EQ(stats.num_too_long, 1u);
  EXPECT_EQ(stats.num_too_short, 1u);
  options.max_track_length = 2;
  EXPECT_THROW(options.Check(), InputError);
}

TEST(TrackBuilder, RecoversSyntheticTracksDeterministically) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 8;
  scene_options.num_points = 300;
  scene_options.visibility = 0.7;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  TrackBuilderOptions options;
  const auto tracks = BuildTracks(options, scene.matches, scene.truth.images);
  ASSERT_EQ(tracks.size(), scene.truth.points3D.size());
  // Every track is exactly one true point's track.
  for (const Track& track : tracks) {
    const point3D_t point3D_id = scene.truth.images.at(track[0].image_id)
                                     .points2D[track[0].point2D_idx]
                                     .point3D_id;
    EXPECT_EQ(track.size(), scene.truth.points3D.at(point3D_id).track.size());
    for (const TrackElement& element : track) {
      EXPECT_EQ(scene.truth.images.at(element.image_id)
                    .points2D[element.point2D_idx]
                    .point3D_id,
                point3D_id);
    }
  }
  // Same tracks whatever the order of the pairs.
  std::vector<ImagePairMatches> reversed(scene.matches.rbegin(),
                                         scene.matches.rend());
  ExpectSameTracks(BuildTracks(options, reversed, scene.truth.images), tracks);
}

TEST(TrackBuilder, DatabaseMatchesFedPairByPairGiveTheSameTracks) {
  const SyntheticScene scene = SceneWithWrongMatches();
  TrackBuilderStats stats;
  const auto tracks = BuildTracks(TrackBuilderOptions(), scene.matches,
                                  scene.truth.images, &stats);
  // The same matches as the database stores them (FeatureMatches), in
  // another order, with a pair of an image with itself (skipped).
  TrackBuilder builder(TrackBuilderOptions(), scene.truth.images);
  builder.AddMatches(1, 1, FeatureMatches(3));
  for (auto it = scene.matches.rbegin(); it != scene.matches.rend(); ++it) {
    FeatureMatches matches;
    for (const auto& [idx1, idx2] : it->matches)
      matches.push_back({idx1, idx2});
    builder.AddMatches(it->image_id1, it->image_id2, matches);
  }
  TrackBuilderStats fed_stats;
  const auto fed = builder.Build(&fed_stats);
  EXPECT_EQ(fed_stats.num_observations, stats.num_observations);
  EXPECT_EQ(fed_stats.num_inconsistent, stats.num_inconsistent);
  EXPECT_GT(stats.num_inconsistent, 0u);
  ExpectSameTracks(fed, tracks);
}

TEST(TrackBuilder, WrongMatchesBreakOnlySomeTracks) {
  const SyntheticScene scene = SceneWithWrongMatches();
  TrackBuilderStats stats;
  const auto tracks = BuildTracks(TrackBuilderOptions(), scene.matches,
                                  scene.truth.images, &stats);
  EXPECT_GT(stats.num_inconsistent, 0u);
  EXPECT_GT(tracks.size(), scene.truth.points3D.size() / 4);
  // Kept tracks see each image at most once.
  for (const Track& track : tracks) {
    for (size_t e = 1; e < track.size(); ++e) {
      EXPECT_LT(track[e - 1].image_id, track[e].image_id);
    }
  }
}

TEST(TrackBuilder, AddTracksLinksObservations) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 4;
  scene_options.num_points = 50;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = StripPoints(scene.truth);
  const auto tracks =
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images);
  const auto ids = AddTracksToReconstruction(tracks, &reconstruction);
  ASSERT_EQ(ids.size(), tracks.size());
  for (size_t t = 0; t < tracks.size(); ++t) {
    for (const TrackElement& element : tracks[t]) {
      EXPECT_EQ(reconstruction.images.at(element.image_id)
                    .points2D[element.point2D_idx]
                    .point3D_id,
                ids[t]);
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
