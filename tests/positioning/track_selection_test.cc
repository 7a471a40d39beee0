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

}  // namespace
}  // namespace colmap_irav4
