#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/track.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// Rigid transform x' = R x + t (COLMAP's cam_from_world when used for images).
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return rotation * x + translation;
  }
  Rigid3d Inverse() const {
    Rigid3d inverse;
    inverse.rotation = rotation.inverse();
    inverse.translation = -(inverse.rotation * translation);
    return inverse;
  }
};

struct Point2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  point3D_t point3D_id = kInvalidPoint3DId;
  // The keypoint's scale in pixels (0: unknown); not in COLMAP's model files.
  float scale = 0;
};

// A registered (or not) image of the model.
struct Image {
  image_t image_id = kInvalidImageId;
  std::string name;
  camera_t camera_id = kInvalidCameraId;
  Rigid3d cam_from_world;
  std::vector<Point2D> points2D;

  // Camera centre in world coordinates.
  Eigen::Vector3d ProjectionCenter() const {
    return cam_from_world.Inverse().translation;
  }
};

struct Point3D {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Matrix<uint8_t, 3, 1> color = Eigen::Matrix<uint8_t, 3, 1>::Zero();
  double error = -1.0;  // mean reprojection error in pixels, -1 if unknown
  std::vector<TrackElement> track;
};

// A sparse model as COLMAP writes it (cameras, images, points3D). Every image
// in `images` is registered; ordered maps keep output deterministic.
struct Reconstruction {
  std::map<camera_t, Camera> cameras;
  std::map<image_t, Image> images;
  std::map<point3D_t, Point3D> points3D;
};

}  // namespace colmap_irav4
