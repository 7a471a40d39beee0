#include "colmap_irav4/positioning/track_selection.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

void PositioningTrackSelectionOptions::Check() const {
  if (tracks_per_image < 0) {
    throw OptionError(&tracks_per_image, "Mapper.positioning_tracks_per_image",
                      "must be >= 0");
  }
  if (tracks_per_pair < 0) {
    throw OptionError(&tracks_per_pair, "Mapper.positioning_tracks_per_pair",
                      "must be >= 0");
  }
}

std::vector<size_t> SelectTracksForPositioning(
    const PositioningTrackSelectionOptions& options,
    const std::vector<Track>& tracks,
    const std::vector<std::pair<image_t, image_t>>& pairs) {
  options.Check();
  std::vector<size_t> selected;
  if (options.tracks_per_image <= 0) {
    selected.resize(tracks.size());
    std::iota(selected.begin(), selected.end(), 0);
    return selected;
  }
  std::vector<size_t> order(tracks.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return tracks[a].size() > tracks[b].size();
  });
  std::unordered_map<image_t, int> image_count;
  std::unordered_map<image_pair_t, int> pair_count;
  if (options.tracks_per_pair > 0) {
    pair_count.reserve(pairs.size());
    for (const auto& [image_id1, image_id2] : pairs) {
      pair_count.emplace(ImagePairToPairId(image_id1, image_id2), 0);
    }
  }
  // Calls visit(count) for the counter of every view-graph pair the track
  // spans, until visit returns true; returns whether one did.
  auto for_pairs = [&](const Track& track, auto&& visit) {
    for (size_t a = 0; a < track.size(); ++a) {
      for (size_t b = a + 1; b < track.size(); ++b) {
        const auto it = pair_count.find(
            ImagePairToPairId(track[a].image_id, track[b].image_id));
        if (it != pair_count.end() && visit(&it->second)) return true;
      }
    }
    return false;
  };
  for (const size_t k : order) {
    const Track& track = tracks[k];
    bool needed = std::any_of(
        track.begin(), track.end(), [&](const TrackElement& element) {
          const auto it = image_count.find(element.image_id);
          return it == image_count.end() ||
                 it->second < options.tracks_per_image;
        });
    if (!needed && !pair_count.empty()) {
      needed = for_pairs(
          track, [&](int* count) { return *count < options.tracks_per_pair; });
    }
    if (!needed) continue;
    selected.push_back(k);
    for (const TrackElement& element : track) ++image_count[element.image_id];
    if (!pair_count.empty()) {
      for_pairs(track, [](int* count) {
        ++*count;
        return false;
      });
    }
  }
  std::sort(selected.begin(), selected.end());
  return selected;
}

}  // namespace colmap_irav4
