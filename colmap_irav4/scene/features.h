#pragma once

#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// Keypoint positions of one image in pixels (COLMAP's convention: the centre
// of the top-left pixel is (0.5, 0.5)). The database stores 2, 4 or 6 floats
// per keypoint; only x, y are kept (shape parameters are not used).
typedef std::vector<Eigen::Vector2f> FeatureKeypoints;

// A correspondence between keypoint point2D_idx1 of the first image of a pair
// and keypoint point2D_idx2 of the second.
struct FeatureMatch {
  point2D_t point2D_idx1 = kInvalidPoint2DIdx;
  point2D_t point2D_idx2 = kInvalidPoint2DIdx;
};
typedef std::vector<FeatureMatch> FeatureMatches;

// The inlier matches of one verified image pair: (point2D_idx in image_id1,
// point2D_idx in image_id2).
struct ImagePairMatches {
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  std::vector<std::pair<point2D_t, point2D_t>> matches;
};

}  // namespace colmap_irav4
