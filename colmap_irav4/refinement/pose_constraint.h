#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// How well each camera of a model is held by its points: the uncertainty of
// its pose estimated from its own observations of points seen in at least
// min_track_length images (a resection, as incremental registration does,
// with the points held fixed), at 1 px of noise per keypoint coordinate.
// Two-view points are left out: they are checked by the pair's epipolar
// geometry alone and follow the camera they should hold (a wrong match
// between repeated structures bends the pair). castle-P19 on main 766c5e0,
// rotation uncertainty over the model's median: images 0012-0015 (0.37-0.87
// deg off the ground truth) 1.8, 4.9, 3.7 and 3.4, every other image at most
// 1.3; fountain-P11 at most 1.3, Herz-Jesus-P8 at most 1.5.
struct PoseConstraintOptions {
  // Points seen in fewer images are left out of the resection.
  int min_track_length = 3;
  // An image whose rotation uncertainty exceeds this multiple of the
  // model's median is poorly constrained (the mapper logs a warning).
  double max_relative_uncertainty = 1.75;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct ImagePoseConstraint {
  image_t image_id = kInvalidImageId;
  std::string name;
  size_t num_observations = 0;
  // Observations of points seen in min_track_length images or more.
  size_t num_multi_view_observations = 0;
  // Largest standard deviation of the rotation (deg) and of the centre over
  // the median depth of its points, at 1 px noise; infinite when its
  // multi-view points do not determine the pose.
  double rotation_uncertainty_deg = 0;
  double relative_center_uncertainty = 0;
  // rotation_uncertainty_deg over the model's median.
  double relative_uncertainty = 0;
  bool poorly_constrained = false;
};

// Every registered image's figures, least constrained first (ties: image id).
std::vector<ImagePoseConstraint> ComputePoseConstraints(
    const PoseConstraintOptions& options, const Reconstruction& reconstruction);

}  // namespace colmap_irav4
