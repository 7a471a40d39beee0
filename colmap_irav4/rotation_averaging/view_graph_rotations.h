#pragma once

#include <map>
#include <string>
#include <vector>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"
#include "colmap_irav4/scene/types.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// The rotation averaging problem of (part of) a view graph: one vertex per
// image of `image_names`, in image id order and named after the image; one
// edge per pair, R_ij = the pair's cam2_from_cam1, weighted by its inlier
// count. Every pair's images must be in image_names (CHECKed). If
// vertex_images is given, (*vertex_images)[v] is the image of vertex v.
RotationGraph RotationGraphFromPairs(
    const std::map<image_t, std::string>& image_names,
    const std::vector<ImagePairGeometry>& pairs,
    std::vector<image_t>* vertex_images = nullptr);

// The same over a whole view graph.
RotationGraph RotationGraphFromViewGraph(
    const ViewGraph& view_graph, std::vector<image_t>* vertex_images = nullptr);

}  // namespace colmap_irav4
