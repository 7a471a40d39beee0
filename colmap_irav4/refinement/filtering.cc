#include "colmap_irav4/refinement/filtering.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

std::vector<TrackElement> FindObservationsWithLargeReprojectionError(
    double max_reproj_error, const Reconstruction& reconstruction,
    const KeypointScaleNoise* noise) {
  std::vector<TrackElement> outliers;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    for (const TrackElement& element : point.track) {
      const Image& image = reconstruction.images.at(element.image_id);
      const Camera& camera = reconstruction.cameras.at(image.camera_id);
      const Point2D& point2D = image.points2D[element.point2D_idx];
      const double error =
          ReprojectionError(camera, image, point.xyz, point2D.xy);
      const double threshold =
          noise == nullptr ? max_reproj_error
                           : max_reproj_error * noise->Factor(point2D.scale);
      if (!(error <= threshold)) outliers.push_back(element);
    }
  }
  return outliers;
}

size_t FilterObservationsWithLargeReprojectionError(
    double max_reproj_error, Reconstruction* reconstruction,
    const KeypointScaleNoise* noise) {
  const std::vector<TrackElement> outliers =
      FindObservationsWithLargeReprojectionError(max_reproj_error,
                                                 *reconstruction, noise);
  for (const TrackElement& element : outliers) {
    DeleteObservation(element.image_id, element.point2D_idx, reconstruction);
  }
  return outliers.size();
}

double MaxTriangulationAngle(const Reconstruction& reconstruction,
                             const Point3D& point) {
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(point.track.size());
  for (const TrackElement& element : point.track) {
    const Eigen::Vector3d ray =
        point.xyz -
        reconstruction.images.at(element.image_id).ProjectionCenter();
    const double norm = ray.norm();
    if (norm > 0) rays.push_back(ray / norm);
  }
  // The smallest cosine over pairs is the largest angle.
  double min_cos = 1.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    for (size_t j = i + 1; j < rays.size(); ++j) {
      min_cos = std::min(min_cos, rays[i].dot(rays[j]));
    }
  }
  return std::acos(std::clamp(min_cos, -1.0, 1.0));
}

size_t FilterPointsWithSmallTriangulationAngle(double min_tri_angle_deg,
                                               Reconstruction* reconstruction) {
  const double min_angle = DegToRad(min_tri_angle_deg);
  std::vector<point3D_t> filtered;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    if (MaxTriangulationAngle(*reconstruction, point) < min_angle) {
      filtered.push_back(point3D_id);
    }
  }
  for (point3D_t point3D_id : filtered)
    DeletePoint3D(point3D_id, reconstruction);
  return filtered.size();
}

void FilterOptions::Check() const {
  if (!(max_reproj_error > 0)) {
    throw OptionError(&max_reproj_error, "Filter.max_reproj_error",
                      "must be positive");
  }
  if (!(min_tri_angle >= 0 && min_tri_angle < 180)) {
    throw OptionError(&min_tri_angle, "Filter.min_tri_angle",
                      "must be in [0, 180)");
  }
  if (min_num_observations_per_image < 0) {
    throw OptionError(&min_num_observations_per_image,
                      "FilterOptions::min_num_observations_per_image",
                      "must be >= 0");
  }
  if (!(min_focal_length_ratio >= 0)) {
    throw OptionError(&min_focal_length_ratio, "Mapper.min_focal_length_ratio",
                      "must be >= 0");
  }
  if (!(max_focal_length_ratio > min_focal_length_ratio)) {
    throw OptionError(&max_focal_length_ratio, "Mapper.max_focal_length_ratio",
                      "must be larger than --Mapper.min_focal_length_ratio");
  }
  if (!(max_extra_param >= 0)) {
    throw OptionError(&max_extra_param, "Mapper.max_extra_param",
                      "must be >= 0");
  }
}

std::vector<image_t> FindImagesWithBogusCameras(
    const FilterOptions& options, const Reconstruction& reconstruction) {
  std::vector<image_t> image_ids;
  for (const auto& [image_id, image] : reconstruction.images) {
    if (CameraHasBogusParams(reconstruction.cameras.at(image.camera_id),
                             options.min_focal_length_ratio,
                             options.max_focal_length_ratio,
                             options.max_extra_param)) {
      image_ids.push_back(image_id);
    }
  }
  return image_ids;
}

FilterSummary RunFiltering(const FilterOptions& options,
                           Reconstruction* reconstruction,
                           const KeypointScaleNoise* noise) {
  options.Check();
  FilterSummary summary;
  summary.bogus_camera_images =
      FindImagesWithBogusCameras(options, *reconstruction);
  for (const image_t image_id : summary.bogus_camera_images) {
    for (const Point2D& point2D :
         reconstruction->images.at(image_id).points2D) {
      summary.num_bogus_camera_observations +=
          point2D.point3D_id != kInvalidPoint3DId;
    }
    DeleteImage(image_id, reconstruction);
  }
  summary.num_observations_filtered =
      FilterObservationsWithLargeReprojectionError(options.max_reproj_error,
                                                   reconstruction, noise);
  summary.num_points_filtered = FilterPointsWithSmallTriangulationAngle(
      options.min_tri_angle, reconstruction);
  if (options.min_num_observations_per_image > 0) {
    std::vector<image_t> filtered;
    for (const auto& [image_id, image] : reconstruction->images) {
      int num_observations = 0;
      for (const Point2D& point2D : image.points2D) {
        num_observations += point2D.point3D_id != kInvalidPoint3DId;
      }
      if (num_observations < options.min_num_observations_per_image) {
        filtered.push_back(image_id);
      }
    }
    for (image_t image_id : filtered) DeleteImage(image_id, reconstruction);
    summary.num_images_filtered = filtered.size();
    summary.filtered_images = std::move(filtered);
  }
  return summary;
}

void TransformReconstruction(const Sim3d& new_from_old,
                             Reconstruction* reconstruction) {
  const Eigen::Quaterniond R(new_from_old.R);
  for (auto& [image_id, image] : reconstruction->images) {
    // x_cam' = scale * x_cam: same projections.
    const Eigen::Quaterniond rotation =
        image.cam_from_world.rotation * R.inverse();
    image.cam_from_world.translation =
        new_from_old.scale * image.cam_from_world.translation -
        rotation * new_from_old.t;
    image.cam_from_world.rotation = rotation.normalized();
  }
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    point.xyz = new_from_old * point.xyz;
  }
}

void NormalizationOptions::Check() const {
  if (!(extent > 0 && std::isfinite(extent)))
    throw OptionError(&extent, "Normalization.extent",
                      "must be positive and finite");
  if (!(min_percentile >= 0 && min_percentile < max_percentile &&
        max_percentile <= 1)) {
    throw OptionError(&min_percentile, "NormalizationOptions::min_percentile",
                      "need 0 <= min_percentile < max_percentile <= 1");
  }
}

Sim3d NormalizeReconstruction(const NormalizationOptions& options,
                              Reconstruction* reconstruction) {
  options.Check();
  std::vector<Eigen::Vector3d> locations;
  if (options.use_images) {
    for (const auto& [image_id, image] : reconstruction->images) {
      locations.push_back(image.ProjectionCenter());
    }
  } else {
    for (const auto& [point3D_id, point] : reconstruction->points3D) {
      locations.push_back(point.xyz);
    }
  }
  Sim3d transform;
  if (locations.empty()) return transform;
  Eigen::Vector3d median;
  double spread = 0;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    values.reserve(locations.size());
    for (const auto& location : locations) values.push_back(location[axis]);
    std::sort(values.begin(), values.end());
    const auto at = [&values](double fraction) {
      return values[static_cast<size_t>(
          std::round(fraction * (values.size() - 1)))];
    };
    median[axis] = at(0.5);
    spread = std::max(spread,
                      at(options.max_percentile) - at(options.min_percentile));
  }
  transform.scale = spread > 1e-12 ? options.extent / spread : 1.0;
  transform.t = -transform.scale * median;
  TransformReconstruction(transform, reconstruction);
  return transform;
}

}  // namespace colmap_irav4
