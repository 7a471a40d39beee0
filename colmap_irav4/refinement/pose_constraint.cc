#include "colmap_irav4/refinement/pose_constraint.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"

namespace colmap_irav4 {

void PoseConstraintOptions::Check() const {
  if (min_track_length < 2) {
    throw OptionError(&min_track_length, "PoseConstraint.min_track_length",
                      "must be >= 2");
  }
  if (!(max_relative_uncertainty > 1)) {
    throw OptionError(&max_relative_uncertainty,
                      "PoseConstraint.max_relative_uncertainty", "must be > 1");
  }
}

namespace {

// Square root of the largest eigenvalue of a symmetric 3x3 block.
double LargestStdDev(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  return std::sqrt(std::max(0.0, solver.eigenvalues().maxCoeff()));
}

}  // namespace

std::vector<ImagePoseConstraint> ComputePoseConstraints(
    const PoseConstraintOptions& options,
    const Reconstruction& reconstruction) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<ImagePoseConstraint> constraints;
  for (const auto& [image_id, image] : reconstruction.images) {
    ImagePoseConstraint constraint;
    constraint.image_id = image_id;
    constraint.name = image.name;
    const double focal =
        CameraMeanFocalLength(reconstruction.cameras.at(image.camera_id));
    const Eigen::Matrix3d R = image.cam_from_world.rotation.toRotationMatrix();
    // Information of (rotation perturbation, centre) from the pinhole
    // projection u = f (x/z, y/z) of p = R (X - C), points fixed.
    Eigen::Matrix<double, 6, 6> information =
        Eigen::Matrix<double, 6, 6>::Zero();
    std::vector<double> depths;
    for (const Point2D& point2D : image.points2D) {
      if (point2D.point3D_id == kInvalidPoint3DId) continue;
      ++constraint.num_observations;
      const Point3D& point = reconstruction.points3D.at(point2D.point3D_id);
      if (static_cast<int>(point.track.size()) < options.min_track_length) {
        continue;
      }
      const Eigen::Vector3d p = image.cam_from_world * point.xyz;
      if (!(p.z() > 0)) continue;
      ++constraint.num_multi_view_observations;
      depths.push_back(p.z());
      Eigen::Matrix<double, 2, 3> du_dp;
      du_dp << 1 / p.z(), 0, -p.x() / (p.z() * p.z()), 0, 1 / p.z(),
          -p.y() / (p.z() * p.z());
      du_dp *= focal;
      // p(theta, C) = exp([theta]x) R (X - C): dp/dtheta = -[p]x, dp/dC = -R.
      Eigen::Matrix<double, 3, 6> dp;
      dp.leftCols<3>() << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;
      dp.rightCols<3>() = -R;
      const Eigen::Matrix<double, 2, 6> J = du_dp * dp;
      information += J.transpose() * J;
    }
    constraint.rotation_uncertainty_deg = kInf;
    constraint.relative_center_uncertainty = kInf;
    const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(information);
    if (constraint.num_multi_view_observations >= 3 && lu.isInvertible()) {
      const Eigen::Matrix<double, 6, 6> covariance = lu.inverse();
      constraint.rotation_uncertainty_deg =
          RadToDeg(LargestStdDev(covariance.topLeftCorner<3, 3>()));
      constraint.relative_center_uncertainty =
          LargestStdDev(covariance.bottomRightCorner<3, 3>()) / Median(depths);
    }
    constraints.push_back(constraint);
  }
  std::vector<double> finite;
  for (const ImagePoseConstraint& constraint : constraints) {
    if (std::isfinite(constraint.rotation_uncertainty_deg)) {
      finite.push_back(constraint.rotation_uncertainty_deg);
    }
  }
  const double median = finite.empty() ? kInf : Median(finite);
  for (ImagePoseConstraint& constraint : constraints) {
    constraint.relative_uncertainty =
        std::isfinite(median) && median > 0
            ? constraint.rotation_uncertainty_deg / median
            : kInf;
    constraint.poorly_constrained =
        !(constraint.relative_uncertainty <= options.max_relative_uncertainty);
  }
  std::stable_sort(
      constraints.begin(), constraints.end(),
      [](const ImagePoseConstraint& a, const ImagePoseConstraint& b) {
        return a.relative_uncertainty > b.relative_uncertainty;
      });
  return constraints;
}

}  // namespace colmap_irav4
