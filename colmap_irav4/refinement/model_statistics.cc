#include "colmap_irav4/refinement/model_statistics.h"

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"

namespace colmap_irav4 {

ObservationStatistics ComputeObservationStatistics(
    const Reconstruction& reconstruction, int grid_size) {
  ObservationStatistics stats;
  stats.num_images = static_cast<int>(reconstruction.images.size());
  stats.num_points = reconstruction.points3D.size();
  std::map<image_t, int> per_image;
  std::map<image_t, std::set<int>> cells;
  std::vector<double> angles;
  angles.reserve(reconstruction.points3D.size());
  size_t num_two_view = 0;
  double error_sum = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    stats.num_observations += point.track.size();
    if (point.track.size() == 2) ++num_two_view;
    angles.push_back(RadToDeg(MaxTriangulationAngle(reconstruction, point)));
    for (const TrackElement& element : point.track) {
      const Image& image = reconstruction.images.at(element.image_id);
      const Camera& camera = reconstruction.cameras.at(image.camera_id);
      const Eigen::Vector2d& xy = image.points2D[element.point2D_idx].xy;
      error_sum += ReprojectionError(camera, image, point.xyz, xy);
      ++per_image[element.image_id];
      const int cx = std::clamp(
          static_cast<int>(xy.x() / static_cast<double>(camera.width) *
                           grid_size),
          0, grid_size - 1);
      const int cy = std::clamp(
          static_cast<int>(xy.y() / static_cast<double>(camera.height) *
                           grid_size),
          0, grid_size - 1);
      cells[element.image_id].insert(cy * grid_size + cx);
    }
  }
  if (stats.num_points > 0) {
    stats.mean_track_length =
        static_cast<double>(stats.num_observations) / stats.num_points;
    stats.two_view_point_fraction =
        static_cast<double>(num_two_view) / stats.num_points;
  }
  if (stats.num_observations > 0) {
    stats.mean_reproj_error = error_sum / stats.num_observations;
  }
  stats.median_tri_angle_deg = Median(angles);
  std::vector<double> counts;
  double coverage_sum = 0;
  stats.min_observations_per_image = stats.num_images > 0 ? -1 : 0;
  for (const auto& [image_id, image] : reconstruction.images) {
    const auto it = per_image.find(image_id);
    const int count = it == per_image.end() ? 0 : it->second;
    counts.push_back(count);
    if (stats.min_observations_per_image < 0 ||
        count < stats.min_observations_per_image) {
      stats.min_observations_per_image = count;
    }
    const auto cell = cells.find(image_id);
    coverage_sum += cell == cells.end()
                        ? 0.0
                        : static_cast<double>(cell->second.size()) /
                              (grid_size * grid_size);
  }
  stats.median_observations_per_image = Median(counts);
  if (stats.num_images > 0)
    stats.mean_grid_coverage = coverage_sum / stats.num_images;
  return stats;
}

int TransferPoses(const Reconstruction& source, bool copy_intrinsics,
                  Reconstruction* target) {
  std::map<std::string, const Image*> source_by_name;
  for (const auto& [image_id, image] : source.images) {
    source_by_name[image.name] = &image;
  }
  std::vector<Eigen::Vector3d> source_centers;
  std::vector<Eigen::Vector3d> target_centers;
  for (const auto& [image_id, image] : target->images) {
    const auto it = source_by_name.find(image.name);
    if (it == source_by_name.end()) continue;
    source_centers.push_back(it->second->ProjectionCenter());
    target_centers.push_back(image.ProjectionCenter());
  }
  if (source_centers.size() < 3) {
    throw InputError("poses", "only " + std::to_string(source_centers.size()) +
                                  " images in common (3 needed)");
  }
  Sim3d target_from_source;
  if (!EstimateSimilarity(source_centers, target_centers,
                          &target_from_source)) {
    throw InputError("poses", "the common camera centres are degenerate");
  }
  Reconstruction aligned = source;
  TransformReconstruction(target_from_source, &aligned);
  std::map<std::string, const Image*> aligned_by_name;
  for (const auto& [image_id, image] : aligned.images) {
    aligned_by_name[image.name] = &image;
  }
  int num_transferred = 0;
  std::set<camera_t> cameras_done;
  for (auto& [image_id, image] : target->images) {
    const auto it = aligned_by_name.find(image.name);
    if (it == aligned_by_name.end()) continue;
    image.cam_from_world = it->second->cam_from_world;
    ++num_transferred;
    if (!copy_intrinsics || !cameras_done.insert(image.camera_id).second) {
      continue;
    }
    Camera& camera = target->cameras.at(image.camera_id);
    const Camera& source_camera = aligned.cameras.at(it->second->camera_id);
    if (source_camera.model_id != camera.model_id) {
      throw InputError("poses", "camera of " + image.name +
                                    " has another camera model in the source");
    }
    camera.params = source_camera.params;
  }
  return num_transferred;
}

TrackCorrectness CompareTracksWithTruth(const Reconstruction& model,
                                        const Reconstruction& truth) {
  std::map<std::string, const Image*> truth_by_name;
  for (const auto& [image_id, image] : truth.images) {
    truth_by_name[image.name] = &image;
  }
  // The truth point of an observation (kInvalidPoint3DId: clutter or an
  // image the truth lacks).
  auto truth_point = [&](const TrackElement& element) {
    const Image& image = model.images.at(element.image_id);
    const auto it = truth_by_name.find(image.name);
    if (it == truth_by_name.end() ||
        element.point2D_idx >= it->second->points2D.size()) {
      return kInvalidPoint3DId;
    }
    return it->second->points2D[element.point2D_idx].point3D_id;
  };
  TrackCorrectness result;
  std::map<image_t, size_t> used_per_image;
  for (const auto& [point3D_id, point] : model.points3D) {
    std::map<point3D_t, int> votes;
    for (const TrackElement& element : point.track) {
      const point3D_t id = truth_point(element);
      if (id != kInvalidPoint3DId) ++votes[id];
    }
    point3D_t majority = kInvalidPoint3DId;
    int best = 0;
    for (const auto& [id, count] : votes) {
      if (count > best) {
        best = count;
        majority = id;
      }
    }
    ++result.num_points;
    result.num_observations += point.track.size();
    size_t wrong = 0;
    for (const TrackElement& element : point.track) {
      const point3D_t id = truth_point(element);
      if (id == kInvalidPoint3DId || id != majority) {
        ++wrong;
      } else {
        ++used_per_image[element.image_id];
      }
    }
    result.num_wrong += wrong;
    if (wrong > 0) ++result.num_points_with_wrong;
  }
  for (const auto& [image_id, image] : model.images) {
    const auto it = truth_by_name.find(image.name);
    if (it == truth_by_name.end()) continue;
    size_t num_truth = 0;
    for (const Point2D& point2D : it->second->points2D) {
      if (point2D.point3D_id != kInvalidPoint3DId) ++num_truth;
    }
    const size_t used = used_per_image[image_id];
    result.num_truth_missing += num_truth > used ? num_truth - used : 0;
  }
  return result;
}

size_t DeleteShortTracks(int min_track_length, Reconstruction* reconstruction) {
  std::vector<point3D_t> short_points;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    if (static_cast<int>(point.track.size()) < min_track_length) {
      short_points.push_back(point3D_id);
    }
  }
  for (const point3D_t point3D_id : short_points) {
    DeletePoint3D(point3D_id, reconstruction);
  }
  return short_points.size();
}

}  // namespace colmap_irav4
