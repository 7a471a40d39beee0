#include "colmap_irav4/positioning/track_builder.h"

#include <algorithm>
#include <limits>

#include <glog/logging.h>

#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

bool ElementLess(const TrackElement& a, const TrackElement& b) {
  return a.image_id != b.image_id ? a.image_id < b.image_id
                                  : a.point2D_idx < b.point2D_idx;
}

}  // namespace

void TrackBuilderOptions::Check() const {
  if (min_track_length < 2) {
    throw OptionError(&min_track_length, "Tracks.min_track_length",
                      "must be at least 2");
  }
  if (max_track_length < min_track_length) {
    throw OptionError(&max_track_length, "Tracks.max_track_length",
                      "must be at least min_track_length");
  }
  if (!(max_duplicate_distance >= 0.0)) {
    throw OptionError(&max_duplicate_distance, "Tracks.max_duplicate_distance",
                      "must be >= 0");
  }
}

TrackBuilder::TrackBuilder(const TrackBuilderOptions& options,
                           const std::map<image_t, Image>& images)
    : options_(options), images_(images) {
  options_.Check();
  size_t num_nodes = 0;
  for (const auto& [image_id, image] : images_) {
    first_node_.emplace_hint(first_node_.end(), image_id, num_nodes);
    num_nodes += image.points2D.size();
  }
  sets_ = UnionFind(num_nodes);
}

size_t TrackBuilder::Node(image_t image_id, point2D_t point2D_idx) const {
  const auto it = first_node_.find(image_id);
  CHECK(it != first_node_.end())
      << "match refers to unknown image " << image_id;
  CHECK_LT(point2D_idx, images_.at(image_id).points2D.size())
      << "match refers to a missing keypoint of image " << image_id;
  return it->second + point2D_idx;
}

void TrackBuilder::AddMatches(image_t image_id1, image_t image_id2,
                              const FeatureMatches& matches) {
  if (image_id1 == image_id2) return;
  for (const FeatureMatch& match : matches) {
    sets_.Union(Node(image_id1, match.point2D_idx1),
                Node(image_id2, match.point2D_idx2));
  }
}

void TrackBuilder::AddMatches(
    image_t image_id1, image_t image_id2,
    const std::vector<std::pair<point2D_t, point2D_t>>& matches) {
  if (image_id1 == image_id2) return;
  for (const auto& [idx1, idx2] : matches) {
    sets_.Union(Node(image_id1, idx1), Node(image_id2, idx2));
  }
}

std::vector<Track> TrackBuilder::Build(TrackBuilderStats* stats) {
  TrackBuilderStats local_stats;
  // Group the matched keypoints (sets of two or more) by set, in node order:
  // each component's elements come out sorted by (image_id, point2D_idx).
  constexpr uint32_t kNoTrack = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> component_of_root(sets_.Size(), kNoTrack);
  std::vector<Track> components;
  for (const auto& [image_id, first_node] : first_node_) {
    const size_t num_points2D = images_.at(image_id).points2D.size();
    for (size_t idx = 0; idx < num_points2D; ++idx) {
      const size_t root = sets_.Find(first_node + idx);
      if (sets_.SetSize(root) < 2) continue;  // never matched
      uint32_t& component = component_of_root[root];
      if (component == kNoTrack) {
        CHECK_LT(components.size(), kNoTrack);
        component = static_cast<uint32_t>(components.size());
        components.emplace_back();
        components.back().reserve(sets_.SetSize(root));
      }
      components[component].push_back({image_id, static_cast<point2D_t>(idx)});
      ++local_stats.num_observations;
    }
  }
  sets_ = UnionFind();
  std::vector<uint32_t>().swap(component_of_root);
  local_stats.num_components = components.size();

  std::vector<Track> tracks;
  const double max_duplicate_distance_sq =
      options_.max_duplicate_distance * options_.max_duplicate_distance;
  for (Track& track : components) {
    // Observations of one image are adjacent (sorted): keep the first of
    // each image unless another one of that image lies far from it.
    Track kept;
    bool consistent = true;
    for (size_t begin = 0; begin < track.size() && consistent;) {
      size_t end = begin + 1;
      while (end < track.size() &&
             track[end].image_id == track[begin].image_id) {
        ++end;
      }
      const Image& image = images_.at(track[begin].image_id);
      for (size_t i = begin; i < end && consistent; ++i) {
        for (size_t j = i + 1; j < end; ++j) {
          if ((image.points2D[track[i].point2D_idx].xy -
               image.points2D[track[j].point2D_idx].xy)
                  .squaredNorm() > max_duplicate_distance_sq) {
            consistent = false;
            break;
          }
        }
      }
      local_stats.num_merged_duplicates += end - begin - 1;
      kept.push_back(track[begin]);
      begin = end;
    }
    Track().swap(track);
    if (!consistent) {
      ++local_stats.num_inconsistent;
      continue;
    }
    if (static_cast<int>(kept.size()) < options_.min_track_length) {
      ++local_stats.num_too_short;
      continue;
    }
    if (static_cast<int>(kept.size()) > options_.max_track_length) {
      ++local_stats.num_too_long;
      continue;
    }
    tracks.push_back(std::move(kept));
  }
  std::sort(tracks.begin(), tracks.end(), [](const Track& a, const Track& b) {
    return ElementLess(a.front(), b.front());
  });
  local_stats.num_tracks = tracks.size();
  if (stats != nullptr) *stats = local_stats;
  return tracks;
}

std::vector<Track> BuildTracks(const TrackBuilderOptions& options,
                               const std::vector<ImagePairMatches>& pairs,
                               const std::map<image_t, Image>& images,
                               TrackBuilderStats* stats) {
  TrackBuilder builder(options, images);
  for (const ImagePairMatches& pair : pairs) {
    builder.AddMatches(pair.image_id1, pair.image_id2, pair.matches);
  }
  return builder.Build(stats);
}

std::vector<point3D_t> AddTracksToReconstruction(
    const std::vector<Track>& tracks, Reconstruction* reconstruction) {
  std::vector<point3D_t> point3D_ids;
  point3D_ids.reserve(tracks.size());
  for (const Track& track : tracks) {
    point3D_ids.push_back(
        AddPoint3D(Eigen::Vector3d::Zero(), track, reconstruction));
  }
  return point3D_ids;
}

}  // namespace colmap_irav4
