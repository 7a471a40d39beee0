#pragma once

// A picture of a sparse model without a GUI: the points and the camera
// frusta seen from above (top view) and from the side, side by side, drawn
// with OpenCV. "Up" is the mean up direction of the cameras (COLMAP's image
// y axis points down), the horizontal axes are the principal axes of the
// points, and the extent is robust (percentiles), so that a few far points
// do not shrink the model to a dot.

#include <string>

#include <opencv2/core.hpp>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

struct ModelRenderOptions {
  // Size of the whole picture (two square-ish panels side by side), px.
  int width = 1600;
  int height = 800;
  // Points drawn with their colours; all-grey models are coloured by height.
  int point_radius_px = 1;
  // Frustum depth as a fraction of the model's extent.
  double frustum_scale = 0.03;
  // Extent of the view: this percentile range of the points and centres.
  double extent_percentile = 2.0;

  void Check() const;  // throws InputError naming the option
};

// BGR 8-bit image of `model` (white background). Throws InputError if the
// model has no images.
cv::Mat RenderModel(const Reconstruction& model,
                    const ModelRenderOptions& options);

}  // namespace colmap_irav4
