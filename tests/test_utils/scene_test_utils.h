#pragma once

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {
namespace test {

// Largest distance between the estimated camera centres, aligned onto the
// true ones by a least-squares similarity, and the true centres, relative to
// the scene radius.
inline double MaxRelativeCenterError(const Reconstruction& estimate,
                                     const Reconstruction& truth,
                                     double scene_radius) {
  std::vector<Eigen::Vector3d> src, dst;
  for (const auto& [image_id, image] : estimate.images) {
    src.push_back(image.ProjectionCenter());
    dst.push_back(truth.images.at(image_id).ProjectionCenter());
  }
  Sim3d sim;
  EXPECT_TRUE(EstimateSimilarity(src, dst, &sim));
  double max_error = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    max_error = std::max(max_error, (sim * src[i] - dst[i]).norm());
  }
  return max_error / scene_radius;
}

// Largest distance between the estimated and the true camera centres, as
// they are (no alignment: a model placed by pose priors in the truth's
// frame).
inline double MaxUnalignedCenterError(const Reconstruction& estimate,
                                      const Reconstruction& truth) {
  double max_error = 0;
  for (const auto& [image_id, image] : estimate.images) {
    max_error =
        std::max(max_error, (image.ProjectionCenter() -
                             truth.images.at(image_id).ProjectionCenter())
                                .norm());
  }
  return max_error;
}

}  // namespace test
}  // namespace colmap_irav4
