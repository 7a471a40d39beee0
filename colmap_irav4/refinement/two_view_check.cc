#include "colmap_irav4/refinement/two_view_check.h"

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

void TwoViewCheckOptions::Check() const {
  if (min_multi_view_observations < 0) {
    throw OptionError(&min_multi_view_observations,
                      "TwoViewCheck.min_multi_view_observations",
                      "must be >= 0");
  }
  if (!(max_reproj_error > 0)) {
    throw OptionError(&max_reproj_error, "TwoViewCheck.max_reproj_error",
                      "must be > 0");
  }
}

bool CheckTwoViewPoints(const TwoViewCheckOptions& options,
                        const BundleAdjustmentOptions& bundle_adjustment,
                        const TriangulationOptions& triangulation,
                        const PoseConstraintOptions& pose_constraint,
                        Reconstruction* reconstruction,
                        const KeypointScaleNoise* noise,
                        TwoViewCheckSummary* summary) {
  *summary = TwoViewCheckSummary();
  std::map<image_t, size_t> multi_view_observations;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    if (point.track.size() < 3) continue;
    for (const TrackElement& element : point.track) {
      ++multi_view_observations[element.image_id];
    }
  }
  const auto held = [&](image_t image_id) {
    const auto it = multi_view_observations.find(image_id);
    return it != multi_view_observations.end() &&
           it->second >=
               static_cast<size_t>(options.min_multi_view_observations);
  };
  std::vector<Track> set_aside;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    if (point.track.size() == 2 && held(point.track[0].image_id) &&
        held(point.track[1].image_id)) {
      set_aside.push_back(point.track);
    }
  }
  if (set_aside.empty()) return true;
  for (const Track& track : set_aside) {
    const point3D_t point3D_id = reconstruction->images.at(track[0].image_id)
                                     .points2D[track[0].point2D_idx]
                                     .point3D_id;
    DeletePoint3D(point3D_id, reconstruction);
  }
  summary->num_points_checked = set_aside.size();
  BundleAdjustmentOptions pose_options = bundle_adjustment;
  pose_options.num_rounds = 1;
  if (!RunBundleAdjustment(pose_options, reconstruction,
                           &summary->bundle_adjustment)) {
    return false;
  }
  const KeypointScaleNoise* check_noise =
      summary->bundle_adjustment.keypoint_noise.Empty()
          ? noise
          : &summary->bundle_adjustment.keypoint_noise;
  // An image its multi-view points hold poorly cannot check a two-view
  // match: the match's error under that pose says little, and the match
  // would be much of what holds it.
  if (options.withhold_poorly_constrained) {
    std::set<image_t> poorly_constrained;
    for (const ImagePoseConstraint& constraint :
         ComputePoseConstraints(pose_constraint, *reconstruction)) {
      if (constraint.poorly_constrained) {
        poorly_constrained.insert(constraint.image_id);
      }
    }
    const size_t num_before = set_aside.size();
    set_aside.erase(
        std::remove_if(set_aside.begin(), set_aside.end(),
                       [&](const Track& track) {
                         return poorly_constrained.count(track[0].image_id) ||
                                poorly_constrained.count(track[1].image_id);
                       }),
        set_aside.end());
    summary->num_points_withheld = num_before - set_aside.size();
    summary->num_images_poorly_constrained = poorly_constrained.size();
  }
  TriangulationOptions two_view = triangulation;
  two_view.ignore_two_view_tracks = false;  // they are all two-view
  two_view.max_reproj_error = options.max_reproj_error;
  const TriangulationSummary restored =
      TriangulateTracks(two_view, set_aside, reconstruction, check_noise);
  summary->num_points_restored = restored.num_points_added;
  summary->num_observations_restored = restored.num_observations_added;
  return true;
}

}  // namespace colmap_irav4
