#include "colmap_irav4/refinement/point_merging.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glog/logging.h>
#include <Eigen/Dense>

#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// The observed keypoints of one image bucketed by a square grid of the
// search radius: those near a position are in its cell and the 8 around.
class KeypointGrid {
 public:
  KeypointGrid(const Image& image, double cell_size) : cell_size_(cell_size) {
    for (point2D_t idx = 0; idx < image.points2D.size(); ++idx) {
      const Point2D& point2D = image.points2D[idx];
      if (point2D.point3D_id == kInvalidPoint3DId) continue;
      cells_[Key(Cell(point2D.xy.x()), Cell(point2D.xy.y()))].push_back(idx);
    }
  }

  // Calls visit(idx) for the keypoints of the 3x3 cells around xy.
  template <typename Visit>
  void ForNear(const Eigen::Vector2d& xy, const Visit& visit) const {
    const int64_t cx = Cell(xy.x()), cy = Cell(xy.y());
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(Key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (const point2D_t idx : it->second) visit(idx);
      }
    }
  }

 private:
  int64_t Cell(double v) const {
    return static_cast<int64_t>(std::floor(v / cell_size_));
  }
  static uint64_t Key(int64_t cx, int64_t cy) {
    // Image coordinates are far below 2^31 cells either way.
    return (static_cast<uint64_t>(cx + (int64_t{1} << 31)) << 32) ^
           static_cast<uint64_t>(cy + (int64_t{1} << 31));
  }

  double cell_size_;
  std::unordered_map<uint64_t, std::vector<point2D_t>> cells_;
};

// RefinePointPosition over `track` (residuals scaled by each camera's mean
// focal length).
void RefinePosition(const Reconstruction& reconstruction,
                    const std::vector<TrackElement>& track,
                    Eigen::Vector3d* xyz) {
  std::vector<NormalizedObservation> observations;
  observations.reserve(track.size());
  for (const TrackElement& element : track) {
    const Image& image = reconstruction.images.at(element.image_id);
    const Camera& camera = reconstruction.cameras.at(image.camera_id);
    const Eigen::Vector2d normalized =
        CameraImageToCamera(camera, image.points2D.at(element.point2D_idx).xy);
    if (!normalized.allFinite()) return;
    observations.push_back({image.cam_from_world.rotation.toRotationMatrix(),
                            image.cam_from_world.translation, normalized,
                            CameraMeanFocalLength(camera)});
  }
  RefinePointPosition(observations, xyz);
}

bool SharesImage(const Point3D& a, const Point3D& b) {
  for (const TrackElement& ea : a.track) {
    for (const TrackElement& eb : b.track) {
      if (ea.image_id == eb.image_id) return true;
    }
  }
  return false;
}

}  // namespace

void PointMergingOptions::Check() const {
  if (!(search_radius > 0)) {
    throw OptionError(&search_radius, "PointMerging.search_radius",
                      "must be positive");
  }
  if (!(max_reproj_error > 0)) {
    throw OptionError(&max_reproj_error, "PointMerging.max_reproj_error",
                      "must be positive");
  }
  if (!(max_cost_increase >= 0)) {
    throw OptionError(&max_cost_increase, "PointMerging.max_cost_increase",
                      "must be >= 0");
  }
  if (max_passes < 1) {
    throw OptionError(&max_passes, "PointMerging.max_passes",
                      "must be at least 1");
  }
}

PointMergingSummary MergePoints(const PointMergingOptions& options,
                                Reconstruction* reconstruction,
                                const KeypointScaleNoise* noise) {
  options.Check();
  PointMergingSummary summary;
  const DenseImageIndex index(*reconstruction);
  const int num_images = static_cast<int>(index.ids.size());
  std::vector<Image*> images(num_images);
  std::vector<const Camera*> cameras(num_images);
  for (int i = 0; i < num_images; ++i) {
    images[i] = &reconstruction->images.at(index.ids[i]);
    cameras[i] = &reconstruction->cameras.at(images[i]->camera_id);
  }
  // The images sharing a point with each image (fixed: merging only joins
  // images already linked through the merged points' neighbours).
  std::vector<std::vector<int>> neighbors(num_images);
  {
    std::vector<int> stamp(num_images, -1);
    for (int i = 0; i < num_images; ++i) {
      stamp[i] = i;
      for (const Point2D& point2D : images[i]->points2D) {
        if (point2D.point3D_id == kInvalidPoint3DId) continue;
        for (const TrackElement& element :
             reconstruction->points3D.at(point2D.point3D_id).track) {
          const int j = index.index.at(element.image_id);
          if (stamp[j] == i) continue;
          stamp[j] = i;
          neighbors[i].push_back(j);
        }
      }
      std::sort(neighbors[i].begin(), neighbors[i].end());
    }
  }
  std::vector<KeypointGrid> grids;
  grids.reserve(num_images);
  for (int i = 0; i < num_images; ++i) {
    grids.emplace_back(*images[i], options.search_radius);
  }
  const auto factor = [&](const Point2D& point2D) {
    return noise == nullptr ? 1.0 : noise->Factor(point2D.scale);
  };
  // Squared reprojection error in noise units (infinite behind a camera).
  const auto squared_error = [&](const TrackElement& element,
                                 const Eigen::Vector3d& xyz) {
    const Image& image = reconstruction->images.at(element.image_id);
    const Point2D& point2D = image.points2D[element.point2D_idx];
    const double error =
        ReprojectionError(reconstruction->cameras.at(image.camera_id), image,
                          xyz, point2D.xy) /
        factor(point2D);
    return error * error;
  };
  const auto cost = [&](const std::vector<TrackElement>& track,
                        const Eigen::Vector3d& xyz) {
    double sum = 0;
    for (const TrackElement& element : track) {
      sum += squared_error(element, xyz);
    }
    return sum;
  };
  // Per-coordinate noise variance, robustly: the median squared
  // reprojection error over the median of a chi-square with 2 degrees of
  // freedom (2 ln 2), times the observations per residual degree of
  // freedom (2 per observation, 3 per point): the outliers a filter has not
  // removed yet do not inflate it.
  double variance = 0;
  {
    std::vector<double> squared;
    size_t num_points = 0;
    for (const auto& [point3D_id, point] : reconstruction->points3D) {
      ++num_points;
      for (const TrackElement& element : point.track) {
        squared.push_back(squared_error(element, point.xyz));
      }
    }
    const double dof = 2.0 * static_cast<double>(squared.size()) -
                       3.0 * static_cast<double>(num_points);
    if (dof > 0) {
      auto middle = squared.begin() + squared.size() / 2;
      std::nth_element(squared.begin(), middle, squared.end());
      variance = *middle / (2.0 * std::log(2.0)) * 2.0 *
                 static_cast<double>(squared.size()) / dof;
    }
  }
  summary.noise_variance = variance;

  // Tries to merge `other` into `point3D_id`; true if done.
  const auto try_merge = [&](point3D_t point3D_id, point3D_t other_id) {
    Point3D& point = reconstruction->points3D.at(point3D_id);
    const Point3D& other = reconstruction->points3D.at(other_id);
    if (SharesImage(point, other)) return false;
    ++summary.num_candidates;
    std::vector<TrackElement> track = point.track;
    track.insert(track.end(), other.track.begin(), other.track.end());
    const double w = static_cast<double>(point.track.size());
    const double w_other = static_cast<double>(other.track.size());
    Eigen::Vector3d xyz = (w * point.xyz + w_other * other.xyz) / (w + w_other);
    RefinePosition(*reconstruction, track, &xyz);
    double joint_cost = 0;
    for (const TrackElement& element : track) {
      const double squared = squared_error(element, xyz);
      if (!(squared <= options.max_reproj_error * options.max_reproj_error)) {
        return false;
      }
      joint_cost += squared;
    }
    if (options.max_cost_increase > 0 && variance > 0) {
      Eigen::Vector3d own = point.xyz, other_own = other.xyz;
      RefinePosition(*reconstruction, point.track, &own);
      RefinePosition(*reconstruction, other.track, &other_own);
      const double increase =
          joint_cost - cost(point.track, own) - cost(other.track, other_own);
      if (!(increase <= options.max_cost_increase * variance)) return false;
    }
    for (const TrackElement& element : other.track) {
      reconstruction->images.at(element.image_id)
          .points2D[element.point2D_idx]
          .point3D_id = point3D_id;
    }
    summary.num_observations_moved += other.track.size();
    point.track = std::move(track);
    point.xyz = xyz;
    reconstruction->points3D.erase(other_id);
    ++summary.num_merges;
    return true;
  };

  std::vector<point3D_t> to_visit;
  to_visit.reserve(reconstruction->points3D.size());
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    to_visit.push_back(point3D_id);
  }
  std::vector<int> stamp(num_images, -1);
  int stamp_value = 0;
  std::vector<int> candidate_images;
  std::vector<std::pair<double, point3D_t>> candidates;
  std::vector<point3D_t> tried;
  for (int pass = 0; pass < options.max_passes && !to_visit.empty(); ++pass) {
    std::vector<point3D_t> grown;
    for (const point3D_t point3D_id : to_visit) {
      bool merged_any = false;
      // A merge adds images: search again from the merged point.
      for (bool merged = true; merged;) {
        merged = false;
        const auto point_it = reconstruction->points3D.find(point3D_id);
        if (point_it == reconstruction->points3D.end()) break;
        const Point3D& point = point_it->second;
        ++stamp_value;
        for (const TrackElement& element : point.track) {
          stamp[index.index.at(element.image_id)] = stamp_value;
        }
        candidate_images.clear();
        for (const TrackElement& element : point.track) {
          for (const int j : neighbors[index.index.at(element.image_id)]) {
            if (stamp[j] == stamp_value) continue;
            stamp[j] = stamp_value;
            candidate_images.push_back(j);
          }
        }
        std::sort(candidate_images.begin(), candidate_images.end());
        candidates.clear();
        for (const int j : candidate_images) {
          const Image& image = *images[j];
          const Camera& camera = *cameras[j];
          const Eigen::Vector3d in_cam = image.cam_from_world * point.xyz;
          if (in_cam.z() <= 0) continue;
          const Eigen::Vector2d xy =
              CameraCameraToImage(camera, in_cam.hnormalized());
          if (!xy.allFinite() || xy.x() < -options.search_radius ||
              xy.y() < -options.search_radius ||
              xy.x() >
                  static_cast<double>(camera.width) + options.search_radius ||
              xy.y() >
                  static_cast<double>(camera.height) + options.search_radius) {
            continue;
          }
          grids[j].ForNear(xy, [&](point2D_t idx) {
            const Point2D& point2D = image.points2D[idx];
            if (point2D.point3D_id == kInvalidPoint3DId ||
                point2D.point3D_id == point3D_id) {
              return;
            }
            const double distance = (point2D.xy - xy).norm();
            if (distance <= options.search_radius) {
              candidates.emplace_back(distance, point2D.point3D_id);
            }
          });
        }
        std::sort(candidates.begin(), candidates.end());
        tried.clear();
        for (const auto& [distance, other_id] : candidates) {
          if (!reconstruction->points3D.count(other_id)) continue;
          if (std::find(tried.begin(), tried.end(), other_id) != tried.end()) {
            continue;
          }
          tried.push_back(other_id);
          if (try_merge(point3D_id, other_id)) {
            merged = true;
            merged_any = true;
            break;
          }
        }
      }
      if (merged_any) grown.push_back(point3D_id);
    }
    to_visit = std::move(grown);
  }
  VLOG(1) << "Point merging: " << summary.num_merges << " points merged ("
          << summary.num_observations_moved << " observations) of "
          << summary.num_candidates << " candidates";
  return summary;
}

}  // namespace colmap_irav4
