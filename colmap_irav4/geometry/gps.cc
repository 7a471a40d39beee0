#include "colmap_irav4/geometry/gps.h"

#include <cmath>

#include <Eigen/Dense>

namespace colmap_irav4 {
namespace {

// WGS84 ellipsoid: semi-major axis (m), flattening, first eccentricity^2.
constexpr double kSemiMajorAxis = 6378137.0;
constexpr double kFlattening = 1.0 / 298.257223563;
constexpr double kEccentricity2 = kFlattening * (2.0 - kFlattening);

double DegToRadians(double deg) { return deg * M_PI / 180.0; }
double RadToDegrees(double rad) { return rad * 180.0 / M_PI; }

}  // namespace

bool IsValidWgs84(const Wgs84& geodetic) {
  return std::isfinite(geodetic.latitude) &&
         std::isfinite(geodetic.longitude) &&
         std::isfinite(geodetic.altitude) &&
         std::abs(geodetic.latitude) <= 90.0 &&
         std::abs(geodetic.longitude) <= 180.0 && geodetic.altitude >= -11000 &&
         geodetic.altitude <= 100000;
}

Eigen::Vector3d Wgs84ToEcef(const Wgs84& geodetic) {
  const double lat = DegToRadians(geodetic.latitude);
  const double lon = DegToRadians(geodetic.longitude);
  const double sin_lat = std::sin(lat);
  // Radius of curvature in the prime vertical.
  const double n =
      kSemiMajorAxis / std::sqrt(1.0 - kEccentricity2 * sin_lat * sin_lat);
  const double h = geodetic.altitude;
  return Eigen::Vector3d((n + h) * std::cos(lat) * std::cos(lon),
                         (n + h) * std::cos(lat) * std::sin(lon),
                         (n * (1.0 - kEccentricity2) + h) * sin_lat);
}

Wgs84 EcefToWgs84(const Eigen::Vector3d& ecef) {
  const double p = std::hypot(ecef.x(), ecef.y());
  Wgs84 geodetic;
  geodetic.longitude = RadToDegrees(std::atan2(ecef.y(), ecef.x()));
  // Fixed-point iteration on the latitude; converges to < 1e-12 rad in a
  // few steps anywhere but exactly at the poles (handled by atan2).
  double lat = std::atan2(ecef.z(), p * (1.0 - kEccentricity2));
  double h = 0;
  for (int iteration = 0; iteration < 10; ++iteration) {
    const double sin_lat = std::sin(lat);
    const double n =
        kSemiMajorAxis / std::sqrt(1.0 - kEccentricity2 * sin_lat * sin_lat);
    h = std::abs(std::cos(lat)) > 1e-9
            ? p / std::cos(lat) - n
            : std::abs(ecef.z()) - n * (1.0 - kEccentricity2);
    lat = std::atan2(ecef.z(), p * (1.0 - kEccentricity2 * n / (n + h)));
  }
  geodetic.latitude = RadToDegrees(lat);
  geodetic.altitude = h;
  return geodetic;
}

EnuFrame::EnuFrame(const Wgs84& origin)
    : origin_(origin), origin_ecef_(Wgs84ToEcef(origin)) {
  const double lat = DegToRadians(origin.latitude);
  const double lon = DegToRadians(origin.longitude);
  enu_from_ecef_ << -std::sin(lon), std::cos(lon), 0,  //
      -std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon),
      std::cos(lat),  //
      std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon),
      std::sin(lat);
}

Eigen::Vector3d EnuFrame::ToEnu(const Wgs84& geodetic) const {
  return enu_from_ecef_ * (Wgs84ToEcef(geodetic) - origin_ecef_);
}

Wgs84 EnuFrame::ToWgs84(const Eigen::Vector3d& enu) const {
  return EcefToWgs84(origin_ecef_ + enu_from_ecef_.transpose() * enu);
}

}  // namespace colmap_irav4
