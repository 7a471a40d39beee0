#include "colmap_irav4/positioning/track_selection.h"

#include <algorithm>
#include <set>

#include <gtest/gtest.h>

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
