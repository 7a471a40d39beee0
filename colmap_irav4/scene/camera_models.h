#pragma once

// The eleven camera models of COLMAP 3.8, with COLMAP's ids, names and
// parameter orders:
//   0 SIMPLE_PINHOLE f,cx,cy            1 PINHOLE fx,fy,cx,cy
//   2 SIMPLE_RADIAL f,cx,cy,k           3 RADIAL f,cx,cy,k1,k2
//   4 OPENCV fx,fy,cx,cy,k1,k2,p1,p2    5 OPENCV_FISHEYE fx,fy,cx,cy,k1..k4
//   6 FULL_OPENCV fx,fy,cx,cy,k1,k2,p1,p2,k3,k4,k5,k6
//   7 FOV fx,fy,cx,cy,omega             8 SIMPLE_RADIAL_FISHEYE f,cx,cy,k
//   9 RADIAL_FISHEYE f,cx,cy,k1,k2
//   10 THIN_PRISM_FISHEYE fx,fy,cx,cy,k1,k2,p1,p2,k3,k4,sx1,sy1
//
// "Image" coordinates are pixels (COLMAP's convention: the centre of the
// top-left pixel is (0.5, 0.5)); "camera" coordinates are the normalised,
// undistorted image plane (x/z, y/z).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "colmap_irav4/scene/camera.h"

namespace colmap_irav4 {

constexpr int kNumCameraModels = 11;

bool IsValidCameraModelId(int model_id);
// -1 for an unknown name / id.
int CameraModelNameToId(const std::string& name);
std::string CameraModelIdToName(int model_id);  // "" if unknown
int CameraModelNumParams(int model_id);         // -1 if unknown
// Parameter names, comma separated, e.g. "fx, fy, cx, cy".
std::string CameraModelParamsInfo(int model_id);
// Indices of the focal length(s), principal point and extra (distortion)
// parameters in the params vector.
std::vector<int> CameraModelFocalLengthIdxs(int model_id);
std::vector<int> CameraModelPrincipalPointIdxs(int model_id);
std::vector<int> CameraModelExtraParamsIdxs(int model_id);
// Whether the params vector has the model's size (and the model is valid).
bool CameraHasValidParams(const Camera& camera);
// Mean focal length in pixels.
double CameraMeanFocalLength(const Camera& camera);
// Whether the parameters are no plausible camera, as COLMAP's
// Camera::HasBogusParams judges them: a focal length outside
// [min_focal_length_ratio, max_focal_length_ratio] x the larger image side
// (negative ones included), a principal point outside the image, or an extra
// (distortion) parameter larger than max_extra_param in absolute value.
bool CameraHasBogusParams(const Camera& camera, double min_focal_length_ratio,
                          double max_focal_length_ratio,
                          double max_extra_param);

// Pixel -> normalised undistorted camera plane (iterative undistortion where
// COLMAP's is). A fisheye (or FOV) pixel seen at 90 degrees or more off-axis
// has no point on that plane: the result is then NaN (use CameraImageToRay).
Eigen::Vector2d CameraImageToCamera(const Camera& camera,
                                    const Eigen::Vector2d& image_point);
// Pixel -> unit viewing ray in camera coordinates, valid at every angle
// (fisheye lenses see beyond 90 degrees).
Eigen::Vector3d CameraImageToRay(const Camera& camera,
                                 const Eigen::Vector2d& image_point);
// Normalised undistorted camera plane -> pixel.
Eigen::Vector2d CameraCameraToImage(const Camera& camera,
                                    const Eigen::Vector2d& camera_point);

// Projection of a point in camera coordinates (u, v, w) with w > 0 to pixels,
// templated for Ceres' automatic differentiation (bundle adjustment).
template <typename T>
void CameraModelImgFromCam(int model_id, const T* params, T u, T v, T w, T* x,
                           T* y);

}  // namespace colmap_irav4

#include "colmap_irav4/scene/camera_models_impl.h"
