#pragma once

#include <string>
#include <vector>

#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// A camera (intrinsics) as COLMAP stores it. The model ids and parameter
// orders are COLMAP's (0 SIMPLE_PINHOLE ... 10 THIN_PRISM_FISHEYE); the
// projection functions live in scene/camera_models.h.
struct Camera {
  camera_t camera_id = kInvalidCameraId;
  int model_id = -1;
  uint64_t width = 0;
  uint64_t height = 0;
  std::vector<double> params;
  bool has_prior_focal_length = false;
};

}  // namespace colmap_irav4
