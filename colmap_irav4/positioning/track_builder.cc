#include "colmap_irav4/positioning/track_builder.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>

#include <glog/logging.h>

#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {
namespace {

uint64_t ObservationKey(image_t image_id, point2D_t point2D_idx) {
  return (static_cast<uint64_t>(image_id) << 32) | point2D_idx;
}

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

std::vector<Track> BuildTracks(const TrackBuilderOptions& options,
                               const std::vector<ImagePairMatches>& pairs,
                               const std::map<image_t, Image>& images,
                               TrackBuilderStats* stats) {
  options.Check();
  TrackBuilderStats local_stats;
  std::unordered_map<uint64_t, size_t> node_of_observation;
  std::vector<TrackElement> observations;
  UnionFind union_find;
  auto node = [&](image_t image_id, point2D_t point2D_idx) {
    auto [it, inserted] = node_of_observation.emplace(
        ObservationKey(image_id, point2D_idx), observations.size());
    if (inserted) {
      auto image_it = images.find(image_id);
      CHECK(image_it != images.end())
          << "match refers to unknown image " << image_id;
      CHECK_LT(point2D_idx, image_it->second.points2D.size())
          << "match refers to a missing keypoint of image " << image_id;
      observations.push_back({image_id, point2D_idx});
      union_find.Add();
    }
    return it->second;
  };
  for (const ImagePairMatches& pair : pairs) {
    if (pair.image_id1 == pair.image_id2) continue;
    for (const auto& [idx1, idx2] : pair.matches) {
      union_find.Union(node(pair.image_id1, idx1), node(pair.image_id2, idx2));
    }
  }
  local_stats.num_observations = observations.size();

  // Group the observations by component.
  std::unordered_map<size_t, size_t> track_of_root;
  std::vector<Track> components;
  for (size_t i = 0; i < observations.size(); ++i) {
    const size_t root = union_find.Find(i);
    auto [it, inserted] = track_of_root.emplace(root, components.size());
    if (inserted) components.emplace_back();
    components[it->second].push_back(observations[i]);
  }
  local_stats.num_components = components.size();

  std::vector<Track> tracks;
  const double max_duplicate_distance_sq =
      options.max_duplicate_distance * options.max_duplicate_distance;
  for (Track& track : components) {
    std::sort(track.begin(), track.end(), ElementLess);
    // Observations of one image are adjacent after sorting: keep the first of
    // each image unless another one of that image lies far from it.
    Track kept;
    bool consistent = true;
    for (size_t begin = 0; begin < track.size() && consistent;) {
      size_t end = begin + 1;
      while (end < track.size() &&
             track[end].image_id == track[begin].image_id) {
        ++end;
      }
      const Image& image = images.at(track[begin].image_id);
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
    if (!consistent) {
      ++local_stats.num_inconsistent;
      continue;
    }
    if (static_cast<int>(kept.size()) < options.min_track_length) {
      ++local_stats.num_too_short;
      continue;
    }
    if (static_cast<int>(kept.size()) > options.max_track_length) {
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
