#pragma once

#include <map>
#include <ostream>
#include <string>

#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/view_graph/focal_calibration.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

struct ViewGraphBuilderOptions {
  // Minimum number of inlier matches of a verified pair (COLMAP's mapper:
  // min_num_matches = 15).
  int min_num_inliers = 15;
  // Minimum inliers / raw matches; only applied where the database still has
  // the raw matches (0 disables).
  double min_inlier_ratio = 0.0;
  // Comma-separated configurations whose pairs are dropped (COLMAP names).
  std::string drop_configs = "UNDEFINED,DEGENERATE,WATERMARK,MULTIPLE";
  // Keep only the largest connected component (by images).
  bool keep_largest_component = true;
  // Threads deriving the relative poses (-1: all cores).
  int num_threads = -1;
  // Focal self-calibration of cameras without a prior focal, before the
  // relative poses are derived.
  FocalCalibrationOptions focal_calibration;
  RelativePoseOptions relative_pose;

  // Throws InputError naming the option if invalid.
  void Check() const;
  // The parsed drop_configs (CHECKs validity: call Check() first).
  std::vector<int> DropConfigs() const;
};

// What the builder read, dropped and kept.
struct ViewGraphSummary {
  int num_cameras = 0;
  int num_images = 0;
  int num_pairs_read = 0;
  int num_pairs_kept = 0;
  std::map<std::string, int> num_dropped;         // by reason
  std::map<std::string, int> num_kept_by_source;  // relative pose source
  int num_kept_without_translation = 0;
  // Connected components of the kept pairs; a candidate component outside
  // the largest, whose poses are not derived, counts as one.
  int num_components = 0;
  int num_images_in_component = 0;
  std::vector<FocalCalibrationResult> focal_calibration;

  void Print(std::ostream& stream) const;
};

// Builds the epipolar graph: filters the verified pairs, derives each kept
// pair's relative pose (R = cam2_from_cam1, unit t) and keeps the largest
// connected component (with keep_largest_component, the poses of pairs
// outside the largest component of the filtered pairs are not derived: they
// count as "outside the largest component"). view_graph.image_names holds the
// component's images; pairs keep the database orientation (image_id1 <
// image_id2). view_graph.cameras are the database's cameras with the focal
// lengths of those without a prior self-calibrated (options.focal_calibration).
// `cameras` (optional, every camera of the database): the intrinsics to
// derive the relative poses with instead of the database's (e.g. a first
// mapping's refined cameras).
ViewGraph BuildViewGraph(const DatabaseContents& database,
                         const ViewGraphBuilderOptions& options,
                         ViewGraphSummary* summary,
                         const std::map<camera_t, Camera>* cameras = nullptr);

}  // namespace colmap_irav4
