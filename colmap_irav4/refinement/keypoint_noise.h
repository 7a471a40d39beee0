#pragma once

#include <cstddef>
#include <vector>

namespace colmap_irav4 {

// The reprojection noise of keypoints by their scale (Point2D::scale),
// relative to the noise of all observations: equal-count bins of scale, each
// with its factor (the bin's median reprojection error over that of all).
// Bundle adjustment estimates it (weight_by_keypoint_scale) and divides each
// residual by its factor; with filter_by_keypoint_noise the reprojection
// filters and the triangulation multiply their pixel thresholds by it, so
// that a threshold means the same number of noise units at every scale.
struct KeypointScaleNoise {
  // The bins' inner edges, px, ascending; a scale on an edge is in the bin
  // above it.
  std::vector<float> edges;
  // One per bin (edges.size() + 1) once estimated; empty: the noise is the
  // same at every scale.
  std::vector<double> factors;

  bool Empty() const { return factors.empty(); }
  // The bin of a scale: the number of edges at or below it.
  size_t Bin(float scale) const;
  // The factor of a keypoint of this scale; 1 when Empty().
  double Factor(float scale) const;
};

}  // namespace colmap_irav4
