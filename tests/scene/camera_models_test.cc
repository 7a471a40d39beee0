#include "colmap_irav4/scene/camera_models.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <ceres/jet.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace colmap_irav4 {
namespace {

const double kPi = 3.14159265358979323846;

Camera MakeCamera(int model_id, std::vector<double> params) {
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = model_id;
  const bool wide = CameraModelIsFisheye(model_id) || model_id == kFOV;
  camera.width = wide ? 848 : 1280;
  camera.height = wide ? 800 : 960;
  camera.params = std::move(params);
  return camera;
}

// Realistic parameters for every model (the fisheye ones from an Intel T265
// and similar lenses).
std::vector<Camera> RealisticCameras() {
  return {
      MakeCamera(0, {1000, 640, 480}),
      MakeCamera(1, {1000, 1010, 641, 479}),
      MakeCamera(2, {1000, 640, 480, -0.1}),
      MakeCamera(3, {1000, 640, 480, -0.15, 0.03}),
      MakeCamera(4, {1000, 1010, 640, 480, -0.2, 0.05, 1e-3, -5e-4}),
      MakeCamera(
          5, {284.468, 285.51, 424.355, 393.742, 0.0008, 0.031, -0.03, 0.005}),
      MakeCamera(6, {1000, 1010, 640, 480, -0.2, 0.05, 1e-3, -5e-4, 0.01, 0.01,
                     -0.002, 0.001}),
      MakeCamera(7, {285, 286, 424, 394, 0.92}),
      MakeCamera(8, {285, 424, 394, 0.02}),
      MakeCamera(9, {285, 424, 394, 0.02, -0.003}),
      MakeCamera(10, {285, 286, 424, 394, 0.02, -0.003, 1e-4, -2e-4, 1e-4,
                      -1e-5, 1e-4, -1e-4}),
  };
}

// Whether the model can see wide angles (fisheye lenses).
bool IsWideAngle(int model_id) {
  return CameraModelIsFisheye(model_id) || model_id == kFOV;
}

TEST(CameraModels, NamesIdsAndNumbersOfParameters) {
  const std::vector<std::pair<std::string, int>> expected = {
      {"SIMPLE_PINHOLE", 3},
      {"PINHOLE", 4},
      {"SIMPLE_RADIAL", 4},
      {"RADIAL", 5},
      {"OPENCV", 8},
      {"OPENCV_FISHEYE", 8},
      {"FULL_OPENCV", 12},
      {"FOV", 5},
      {"SIMPLE_RADIAL_FISHEYE", 4},
      {"RADIAL_FISHEYE", 5},
      {"THIN_PRISM_FISHEYE", 12}};
  ASSERT_EQ(expected.size(), static_cast<size_t>(kNumCameraModels));
  for (int id = 0; id < kNumCameraModels; ++id) {
    EXPECT_TRUE(IsValidCameraModelId(id));
    EXPECT_EQ(CameraModelIdToName(id), expected[id].first);
    EXPECT_EQ(CameraModelNameToId(expected[id].first), id);
    EXPECT_EQ(CameraModelNumParams(id), expected[id].second);
    // The info string lists one name per parameter.
    const std::string info = CameraModelParamsInfo(id);
    EXPECT_EQ(std::count(info.begin(), info.end(), ',') + 1,
              expected[id].second)
        << info;
    // Focal, principal point and extra indices partition the parameters.
    std::vector<int> all = CameraModelFocalLengthIdxs(id);
    for (int idx : CameraModelPrincipalPointIdxs(id)) all.push_back(idx);
    for (int idx : CameraModelExtraParamsIdxs(id)) all.push_back(idx);
    ASSERT_EQ(all.size(), static_cast<size_t>(expected[id].second));
    for (size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i], int(i));
  }
  EXPECT_EQ(CameraModelParamsInfo(5), "fx, fy, cx, cy, k1, k2, k3, k4");
  EXPECT_EQ(CameraModelParamsInfo(10),
            "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1");
  EXPECT_EQ(CameraModelPrincipalPointIdxs(2), (std::vector<int>{1, 2}));
  EXPECT_EQ(CameraModelPrincipalPointIdxs(4), (std::vector<int>{2, 3}));
}

TEST(CameraModels, InvalidIdsAndParametersAreRejected) {
  for (int id : {-1, 11, 12, 100}) {
    EXPECT_FALSE(IsValidCameraModelId(id));
    EXPECT_EQ(CameraModelIdToName(id), "");
    EXPECT_EQ(CameraModelNumParams(id), -1);
    EXPECT_EQ(CameraModelParamsInfo(id), "");
    EXPECT_TRUE(CameraModelFocalLengthIdxs(id).empty());
  }
  EXPECT_EQ(CameraModelNameToId("PINHOLE_X"), -1);
  EXPECT_EQ(CameraModelNameToId("pinhole"), -1);
  EXPECT_EQ(CameraModelNameToId(""), -1);
  EXPECT_FALSE(CameraHasValidParams(MakeCamera(1, {1000, 1000, 640})));
  EXPECT_FALSE(CameraHasValidParams(MakeCamera(11, {1, 2, 3})));
  for (const Camera& camera : RealisticCameras()) {
    EXPECT_TRUE(CameraHasValidParams(camera));
  }
}

TEST(CameraModels, MeanFocalLength) {
  EXPECT_DOUBLE_EQ(CameraMeanFocalLength(MakeCamera(0, {900, 1, 2})), 900);
  EXPECT_DOUBLE_EQ(CameraMeanFocalLength(MakeCamera(1, {900, 1000, 1, 2})),
                   950);
}

// COLMAP's limits (focal over the larger side in [0.1, 10], |extra| <= 1,
// principal point in the image): every realistic camera passes, and each way
// out of them is caught, a negative focal length and NaN too.
TEST(CameraModels, BogusParams) {
  const auto bogus = [](const Camera& camera) {
    return CameraHasBogusParams(camera, 0.1, 10.0, 1.0);
  };
  for (const Camera& camera : RealisticCameras()) {
    EXPECT_FALSE(bogus(camera)) << camera.model_id;
  }
  // 1280 x 960: the larger side is the width.
  EXPECT_FALSE(bogus(MakeCamera(2, {128, 640, 480, 0})));
  EXPECT_TRUE(bogus(MakeCamera(2, {127, 640, 480, 0})));
  EXPECT_FALSE(bogus(MakeCamera(2, {12800, 640, 480, 0})));
  EXPECT_TRUE(bogus(MakeCamera(2, {12801, 640, 480, 0})));
  EXPECT_TRUE(bogus(MakeCamera(2, {-1049, 640, 480, 0})));
  EXPECT_TRUE(bogus(MakeCamera(2, {std::nan(""), 640, 480, 0})));
  // Each focal length of a two-focal model counts.
  EXPECT_TRUE(bogus(MakeCamera(1, {1000, 44, 640, 480})));
  EXPECT_FALSE(bogus(MakeCamera(2, {1000, 640, 480, -1.0})));
  EXPECT_TRUE(bogus(MakeCamera(2, {1000, 640, 480, -1.01})));
  EXPECT_TRUE(bogus(MakeCamera(4, {1000, 1000, 640, 480, 0, 0, 0, 1.5})));
  EXPECT_TRUE(bogus(MakeCamera(0, {1000, -1, 480})));
  EXPECT_TRUE(bogus(MakeCamera(0, {1000, 640, 961})));
  EXPECT_FALSE(bogus(MakeCamera(0, {1000, 1280, 960})));
  // Other limits.
  EXPECT_FALSE(
      CameraHasBogusParams(MakeCamera(2, {44, 640, 480, 0}), 0.0, 10.0, 1.0));
  EXPECT_FALSE(CameraHasBogusParams(MakeCamera(2, {1000, 640, 480, 2.0}), 0.1,
                                    10.0, 3.0));
}

// Every pixel of the image (on a grid) maps to the camera plane and back.
TEST(CameraModels, ImageToCameraToImageRoundTrip) {
  for (const Camera& camera : RealisticCameras()) {
    double max_error = 0.0;
    int num_beyond_90 = 0;
    for (double x = 0.5; x < camera.width; x += 20.0) {
      for (double y = 0.5; y < camera.height; y += 20.0) {
        const Eigen::Vector2d image_point(x, y);
        const Eigen::Vector2d camera_point =
            CameraImageToCamera(camera, image_point);
        if (IsWideAngle(camera.model_id)) {
          // Pixels at 90 degrees off-axis or beyond have no pinhole point;
          // and stop short of 90 degrees where r = tan(angle) explodes.
          if (!camera_point.allFinite()) {
            EXPECT_LT(CameraImageToRay(camera, image_point).z(), 1e-9);
            ++num_beyond_90;
            continue;
          }
          if (std::atan(camera_point.norm()) > 88.0 / 180.0 * kPi) continue;
        } else {
          ASSERT_TRUE(camera_point.allFinite());
        }
        // The viewing ray is the same.
        const Eigen::Vector3d ray = CameraImageToRay(camera, image_point);
        EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
        EXPECT_LT((ray - camera_point.homogeneous().normalized()).norm(),
                  1e-12);
        max_error = std::max(
            max_error,
            (CameraCameraToImage(camera, camera_point) - image_point).norm());
      }
    }
    EXPECT_LT(max_error, 1e-8) << CameraModelIdToName(camera.model_id);
    // The T265 lens sees beyond 90 degrees in its corners.
    if (camera.model_id == kOpenCVFisheye) {
      EXPECT_GT(num_beyond_90, 0);
    }
  }
}

// Fisheye pixels beyond 90 degrees off-axis give rays behind the image
// plane, at the angle the model's formula gives.
TEST(CameraModels, FisheyeRaysBeyondNinetyDegrees) {
  const Camera camera = RealisticCameras()[kOpenCVFisheye];
  const std::vector<double>& p = camera.params;
  int num_behind = 0;
  for (double x = 0.5; x < 424.0; x += 10.0) {
    const Eigen::Vector2d image_point(x, 0.8 * x);
    const Eigen::Vector3d ray = CameraImageToRay(camera, image_point);
    ASSERT_NEAR(ray.norm(), 1.0, 1e-12);
    const double theta = std::acos(ray.z());
    const double t2 = theta * theta;
    const double thetad =
        theta * (1 + p[4] * t2 + p[5] * t2 * t2 + p[6] * std::pow(t2, 3) +
                 p[7] * std::pow(t2, 4));
    const Eigen::Vector2d normalized((x - p[2]) / p[0],
                                     (0.8 * x - p[3]) / p[1]);
    EXPECT_NEAR(thetad, normalized.norm(), 1e-10);
    // Same azimuth as the pixel.
    EXPECT_LT(std::abs(normalized.x() * ray.y() - normalized.y() * ray.x()),
              1e-10);
    EXPECT_GT(normalized.x() * ray.x(), 0.0);
    if (ray.z() < 0) {
      ++num_behind;
      EXPECT_FALSE(CameraImageToCamera(camera, image_point).allFinite());
    }
  }
  EXPECT_GT(num_behind, 0);
}

// Rays up to 85 degrees off-axis for the fisheye models and 35 degrees for
// the others map to pixels and back to the same ray.
TEST(CameraModels, CameraToImageToCameraRoundTrip) {
  for (const Camera& camera : RealisticCameras()) {
    const double max_angle = IsWideAngle(camera.model_id) ? 85.0 : 35.0;
    double max_angle_error = 0.0;
    for (double angle = 0.0; angle <= max_angle; angle += 2.5) {
      for (double azimuth = 0.0; azimuth < 360.0; azimuth += 15.0) {
        const double r = std::tan(angle / 180.0 * kPi);
        const Eigen::Vector2d camera_point(r * std::cos(azimuth / 180.0 * kPi),
                                           r * std::sin(azimuth / 180.0 * kPi));
        const Eigen::Vector2d image_point =
            CameraCameraToImage(camera, camera_point);
        const Eigen::Vector2d back = CameraImageToCamera(camera, image_point);
        ASSERT_TRUE(back.allFinite());
        const Eigen::Vector3d ray1 = camera_point.homogeneous().normalized();
        const Eigen::Vector3d ray2 = back.homogeneous().normalized();
        max_angle_error =
            std::max(max_angle_error,
                     std::atan2(ray1.cross(ray2).norm(), ray1.dot(ray2)));
      }
    }
    EXPECT_LT(max_angle_error, 1e-11) << CameraModelIdToName(camera.model_id);
  }
}

// Projections written out from COLMAP's documented formulas, independently of
// the implementation's structure.
Eigen::Vector2d ReferenceProjection(const Camera& camera, double u, double v) {
  const std::vector<double>& p = camera.params;
  const double r2 = u * u + v * v;
  const double r = std::sqrt(r2);
  const double theta = std::atan(r);
  const double t2 = theta * theta;
  switch (camera.model_id) {
    case 0:
      return {p[0] * u + p[1], p[0] * v + p[2]};
    case 1:
      return {p[0] * u + p[2], p[1] * v + p[3]};
    case 2:
      return {p[0] * (u + u * p[3] * r2) + p[1],
              p[0] * (v + v * p[3] * r2) + p[2]};
    case 3: {
      const double radial = p[3] * r2 + p[4] * r2 * r2;
      return {p[0] * (u + u * radial) + p[1], p[0] * (v + v * radial) + p[2]};
    }
    case 4: {
      const double radial = p[4] * r2 + p[5] * r2 * r2;
      const double du = u * radial + 2 * p[6] * u * v + p[7] * (r2 + 2 * u * u);
      const double dv = v * radial + 2 * p[7] * u * v + p[6] * (r2 + 2 * v * v);
      return {p[0] * (u + du) + p[2], p[1] * (v + dv) + p[3]};
    }
    case 5: {
      const double thetad =
          theta * (1 + p[4] * t2 + p[5] * t2 * t2 + p[6] * std::pow(t2, 3) +
                   p[7] * std::pow(t2, 4));
      return {p[0] * u * thetad / r + p[2], p[1] * v * thetad / r + p[3]};
    }
    case 6: {
      const double radial =
          (1 + p[4] * r2 + p[5] * r2 * r2 + p[8] * std::pow(r2, 3)) /
          (1 + p[9] * r2 + p[10] * r2 * r2 + p[11] * std::pow(r2, 3));
      const double du =
          u * radial - u + 2 * p[6] * u * v + p[7] * (r2 + 2 * u * u);
      const double dv =
          v * radial - v + 2 * p[7] * u * v + p[6] * (r2 + 2 * v * v);
      return {p[0] * (u + du) + p[2], p[1] * (v + dv) + p[3]};
    }
    case 7: {
      const double omega = p[4];
      const double factor =
          std::atan(2 * r * std::tan(omega / 2)) / (r * omega);
      return {p[0] * u * factor + p[2], p[1] * v * factor + p[3]};
    }
    case 8: {
      const double thetad = theta * (1 + p[3] * t2);
      return {p[0] * u * thetad / r + p[1], p[0] * v * thetad / r + p[2]};
    }
    case 9: {
      const double thetad = theta * (1 + p[3] * t2 + p[4] * t2 * t2);
      return {p[0] * u * thetad / r + p[1], p[0] * v * thetad / r + p[2]};
    }
    case 10: {
      const double uu = theta * u / r;
      const double vv = theta * v / r;
      const double rr2 = uu * uu + vv * vv;
      const double radial = p[4] * rr2 + p[5] * rr2 * rr2 +
                            p[8] * std::pow(rr2, 3) + p[9] * std::pow(rr2, 4);
      const double du = uu * radial + 2 * p[6] * uu * vv +
                        p[7] * (rr2 + 2 * uu * uu) + p[10] * rr2;
      const double dv = vv * radial + 2 * p[7] * uu * vv +
                        p[6] * (rr2 + 2 * vv * vv) + p[11] * rr2;
      return {p[0] * (uu + du) + p[2], p[1] * (vv + dv) + p[3]};
    }
  }
  return {NAN, NAN};
}

TEST(CameraModels, ProjectionFollowsCOLMAPFormulas) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> coordinate(-0.7, 0.7);
  for (Camera camera : RealisticCameras()) {
    // Exaggerate the distortion so that every term matters.
    for (int idx : CameraModelExtraParamsIdxs(camera.model_id)) {
      camera.params[idx] *= 3.0;
    }
    for (int k = 0; k < 200; ++k) {
      const double u = coordinate(rng);
      const double v = coordinate(rng);
      const Eigen::Vector2d expected = ReferenceProjection(camera, u, v);
      const Eigen::Vector2d actual =
          CameraCameraToImage(camera, Eigen::Vector2d(u, v));
      EXPECT_LT((actual - expected).norm(), 1e-9)
          << CameraModelIdToName(camera.model_id) << " at " << u << " " << v;
    }
  }
}

TEST(CameraModels, PrincipalPointIsTheOpticalAxis) {
  for (const Camera& camera : RealisticCameras()) {
    const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
    const Eigen::Vector2d principal_point(camera.params[pp[0]],
                                          camera.params[pp[1]]);
    EXPECT_LT(
        (CameraCameraToImage(camera, Eigen::Vector2d::Zero()) - principal_point)
            .norm(),
        1e-12);
    EXPECT_LT(CameraImageToCamera(camera, principal_point).norm(), 1e-12);
  }
}

// The template with T = double and T = Jet gives CameraCameraToImage's values,
// and the Jet's derivatives match central differences.
TEST(CameraModels, TemplateAgreesAndDifferentiates) {
  typedef ceres::Jet<double, 3> Jet;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> coordinate(-0.8, 0.8);
  for (const Camera& camera : RealisticCameras()) {
    const int num_params = camera.params.size();
    std::vector<Jet> param_jets(num_params);
    for (int i = 0; i < num_params; ++i) param_jets[i] = Jet(camera.params[i]);
    for (int k = 0; k < 50; ++k) {
      // Include the optical axis, where the fisheye models branch.
      const double u = k == 0 ? 0.0 : coordinate(rng);
      const double v = k == 0 ? 0.0 : coordinate(rng);
      const double w = 1.0 + 2.0 * (k % 3);
      double x, y;
      CameraModelImgFromCam(camera.model_id, camera.params.data(), u * w, v * w,
                            w, &x, &y);
      const Eigen::Vector2d expected =
          CameraCameraToImage(camera, Eigen::Vector2d(u, v));
      EXPECT_NEAR(x, expected.x(), 1e-9);
      EXPECT_NEAR(y, expected.y(), 1e-9);

      Jet xj, yj;
      CameraModelImgFromCam(camera.model_id, param_jets.data(), Jet(u * w, 0),
                            Jet(v * w, 1), Jet(w, 2), &xj, &yj);
      EXPECT_NEAR(xj.a, x, 1e-9);
      EXPECT_NEAR(yj.a, y, 1e-9);
      const double h = 1e-6;
      const double uvw[3] = {u * w, v * w, w};
      for (int d = 0; d < 3; ++d) {
        double plus[3] = {uvw[0], uvw[1], uvw[2]};
        double minus[3] = {uvw[0], uvw[1], uvw[2]};
        plus[d] += h;
        minus[d] -= h;
        double xp, yp, xm, ym;
        CameraModelImgFromCam(camera.model_id, camera.params.data(), plus[0],
                              plus[1], plus[2], &xp, &yp);
        CameraModelImgFromCam(camera.model_id, camera.params.data(), minus[0],
                              minus[1], minus[2], &xm, &ym);
        const double scale = 1.0 + std::abs(xj.v[d]) + std::abs(yj.v[d]);
        EXPECT_NEAR(xj.v[d], (xp - xm) / (2 * h), 1e-5 * scale)
            << CameraModelIdToName(camera.model_id) << " d" << d;
        EXPECT_NEAR(yj.v[d], (yp - ym) / (2 * h), 1e-5 * scale)
            << CameraModelIdToName(camera.model_id) << " d" << d;
      }
    }
  }
}

// Derivatives with respect to the intrinsics (what bundle adjustment refines).
TEST(CameraModels, TemplateDerivativesWithRespectToParameters) {
  typedef ceres::Jet<double, 12> Jet;
  const double u = 0.31, v = -0.22;
  for (const Camera& camera : RealisticCameras()) {
    const int num_params = camera.params.size();
    std::vector<Jet> param_jets(num_params);
    for (int i = 0; i < num_params; ++i) {
      param_jets[i] = Jet(camera.params[i], i);
    }
    Jet xj, yj;
    CameraModelImgFromCam(camera.model_id, param_jets.data(), Jet(u), Jet(v),
                          Jet(1.0), &xj, &yj);
    for (int i = 0; i < num_params; ++i) {
      const double h = 1e-6 * std::max(1.0, std::abs(camera.params[i]));
      std::vector<double> plus = camera.params, minus = camera.params;
      plus[i] += h;
      minus[i] -= h;
      double xp, yp, xm, ym;
      CameraModelImgFromCam(camera.model_id, plus.data(), u, v, 1.0, &xp, &yp);
      CameraModelImgFromCam(camera.model_id, minus.data(), u, v, 1.0, &xm, &ym);
      const double scale = 1.0 + std::abs(xj.v[i]) + std::abs(yj.v[i]);
      EXPECT_NEAR(xj.v[i], (xp - xm) / (2 * h), 1e-5 * scale)
          << CameraModelIdToName(camera.model_id) << " param " << i;
      EXPECT_NEAR(yj.v[i], (yp - ym) / (2 * h), 1e-5 * scale)
          << CameraModelIdToName(camera.model_id) << " param " << i;
    }
  }
}

// The FOV model's series branches (omega -> 0) agree with the closed form.
TEST(CameraModels, FOVSmallOmegaIsContinuous) {
  const Eigen::Vector2d point(0.4, -0.3);
  const Camera pinhole = MakeCamera(1, {500, 500, 320, 240});
  const Camera fov_zero = MakeCamera(7, {500, 500, 320, 240, 0.0});
  const Camera fov_tiny = MakeCamera(7, {500, 500, 320, 240, 1e-7});
  const Camera fov_small = MakeCamera(7, {500, 500, 320, 240, 1e-5});
  EXPECT_LT((CameraCameraToImage(fov_zero, point) -
             CameraCameraToImage(pinhole, point))
                .norm(),
            1e-12);
  EXPECT_LT((CameraCameraToImage(fov_tiny, point) -
             CameraCameraToImage(fov_small, point))
                .norm(),
            1e-6);
  EXPECT_LT((CameraImageToCamera(fov_tiny, Eigen::Vector2d(10, 20)) -
             CameraImageToCamera(fov_small, Eigen::Vector2d(10, 20)))
                .norm(),
            1e-8);
}

}  // namespace
}  // namespace colmap_irav4
