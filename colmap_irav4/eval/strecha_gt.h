#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// Ground truth camera of the Strecha et al. (CVPR 2008) datasets, from a
// gt_cameras/<image>.camera file: K (3 rows), radial distortion (3 numbers),
// R = camera-to-world rotation (3 rows), C = camera centre, "W H".
// Projection x ~ K R^T (X - C), so cam_from_world = (R^T, -R^T C).
struct StrechaCamera {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Vector3d distortion = Eigen::Vector3d::Zero();
  Rigid3d cam_from_world;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  int width = 0;
  int height = 0;
};

// One .camera file; InputError naming the file if malformed.
StrechaCamera ReadStrechaCamera(const std::string& path);
// Every <name>.camera file of a gt_cameras directory, keyed by <name> (the
// image name, e.g. "0000.jpg").
std::map<std::string, StrechaCamera> ReadStrechaGroundTruth(
    const std::string& gt_dir);

// The starting point of the experiments on the stages after rotation
// averaging: every database image with all its keypoints, its ground truth
// rotation turned by `rotation_noise_deg` about a random axis (positions
// unknown), and every stored pair's inlier matches. InputError naming
// `gt_path` when an image has no ground truth camera.
struct StrechaStart {
  Reconstruction reconstruction;
  std::vector<ImagePairMatches> pairs;
};
StrechaStart MakeStrechaStart(const DatabaseContents& database,
                              const std::map<std::string, StrechaCamera>& gt,
                              const std::string& gt_path,
                              double rotation_noise_deg, uint64_t seed);

}  // namespace colmap_irav4
