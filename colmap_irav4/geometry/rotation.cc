#include "colmap_irav4/geometry/rotation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {

double AngularDistance(const Eigen::Matrix3d& R1, const Eigen::Matrix3d& R2) {
  return RotationAngle(R2 * R1.transpose());
}

double AngularDistanceDeg(const Eigen::Matrix3d& R1,
                          const Eigen::Matrix3d& R2) {
  return RadToDeg(AngularDistance(R1, R2));
}

double RotationAngle(const Eigen::Matrix3d& R) {
  // arccos is ill-conditioned near 0; atan2 of the skew part and the trace is
  // accurate over the whole range.
  const double cos_angle = (R.trace() - 1.0) / 2.0;
  const Eigen::Vector3d skew(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0),
                             R(1, 0) - R(0, 1));
  const double sin_angle = 0.5 * skew.norm();
  return std::atan2(sin_angle, std::clamp(cos_angle, -1.0, 1.0));
}

Eigen::Matrix3d AngleAxisToRotation(const Eigen::Vector3d& angle_axis) {
  const double angle = angle_axis.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, angle_axis / angle).toRotationMatrix();
}

Eigen::Vector3d RotationToAngleAxis(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd angle_axis(Eigen::Quaterniond(R).normalized());
  return angle_axis.angle() * angle_axis.axis();
}

Eigen::Matrix3d QuaternionToRotation(const Eigen::Vector4d& qvec) {
  return Eigen::Quaterniond(qvec(0), qvec(1), qvec(2), qvec(3))
      .normalized()
      .toRotationMatrix();
}

Eigen::Vector4d RotationToQuaternion(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(R).normalized();
  Eigen::Vector4d qvec(q.w(), q.x(), q.y(), q.z());
  if (qvec(0) < 0) qvec = -qvec;
  return qvec;
}

Eigen::Matrix3d ProjectToRotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0
                                                                          : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

bool IsRotation(const Eigen::Matrix3d& M, double tolerance) {
  return (M * M.transpose() - Eigen::Matrix3d::Identity()).norm() <=
             tolerance &&
         std::abs(M.determinant() - 1.0) <= tolerance;
}

Eigen::Matrix3d RandomRotation(std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector4d wxyz = RandomVector<4>(normal, *rng);
  const Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  return q.normalized().toRotationMatrix();
}

Eigen::Matrix3d RandomRotationWithAngle(double angle_rad,
                                        std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d axis = RandomVector<3>(normal, *rng);
  while (axis.norm() < 1e-12) {
    axis = RandomVector<3>(normal, *rng);
  }
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

}  // namespace colmap_irav4
