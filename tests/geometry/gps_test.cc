#include "colmap_irav4/geometry/gps.h"

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(Gps, EcefOfKnownPoints) {
  // The equator at the prime meridian: the semi-major axis on x.
  EXPECT_NEAR((Wgs84ToEcef({0, 0, 0}) - Eigen::Vector3d(6378137, 0, 0)).norm(),
              0, 1e-6);
  // The north pole: the semi-minor axis b = a (1 - f) on z.
  EXPECT_NEAR(
      (Wgs84ToEcef({90, 0, 0}) - Eigen::Vector3d(0, 0, 6356752.314245)).norm(),
      0, 1e-5);
  // 45 deg north, 100 m up, 90 deg east: on y and z.
  const Eigen::Vector3d p = Wgs84ToEcef({45, 90, 100});
  EXPECT_NEAR(p.x(), 0, 1e-6);
  EXPECT_NEAR(p.y(), 4517590.878849 + 100 * std::sqrt(0.5), 1e-5);
  EXPECT_NEAR(p.z(), 4487348.408866 + 100 * std::sqrt(0.5), 1e-5);
}

TEST(Gps, EcefRoundTrip) {
  for (const Wgs84& geodetic :
       {Wgs84{47.3769, 8.5417, 408}, Wgs84{-33.86, 151.21, -20},
        Wgs84{89.9, -179.5, 8000}, Wgs84{0.001, 0.002, 0}}) {
    const Wgs84 back = EcefToWgs84(Wgs84ToEcef(geodetic));
    EXPECT_NEAR(back.latitude, geodetic.latitude, 1e-10);
    EXPECT_NEAR(back.longitude, geodetic.longitude, 1e-10);
    EXPECT_NEAR(back.altitude, geodetic.altitude, 1e-6);
  }
}

TEST(Gps, EnuOfKnownOffsets) {
  const EnuFrame equator({0, 0, 0});
  EXPECT_NEAR(equator.ToEnu({0, 0, 0}).norm(), 0, 1e-9);
  // Up is the altitude.
  EXPECT_NEAR((equator.ToEnu({0, 0, 10}) - Eigen::Vector3d(0, 0, 10)).norm(), 0,
              1e-9);
  // 0.001 deg along the equator: a * pi / 180000 = 111.3195 m east (and
  // the earth's curvature drops it ~1 mm).
  const Eigen::Vector3d east = equator.ToEnu({0, 0.001, 0});
  EXPECT_NEAR(east.x(), 111.3195, 1e-3);
  EXPECT_NEAR(east.y(), 0, 1e-9);
  EXPECT_NEAR(east.z(), -0.00097, 1e-4);
  // 0.001 deg north at the equator: the meridian radius a (1 - e^2) =
  // 6335439.327 m gives 110.5743 m.
  const Eigen::Vector3d north = equator.ToEnu({0.001, 0, 0});
  EXPECT_NEAR(north.x(), 0, 1e-9);
  EXPECT_NEAR(north.y(), 110.5743, 1e-3);
  // Away from the equator east shrinks with cos(latitude).
  const EnuFrame zurich({47.3769, 8.5417, 408});
  const Eigen::Vector3d e = zurich.ToEnu({47.3769, 8.5427, 408});
  EXPECT_NEAR(e.x(), 75.5243, 1e-3);  // (N + h) cos(lat) dlon
  EXPECT_NEAR(e.y(), 0, 1e-3);
  // ToWgs84 inverts ToEnu.
  const Wgs84 back = zurich.ToWgs84(Eigen::Vector3d(120, -45, 3));
  EXPECT_NEAR((zurich.ToEnu(back) - Eigen::Vector3d(120, -45, 3)).norm(), 0,
              1e-6);
}

TEST(Gps, ValidRanges) {
  EXPECT_TRUE(IsValidWgs84({47, 8, 400}));
  EXPECT_FALSE(IsValidWgs84({91, 8, 400}));
  EXPECT_FALSE(IsValidWgs84({47, 181, 400}));
  EXPECT_FALSE(IsValidWgs84({47, 8, 1e6}));
  EXPECT_FALSE(IsValidWgs84({std::nan(""), 8, 400}));
}

}  // namespace
}  // namespace colmap_irav4
