#include "colmap_irav4/positioning/track_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

void PositioningTrackSelectionOptions::Check() const {
  if (tracks_per_image < 0) {
    throw OptionError(&tracks_per_image, "Mapper.positioning_tracks_per_image",
                      "must be >= 0");
  }
  if (grid_size < 1) {
    throw OptionError(&grid_size, "Mapper.positioning_grid_size",
                      "must be >= 1");
  }
  if (tracks_per_pair < 0) {
    throw OptionError(&tracks_per_pair, "Mapper.positioning_tracks_per_pair",
                      "must be >= 0");
  }
  if (quota_pairs_per_image < -1) {
    throw OptionError(&quota_pairs_per_image,
                      "Mapper.positioning_quota_pairs_per_image",
                      "must be >= -1");
  }
  if (max_observations_per_image < 0) {
    throw OptionError(&max_observations_per_image,
                      "Mapper.positioning_max_observations_per_image",
                      "must be >= 0");
  }
  if (max_observations_min_num_images < 0) {
    throw OptionError(&max_observations_min_num_images,
                      "Mapper.positioning_max_observations_min_num_images",
                      "must be >= 0");
  }
}

int GridCell(double x, double y, double width, double height, int grid_size) {
  auto index = [grid_size](double v, double size) {
    const double scaled = size > 0 ? std::floor(v / size * grid_size) : 0.0;
    return static_cast<int>(
        std::clamp(scaled, 0.0, static_cast<double>(grid_size - 1)));
  };
  return index(y, height) * grid_size + index(x, width);
}

std::vector<size_t> PairQuotaPairs(
    const std::vector<std::pair<image_t, image_t>>& pairs,
    const std::vector<double>& weights, int pairs_per_image) {
  CHECK_EQ(weights.size(), pairs.size());
  std::vector<size_t> kept;
  if (pairs_per_image < 0) {
    kept.resize(pairs.size());
    std::iota(kept.begin(), kept.end(), 0);
    return kept;
  }
  std::vector<size_t> order(pairs.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return weights[a] > weights[b]; });
  // Union-find over the images (path halving), for Kruskal's forest.
  std::unordered_map<image_t, size_t> index;
  for (const auto& [image_id1, image_id2] : pairs) {
    index.emplace(image_id1, index.size());
    index.emplace(image_id2, index.size());
  }
  std::vector<size_t> parent(index.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::vector<int> num_strongest(index.size(), 0);
  std::vector<char> keep(pairs.size(), 0);
  for (const size_t k : order) {
    const size_t i = index.at(pairs[k].first);
    const size_t j = index.at(pairs[k].second);
    const size_t root_i = find(i);
    const size_t root_j = find(j);
    if (root_i != root_j) {
      parent[root_i] = root_j;
      keep[k] = 1;
    }
    for (const size_t image : {i, j}) {
      if (num_strongest[image] < pairs_per_image) {
        ++num_strongest[image];
        keep[k] = 1;
      }
    }
  }
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (keep[k]) kept.push_back(k);
  }
  return kept;
}

std::vector<size_t> SelectTracksForPositioning(
    const PositioningTrackSelectionOptions& options,
    const std::vector<Track>& tracks,
    const std::vector<std::pair<image_t, image_t>>& pairs,
    const ObservationCellFn& cell, const std::vector<double>& pair_weights,
    std::vector<Track>* observations) {
  options.Check();
  CHECK(pair_weights.empty() || pair_weights.size() == pairs.size());
  std::vector<size_t> selected;
  if (options.tracks_per_image <= 0) {
    selected.resize(tracks.size());
    std::iota(selected.begin(), selected.end(), 0);
    if (observations != nullptr) *observations = tracks;
    return selected;
  }
  std::vector<size_t> order(tracks.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return tracks[a].size() > tracks[b].size();
  });
  const bool spread = cell != nullptr && options.grid_size > 1;
  const int num_cells = spread ? options.grid_size * options.grid_size : 1;
  const int per_cell = (options.tracks_per_image + num_cells - 1) / num_cells;
  // The (image, cell) key of every observation, once: offsets[k] is the
  // first of track k's.
  std::vector<size_t> offsets(tracks.size() + 1, 0);
  for (size_t k = 0; k < tracks.size(); ++k) {
    offsets[k + 1] = offsets[k] + tracks[k].size();
  }
  std::vector<uint64_t> keys(offsets.back());
  for (size_t k = 0; k < tracks.size(); ++k) {
    for (size_t j = 0; j < tracks[k].size(); ++j) {
      const TrackElement& element = tracks[k][j];
      keys[offsets[k] + j] =
          static_cast<uint64_t>(element.image_id) * num_cells +
          (spread ? std::clamp(cell(element), 0, num_cells - 1) : 0);
    }
  }
  std::unordered_map<uint64_t, int> cell_count;
  std::unordered_map<image_t, int> image_count;
  std::unordered_map<image_pair_t, int> pair_count;
  if (options.tracks_per_pair > 0) {
    std::vector<double> weights = pair_weights;
    if (weights.empty() && options.quota_pairs_per_image >= 0) {
      // The tracks spanning each pair.
      std::unordered_map<image_pair_t, size_t> pair_index;
      pair_index.reserve(pairs.size());
      for (size_t k = 0; k < pairs.size(); ++k) {
        pair_index.emplace(ImagePairToPairId(pairs[k].first, pairs[k].second),
                           k);
      }
      weights.assign(pairs.size(), 0.0);
      for (const Track& track : tracks) {
        for (size_t a = 0; a < track.size(); ++a) {
          for (size_t b = a + 1; b < track.size(); ++b) {
            const auto it = pair_index.find(
                ImagePairToPairId(track[a].image_id, track[b].image_id));
            if (it != pair_index.end()) ++weights[it->second];
          }
        }
      }
    } else if (weights.empty()) {
      weights.assign(pairs.size(), 0.0);
    }
    const std::vector<size_t> quota_pairs =
        PairQuotaPairs(pairs, weights, options.quota_pairs_per_image);
    pair_count.reserve(quota_pairs.size());
    for (const size_t k : quota_pairs) {
      pair_count.emplace(ImagePairToPairId(pairs[k].first, pairs[k].second), 0);
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
  std::vector<char> is_selected(tracks.size(), 0);
  // The observation cap: each image's observations kept for positioning so
  // far, and each selected track's kept observations (in selection order).
  bool cap = observations != nullptr && options.max_observations_per_image > 0;
  if (cap && options.max_observations_min_num_images > 0) {
    std::unordered_set<image_t> images;
    for (const Track& track : tracks) {
      for (const TrackElement& element : track) images.insert(element.image_id);
    }
    cap = images.size() >=
          static_cast<size_t>(options.max_observations_min_num_images);
  }
  constexpr size_t kMinObservationsPerTrack = 3;
  std::unordered_map<image_t, int> kept_count;
  std::vector<Track> kept_observations;
  // `needed`: per observation of track k, whether it selected the track.
  auto select = [&](size_t k, const std::vector<char>& needed) {
    is_selected[k] = 1;
    selected.push_back(k);
    for (size_t j = offsets[k]; j < offsets[k + 1]; ++j) ++cell_count[keys[j]];
    for (const TrackElement& element : tracks[k])
      ++image_count[element.image_id];
    if (!pair_count.empty()) {
      for_pairs(tracks[k], [](int* count) {
        ++*count;
        return false;
      });
    }
    if (!cap) return;
    const Track& track = tracks[k];
    std::vector<char> keep(track.size(), 0);
    size_t num_kept = 0;
    for (size_t j = 0; j < track.size(); ++j) {
      if (needed[j] ||
          kept_count[track[j].image_id] < options.max_observations_per_image) {
        keep[j] = 1;
        ++num_kept;
      }
    }
    // At least kMinObservationsPerTrack: those in the images with the
    // fewest kept observations.
    while (num_kept < std::min(kMinObservationsPerTrack, track.size())) {
      size_t best = track.size();
      for (size_t j = 0; j < track.size(); ++j) {
        if (keep[j]) continue;
        if (best == track.size() ||
            kept_count[track[j].image_id] < kept_count[track[best].image_id]) {
          best = j;
        }
      }
      keep[best] = 1;
      ++num_kept;
    }
    Track kept;
    kept.reserve(num_kept);
    for (size_t j = 0; j < track.size(); ++j) {
      if (!keep[j]) continue;
      kept.push_back(track[j]);
      ++kept_count[track[j].image_id];
    }
    kept_observations.push_back(std::move(kept));
  };
  // The cells' quotas and the pairs' quotas.
  std::vector<char> needed;
  for (const size_t k : order) {
    const Track& track = tracks[k];
    needed.assign(track.size(), 0);
    bool any = false;
    for (size_t j = 0; j < track.size(); ++j) {
      const auto it = cell_count.find(keys[offsets[k] + j]);
      if (it == cell_count.end() || it->second < per_cell) {
        needed[j] = 1;
        any = true;
        if (!cap) break;  // one is enough to select the track
      }
    }
    if (!any && !pair_count.empty()) {
      // The first pair below its quota: both its observations.
      for (size_t a = 0; a < track.size() && !any; ++a) {
        for (size_t b = a + 1; b < track.size(); ++b) {
          const auto it = pair_count.find(
              ImagePairToPairId(track[a].image_id, track[b].image_id));
          if (it != pair_count.end() && it->second < options.tracks_per_pair) {
            needed[a] = needed[b] = 1;
            any = true;
            break;
          }
        }
      }
    }
    if (any) select(k, needed);
  }
  // Images whose keypoints fill few cells: up to tracks_per_image anyway
  // (without spreading the first pass already did this).
  if (spread) {
    for (const size_t k : order) {
      if (is_selected[k]) continue;
      const Track& track = tracks[k];
      needed.assign(track.size(), 0);
      bool any = false;
      for (size_t j = 0; j < track.size(); ++j) {
        if (image_count[track[j].image_id] < options.tracks_per_image) {
          needed[j] = 1;
          any = true;
        }
      }
      if (any) select(k, needed);
    }
  }
  if (observations != nullptr) {
    // Parallel to the sorted indices.
    std::vector<size_t> rank(selected.size());
    std::iota(rank.begin(), rank.end(), 0);
    std::sort(rank.begin(), rank.end(),
              [&](size_t a, size_t b) { return selected[a] < selected[b]; });
    observations->clear();
    observations->reserve(selected.size());
    for (const size_t r : rank) {
      observations->push_back(cap ? std::move(kept_observations[r])
                                  : tracks[selected[r]]);
    }
  }
  std::sort(selected.begin(), selected.end());
  return selected;
}

size_t RestorePositioningObservations(
    const std::vector<std::pair<point3D_t, TrackElement>>& dropped,
    double max_angular_error_deg, Reconstruction* reconstruction) {
  const double min_cos = std::cos(DegToRad(max_angular_error_deg));
  size_t num_restored = 0;
  for (const auto& [point3D_id, element] : dropped) {
    const auto point_it = reconstruction->points3D.find(point3D_id);
    if (point_it == reconstruction->points3D.end()) continue;
    const auto image_it = reconstruction->images.find(element.image_id);
    if (image_it == reconstruction->images.end()) continue;
    Image& image = image_it->second;
    Point2D& point2D = image.points2D.at(element.point2D_idx);
    if (point2D.point3D_id != kInvalidPoint3DId) continue;
    if (max_angular_error_deg > 0) {
      const Camera& camera = reconstruction->cameras.at(image.camera_id);
      const Eigen::Vector2d normalized =
          CameraImageToCamera(camera, point2D.xy);
      if (!normalized.allFinite()) continue;
      const Eigen::Vector3d direction =
          image.cam_from_world.rotation.inverse() * normalized.homogeneous();
      const Eigen::Vector3d ray =
          point_it->second.xyz - image.ProjectionCenter();
      if (!(ray.dot(direction) >= min_cos * ray.norm() * direction.norm())) {
        continue;
      }
    }
    point2D.point3D_id = point3D_id;
    point_it->second.track.push_back(element);
    ++num_restored;
  }
  return num_restored;
}

}  // namespace colmap_irav4
