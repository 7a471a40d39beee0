#pragma once

#include <map>
#include <string>
#include <vector>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// Errors of a view graph's relative poses against ground-truth absolute poses
// (cam_from_world by image name): rotation d(R_ij, R_j R_i^T) and the angle
// between the unit t_ij and the ground-truth direction of cam_j_from_cam_i's
// translation (pairs with a translation only). Degrees.
struct RelativePoseErrors {
  int num_pairs = 0;  // pairs whose two images have ground truth
  std::vector<double> rotation_errors_deg;
  double rotation_median_deg = 0, rotation_mean_deg = 0, rotation_max_deg = 0;
  int num_rotation_over_5deg = 0;
  std::vector<double> translation_errors_deg;
  double translation_median_deg = 0, translation_mean_deg = 0,
         translation_max_deg = 0;
  int num_translation_over_5deg = 0;
  // Median rotation error against the transposed ground truth (R_i R_j^T):
  // large when the convention is right (a direction check).
  double rotation_median_transposed_deg = 0;
};

RelativePoseErrors EvaluateRelativePoses(
    const ViewGraph& view_graph,
    const std::map<std::string, Rigid3d>& gt_cam_from_world);

}  // namespace colmap_irav4
