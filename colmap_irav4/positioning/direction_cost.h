#pragma once

#include <ceres/ceres.h>
#include <Eigen/Core>

namespace colmap_irav4 {

// The scale-free direction residual of global positioning (a = camera
// centre, b = point, d = unit world bearing): r = s d - (b - a) with s >= 1.
// The scale is at its optimum for the current a, b:
// s = max(1, <d, b - a>), so r = s d - (b - a) without a scale variable
// (variable projection: same minima, and no per-observation parameter
// blocks, so that Schur elimination of the points leaves only the cameras).
struct ProjectedDirectionCost {
  explicit ProjectedDirectionCost(const Eigen::Vector3d& direction)
      : direction_(direction) {}

  template <typename T>
  bool operator()(const T* a, const T* b, T* residuals) const {
    const T u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    T scale = u[0] * T(direction_[0]) + u[1] * T(direction_[1]) +
              u[2] * T(direction_[2]);
    if (scale < T(1)) scale = T(1);
    for (int k = 0; k < 3; ++k) residuals[k] = scale * T(direction_[k]) - u[k];
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& direction) {
    return new ceres::AutoDiffCostFunction<ProjectedDirectionCost, 3, 3, 3>(
        new ProjectedDirectionCost(direction));
  }

  const Eigen::Vector3d direction_;
};

}  // namespace colmap_irav4
