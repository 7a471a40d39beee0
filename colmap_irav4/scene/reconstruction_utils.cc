#include "colmap_irav4/scene/reconstruction_utils.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include <glog/logging.h>

#include "colmap_irav4/scene/camera_models.h"

namespace colmap_irav4 {

point3D_t AddPoint3D(const Eigen::Vector3d& xyz,
                     const std::vector<TrackElement>& track,
                     Reconstruction* reconstruction) {
  const point3D_t point3D_id =
      reconstruction->points3D.empty()
          ? 1
          : reconstruction->points3D.rbegin()->first + 1;
  Point3D& point = reconstruction->points3D[point3D_id];
  point.xyz = xyz;
  point.track = track;
  for (const TrackElement& element : track) {
    Image& image = reconstruction->images.at(element.image_id);
    CHECK_LT(element.point2D_idx, image.points2D.size());
    Point2D& point2D = image.points2D[element.point2D_idx];
    CHECK_EQ(point2D.point3D_id, kInvalidPoint3DId)
        << "observation already belongs to a point";
    point2D.point3D_id = point3D_id;
  }
  return point3D_id;
}

void DeletePoint3D(point3D_t point3D_id, Reconstruction* reconstruction) {
  auto it = reconstruction->points3D.find(point3D_id);
  if (it == reconstruction->points3D.end()) return;
  for (const TrackElement& element : it->second.track) {
    auto image_it = reconstruction->images.find(element.image_id);
    if (image_it == reconstruction->images.end()) continue;
    Point2D& point2D = image_it->second.points2D.at(element.point2D_idx);
    if (point2D.point3D_id == point3D_id)
      point2D.point3D_id = kInvalidPoint3DId;
  }
  reconstruction->points3D.erase(it);
}

point3D_t UnlinkObservation(image_t image_id, point2D_t point2D_idx,
                            Reconstruction* reconstruction) {
  Point2D& point2D =
      reconstruction->images.at(image_id).points2D.at(point2D_idx);
  const point3D_t point3D_id = point2D.point3D_id;
  if (point3D_id == kInvalidPoint3DId) return kInvalidPoint3DId;
  point2D.point3D_id = kInvalidPoint3DId;
  auto& track = reconstruction->points3D.at(point3D_id).track;
  for (auto it = track.begin(); it != track.end(); ++it) {
    if (it->image_id == image_id && it->point2D_idx == point2D_idx) {
      track.erase(it);
      break;
    }
  }
  return point3D_id;
}

bool DeleteObservation(image_t image_id, point2D_t point2D_idx,
                       Reconstruction* reconstruction) {
  const point3D_t point3D_id =
      UnlinkObservation(image_id, point2D_idx, reconstruction);
  if (point3D_id == kInvalidPoint3DId) return false;
  if (reconstruction->points3D.at(point3D_id).track.size() < 2) {
    DeletePoint3D(point3D_id, reconstruction);
    return true;
  }
  return false;
}

void DeleteImage(image_t image_id, Reconstruction* reconstruction) {
  auto it = reconstruction->images.find(image_id);
  if (it == reconstruction->images.end()) return;
  for (point2D_t idx = 0; idx < it->second.points2D.size(); ++idx) {
    DeleteObservation(image_id, idx, reconstruction);
  }
  reconstruction->images.erase(it);
}

std::string NonFiniteValueProblem(const Reconstruction& reconstruction) {
  for (const auto& [camera_id, camera] : reconstruction.cameras) {
    for (size_t k = 0; k < camera.params.size(); ++k) {
      if (!std::isfinite(camera.params[k])) {
        return "camera " + std::to_string(camera_id) + ": parameter " +
               std::to_string(k) + " is not finite (" +
               std::to_string(camera.params[k]) + ")";
      }
    }
  }
  for (const auto& [image_id, image] : reconstruction.images) {
    const std::string what =
        "image " + std::to_string(image_id) + " (" + image.name + "): ";
    if (!image.cam_from_world.rotation.coeffs().allFinite()) {
      return what + "rotation is not finite";
    }
    if (!image.cam_from_world.translation.allFinite()) {
      return what + "translation is not finite";
    }
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      if (!image.points2D[k].xy.allFinite()) {
        return what + "point2D " + std::to_string(k) + " is not finite";
      }
    }
  }
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    if (!point.xyz.allFinite()) {
      return "point3D " + std::to_string(point3D_id) +
             ": position is not finite";
    }
    if (std::isnan(point.error)) {
      return "point3D " + std::to_string(point3D_id) +
             ": error is not finite (nan)";
    }
  }
  return "";
}

std::map<image_t, int> RemoveNonFinitePoints2D(Reconstruction* reconstruction) {
  std::map<image_t, int> removed;
  for (auto& [image_id, image] : reconstruction->images) {
    std::vector<point2D_t> new_index(image.points2D.size());
    std::vector<Point2D> kept;
    kept.reserve(image.points2D.size());
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      new_index[k] = static_cast<point2D_t>(kept.size());
      if (image.points2D[k].xy.allFinite()) {
        kept.push_back(image.points2D[k]);
        continue;
      }
      // Never an observation (the database reader excludes them); unlinked
      // all the same should that change.
      UnlinkObservation(image_id, static_cast<point2D_t>(k), reconstruction);
      ++removed[image_id];
    }
    if (removed.count(image_id) == 0) continue;
    image.points2D = std::move(kept);
    for (auto& [point3D_id, point] : reconstruction->points3D) {
      for (TrackElement& element : point.track) {
        if (element.image_id == image_id) {
          element.point2D_idx = new_index[element.point2D_idx];
        }
      }
    }
  }
  return removed;
}

double ReprojectionError(const Camera& camera, const Image& image,
                         const Eigen::Vector3d& xyz,
                         const Eigen::Vector2d& xy) {
  const Eigen::Vector3d in_cam = image.cam_from_world * xyz;
  if (in_cam.z() <= std::numeric_limits<double>::epsilon()) {
    return std::numeric_limits<double>::infinity();
  }
  const Eigen::Vector2d projected =
      CameraCameraToImage(camera, in_cam.hnormalized());
  return (projected - xy).norm();
}

double MeanPointReprojectionError(const Reconstruction& reconstruction) {
  double sum = 0.0;
  size_t count = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    if (point.track.empty()) continue;
    sum += point.error;
    ++count;
  }
  return count == 0 ? 0.0 : sum / count;
}

double UpdateReprojectionErrors(Reconstruction* reconstruction) {
  double sum = 0.0;
  size_t count = 0;
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    double point_sum = 0.0;
    for (const TrackElement& element : point.track) {
      const Image& image = reconstruction->images.at(element.image_id);
      const Camera& camera = reconstruction->cameras.at(image.camera_id);
      point_sum += ReprojectionError(camera, image, point.xyz,
                                     image.points2D[element.point2D_idx].xy);
    }
    point.error = point.track.empty() ? -1.0 : point_sum / point.track.size();
    sum += point_sum;
    count += point.track.size();
  }
  return count == 0 ? 0.0 : sum / count;
}

size_t NumObservations(const Reconstruction& reconstruction) {
  size_t count = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    count += point.track.size();
  }
  return count;
}

DenseImageIndex::DenseImageIndex(const Reconstruction& reconstruction) {
  ids.reserve(reconstruction.images.size());
  for (const auto& [image_id, image] : reconstruction.images) {
    index[image_id] = static_cast<int>(ids.size());
    ids.push_back(image_id);
  }
}

double MeanTrackLength(const Reconstruction& reconstruction) {
  if (reconstruction.points3D.empty()) return 0.0;
  return static_cast<double>(NumObservations(reconstruction)) /
         reconstruction.points3D.size();
}

double SchurDensity(const std::vector<const Track*>& tracks,
                    int max_num_images) {
  std::unordered_map<image_t, size_t> index;
  for (const Track* track : tracks) {
    for (const TrackElement& element : *track) {
      index.emplace(element.image_id, index.size());
    }
  }
  const size_t n = index.size();
  if (n < 2) return 0;
  if (n > static_cast<size_t>(max_num_images)) return -1;
  std::vector<bool> shared(n * n, false);
  size_t num_shared = 0;
  std::vector<size_t> images;
  for (const Track* track : tracks) {
    images.clear();
    for (const TrackElement& element : *track) {
      images.push_back(index.at(element.image_id));
    }
    for (size_t a = 0; a < images.size(); ++a) {
      for (size_t b = a + 1; b < images.size(); ++b) {
        const size_t i = std::min(images[a], images[b]);
        const size_t j = std::max(images[a], images[b]);
        if (i == j || shared[i * n + j]) continue;
        shared[i * n + j] = true;
        ++num_shared;
      }
    }
  }
  return static_cast<double>(num_shared) / (n * (n - 1) / 2.0);
}

}  // namespace colmap_irav4
