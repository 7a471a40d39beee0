#pragma once

// Residuals of pose priors (scene/pose_prior.h) for Ceres, shared by global
// positioning and bundle adjustment.

#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

namespace colmap_irav4 {

// The loss on a prior's whitened residual (s: its squared norm, in squared
// standard deviations): least squares up to `quadratic_std` standard
// deviations, a Cauchy tail of scale `cauchy_scale` beyond,
//   rho(s) = s                                   for s <= T^2,
//   rho(s) = T^2 + b log(1 + (s - T^2) / b)      beyond (b = cauchy_scale^2),
// continuous with its slope at T^2 (rho' = 1 on both sides). Why not a
// Cauchy throughout: valid priors (within 4 std: 99.9% of them) then weigh
// 1 / (1 + r^2 / b), a third less at 2 std, so the frame fitted to noisy
// priors is not their least-squares fit (tests/refinement/
// bundle_adjustment_priors_test.cc: 0.23 m off it on 12 cameras with 1 m
// priors); the tail still redescends, an outlier 20 std off weighs 2% of a
// valid prior.
class QuadraticCauchyTailLoss : public ceres::LossFunction {
 public:
  QuadraticCauchyTailLoss(double quadratic_std, double cauchy_scale)
      : threshold_(quadratic_std * quadratic_std),
        b_(cauchy_scale * cauchy_scale) {}
  void Evaluate(double s, double rho[3]) const override {
    if (s <= threshold_) {
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    }
    const double u = s - threshold_;
    rho[0] = threshold_ + b_ * std::log1p(u / b_);
    rho[1] = b_ / (b_ + u);
    rho[2] = -rho[1] * rho[1] / b_;
  }

 private:
  const double threshold_;
  const double b_;
};

// W (c - prior) for a camera centre c (W: PositionPriorSqrtInformation).
struct PositionPriorCost {
  PositionPriorCost(const Eigen::Vector3d& prior,
                    const Eigen::Matrix3d& sqrt_information)
      : prior_(prior), sqrt_information_(sqrt_information) {}
  template <typename T>
  bool operator()(const T* center, T* residuals) const {
    const Eigen::Matrix<T, 3, 1> d(center[0] - T(prior_[0]),
                                   center[1] - T(prior_[1]),
                                   center[2] - T(prior_[2]));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residuals);
    r = sqrt_information_.cast<T>() * d;
    return true;
  }
  static ceres::CostFunction* Create(const Eigen::Vector3d& prior,
                                     const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PositionPriorCost, 3, 3>(
        new PositionPriorCost(prior, sqrt_information));
  }
  const Eigen::Vector3d prior_;
  const Eigen::Matrix3d sqrt_information_;
};

// The same prior on the centre c = -R^T t of a pose parameterised by its
// cam_from_world rotation (Eigen quaternion x, y, z, w) and translation.
struct PositionPriorFromTranslationCost {
  PositionPriorFromTranslationCost(const Eigen::Vector3d& prior,
                                   const Eigen::Matrix3d& sqrt_information)
      : center_cost_(prior, sqrt_information) {}
  template <typename T>
  bool operator()(const T* rotation, const T* translation, T* residuals) const {
    // Ceres' quaternions are w, x, y, z; the inverse rotation is the
    // conjugate.
    const T inverse[4] = {rotation[3], -rotation[0], -rotation[1],
                          -rotation[2]};
    T center[3];
    ceres::UnitQuaternionRotatePoint(inverse, translation, center);
    for (T& value : center) value = -value;
    return center_cost_(center, residuals);
  }
  static ceres::CostFunction* Create(const Eigen::Vector3d& prior,
                                     const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PositionPriorFromTranslationCost, 3,
                                           4, 3>(
        new PositionPriorFromTranslationCost(prior, sqrt_information));
  }
  const PositionPriorCost center_cost_;
};

// The measured direction of gravity in the camera frame g against the
// camera's down R (0, 0, -1) (cam_from_world rotation, Eigen quaternion
// x, y, z, w): g x (R down) / std, whose norm is the sine of the angle
// between them in standard deviations.
struct GravityPriorCost {
  GravityPriorCost(const Eigen::Vector3d& gravity, double std_rad)
      : gravity_(gravity), inverse_std_(1.0 / std_rad) {}
  template <typename T>
  bool operator()(const T* rotation, T* residuals) const {
    const T q[4] = {rotation[3], rotation[0], rotation[1], rotation[2]};
    const T down[3] = {T(0), T(0), T(-1)};
    T predicted[3];
    ceres::UnitQuaternionRotatePoint(q, down, predicted);
    const T g[3] = {T(gravity_[0]), T(gravity_[1]), T(gravity_[2])};
    ceres::CrossProduct(g, predicted, residuals);
    for (int k = 0; k < 3; ++k) residuals[k] *= T(inverse_std_);
    return true;
  }
  static ceres::CostFunction* Create(const Eigen::Vector3d& gravity,
                                     double std_rad) {
    return new ceres::AutoDiffCostFunction<GravityPriorCost, 3, 4>(
        new GravityPriorCost(gravity, std_rad));
  }
  const Eigen::Vector3d gravity_;
  const double inverse_std_;
};

}  // namespace colmap_irav4
