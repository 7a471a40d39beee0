#pragma once

#include <type_traits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "colmap_irav4/scene/camera_models.h"

namespace colmap_irav4 {

// Reprojection residual in pixels (bundle adjustment's, for Ceres' automatic
// differentiation and the Schur solver alike); blocks: quaternion (x, y, z,
// w), translation (or, with `center`, the projection centre), point, camera
// params (kNumParams). With a weight, the residual is scaled by it when
// evaluated (the weight may change between solves).
template <int kNumParams>
struct ReprojectionCost {
  ReprojectionCost(int model_id, const Eigen::Vector2d& xy,
                   const double* weight, bool center)
      : model_id_(model_id), xy_(xy), weight_(weight), center_(center) {}

  template <typename T>
  bool operator()(const T* rotation, const T* position, const T* point,
                  const T* params, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> xyz(point);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(position);
    const Eigen::Matrix<T, 3, 1> in_cam =
        center_ ? Eigen::Matrix<T, 3, 1>(q * (xyz - p))
                : Eigen::Matrix<T, 3, 1>(q * xyz + p);
    T x, y;
    CameraModelImgFromCam<T>(model_id_, params, in_cam[0], in_cam[1], in_cam[2],
                             &x, &y);
    residuals[0] = x - T(xy_[0]);
    residuals[1] = y - T(xy_[1]);
    if (weight_ != nullptr) {
      residuals[0] *= *weight_;
      residuals[1] *= *weight_;
    }
    return true;
  }

  const int model_id_;
  const Eigen::Vector2d xy_;
  const double* weight_;
  const bool center_;
};

// Calls f(std::integral_constant<int, N>()) with N = num_params, one of the
// camera models' parameter counts (3, 4, 5, 8, 12): the size of
// ReprojectionCost's camera block. Returns false for another count.
template <typename F>
bool WithNumCameraParams(int num_params, F&& f) {
  switch (num_params) {
    case 3:
      f(std::integral_constant<int, 3>());
      return true;
    case 4:
      f(std::integral_constant<int, 4>());
      return true;
    case 5:
      f(std::integral_constant<int, 5>());
      return true;
    case 8:
      f(std::integral_constant<int, 8>());
      return true;
    case 12:
      f(std::integral_constant<int, 12>());
      return true;
  }
  return false;
}

}  // namespace colmap_irav4
