#pragma once

#include <string>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// Point colours: mean over each track of the image pixel at the observation
// (images read from image_path with OpenCV); points whose images are all
// missing stay grey (128). Returns the number of images that could not be
// used (each logged once with the reason): missing or unreadable, not a
// regular file (never opened: a named pipe would block), or of another size
// than their camera's.
// `downscale` (1, 2, 4, 8): the images are decoded at that fraction of their
// size (JPEG's DCT scaling) and sampled at the scaled positions.
// Images are read on up to `num_threads` threads (-1: all cores); the result
// does not depend on the thread count.
int ColorPointsFromImages(const std::string& image_path,
                          Reconstruction* reconstruction, int downscale = 1,
                          int num_threads = 1);

}  // namespace colmap_irav4
