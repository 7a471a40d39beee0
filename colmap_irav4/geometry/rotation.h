#pragma once

#include <random>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace colmap_irav4 {

// One rotation convention for the whole code base (see DESIGN.md):
//   absolute rotation R_i = cam_from_world (COLMAP's),
//   relative rotation R_ij = cam_j_from_cam_i = R_j R_i^T.

constexpr double kPi = 3.14159265358979323846;
inline double DegToRad(double deg) { return deg * kPi / 180.0; }
inline double RadToDeg(double rad) { return rad * 180.0 / kPi; }

// d(R1, R2) = arccos((tr(R2 R1^T) - 1) / 2), in radians / degrees. Clamped so
// that round-off never yields NaN.
double AngularDistance(const Eigen::Matrix3d& R1, const Eigen::Matrix3d& R2);
double AngularDistanceDeg(const Eigen::Matrix3d& R1, const Eigen::Matrix3d& R2);
// Rotation angle of R (its distance to the identity), radians.
double RotationAngle(const Eigen::Matrix3d& R);

// Angle-axis (Rodrigues) vector <-> rotation matrix.
Eigen::Matrix3d AngleAxisToRotation(const Eigen::Vector3d& angle_axis);
Eigen::Vector3d RotationToAngleAxis(const Eigen::Matrix3d& R);

// COLMAP quaternion order (qw, qx, qy, qz) <-> rotation matrix. The input
// quaternion is normalised; the output has qw >= 0.
Eigen::Matrix3d QuaternionToRotation(const Eigen::Vector4d& qvec);
Eigen::Vector4d RotationToQuaternion(const Eigen::Matrix3d& R);

// Nearest rotation (Frobenius) to an arbitrary 3x3 matrix, via SVD.
Eigen::Matrix3d ProjectToRotation(const Eigen::Matrix3d& M);
// Whether M is a rotation up to tolerance (orthonormal, det +1).
bool IsRotation(const Eigen::Matrix3d& M, double tolerance = 1e-6);

// Uniformly distributed random rotation (Haar measure).
Eigen::Matrix3d RandomRotation(std::mt19937_64* rng);
// Rotation by `angle_rad` about a uniformly random axis.
Eigen::Matrix3d RandomRotationWithAngle(double angle_rad, std::mt19937_64* rng);

}  // namespace colmap_irav4
