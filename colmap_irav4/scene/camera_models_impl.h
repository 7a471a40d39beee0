#pragma once

// Template definitions of camera_models.h (to be implemented).

namespace colmap_irav4 {

template <typename T>
void CameraModelImgFromCam(int model_id, const T* params, T u, T v, T w, T* x,
                           T* y);

}  // namespace colmap_irav4
