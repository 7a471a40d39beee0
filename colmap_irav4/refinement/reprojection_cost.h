#pragma once

#include <cmath>
#include <type_traits>
#include <utility>

#include <ceres/jet.h>
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

// ReprojectionCost's residual (unweighted) and its Jacobians, the rotation's
// in the tangent space of ceres::EigenQuaternionManifold (Plus(q, d) =
// Exp(d) q, a rotation by 2 d: -2 [R x]_x through the projection), without
// differentiating the rotation automatically: only the projection of the
// point in camera coordinates (u, v, w) and the camera parameters go through
// Ceres' Jet (3 + kNumParams dual parts instead of 10 + kNumParams), the
// rest is the chain rule. Equal to the automatic Jacobians times the
// manifold's PlusJacobian up to rounding (unit quaternion).
template <int kNumParams>
struct ReprojectionJacobians {
  Eigen::Matrix<double, 2, 3> rotation;  // tangent of the quaternion
  Eigen::Matrix<double, 2, 3> position;  // translation or centre
  Eigen::Matrix<double, 2, 3> point;
  Eigen::Matrix<double, 2, kNumParams> params;
};

template <int kNumParams>
bool LinearizeReprojection(int model_id, const Eigen::Vector2d& xy, bool center,
                           const double* rotation, const double* position,
                           const double* point, const double* params,
                           double residual[2],
                           ReprojectionJacobians<kNumParams>* jacobians) {
  using Jet = ceres::Jet<double, 3 + kNumParams>;
  const Eigen::Map<const Eigen::Quaterniond> q(rotation);
  const Eigen::Map<const Eigen::Vector3d> p(position);
  const Eigen::Map<const Eigen::Vector3d> xyz(point);
  // The point rotated into the camera's axes (before the translation).
  const Eigen::Vector3d rotated =
      center ? Eigen::Vector3d(q * (xyz - p)) : Eigen::Vector3d(q * xyz);
  const Eigen::Vector3d in_cam =
      center ? rotated : Eigen::Vector3d(rotated + p);
  Jet jet_params[kNumParams];
  for (int i = 0; i < kNumParams; ++i) {
    jet_params[i] = Jet(params[i], 3 + i);
  }
  Jet x, y;
  CameraModelImgFromCam<Jet>(model_id, jet_params, Jet(in_cam[0], 0),
                             Jet(in_cam[1], 1), Jet(in_cam[2], 2), &x, &y);
  residual[0] = x.a - xy[0];
  residual[1] = y.a - xy[1];
  Eigen::Matrix<double, 2, 3> d_in_cam;
  d_in_cam.row(0) = x.v.template head<3>().transpose();
  d_in_cam.row(1) = y.v.template head<3>().transpose();
  jacobians->params.row(0) = x.v.template tail<kNumParams>().transpose();
  jacobians->params.row(1) = y.v.template tail<kNumParams>().transpose();
  jacobians->point = d_in_cam * q.toRotationMatrix();
  jacobians->position =
      center ? Eigen::Matrix<double, 2, 3>(-jacobians->point) : d_in_cam;
  Eigen::Matrix3d cross;  // [rotated]_x
  cross << 0, -rotated[2], rotated[1], rotated[2], 0, -rotated[0], -rotated[1],
      rotated[0], 0;
  jacobians->rotation = -2 * d_in_cam * cross;
  return std::isfinite(residual[0]) && std::isfinite(residual[1]);
}

// Calls f(std::integral_constant<int, N>()) with N = n when n is one of Ns
// (a size known at run time dispatched to code compiled for it); false for
// another n.
template <int... Ns, typename F>
bool WithConstant(int n, F&& f) {
  return ((n == Ns ? (f(std::integral_constant<int, Ns>()), true) : false) ||
          ...);
}

// WithConstant over the camera models' parameter counts (3, 4, 5, 8, 12):
// the size of ReprojectionCost's camera block.
template <typename F>
bool WithNumCameraParams(int num_params, F&& f) {
  return WithConstant<3, 4, 5, 8, 12>(num_params, std::forward<F>(f));
}

}  // namespace colmap_irav4
