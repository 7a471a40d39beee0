#pragma once

#include <cstddef>

#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// A point seen in two images only is checked by nothing but the epipolar
// geometry of its pair, and the poses it helped adjust: a wrong match that
// fits them (repeated structure: a match one arch along, near the epipolar
// line) bends the pair's relative pose towards itself until it passes the
// reprojection filter. Such matches are only caught by poses that do not
// depend on them. The check: the two-view points are set aside, the poses
// adjusted on the points seen three times or more, and the two-view tracks
// triangulated again from those poses (only consistent observations come
// back). castle-P19 (19 images, arches repeated along a courtyard): 66 of
// 1,667 two-view points have a reprojection error > 4 px under the ground
// truth poses, and the model's centre median is 55.9 mm with them, 23.9 mm
// without them (refinement_benchmark final_ba).
struct TwoViewCheckOptions {
  // Run the check (after retriangulation, before the next adjustment).
  bool enabled = true;
  // Only the two-view points between images that each have at least this
  // many observations of points seen three times or more are set aside: an
  // image with fewer keeps its two-view points in the pose adjustment, which
  // it needs to be held at all.
  int min_multi_view_observations = 100;
  // A set-aside track comes back when both its observations are within this
  // reprojection error (px; times the noise factor of the keypoint's scale
  // when the adjustment estimated one) under the checked poses.
  double max_reproj_error = 3.0;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct TwoViewCheckSummary {
  size_t num_points_checked = 0;  // two-view points set aside
  size_t num_points_restored = 0;
  size_t num_observations_restored = 0;
  BundleAdjustmentSummary bundle_adjustment;  // of the pose adjustment
};

// The check above. `bundle_adjustment` adjusts the poses (one round is
// enough: its filter runs on the multi-view points only), `triangulation`
// and `noise` (optional) triangulate the set-aside tracks again. Returns
// false if the adjustment failed (the model then has the poses and points
// before it, without the two-view points).
bool CheckTwoViewPoints(const TwoViewCheckOptions& options,
                        const BundleAdjustmentOptions& bundle_adjustment,
                        const TriangulationOptions& triangulation,
                        Reconstruction* reconstruction,
                        const KeypointScaleNoise* noise,
                        TwoViewCheckSummary* summary);

}  // namespace colmap_irav4
