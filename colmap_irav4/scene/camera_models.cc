#include "colmap_irav4/scene/camera_models.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include <ceres/jet.h>
#include <glog/logging.h>
#include <Eigen/LU>

namespace colmap_irav4 {
namespace {

struct ModelInfo {
  const char* name;
  int num_params;
  const char* params_info;
};

// Indexed by model id.
const ModelInfo kModelInfos[kNumCameraModels] = {
    {"SIMPLE_PINHOLE", 3, "f, cx, cy"},
    {"PINHOLE", 4, "fx, fy, cx, cy"},
    {"SIMPLE_RADIAL", 4, "f, cx, cy, k"},
    {"RADIAL", 5, "f, cx, cy, k1, k2"},
    {"OPENCV", 8, "fx, fy, cx, cy, k1, k2, p1, p2"},
    {"OPENCV_FISHEYE", 8, "fx, fy, cx, cy, k1, k2, k3, k4"},
    {"FULL_OPENCV", 12, "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6"},
    {"FOV", 5, "fx, fy, cx, cy, omega"},
    {"SIMPLE_RADIAL_FISHEYE", 4, "f, cx, cy, k"},
    {"RADIAL_FISHEYE", 5, "f, cx, cy, k1, k2"},
    {"THIN_PRISM_FISHEYE", 12,
     "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1"},
};

void CheckCamera(const Camera& camera) {
  CHECK(CameraHasValidParams(camera))
      << "Camera " << camera.camera_id << " has model id " << camera.model_id
      << " and " << camera.params.size() << " parameters";
}

// Solves D(p) = target for p by Newton's method, starting at the target (the
// distortion is a perturbation of the identity); the Jacobian of D comes
// from automatic differentiation.
Eigen::Vector2d InvertDistortion(int model_id, const double* extra,
                                 const Eigen::Vector2d& target) {
  typedef ceres::Jet<double, 2> Jet;
  constexpr int kMaxNumIterations = 100;
  // Jets of the parameters with zero derivatives.
  Jet extra_jets[8];
  const int num_extra =
      CameraModelNumParams(model_id) - CameraModelExtraParamsOffset(model_id);
  for (int i = 0; i < num_extra; ++i) extra_jets[i] = Jet(extra[i]);

  Eigen::Vector2d p = target;
  for (int iteration = 0; iteration < kMaxNumIterations; ++iteration) {
    Jet ud, vd;
    CameraModelDistort(model_id, extra_jets, Jet(p.x(), 0), Jet(p.y(), 1), &ud,
                       &vd);
    const Eigen::Vector2d residual(ud.a - target.x(), vd.a - target.y());
    Eigen::Matrix2d jacobian;
    jacobian.row(0) = ud.v.transpose();
    jacobian.row(1) = vd.v.transpose();
    const double det = jacobian.determinant();
    if (!std::isfinite(det) || std::abs(det) < 1e-300) break;
    const Eigen::Vector2d step = jacobian.inverse() * residual;
    p -= step;
    if (!p.allFinite()) break;
    // Newton converges quadratically; stop at the precision of doubles.
    if (step.norm() <= 1e-15 * (1.0 + p.norm())) break;
  }
  // Pixels outside the model's image (where the distortion folds back) have
  // no solution: say so rather than return where Newton stopped.
  double ud, vd;
  CameraModelDistort(model_id, extra, p.x(), p.y(), &ud, &vd);
  if (!p.allFinite() || (Eigen::Vector2d(ud, vd) - target).norm() >
                            1e-9 * (1.0 + target.norm())) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return p;
}

}  // namespace

bool IsValidCameraModelId(int model_id) {
  return model_id >= 0 && model_id < kNumCameraModels;
}

int CameraModelNameToId(const std::string& name) {
  for (int id = 0; id < kNumCameraModels; ++id) {
    if (name == kModelInfos[id].name) return id;
  }
  return -1;
}

std::string CameraModelIdToName(int model_id) {
  return IsValidCameraModelId(model_id) ? kModelInfos[model_id].name : "";
}

int CameraModelNumParams(int model_id) {
  return IsValidCameraModelId(model_id) ? kModelInfos[model_id].num_params : -1;
}

std::string CameraModelParamsInfo(int model_id) {
  return IsValidCameraModelId(model_id) ? kModelInfos[model_id].params_info
                                        : "";
}

std::vector<int> CameraModelFocalLengthIdxs(int model_id) {
  if (!IsValidCameraModelId(model_id)) return {};
  if (CameraModelHasSingleFocal(model_id)) return {0};
  return {0, 1};
}

std::vector<int> CameraModelPrincipalPointIdxs(int model_id) {
  if (!IsValidCameraModelId(model_id)) return {};
  if (CameraModelHasSingleFocal(model_id)) return {1, 2};
  return {2, 3};
}

std::vector<int> CameraModelExtraParamsIdxs(int model_id) {
  if (!IsValidCameraModelId(model_id)) return {};
  std::vector<int> idxs;
  for (int i = CameraModelExtraParamsOffset(model_id);
       i < CameraModelNumParams(model_id); ++i) {
    idxs.push_back(i);
  }
  return idxs;
}

bool CameraHasValidParams(const Camera& camera) {
  return IsValidCameraModelId(camera.model_id) &&
         static_cast<int>(camera.params.size()) ==
             CameraModelNumParams(camera.model_id);
}

double CameraMeanFocalLength(const Camera& camera) {
  CheckCamera(camera);
  const std::vector<int> idxs = CameraModelFocalLengthIdxs(camera.model_id);
  double sum = 0.0;
  for (const int idx : idxs) sum += camera.params[idx];
  return sum / idxs.size();
}

bool CameraHasBogusParams(const Camera& camera, double min_focal_length_ratio,
                          double max_focal_length_ratio,
                          double max_extra_param) {
  CheckCamera(camera);
  const double max_size =
      static_cast<double>(std::max(camera.width, camera.height));
  for (const int idx : CameraModelFocalLengthIdxs(camera.model_id)) {
    const double ratio = camera.params[idx] / max_size;
    // Written so that a NaN parameter is bogus too.
    if (!(ratio >= min_focal_length_ratio && ratio <= max_focal_length_ratio)) {
      return true;
    }
  }
  const std::vector<int> principal =
      CameraModelPrincipalPointIdxs(camera.model_id);
  const double cx = camera.params[principal[0]];
  const double cy = camera.params[principal[1]];
  if (!(cx >= 0 && cx <= static_cast<double>(camera.width) && cy >= 0 &&
        cy <= static_cast<double>(camera.height))) {
    return true;
  }
  for (const int idx : CameraModelExtraParamsIdxs(camera.model_id)) {
    if (!(std::abs(camera.params[idx]) <= max_extra_param)) return true;
  }
  return false;
}

namespace {

// Pixel -> undistorted point on the pinhole plane, or on the equidistant
// plane (|p| = angle from the optical axis) for the fisheye models and for
// FOV at non-zero radius; *equidistant says which.
Eigen::Vector2d ImageToUndistortedPlane(const Camera& camera,
                                        const Eigen::Vector2d& image_point,
                                        bool* equidistant) {
  CheckCamera(camera);
  const int model_id = camera.model_id;
  const double* params = camera.params.data();
  Eigen::Vector2d p;
  if (CameraModelHasSingleFocal(model_id)) {
    p = Eigen::Vector2d((image_point.x() - params[1]) / params[0],
                        (image_point.y() - params[2]) / params[0]);
  } else {
    p = Eigen::Vector2d((image_point.x() - params[2]) / params[0],
                        (image_point.y() - params[3]) / params[1]);
  }
  const double* extra = params + CameraModelExtraParamsOffset(model_id);
  *equidistant = false;
  switch (model_id) {
    case kSimplePinhole:
    case kPinhole:
      return p;
    case kFOV: {
      // r_d = atan(2 r tan(omega / 2)) / omega: the angle of the ray is
      // atan(r) = atan(tan(r_d omega) / (2 tan(omega / 2))). Return the
      // equidistant point (angle along the direction of p).
      // The model is even in omega.
      const double omega = std::abs(extra[0]);
      const double rd = p.norm();
      if (rd < 1e-7 || omega * omega < 1e-12) {
        // No wide angles here: the pinhole point is accurate.
        return p * internal::FOVUndistortionFactor(omega, p.squaredNorm());
      }
      const double s = std::sin(rd * omega);
      const double c = std::cos(rd * omega);
      // atan(tan(a) / b) for a in [0, pi), b > 0, continuous through pi/2.
      *equidistant = true;
      return p / rd * std::atan2(s, c * 2.0 * std::tan(0.5 * omega));
    }
    default:
      break;
  }
  p = InvertDistortion(model_id, extra, p);
  *equidistant = CameraModelIsFisheye(model_id);
  return p;
}

}  // namespace

Eigen::Vector2d CameraImageToCamera(const Camera& camera,
                                    const Eigen::Vector2d& image_point) {
  bool equidistant;
  Eigen::Vector2d p =
      ImageToUndistortedPlane(camera, image_point, &equidistant);
  if (equidistant) {
    // Equidistant plane -> pinhole plane: r = tan(theta).
    const double theta = p.norm();
    if (theta >= 0.5 * M_PI) {
      return Eigen::Vector2d::Constant(
          std::numeric_limits<double>::quiet_NaN());
    }
    if (theta > 1e-8) {
      p *= std::tan(theta) / theta;
    } else {
      p *= 1.0 + theta * theta / 3.0;
    }
  }
  return p;
}

Eigen::Vector3d CameraImageToRay(const Camera& camera,
                                 const Eigen::Vector2d& image_point) {
  bool equidistant;
  const Eigen::Vector2d p =
      ImageToUndistortedPlane(camera, image_point, &equidistant);
  if (!equidistant) return p.homogeneous().normalized();
  const double theta = p.norm();
  if (theta < 1e-12) return Eigen::Vector3d(p.x(), p.y(), 1.0).normalized();
  const double scale = std::sin(theta) / theta;
  return Eigen::Vector3d(p.x() * scale, p.y() * scale, std::cos(theta));
}

Eigen::Vector2d CameraCameraToImage(const Camera& camera,
                                    const Eigen::Vector2d& camera_point) {
  CheckCamera(camera);
  Eigen::Vector2d image_point;
  CameraModelImgFromCam(camera.model_id, camera.params.data(), camera_point.x(),
                        camera_point.y(), 1.0, &image_point.x(),
                        &image_point.y());
  return image_point;
}

}  // namespace colmap_irav4
