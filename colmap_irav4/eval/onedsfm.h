#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Readers for the 1DSfM datasets (Wilson and Snavely, ECCV 2014). Everything
// is converted to this project's convention at the reader: R_i =
// cam_from_world in OpenCV axes (x right, y down, looking down +z), R_ij =
// cam_j_from_cam_i = R_j R_i^T, t_ij the unit translation of cam_j_from_cam_i.
//
// The files use Bundler's camera axes (looking down -z, +y up), i.e.
// R_bundler = D R_opencv with D = diag(1, -1, -1), and EGs.txt stores
// R_i R_j^T (world-to-camera R_i), the transpose of our R_ij; the test
// onedsfm_test proves this direction on the real Madrid graph by triplet
// cycle consistency.

// One EGs.txt line, converted.
struct OneDsfmEdge {
  int i = -1;
  int j = -1;
  Eigen::Matrix3d R_ij = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_ij = Eigen::Vector3d::Zero();
};

// How to read the EGs.txt rotation; kStored keeps the file's matrix as is
// (only for the test that proves the direction).
enum class OneDsfmRotation { kConvert, kStored };

// EGs.txt: "i j r11 r12 ... r33 t1 t2 t3" per line. `num_images` (> 0) bounds
// the indices (from list.txt); pass 0 to skip the bound.
std::vector<OneDsfmEdge> ReadOneDsfmEdges(
    const std::string& path, int num_images = 0,
    OneDsfmRotation rotation = OneDsfmRotation::kConvert);
// list.txt: line k is image k ("<name> [0 <focal>]"); returns the names.
std::vector<std::string> ReadOneDsfmList(const std::string& path);
// cc.txt: one image index per line.
std::vector<int> ReadOneDsfmComponent(const std::string& path,
                                      int num_images = 0);

// A Bundler v0.3 camera, converted: R = cam_from_world (OpenCV axes), t its
// translation. Cameras that Bundler did not reconstruct (all-zero rotation)
// have registered = false.
struct BundlerCamera {
  double focal = 0.0;
  double k1 = 0.0;
  double k2 = 0.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  bool registered = false;
};
struct BundlerPoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  // Indices of the cameras that observe the point.
  std::vector<int> cameras;
};
struct BundlerFile {
  std::vector<BundlerCamera> cameras;
  std::vector<BundlerPoint> points;
};
BundlerFile ReadBundlerFile(const std::string& path);

// A 1DSfM scene directory (EGs.txt, list.txt, cc.txt, gt_bundle.out when
// present) as a rotation graph restricted to cc.txt's images (all images if
// cc.txt is absent), vertices named by list.txt's image names (or the index
// when list.txt is absent). Edge weights are 1 (EGs.txt has no inlier counts).
struct OneDsfmScene {
  RotationGraph graph;
  // graph vertex -> 1DSfM image index.
  std::vector<int> image_index;
  // Ground truth per vertex, from gt_bundle.out (empty when absent);
  // has_ground_truth[v] false for cameras Bundler did not reconstruct.
  std::vector<Eigen::Matrix3d> ground_truth;
  std::vector<bool> has_ground_truth;
};
OneDsfmScene ReadOneDsfmScene(const std::string& directory);

}  // namespace colmap_irav4
