#pragma once

#include <vector>

#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// One observation of a scene point: keypoint point2D_idx of image image_id.
struct TrackElement {
  image_t image_id = kInvalidImageId;
  point2D_t point2D_idx = kInvalidPoint2DIdx;
};

// A feature track: observations of one scene point, at most one per image,
// sorted by (image_id, point2D_idx).
typedef std::vector<TrackElement> Track;

}  // namespace colmap_irav4
