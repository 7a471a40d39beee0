#pragma once

#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/track.h"
#include "colmap_irav4/scene/types.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {

struct TrackBuilderOptions {
  // Tracks observed in fewer images are dropped.
  int min_track_length = 2;
  // Tracks observed in more images are dropped (likely merged repetitions).
  int max_track_length = 1000;
  // Two observations of one track in the same image closer than this (px) are
  // one feature detected twice: one is kept. Farther apart: the track is
  // inconsistent and dropped.
  double max_duplicate_distance = 4.0;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct TrackBuilderStats {
  size_t num_observations = 0;       // distinct matched observations
  size_t num_components = 0;         // union-find components
  size_t num_inconsistent = 0;       // dropped: one image at distant pixels
  size_t num_merged_duplicates = 0;  // near-duplicate observations removed
  size_t num_too_short = 0;
  size_t num_too_long = 0;
  size_t num_tracks = 0;  // kept
};

// Union-find over the keypoints of `images` (positions from
// images[image_id].points2D) linked by the matches, fed one pair at a time
// (the caller's matches are never copied). A match referring to a missing
// image or keypoint index is an error of the caller: CHECK. Memory: 8 bytes
// per keypoint of `images` during AddMatches, plus the tracks (a hash map
// of matched observations took 64 bytes per observation). The result is
// deterministic: elements sorted by (image_id, point2D_idx) and tracks
// sorted by their first element.
class TrackBuilder {
 public:
  // `images` must outlive the builder.
  TrackBuilder(const TrackBuilderOptions& options,
               const std::map<image_t, Image>& images);

  // Links keypoint a of image_id1 with keypoint b of image_id2 for each
  // (a, b) of `matches` (pairs of an image with itself are skipped).
  void AddMatches(image_t image_id1, image_t image_id2,
                  const FeatureMatches& matches);
  void AddMatches(image_t image_id1, image_t image_id2,
                  const std::vector<std::pair<point2D_t, point2D_t>>& matches);

  // The tracks of the linked keypoints (the builder is spent).
  std::vector<Track> Build(TrackBuilderStats* stats = nullptr);

 private:
  size_t Node(image_t image_id, point2D_t point2D_idx) const;

  const TrackBuilderOptions options_;
  const std::map<image_t, Image>& images_;
  // Node of keypoint 0 of each image (images in ascending id, so that nodes
  // in ascending order are observations in (image_id, point2D_idx) order).
  std::map<image_t, size_t> first_node_;
  UnionFind sets_;
};

// The tracks of `pairs` (a TrackBuilder fed every pair in turn).
std::vector<Track> BuildTracks(const TrackBuilderOptions& options,
                               const std::vector<ImagePairMatches>& pairs,
                               const std::map<image_t, Image>& images,
                               TrackBuilderStats* stats = nullptr);

// Adds one Point3D (position unknown: zero, error -1) per track to the
// reconstruction and links the observations (points2D[].point3D_id). Returns
// the new point ids in track order.
std::vector<point3D_t> AddTracksToReconstruction(
    const std::vector<Track>& tracks, Reconstruction* reconstruction);

}  // namespace colmap_irav4
