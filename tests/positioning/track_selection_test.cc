#include "colmap_irav4/positioning/track_selection.h"

#include <algorithm>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

Track MakeTrack(const std::vector<image_t>& image_ids) {
  Track track;
  for (const image_t image_id : image_ids) track.push_back({image_id, 0});
  return track;
}

// Two chains of images, 1-4 and 5-8, each with 50 tracks seen by all its
// images; the only tie between them is the pair (4, 5), whose 12 tracks
// are seen by those two images alone.
struct TwoChains {
  std::vector<Track> tracks;
  std::vector<std::pair<image_t, image_t>> pairs;
  TwoChains() {
    for (int k = 0; k < 50; ++k) {
      tracks.push_back(MakeTrack({1, 2, 3, 4}));
      tracks.push_back(MakeTrack({5, 6, 7, 8}));
    }
    for (int k = 0; k < 12; ++k) tracks.push_back(MakeTrack({4, 5}));
    for (image_t a = 1; a <= 8; ++a) {
      for (image_t b = a + 1; b <= 8; ++b) {
        if ((a <= 4) == (b <= 4)) pairs.emplace_back(a, b);
      }
    }
    pairs.emplace_back(5, 4);  // either order
  }
  // Selected tracks spanning both chains.
  int NumJunctionTracks(const std::vector<size_t>& selected) const {
    return static_cast<int>(
        std::count_if(selected.begin(), selected.end(),
                      [&](size_t k) { return tracks[k].size() == 2; }));
  }
};

TEST(TrackSelection, KeepsTheTracksOfAPairThatAloneTiesTwoParts) {
  const TwoChains scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 10;
  // Without a pair quota the per-image quota of images 4 and 5 is filled by
  // the longer tracks of their own chains: nothing ties the chains together
  // and positioning places them independently (the 1,000-image courtyard's
  // halves ended up 114 m apart this way).
  options.tracks_per_pair = 0;
  const std::vector<size_t> per_image_only =
      SelectTracksForPositioning(options, scene.tracks, scene.pairs);
  EXPECT_EQ(scene.NumJunctionTracks(per_image_only), 0);
  EXPECT_EQ(per_image_only.size(), 20u);

  options.tracks_per_pair = 10;
  const std::vector<size_t> selected =
      SelectTracksForPositioning(options, scene.tracks, scene.pairs);
  EXPECT_EQ(scene.NumJunctionTracks(selected), 10);
  // Still bounded: the chains' pairs were already covered.
  EXPECT_EQ(selected.size(), 30u);
  EXPECT_TRUE(std::is_sorted(selected.begin(), selected.end()));
}

TEST(TrackSelection, PairQuotaCountsOnlyViewGraphPairs) {
  TwoChains scene;
  // (4, 5) is not a view-graph pair: its tracks only count per image.
  scene.pairs.pop_back();
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 10;
  options.tracks_per_pair = 10;
  EXPECT_EQ(scene.NumJunctionTracks(
                SelectTracksForPositioning(options, scene.tracks, scene.pairs)),
            0);
}

TEST(TrackSelection, ZeroPerImageQuotaSelectsEveryTrack) {
  const TwoChains scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 0;
  EXPECT_EQ(
      SelectTracksForPositioning(options, scene.tracks, scene.pairs).size(),
      scene.tracks.size());
}

TEST(TrackSelection, RejectsNegativeQuotas) {
  {
    PositioningTrackSelectionOptions options;
    options.max_observations_per_image = -1;
    EXPECT_THROW(options.Check(), OptionError);
    options.max_observations_per_image = 1000;
    options.max_observations_min_num_images = -1;
    EXPECT_THROW(options.Check(), OptionError);
  }
  const TwoChains scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_pair = -1;
  EXPECT_THROW(SelectTracksForPositioning(options, scene.tracks, scene.pairs),
               OptionError);
}

// Two images; 100 tracks seen by both, the 60 longest-ranked (first) in the
// top-left cell of each image, the others 10 per remaining cell...; the
// spread selection takes tracks from every cell, the longest-first one only
// from the crowded corner.
TEST(TrackSelection, GridSpreadsTheTracksOverTheImage) {
  std::vector<Track> tracks;
  std::vector<int> track_cell;
  // 40 long tracks (3 images) in cell 0, then 10 two-image tracks in each of
  // cells 1-3 of a 2 x 2 grid.
  for (int k = 0; k < 40; ++k) {
    tracks.push_back(MakeTrack({1, 2, 3}));
    track_cell.push_back(0);
  }
  for (int c = 1; c < 4; ++c) {
    for (int k = 0; k < 10; ++k) {
      tracks.push_back(MakeTrack({1, 2}));
      track_cell.push_back(c);
    }
  }
  // The cell of an observation: its track's (point2D_idx = track index).
  for (size_t k = 0; k < tracks.size(); ++k) {
    for (TrackElement& element : tracks[k]) element.point2D_idx = k;
  }
  const ObservationCellFn cell = [&](const TrackElement& element) {
    return track_cell.at(element.point2D_idx);
  };
  const std::vector<std::pair<image_t, image_t>> pairs = {
      {1, 2}, {1, 3}, {2, 3}};
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 20;
  options.tracks_per_pair = 0;
  auto cells_covered = [&](const std::vector<size_t>& selected) {
    std::set<int> cells;
    for (const size_t k : selected) cells.insert(track_cell[k]);
    return cells.size();
  };
  options.grid_size = 1;
  const std::vector<size_t> longest =
      SelectTracksForPositioning(options, tracks, pairs, cell);
  EXPECT_EQ(longest.size(), 20u);
  EXPECT_EQ(cells_covered(longest), 1u);
  // Without a cell function: the same as grid_size 1.
  EXPECT_EQ(SelectTracksForPositioning(options, tracks, pairs), longest);

  options.grid_size = 2;  // 5 per cell
  const std::vector<size_t> spread =
      SelectTracksForPositioning(options, tracks, pairs, cell);
  EXPECT_EQ(cells_covered(spread), 4u);
  // 5 per cell for images 1 and 2, then image 3 (cell 0 only) filled up to
  // its 20 observations with long tracks.
  EXPECT_EQ(spread.size(), 35u);
  for (const size_t k : spread) {
    EXPECT_TRUE(track_cell[k] == 0 || k % 10 < 5) << k;
  }
}

TEST(TrackSelection, GridKeepsThePairQuota) {
  const TwoChains scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 16;
  options.grid_size = 2;
  options.tracks_per_pair = 10;
  // Every observation in cell 0: the grid's per-cell quota (4) is filled by
  // the chains' tracks; the junction pair still gets its 10.
  const std::vector<size_t> selected =
      SelectTracksForPositioning(options, scene.tracks, scene.pairs,
                                 [](const TrackElement&) { return 0; });
  EXPECT_EQ(scene.NumJunctionTracks(selected), 10);
  // Without the pair quota the grid alone would lose them.
  options.tracks_per_pair = 0;
  EXPECT_EQ(scene.NumJunctionTracks(SelectTracksForPositioning(
                options, scene.tracks, scene.pairs,
                [](const TrackElement&) { return 0; })),
            0);
}

// Two dense clusters of `n` images each (every pair of a cluster a view-graph
// pair with 15 two-image tracks, as a photo collection's graph), tied by one
// pair (n, n + 1) of 12 tracks, the weakest pair of the graph.
struct DenseClusters {
  std::vector<Track> tracks;
  std::vector<std::pair<image_t, image_t>> pairs;
  explicit DenseClusters(image_t n) {
    for (const image_t first : {image_t{1}, n + 1}) {
      for (image_t a = first; a < first + n; ++a) {
        for (image_t b = a + 1; b < first + n; ++b) {
          pairs.emplace_back(a, b);
          for (int k = 0; k < 15; ++k) tracks.push_back(MakeTrack({a, b}));
        }
      }
    }
    pairs.emplace_back(n, n + 1);
    for (int k = 0; k < 12; ++k) tracks.push_back(MakeTrack({n, n + 1}));
  }
  size_t NumObservations(const std::vector<size_t>& selected) const {
    size_t num = 0;
    for (const size_t k : selected) num += tracks[k].size();
    return num;
  }
  int NumBridgeTracks(const std::vector<size_t>& selected, image_t n) const {
    return static_cast<int>(
        std::count_if(selected.begin(), selected.end(), [&](size_t k) {
          return tracks[k][0].image_id == n && tracks[k][1].image_id == n + 1;
        }));
  }
};

TEST(TrackSelection, PairQuotaOnASparseSubgraphGrowsLinearlyWithTheImages) {
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 20;
  options.tracks_per_pair = 10;
  options.quota_pairs_per_image = 3;
  const DenseClusters small(20);
  const DenseClusters large(40);
  const std::vector<size_t> small_selected =
      SelectTracksForPositioning(options, small.tracks, small.pairs);
  const std::vector<size_t> large_selected =
      SelectTracksForPositioning(options, large.tracks, large.pairs);
  // The bridge, the weakest pair and no image's strongest, keeps its tracks:
  // it is in every spanning forest.
  EXPECT_EQ(small.NumBridgeTracks(small_selected, 20), 10);
  EXPECT_EQ(large.NumBridgeTracks(large_selected, 40), 10);
  // Twice the images (four times the pairs): about twice the observations.
  const double ratio =
      static_cast<double>(large.NumObservations(large_selected)) /
      small.NumObservations(small_selected);
  EXPECT_LT(ratio, 2.2);
  EXPECT_GT(ratio, 1.8);
  // Bounded per image: the forest and 3 strongest pairs per image, 10
  // tracks of 2 observations each, and each image's quota of 20.
  EXPECT_LE(large.NumObservations(large_selected),
            (79u + 3 * 80) * 10 * 2 + 80 * 20 * 2);

  // The quota on every pair: the observations follow the pairs.
  options.quota_pairs_per_image = -1;
  const std::vector<size_t> small_all =
      SelectTracksForPositioning(options, small.tracks, small.pairs);
  const std::vector<size_t> large_all =
      SelectTracksForPositioning(options, large.tracks, large.pairs);
  EXPECT_GT(static_cast<double>(large.NumObservations(large_all)) /
                small.NumObservations(small_all),
            3.5);
  EXPECT_EQ(large.NumBridgeTracks(large_all, 40), 10);
}

TEST(TrackSelection, PairQuotaPairsKeepTheBridgesAndEachImagesStrongest) {
  // A path 1-2-3-4 of weak pairs plus strong pairs (1, 3) and (2, 4), and a
  // chord (1, 4) weaker than all.
  const std::vector<std::pair<image_t, image_t>> pairs = {
      {1, 2}, {2, 3}, {3, 4}, {1, 3}, {2, 4}, {1, 4}, {4, 5}};
  const std::vector<double> weights = {5, 6, 7, 50, 40, 1, 2};
  // The forest: (1, 3), (2, 4), then (3, 4) joins them; (4, 5) the bridge.
  EXPECT_EQ(PairQuotaPairs(pairs, weights, 0),
            (std::vector<size_t>{2, 3, 4, 6}));
  // ... and each image's strongest: 1 -> (1, 3), 2 -> (2, 4), 3 -> (1, 3),
  // 4 -> (2, 4), 5 -> (4, 5): nothing more.
  EXPECT_EQ(PairQuotaPairs(pairs, weights, 1),
            (std::vector<size_t>{2, 3, 4, 6}));
  // Two each: also 1 -> (1, 2), 2 -> (2, 3), 3 and 4 -> (3, 4).
  EXPECT_EQ(PairQuotaPairs(pairs, weights, 2),
            (std::vector<size_t>{0, 1, 2, 3, 4, 6}));
  EXPECT_EQ(PairQuotaPairs(pairs, weights, -1).size(), pairs.size());
}

TEST(TrackSelection, PairQuotaWeightsGivenOrCounted) {
  const TwoChains scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 10;
  options.tracks_per_pair = 10;
  options.quota_pairs_per_image = 0;  // the spanning forest only
  // Counted from the tracks or the inliers given: the junction is a bridge.
  EXPECT_EQ(scene.NumJunctionTracks(
                SelectTracksForPositioning(options, scene.tracks, scene.pairs)),
            10);
  const std::vector<double> weights(scene.pairs.size(), 1.0);
  EXPECT_EQ(scene.NumJunctionTracks(SelectTracksForPositioning(
                options, scene.tracks, scene.pairs, nullptr, weights)),
            10);
  options.quota_pairs_per_image = -2;
  EXPECT_THROW(SelectTracksForPositioning(options, scene.tracks, scene.pairs),
               OptionError);
}

// Images 1-9 share 100 tracks seen by all nine; image 10 is seen only by 20
// shorter tracks that also cross images 1-5. Quota 50: the first 50 long
// tracks fill images 1-9, then each short track is selected for image 10.
struct CrossingTracks {
  std::vector<Track> tracks;
  CrossingTracks() {
    for (int k = 0; k < 100; ++k) {
      tracks.push_back(MakeTrack({1, 2, 3, 4, 5, 6, 7, 8, 9}));
    }
    for (int k = 0; k < 20; ++k)
      tracks.push_back(MakeTrack({1, 2, 3, 4, 5, 10}));
  }
};

std::map<image_t, int> CountPerImage(const std::vector<Track>& tracks) {
  std::map<image_t, int> count;
  for (const Track& track : tracks) {
    for (const TrackElement& element : track) ++count[element.image_id];
  }
  return count;
}

TEST(TrackSelection, ObservationCapBoundsEachImageAndKeepsTheSelectingOnes) {
  const CrossingTracks scene;
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 50;
  options.tracks_per_pair = 0;
  options.max_observations_per_image = 0;
  std::vector<Track> all;
  const std::vector<size_t> uncapped =
      SelectTracksForPositioning(options, scene.tracks, {}, nullptr, {}, &all);
  ASSERT_EQ(uncapped.size(), 70u);
  ASSERT_EQ(all.size(), uncapped.size());
  for (size_t i = 0; i < uncapped.size(); ++i) {
    EXPECT_EQ(all[i].size(), scene.tracks[uncapped[i]].size());
  }
  // Without the cap images 1-5 get 50 + 20 observations.
  EXPECT_EQ(CountPerImage(all).at(1), 70);

  options.max_observations_per_image = 50;
  // Not below 11 images (the scene has 10).
  options.max_observations_min_num_images = 11;
  std::vector<Track> kept;
  EXPECT_EQ(
      SelectTracksForPositioning(options, scene.tracks, {}, nullptr, {}, &kept),
      uncapped);
  EXPECT_EQ(CountPerImage(kept), CountPerImage(all));
  options.max_observations_min_num_images = 10;
  const std::vector<size_t> capped =
      SelectTracksForPositioning(options, scene.tracks, {}, nullptr, {}, &kept);
  // The same tracks, fewer observations.
  EXPECT_EQ(capped, uncapped);
  ASSERT_EQ(kept.size(), capped.size());
  std::map<image_t, int> num_minimal;  // tracks kept at 3 observations
  for (size_t i = 0; i < capped.size(); ++i) {
    const Track& track = scene.tracks[capped[i]];
    ASSERT_GE(kept[i].size(), 3u);
    // A subsequence of the track.
    size_t j = 0;
    for (const TrackElement& element : track) {
      if (j < kept[i].size() && kept[i][j].image_id == element.image_id) ++j;
    }
    EXPECT_EQ(j, kept[i].size());
    if (track.size() == 6) {
      // Selected for image 10: that observation stays, 2 more in 1-5.
      EXPECT_EQ(kept[i].size(), 3u);
      EXPECT_TRUE(std::any_of(
          kept[i].begin(), kept[i].end(),
          [](const TrackElement& element) { return element.image_id == 10; }));
    } else {
      EXPECT_EQ(kept[i].size(), track.size());
    }
    if (kept[i].size() == 3) {
      for (const TrackElement& element : kept[i])
        ++num_minimal[element.image_id];
    }
  }
  // The cap holds but for the 3 observations every track keeps.
  const std::map<image_t, int> count = CountPerImage(kept);
  EXPECT_EQ(count.at(10), 20);
  for (image_t image_id = 1; image_id <= 9; ++image_id) {
    EXPECT_LE(count.at(image_id), 50 + num_minimal[image_id]) << image_id;
  }
  // The 40 observations over 3 per short track spread over images 1-5.
  for (image_t image_id = 1; image_id <= 5; ++image_id) {
    EXPECT_LE(count.at(image_id), 50 + 8) << image_id;
  }
}

TEST(TrackSelection, ObservationCapKeepsThePairThatSelectedATrack) {
  // 60 long tracks over images 1-4 (and 7, 8) cover the pairs of 1-4; 12
  // tracks cross 1-4 and 5, the only tie to image 5 (pair (4, 5)). Quota 5
  // per image: 5 of them are selected for image 5, 5 more for the pair
  // (4, 5), whose images are both at the cap by then.
  std::vector<Track> tracks;
  for (int k = 0; k < 60; ++k) tracks.push_back(MakeTrack({1, 2, 3, 4, 7, 8}));
  for (int k = 0; k < 12; ++k) tracks.push_back(MakeTrack({1, 2, 3, 4, 5}));
  const std::vector<std::pair<image_t, image_t>> pairs = {
      {1, 2}, {1, 3}, {1, 4}, {2, 3}, {2, 4}, {3, 4}, {4, 5}};
  PositioningTrackSelectionOptions options;
  options.tracks_per_image = 5;
  options.tracks_per_pair = 10;
  options.max_observations_per_image = 5;
  options.max_observations_min_num_images = 0;
  std::vector<Track> kept;
  const std::vector<size_t> selected =
      SelectTracksForPositioning(options, tracks, pairs, nullptr, {}, &kept);
  ASSERT_EQ(kept.size(), selected.size());
  int num_ties = 0;
  for (size_t i = 0; i < selected.size(); ++i) {
    if (tracks[selected[i]].size() != 5) continue;
    ++num_ties;
    std::set<image_t> images;
    for (const TrackElement& element : kept[i]) images.insert(element.image_id);
    EXPECT_EQ(images.size(), 3u);
    EXPECT_EQ(images.count(5), 1u) << selected[i];
    // The last five (in selection order) by the pair quota: both of it.
    if (selected[i] >= 65) {
      EXPECT_EQ(images.count(4), 1u) << selected[i];
    }
  }
  EXPECT_EQ(num_ties, 10);
  // Image 5 by the selecting observations (its quota, the pair's quota),
  // beyond the cap.
  const std::map<image_t, int> count = CountPerImage(kept);
  EXPECT_EQ(count.at(5), 10);
}

TEST(TrackSelection, RestoresTheObservationsLeftOutWithinTheAngle) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 6;
  scene_options.num_points = 50;
  scene_options.visibility = 1.0;
  Reconstruction model = GenerateSyntheticScene(scene_options).truth;
  ASSERT_GE(model.points3D.size(), 2u);
  auto it = model.points3D.begin();
  const point3D_t a = it->first;
  const Eigen::Vector3d xyz_a = it->second.xyz;
  const point3D_t b = (++it)->first;
  ASSERT_GE(model.points3D.at(a).track.size(), 4u);
  ASSERT_GE(model.points3D.at(b).track.size(), 4u);
  // One observation of each taken out of its point.
  const TrackElement of_a = model.points3D.at(a).track.back();
  const TrackElement of_b = model.points3D.at(b).track.back();
  UnlinkObservation(of_a.image_id, of_a.point2D_idx, &model);
  UnlinkObservation(of_b.image_id, of_b.point2D_idx, &model);
  // b's observation handed to a: its bearing is off a's ray.
  const Image& image_b = model.images.at(of_b.image_id);
  const Eigen::Vector3d to_a = xyz_a - image_b.ProjectionCenter();
  const Eigen::Vector3d to_b =
      model.points3D.at(b).xyz - image_b.ProjectionCenter();
  ASSERT_LT(to_a.normalized().dot(to_b.normalized()),
            std::cos(5.0 * 3.14159265358979 / 180));
  const std::vector<std::pair<point3D_t, TrackElement>> dropped = {{a, of_a},
                                                                   {a, of_b}};
  EXPECT_EQ(RestorePositioningObservations(dropped, 5.0, &model), 1u);
  EXPECT_EQ(
      model.images.at(of_a.image_id).points2D.at(of_a.point2D_idx).point3D_id,
      a);
  EXPECT_EQ(
      model.images.at(of_b.image_id).points2D.at(of_b.point2D_idx).point3D_id,
      kInvalidPoint3DId);
  // Not twice.
  EXPECT_EQ(RestorePositioningObservations(dropped, 5.0, &model), 0u);
  // No angle: every free one.
  EXPECT_EQ(RestorePositioningObservations(dropped, 0.0, &model), 1u);
}

TEST(TrackSelection, GridCellOfAKeypoint) {
  EXPECT_EQ(GridCell(0, 0, 1600, 1200, 4), 0);
  EXPECT_EQ(GridCell(1599, 0, 1600, 1200, 4), 3);
  EXPECT_EQ(GridCell(0, 1199, 1600, 1200, 4), 12);
  EXPECT_EQ(GridCell(900, 700, 1600, 1200, 4), 2 * 4 + 2);
  // Outside the image: the nearest cell.
  EXPECT_EQ(GridCell(-5, 1300, 1600, 1200, 4), 12);
  EXPECT_EQ(GridCell(800, 600, 1600, 1200, 1), 0);
}

}  // namespace
}  // namespace colmap_irav4
