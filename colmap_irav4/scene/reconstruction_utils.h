#pragma once

// Editing and measuring a Reconstruction while keeping points2D[].point3D_id
// and the points' tracks consistent with each other.

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// Adds a point (id = largest id + 1, or 1) and links its observations, which
// must exist and be free. Returns the id.
point3D_t AddPoint3D(const Eigen::Vector3d& xyz,
                     const std::vector<TrackElement>& track,
                     Reconstruction* reconstruction);
// Removes the point and unlinks its observations.
void DeletePoint3D(point3D_t point3D_id, Reconstruction* reconstruction);
// Unlinks one observation from its point and returns the point's id
// (kInvalidPoint3DId if the keypoint had none); the point stays, whatever
// its track's length.
point3D_t UnlinkObservation(image_t image_id, point2D_t point2D_idx,
                            Reconstruction* reconstruction);
// Unlinks one observation from its point; a point left with fewer than two
// observations is deleted. Returns whether the point was deleted.
bool DeleteObservation(image_t image_id, point2D_t point2D_idx,
                       Reconstruction* reconstruction);
// Unlinks every observation of the image and removes it from the model.
void DeleteImage(image_t image_id, Reconstruction* reconstruction);

// The first non-finite value of the model ("camera 1: parameter 0 is nan",
// "image 3 (a.jpg): translation is not finite", "point3D 7: position is not
// finite", ...); "" if every value is finite. No such model is written or
// read.
std::string NonFiniteValueProblem(const Reconstruction& reconstruction);
// Removes the 2D points with non-finite coordinates (keypoints the database
// held as NaN or inf; never observations) and renumbers the others in the
// tracks. Returns the number removed per image.
std::map<image_t, int> RemoveNonFinitePoints2D(Reconstruction* reconstruction);

// Reprojection error in pixels of `xyz` observed at `xy` in `image`;
// +infinity when the point is not in front of the camera.
double ReprojectionError(const Camera& camera, const Image& image,
                         const Eigen::Vector3d& xyz, const Eigen::Vector2d& xy);

// Sets every point's `error` (mean over its track) and returns the mean over
// all observations (0 without observations).
double UpdateReprojectionErrors(Reconstruction* reconstruction);
// Mean over the points with observations of their `error` (set by
// UpdateReprojectionErrors): COLMAP model_analyzer's mean reprojection error.
double MeanPointReprojectionError(const Reconstruction& reconstruction);
size_t NumObservations(const Reconstruction& reconstruction);

// The model's images numbered 0..n-1 in image id order, for graphs over them.
struct DenseImageIndex {
  explicit DenseImageIndex(const Reconstruction& reconstruction);
  std::vector<image_t> ids;      // number -> image id
  std::map<image_t, int> index;  // image id -> number
};
// Mean over points of the number of observations (0 without points).
double MeanTrackLength(const Reconstruction& reconstruction);

// The fraction of the n (n - 1) / 2 pairs of the n images observing the
// points of `tracks` that share at least one point (0 for fewer than two
// images; -1 beyond max_num_images, where the n^2 bits it takes would not
// be small).
double SchurDensity(const std::vector<const Track*>& tracks,
                    int max_num_images = 30000);

}  // namespace colmap_irav4
