#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Relative poses as written by `colmap_irav4 view_graph`, one pair a line:
//   IMG1 IMG2 QW QX QY QZ TX TY TZ [INLIERS]
// with q, t = cam2_from_cam1 (so R_12 in our convention). Returns a rotation
// graph with one vertex per image name in order of first appearance, edge
// weights = INLIERS (1 when the column is absent). A repeated pair keeps its
// first line (with a warning). Throws InputError("<path>", "line <n>: ...")
// for a wrong column count, a non-numeric field, a quaternion that is not a
// unit quaternion, a pair of an image with itself, or a file without pairs.
RotationGraph ReadRelativePoses(const std::string& path);

// Absolute rotations, one image a line: IMAGE_NAME QW QX QY QZ, q =
// cam_from_world. Names must be unique.
std::vector<std::pair<std::string, Eigen::Matrix3d>> ReadAbsoluteRotations(
    const std::string& path);

// Writes the estimated vertices (names from the graph) in the format above,
// through a temporary file renamed into place, so that a reader never sees a
// partial file. Throws InputError if the file cannot be written.
void WriteAbsoluteRotations(const std::string& path,
                            const std::vector<std::string>& names,
                            const std::vector<Eigen::Matrix3d>& rotations,
                            const std::vector<bool>& estimated);

}  // namespace colmap_irav4
