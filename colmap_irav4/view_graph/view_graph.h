#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// One verified image pair of the epipolar graph, oriented image_id1 ->
// image_id2: R = cam2_from_cam1 = R_2 R_1^T, t = unit translation of
// cam2_from_cam1 (x2 = R x1 + t, up to scale).
struct ImagePairGeometry {
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int num_inliers = 0;
  int config = 0;  // COLMAP TwoViewGeometry::ConfigurationType
};

// The epipolar graph (view graph): images and the pairs kept after filtering.
struct ViewGraph {
  std::map<image_t, std::string> image_names;
  std::vector<ImagePairGeometry> pairs;
  // The cameras the relative poses were derived with (focal lengths possibly
  // self-calibrated); may be empty for graphs not built from a database.
  std::map<camera_t, Camera> cameras;
};

// The pairs with both images in `images`, in their order.
std::vector<ImagePairGeometry> PairsWithin(
    const std::vector<ImagePairGeometry>& pairs,
    const std::set<image_t>& images);

// Connected components of the images of `pairs` (util/union_find.h's
// ConnectedComponents), largest first (ties: the component with the
// smallest image id first); each sorted ascending.
std::vector<std::vector<image_t>> PairComponents(
    const std::vector<ImagePairGeometry>& pairs);

// The angle between the pair's measured relative rotation and the one the
// absolute rotations (cam_from_world) R1, R2 of its images predict,
// R_12 = R2 R1^T (deg).
double RelativeRotationErrorDeg(const ImagePairGeometry& pair,
                                const Eigen::Matrix3d& R1,
                                const Eigen::Matrix3d& R2);

}  // namespace colmap_irav4
