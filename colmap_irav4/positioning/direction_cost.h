#pragma once

#include <string>

#include <ceres/ceres.h>
#include <Eigen/Core>

namespace colmap_irav4 {

// r = s * d - (b - a): the scale-free direction residual shared by global
// positioning (a = camera centre, b = point) and translation averaging (a, b =
// camera centres). Blocks: a (3), b (3), s (1, bounded below to fix scale).
struct ScaledDirectionCost {
  explicit ScaledDirectionCost(const Eigen::Vector3d& direction) : direction_(direction) {}

  template <typename T>
  bool operator()(const T* a, const T* b, const T* scale, T* residuals) const {
    for (int k = 0; k < 3; ++k) {
      residuals[k] = scale[0] * T(direction_[k]) - (b[k] - a[k]);
    }
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& direction) {
    return new ceres::AutoDiffCostFunction<ScaledDirectionCost, 3, 3, 3, 1>(
        new ScaledDirectionCost(direction));
  }

  const Eigen::Vector3d direction_;
};

// "huber", "cauchy" or "trivial" (nullptr).
inline ceres::LossFunction* CreateLossFunction(const std::string& name, double scale) {
  if (name == "huber") return new ceres::HuberLoss(scale);
  if (name == "cauchy") return new ceres::CauchyLoss(scale);
  return nullptr;
}

}  // namespace colmap_irav4
