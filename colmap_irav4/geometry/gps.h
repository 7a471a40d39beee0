#pragma once

#include <Eigen/Core>

namespace colmap_irav4 {

// WGS84 geodetic coordinates: latitude and longitude in degrees, altitude
// in metres above the ellipsoid (EXIF's altitude is above sea level; the
// difference, the geoid height, is a constant offset over a scene).
struct Wgs84 {
  double latitude = 0;
  double longitude = 0;
  double altitude = 0;
};

// Whether latitude is in [-90, 90], longitude in [-180, 180] and altitude in
// [-11000, 100000] m (the deepest trench to a stratospheric balloon), all
// finite.
bool IsValidWgs84(const Wgs84& geodetic);

// Earth-centred, earth-fixed coordinates (m) of a geodetic position.
Eigen::Vector3d Wgs84ToEcef(const Wgs84& geodetic);
// The inverse (Bowring's iteration; sub-millimetre near the surface).
Wgs84 EcefToWgs84(const Eigen::Vector3d& ecef);

// A local east-north-up frame (metres) with its origin at a geodetic
// position: x east, y north, z up (the ellipsoid's normal at the origin).
class EnuFrame {
 public:
  explicit EnuFrame(const Wgs84& origin);
  const Wgs84& Origin() const { return origin_; }
  Eigen::Vector3d ToEnu(const Wgs84& geodetic) const;
  Wgs84 ToWgs84(const Eigen::Vector3d& enu) const;
  const Eigen::Vector3d& OriginEcef() const { return origin_ecef_; }
  const Eigen::Matrix3d& EnuFromEcef() const { return enu_from_ecef_; }

 private:
  Wgs84 origin_;
  Eigen::Vector3d origin_ecef_;
  Eigen::Matrix3d enu_from_ecef_;
};

}  // namespace colmap_irav4
