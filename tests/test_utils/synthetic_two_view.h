#pragma once

// A synthetic verified image pair with known relative pose, for tests.

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <Eigen/Dense>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {
namespace test {

struct SyntheticPair {
  Camera camera1, camera2;
  Eigen::Matrix3d R;  // cam2_from_cam1
  Eigen::Vector3d t;  // unit (zero for a pure rotation)
  FeatureKeypoints keypoints1, keypoints2;
  TwoViewGeometry geometry;  // image ids 1 -> 2, inlier matches, E, F, H
};

inline Camera MakeCamera(int model_id, camera_t camera_id = 1) {
  Camera camera;
  camera.camera_id = camera_id;
  camera.model_id = model_id;
  camera.width = 1600;
  camera.height = 1200;
  const std::string name = CameraModelIdToName(model_id);
  if (name == "PINHOLE") {
    camera.params = {1500, 1520, 800, 600};
  } else if (name == "SIMPLE_PINHOLE") {
    camera.params = {1500, 800, 600};
  } else if (name == "SIMPLE_RADIAL") {
    camera.params = {1500, 800, 600, -0.05};
  } else if (name == "OPENCV") {
    camera.params = {1500, 1520, 800, 600, -0.1, 0.02, 0.001, -0.001};
  } else if (name == "OPENCV_FISHEYE") {
    camera.params = {600, 610, 800, 600, 0.01, 0.03, -0.03, 0.005};
  } else {
    ADD_FAILURE() << "no test parameters for " << name;
  }
  return camera;
}

// Points in a box in front of camera 1 (or on a plane when planar), seen by
// both cameras; pixel noise of noise_px (Gaussian) on the keypoints.
inline SyntheticPair MakeSyntheticPair(const Camera& camera1,
                                       const Camera& camera2,
                                       const Eigen::Matrix3d& R,
                                       const Eigen::Vector3d& translation,
                                       int num_points, double noise_px,
                                       bool planar, std::mt19937_64* rng) {
  SyntheticPair pair;
  pair.camera1 = camera1;
  pair.camera2 = camera2;
  pair.R = R;
  pair.t = translation.norm() > 0 ? Eigen::Vector3d(translation.normalized())
                                  : Eigen::Vector3d::Zero();
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::normal_distribution<double> noise(0, noise_px);
  // Plane n^T X = 1 in camera 1 (depth ~ 5).
  const Eigen::Vector3d n = Eigen::Vector3d(0.05, -0.1, 1).normalized() / 5.0;
  while (static_cast<int>(pair.keypoints1.size()) < num_points) {
    Eigen::Vector3d X = RandomVector<3>(uniform, *rng)
                            .cwiseProduct(Eigen::Vector3d(2, 1.5, 2)) +
                        Eigen::Vector3d(0, 0, 5);
    if (planar) X *= 1.0 / n.dot(X);
    const Eigen::Vector3d X2 = R * X + translation;
    if (X.z() < 0.5 || X2.z() < 0.5) continue;
    Eigen::Vector2d x1 = CameraCameraToImage(camera1, X.hnormalized());
    Eigen::Vector2d x2 = CameraCameraToImage(camera2, X2.hnormalized());
    if (x1.x() < 0 || x1.y() < 0 || x1.x() > camera1.width ||
        x1.y() > camera1.height || x2.x() < 0 || x2.y() < 0 ||
        x2.x() > camera2.width || x2.y() > camera2.height) {
      continue;
    }
    if (noise_px > 0) {
      x1 += RandomVector<2>(noise, *rng);
      x2 += RandomVector<2>(noise, *rng);
    }
    pair.keypoints1.push_back(x1.cast<float>());
    pair.keypoints2.push_back(x2.cast<float>());
  }
  // Matches in shuffled keypoint order, to test the indexing.
  std::vector<point2D_t> order2(num_points);
  for (int i = 0; i < num_points; ++i) order2[i] = i;
  std::shuffle(order2.begin(), order2.end(), *rng);
  FeatureKeypoints shuffled(num_points);
  for (int i = 0; i < num_points; ++i) shuffled[order2[i]] = pair.keypoints2[i];
  pair.keypoints2 = shuffled;
  TwoViewGeometry& geometry = pair.geometry;
  geometry.image_id1 = 1;
  geometry.image_id2 = 2;
  for (int i = 0; i < num_points; ++i) {
    geometry.inlier_matches.push_back({static_cast<point2D_t>(i), order2[i]});
  }
  const Eigen::Matrix3d K1 = CameraCalibrationMatrix(camera1);
  const Eigen::Matrix3d K2 = CameraCalibrationMatrix(camera2);
  geometry.E = EssentialFromPose(R, translation);
  geometry.F = K2.inverse().transpose() * geometry.E * K1.inverse();
  geometry.H = K2 * (R + translation * n.transpose()) * K1.inverse();
  geometry.config = TwoViewGeometry::CALIBRATED;
  return pair;
}

}  // namespace test
}  // namespace colmap_irav4
