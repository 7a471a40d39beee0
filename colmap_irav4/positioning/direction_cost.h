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
// The reference form for automatic differentiation; positioning solves with
// ProjectedDirectionCostFunction, its analytic twin.
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

// ProjectedDirectionCost with its Jacobians written out: the same values bit
// for bit as AutoDiffCostFunction<ProjectedDirectionCost> computes (the same
// operations in the same order; tested), without its two heap objects (the
// functor and the wrapper). Positioning keeps one per observation in a
// contiguous store that the problem does not own, so that each costs its 64
// bytes plus Ceres' parameter-size vector instead of about 190 bytes with
// the problem's ownership table (issue 24, memory).
// dr/db = d d^T - I while s > 1 (the scale follows b - a), -I where s is
// held at 1; dr/da = -dr/db.
class ProjectedDirectionCostFunction final
    : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  ProjectedDirectionCostFunction() = default;
  explicit ProjectedDirectionCostFunction(const Eigen::Vector3d& direction)
      : direction_{direction[0], direction[1], direction[2]} {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* a = parameters[0];
    const double* b = parameters[1];
    const double* d = direction_;
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double scale = u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
    const bool clamped = scale < 1.0;
    if (clamped) scale = 1.0;
    for (int k = 0; k < 3; ++k) residuals[k] = scale * d[k] - u[k];
    if (jacobians == nullptr) return true;
    // Row-major 3x3 blocks, as Ceres stores them.
    double db[9];
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) {
        db[3 * k + j] = (clamped ? 0.0 : d[j] * d[k]) - (j == k ? 1.0 : 0.0);
      }
    }
    if (jacobians[0] != nullptr) {
      for (int i = 0; i < 9; ++i) jacobians[0][i] = -db[i];
    }
    if (jacobians[1] != nullptr) {
      for (int i = 0; i < 9; ++i) jacobians[1][i] = db[i];
    }
    return true;
  }

  Eigen::Vector3d direction() const {
    return Eigen::Vector3d(direction_[0], direction_[1], direction_[2]);
  }

 private:
  double direction_[3] = {0, 0, 0};
};

}  // namespace colmap_irav4
