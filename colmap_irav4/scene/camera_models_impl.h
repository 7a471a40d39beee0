#pragma once

// Template definitions of camera_models.h: the projection of every model,
// written once for T = double and T = ceres::Jet (automatic differentiation).
//
// A projection is split in three steps:
//   1. for the fisheye models, the pinhole point (u, v) = (X/Z, Y/Z) is mapped
//      to the equidistant plane (theta * u / r, theta * v / r), theta =
//      atan(r), r = |(u, v)|;
//   2. the model's distortion D in that plane (or on the pinhole plane for
//      the perspective models): CameraModelDistort below;
//   3. the affine map to pixels (focal lengths, principal point).
// CameraImageToCamera inverts step 2 by Newton's method (Jacobian by Jet) in
// the same plane, which stays well conditioned for fisheye points at wide
// angles, where the pinhole coordinates diverge.

#include <cmath>
#include <limits>

#include <ceres/jet.h>
#include <glog/logging.h>

namespace colmap_irav4 {

// Model ids (COLMAP's).
enum CameraModelId : int {
  kSimplePinhole = 0,
  kPinhole = 1,
  kSimpleRadial = 2,
  kRadial = 3,
  kOpenCV = 4,
  kOpenCVFisheye = 5,
  kFullOpenCV = 6,
  kFOV = 7,
  kSimpleRadialFisheye = 8,
  kRadialFisheye = 9,
  kThinPrismFisheye = 10,
};

// Whether the model's distortion acts on the equidistant (fisheye) plane.
inline bool CameraModelIsFisheye(int model_id) {
  return model_id == kOpenCVFisheye || model_id == kSimpleRadialFisheye ||
         model_id == kRadialFisheye || model_id == kThinPrismFisheye;
}

// Models with one focal length (f, cx, cy, extra...); the others have
// (fx, fy, cx, cy, extra...).
inline bool CameraModelHasSingleFocal(int model_id) {
  return model_id == kSimplePinhole || model_id == kSimpleRadial ||
         model_id == kRadial || model_id == kSimpleRadialFisheye ||
         model_id == kRadialFisheye;
}

// Index of the first extra (distortion) parameter.
inline int CameraModelExtraParamsOffset(int model_id) {
  return CameraModelHasSingleFocal(model_id) ? 3 : 4;
}

namespace internal {

// OpenCV's radial + tangential terms added to (u, v).
template <typename T>
inline void AddTangential(T p1, T p2, T u, T v, T r2, T* du, T* dv) {
  *du += T(2) * p1 * u * v + p2 * (r2 + T(2) * u * u);
  *dv += T(2) * p2 * u * v + p1 * (r2 + T(2) * v * v);
}

// FOV model (Devernay-Faugeras): r_d = atan(2 r tan(omega / 2)) / omega.
// Returns r_d / r; the series cover omega -> 0 and r -> 0, where the closed
// form divides by zero (their truncation errors are below 1e-20).
template <typename T>
inline T FOVDistortionFactor(T omega, T r2) {
  using std::atan;
  using std::sqrt;
  using std::tan;
  const T omega2 = omega * omega;
  if (omega2 < T(1e-12)) {
    // atan(r (omega + omega^3 / 12)) / (r omega) to second order in omega.
    return T(1) + omega2 / T(12) - omega2 * r2 / T(3);
  }
  const T a = T(2) * tan(omega / T(2));
  if (r2 < T(1e-14)) {
    // atan(a r) / (r omega) to second order in r.
    return a / omega * (T(1) - a * a * r2 / T(3));
  }
  const T r = sqrt(r2);
  return atan(a * r) / (r * omega);
}

// Inverse: r = tan(r_d omega) / (2 tan(omega / 2)); returns r / r_d.
template <typename T>
inline T FOVUndistortionFactor(T omega, T rd2) {
  using std::sqrt;
  using std::tan;
  const T omega2 = omega * omega;
  if (omega2 < T(1e-12)) {
    return T(1) - omega2 / T(12) + omega2 * rd2 / T(3);
  }
  const T a = T(2) * tan(omega / T(2));
  if (rd2 < T(1e-14)) {
    return omega / a * (T(1) + omega2 * rd2 / T(3));
  }
  const T rd = sqrt(rd2);
  return tan(rd * omega) / (rd * a);
}

}  // namespace internal

// Step 1 of the fisheye models: pinhole plane -> equidistant plane.
template <typename T>
inline void PinholeToEquidistant(T u, T v, T* uu, T* vv) {
  using std::atan;
  using std::sqrt;
  const T r2 = u * u + v * v;
  if (r2 > T(std::numeric_limits<double>::epsilon())) {
    const T r = sqrt(r2);
    const T scale = atan(r) / r;
    *uu = u * scale;
    *vv = v * scale;
  } else {
    // atan(r) / r = 1 - r^2 / 3 + O(r^4).
    const T scale = T(1) - r2 / T(3);
    *uu = u * scale;
    *vv = v * scale;
  }
}

// Step 2: the model's distortion D; `extra` points at the first extra
// parameter. For the fisheye models (u, v) is on the equidistant plane. For
// FOV this is the whole (non-additive) distortion. Models without distortion
// return (u, v).
template <typename T>
inline void CameraModelDistort(int model_id, const T* extra, T u, T v, T* ud,
                               T* vd) {
  using std::sqrt;
  switch (model_id) {
    case kSimplePinhole:
    case kPinhole:
      *ud = u;
      *vd = v;
      return;
    case kSimpleRadial: {
      const T radial = T(1) + extra[0] * (u * u + v * v);
      *ud = u * radial;
      *vd = v * radial;
      return;
    }
    case kRadial: {
      const T r2 = u * u + v * v;
      const T radial = T(1) + extra[0] * r2 + extra[1] * r2 * r2;
      *ud = u * radial;
      *vd = v * radial;
      return;
    }
    case kOpenCV: {  // k1, k2, p1, p2
      const T r2 = u * u + v * v;
      const T radial = T(1) + extra[0] * r2 + extra[1] * r2 * r2;
      *ud = u * radial;
      *vd = v * radial;
      internal::AddTangential(extra[2], extra[3], u, v, r2, ud, vd);
      return;
    }
    case kFullOpenCV: {  // k1, k2, p1, p2, k3, k4, k5, k6
      const T r2 = u * u + v * v;
      const T r4 = r2 * r2;
      const T r6 = r4 * r2;
      const T radial = (T(1) + extra[0] * r2 + extra[1] * r4 + extra[4] * r6) /
                       (T(1) + extra[5] * r2 + extra[6] * r4 + extra[7] * r6);
      *ud = u * radial;
      *vd = v * radial;
      internal::AddTangential(extra[2], extra[3], u, v, r2, ud, vd);
      return;
    }
    case kOpenCVFisheye: {  // theta_d = theta (1 + k1 t^2 + ... + k4 t^8)
      const T t2 = u * u + v * v;
      const T radial =
          T(1) +
          t2 * (extra[0] + t2 * (extra[1] + t2 * (extra[2] + t2 * extra[3])));
      *ud = u * radial;
      *vd = v * radial;
      return;
    }
    case kSimpleRadialFisheye: {
      const T radial = T(1) + extra[0] * (u * u + v * v);
      *ud = u * radial;
      *vd = v * radial;
      return;
    }
    case kRadialFisheye: {
      const T t2 = u * u + v * v;
      const T radial = T(1) + t2 * (extra[0] + t2 * extra[1]);
      *ud = u * radial;
      *vd = v * radial;
      return;
    }
    case kThinPrismFisheye: {  // k1, k2, p1, p2, k3, k4, sx1, sy1
      const T t2 = u * u + v * v;
      const T radial =
          T(1) +
          t2 * (extra[0] + t2 * (extra[1] + t2 * (extra[4] + t2 * extra[5])));
      *ud = u * radial + extra[6] * t2;
      *vd = v * radial + extra[7] * t2;
      internal::AddTangential(extra[2], extra[3], u, v, t2, ud, vd);
      return;
    }
    case kFOV: {
      const T factor = internal::FOVDistortionFactor(extra[0], u * u + v * v);
      *ud = u * factor;
      *vd = v * factor;
      return;
    }
    default:
      LOG(FATAL) << "Invalid camera model id " << model_id;
  }
}

template <typename T>
void CameraModelImgFromCam(int model_id, const T* params, T u, T v, T w, T* x,
                           T* y) {
  T un = u / w;
  T vn = v / w;
  if (CameraModelIsFisheye(model_id)) {
    PinholeToEquidistant(u / w, v / w, &un, &vn);
  }
  T ud, vd;
  CameraModelDistort(model_id, params + CameraModelExtraParamsOffset(model_id),
                     un, vn, &ud, &vd);
  if (CameraModelHasSingleFocal(model_id)) {
    *x = params[0] * ud + params[1];
    *y = params[0] * vd + params[2];
  } else {
    *x = params[0] * ud + params[2];
    *y = params[1] * vd + params[3];
  }
}

}  // namespace colmap_irav4
