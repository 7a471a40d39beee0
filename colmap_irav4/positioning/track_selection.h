#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "colmap_irav4/scene/track.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// The tracks global positioning solves for: a subset that ties every camera
// down and keeps the view graph's connections, the rest being triangulated
// from the refined poses afterwards.
struct PositioningTrackSelectionOptions {
  // Longest tracks first, each kept while one of its images has fewer than
  // this many observations from the tracks kept so far (0: every track).
  int tracks_per_image = 500;
  // ... or while one of the view-graph pairs it spans is covered by fewer
  // than this many kept tracks (0: no pair quota). Without it, a pair that
  // alone ties two parts of the graph together (a corner of a long loop
  // seen by one or two images) can lose all its tracks to the per-image
  // quota: positioning then places the parts independently, at an arbitrary
  // relative offset and scale that no later stage can repair.
  int tracks_per_pair = 10;

  // Throws OptionError naming the offending option.
  void Check() const;
};

// Returns the indices of the selected tracks, in increasing order. `pairs`:
// the view graph's pairs (image ids in either order); tracks spanning other
// image pairs count for the per-image quota only. Deterministic.
std::vector<size_t> SelectTracksForPositioning(
    const PositioningTrackSelectionOptions& options,
    const std::vector<Track>& tracks,
    const std::vector<std::pair<image_t, image_t>>& pairs);

}  // namespace colmap_irav4
