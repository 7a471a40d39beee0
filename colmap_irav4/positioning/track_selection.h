#pragma once

#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/track.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// The tracks global positioning solves for: a subset that ties every camera
// down, spread over each image, and keeps the view graph's connections, the
// rest being triangulated from the refined poses afterwards.
struct PositioningTrackSelectionOptions {
  // Longest tracks first, each kept while one of its observations falls in
  // a cell of its image's grid (grid_size x grid_size cells) that has fewer
  // than tracks_per_image / grid_size^2 (rounded up) observations from the
  // tracks kept so far; then, for images whose keypoints fill few cells,
  // while one of its images has fewer than tracks_per_image observations
  // (0: every track).
  int tracks_per_image = 500;
  // Cells per side of each image's grid (1: no spreading, the longest
  // tracks only). Spread observations constrain a camera's position better
  // than the same number bunched where the longest tracks happen to be.
  int grid_size = 1;
  // ... or while one of the view-graph pairs it spans is covered by fewer
  // than this many kept tracks (0: no pair quota). Without it, a pair that
  // alone ties two parts of the graph together (a corner of a long loop
  // seen by one or two images) can lose all its tracks to the per-image
  // quota: positioning then places the parts independently, at an arbitrary
  // relative offset and scale that no later stage can repair.
  int tracks_per_pair = 10;
  // The pairs that have the pair quota: a maximum spanning forest of the
  // view graph by pair strength (every pair that alone ties two parts of
  // the graph is in it) plus each image's this many strongest pairs
  // (PairQuotaPairs; -1: every view-graph pair). Bounds the pair quota's
  // tracks by the images instead of the pairs; on the photo scenes measured
  // the per-image quota's long tracks already cover the pairs (5: 164,548
  // -> 164,208 tracks at 5,000 images, 66,480 -> 66,432 at 1,000, whose
  // fold cut and models then came out differently, not better), so every
  // pair by default (docs/notes/2026-12-05-positioning-density.md).
  int quota_pairs_per_image = -1;
  // Observations per image in the positioning problem: a selected track
  // gives positioning its observations that selected it (below a cell's,
  // image's or pair's quota), those in images with fewer than this many
  // kept so far (selection order) and at least 3 (positioning's shortest
  // track); its others are added back after positioning (0: all). On dense
  // graphs the long tracks otherwise put ~1,350 observations per image into
  // the problem at 5,000 photo images, ~570 bytes each at the peak
  // (docs/notes/2026-12-05-positioning-observation-cap.md).
  int max_observations_per_image = 1000;
  // ... from this many images in the tracks: below, the problem is small
  // (< 1.5 GB at 2,000 photo images) and small scenes with long tracks
  // (castle-P19: up to ~1,300 per image) keep every observation.
  int max_observations_min_num_images = 2000;

  // Throws OptionError naming the offending option.
  void Check() const;
};

// The cell of an observation in its image's grid, in [0, grid_size^2).
typedef std::function<int(const TrackElement&)> ObservationCellFn;

// The cell of keypoint (x, y) in a width x height image's grid_size x
// grid_size grid (keypoints outside the image: the nearest cell).
int GridCell(double x, double y, double width, double height, int grid_size);

// The indices (increasing) of the pairs given the pair quota: those of a
// maximum spanning forest by `weights` (Kruskal, ties by index) and each
// image's `pairs_per_image` strongest (ties by index); every pair when
// pairs_per_image < 0. At most (images - 1) + pairs_per_image x images pairs:
// linear in the images whatever the graph's density. `weights`: parallel to
// `pairs`.
std::vector<size_t> PairQuotaPairs(
    const std::vector<std::pair<image_t, image_t>>& pairs,
    const std::vector<double>& weights, int pairs_per_image);

// Returns the indices of the selected tracks, in increasing order. `pairs`:
// the view graph's pairs (image ids in either order); tracks spanning other
// image pairs count for the per-image quota only. `cell`: each
// observation's grid cell (GridCell); null: no spreading (as grid_size 1).
// `pair_weights`: the pairs' strengths (the mapper: their inliers), parallel
// to `pairs`, choosing the pairs of the pair quota (PairQuotaPairs); empty:
// the number of tracks spanning each pair. `observations`: if not null,
// parallel to the result, each selected track's observations positioning
// uses (all of them unless max_observations_per_image drops some; in the
// track's order). Deterministic.
std::vector<size_t> SelectTracksForPositioning(
    const PositioningTrackSelectionOptions& options,
    const std::vector<Track>& tracks,
    const std::vector<std::pair<image_t, image_t>>& pairs,
    const ObservationCellFn& cell = nullptr,
    const std::vector<double>& pair_weights = {},
    std::vector<Track>* observations = nullptr);

// Links the observations `dropped` (a point and one of its track's
// observations left out of positioning) to their point when the point and
// the observation's image are in the model, the keypoint is free and its
// bearing is within max_angular_error_deg of the ray from the camera centre
// to the point (positioning's own filter; 0: always). Returns how many.
size_t RestorePositioningObservations(
    const std::vector<std::pair<point3D_t, TrackElement>>& dropped,
    double max_angular_error_deg, Reconstruction* reconstruction);

}  // namespace colmap_irav4
