#include "colmap_irav4/refinement/keypoint_noise.h"

#include <algorithm>

#include <glog/logging.h>

namespace colmap_irav4 {

size_t KeypointScaleNoise::Bin(float scale) const {
  return std::upper_bound(edges.begin(), edges.end(), scale) - edges.begin();
}

double KeypointScaleNoise::Factor(float scale) const {
  if (Empty()) return 1.0;
  CHECK_EQ(factors.size(), edges.size() + 1);
  return factors[Bin(scale)];
}

}  // namespace colmap_irav4
