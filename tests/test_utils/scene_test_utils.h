#pragma once

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {
namespace test {

// Poses rotated by ~angle_deg, centres moved by ~center_noise, points moved
// by ~point_noise, focal lengths scaled by focal_factor.
inline void PerturbModel(double angle_deg, double center_noise,
                         double point_noise, double focal_factor, uint64_t seed,
                         Reconstruction* reconstruction) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (auto& [image_id, image] : reconstruction->images) {
    const Eigen::Vector3d center =
        image.ProjectionCenter() + center_noise * RandomVector<3>(normal, rng);
    image.cam_from_world.rotation =
        Eigen::Quaterniond(RandomRotationWithAngle(DegToRad(angle_deg), &rng)) *
        image.cam_from_world.rotation;
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    point.xyz += point_noise * RandomVector<3>(normal, rng);
  }
  for (auto& [camera_id, camera] : reconstruction->cameras) {
    for (int idx : CameraModelFocalLengthIdxs(camera.model_id))
      camera.params[idx] *= focal_factor;
  }
}

// Largest distance between the estimated camera centres, aligned onto the
// true ones by a least-squares similarity, and the true centres, relative to
// the scene radius.
inline double MaxRelativeCenterError(const Reconstruction& estimate,
                                     const Reconstruction& truth,
                                     double scene_radius) {
  std::vector<Eigen::Vector3d> src, dst;
  for (const auto& [image_id, image] : estimate.images) {
    src.push_back(image.ProjectionCenter());
    dst.push_back(truth.images.at(image_id).ProjectionCenter());
  }
  Sim3d sim;
  EXPECT_TRUE(EstimateSimilarity(src, dst, &sim));
  double max_error = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    max_error = std::max(max_error, (sim * src[i] - dst[i]).norm());
  }
  return max_error / scene_radius;
}

// Largest distance between the estimated and the true camera centres, as
// they are (no alignment: a model placed by pose priors in the truth's
// frame).
inline double MaxUnalignedCenterError(const Reconstruction& estimate,
                                      const Reconstruction& truth) {
  double max_error = 0;
  for (const auto& [image_id, image] : estimate.images) {
    max_error =
        std::max(max_error, (image.ProjectionCenter() -
                             truth.images.at(image_id).ProjectionCenter())
                                .norm());
  }
  return max_error;
}

// A copy of `model` whose cameras, images and points are allocated in
// reverse id order, so laid out on the heap unlike the original: a solve must
// give the same bits on both (Ceres orders blocks by address).
inline Reconstruction CopyInReverseOrder(const Reconstruction& model) {
  Reconstruction copy;
  for (auto it = model.cameras.rbegin(); it != model.cameras.rend(); ++it) {
    copy.cameras.emplace_hint(copy.cameras.begin(), it->first, it->second);
  }
  for (auto it = model.images.rbegin(); it != model.images.rend(); ++it) {
    copy.images.emplace_hint(copy.images.begin(), it->first, it->second);
  }
  for (auto it = model.points3D.rbegin(); it != model.points3D.rend(); ++it) {
    copy.points3D.emplace_hint(copy.points3D.begin(), it->first, it->second);
  }
  return copy;
}

// The same cameras, poses and points, bit for bit.
inline void ExpectSameBits(const Reconstruction& a, const Reconstruction& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (const auto& [camera_id, camera] : a.cameras) {
    EXPECT_EQ(camera.params, b.cameras.at(camera_id).params) << camera_id;
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (const auto& [image_id, image] : a.images) {
    const Rigid3d& pose = b.images.at(image_id).cam_from_world;
    EXPECT_TRUE(image.cam_from_world.rotation.coeffs() ==
                pose.rotation.coeffs())
        << image_id;
    EXPECT_TRUE(image.cam_from_world.translation == pose.translation)
        << image_id;
  }
  ASSERT_EQ(a.points3D.size(), b.points3D.size());
  for (const auto& [point3D_id, point] : a.points3D) {
    ASSERT_TRUE(b.points3D.count(point3D_id)) << point3D_id;
    EXPECT_TRUE(point.xyz == b.points3D.at(point3D_id).xyz) << point3D_id;
    EXPECT_EQ(point.track.size(), b.points3D.at(point3D_id).track.size());
  }
}

}  // namespace test
}  // namespace colmap_irav4
