#pragma once

#include <vector>

#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// The observations whose reprojection error exceeds max_reproj_error (px;
// with `noise`, times the noise factor of the keypoint's scale: an empty one
// changes nothing) or whose point is behind the camera.
std::vector<TrackElement> FindObservationsWithLargeReprojectionError(
    double max_reproj_error, const Reconstruction& reconstruction,
    const KeypointScaleNoise* noise = nullptr);

// Unlinks the observations FindObservationsWithLargeReprojectionError finds;
// points left with fewer than two observations are deleted. Returns the
// number of observations removed.
size_t FilterObservationsWithLargeReprojectionError(
    double max_reproj_error, Reconstruction* reconstruction,
    const KeypointScaleNoise* noise = nullptr);

// Largest angle (rad) between the viewing rays of a point's observations.
double MaxTriangulationAngle(const Reconstruction& reconstruction,
                             const Point3D& point);

// Deletes points whose largest triangulation angle is below min_tri_angle_deg
// (their depth is unreliable). Returns the number of points deleted.
size_t FilterPointsWithSmallTriangulationAngle(double min_tri_angle_deg,
                                               Reconstruction* reconstruction);

struct FilterOptions {
  // Observations over this reprojection error (px) are removed (COLMAP's
  // filter_max_reproj_error).
  double max_reproj_error = 4.0;
  // Points seen under a smaller largest angle (deg) are removed (COLMAP's
  // filter_min_tri_angle).
  double min_tri_angle = 1.5;
  // Images left with fewer observations are deleted (unregistered). 1, as
  // COLMAP's FilterImages: an image no point is seen in has a pose nothing in
  // the model supports (in a global mapper: whatever rotation averaging and
  // positioning gave it, e.g. from a false pair whose matches the filters
  // removed since).
  int min_num_observations_per_image = 1;
  // Images whose camera has parameters no camera has are deleted
  // (unregistered) with their observations, as COLMAP's incremental mapper
  // filters images (its Mapper.min_focal_length_ratio, max_focal_length_ratio
  // and max_extra_param): a barely constrained camera whose intrinsics bundle
  // adjustment refines can drift to a focal length near zero or below it,
  // and its pose and points with it. Focal length over the larger image side:
  double min_focal_length_ratio = 0.1;
  double max_focal_length_ratio = 10.0;
  // Largest absolute value of an extra (distortion) parameter.
  double max_extra_param = 1.0;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct FilterSummary {
  size_t num_observations_filtered = 0;
  size_t num_points_filtered = 0;  // by triangulation angle
  size_t num_images_filtered = 0;
  std::vector<image_t> filtered_images;  // the deleted ones, in id order
  // Images deleted first, as their camera has bogus parameters (not counted
  // above), in id order, and the observations deleted with them.
  std::vector<image_t> bogus_camera_images;
  size_t num_bogus_camera_observations = 0;
};

// The images whose camera has bogus parameters (CameraHasBogusParams with the
// options' limits), in id order.
std::vector<image_t> FindImagesWithBogusCameras(
    const FilterOptions& options, const Reconstruction& reconstruction);

// Deletes the images FindImagesWithBogusCameras finds, then filters
// observations by reprojection error, points by triangulation angle and
// images by their observations left. `noise` (optional) scales the
// reprojection threshold per keypoint, as in
// FindObservationsWithLargeReprojectionError.
FilterSummary RunFiltering(const FilterOptions& options,
                           Reconstruction* reconstruction,
                           const KeypointScaleNoise* noise = nullptr);

// Applies x' = scale * R x + t to the whole model (points and poses; the
// images are unchanged).
void TransformReconstruction(const Sim3d& new_from_old,
                             Reconstruction* reconstruction);

struct NormalizationOptions {
  // Extent of the central part of the model after normalisation.
  double extent = 10.0;
  // The central part: between these percentiles of the coordinates, per axis
  // (COLMAP's Normalize uses 0.1 and 0.9).
  double min_percentile = 0.1;
  double max_percentile = 0.9;
  // Measure on camera centres (else on points).
  bool use_images = true;

  // Throws InputError naming the offending option.
  void Check() const;
};

// Translates the model so that the median of the camera centres (or points)
// is the origin and scales it so that the largest per-axis spread between
// the percentiles is `extent`. Returns the transform applied (identity if the
// model is empty or degenerate).
Sim3d NormalizeReconstruction(const NormalizationOptions& options,
                              Reconstruction* reconstruction);

}  // namespace colmap_irav4
