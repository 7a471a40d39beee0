#include "colmap_irav4/rotation_averaging/view_graph_rotations.h"

#include <glog/logging.h>

namespace colmap_irav4 {

RotationGraph RotationGraphFromPairs(
    const std::map<image_t, std::string>& image_names,
    const std::vector<ImagePairGeometry>& pairs,
    std::vector<image_t>* vertex_images) {
  RotationGraph graph;
  std::map<image_t, int> vertex_of;
  if (vertex_images != nullptr) vertex_images->clear();
  for (const auto& [image_id, name] : image_names) {
    vertex_of[image_id] = graph.AddVertex(name);
    if (vertex_images != nullptr) vertex_images->push_back(image_id);
  }
  for (const ImagePairGeometry& pair : pairs) {
    const auto it1 = vertex_of.find(pair.image_id1);
    const auto it2 = vertex_of.find(pair.image_id2);
    CHECK(it1 != vertex_of.end() && it2 != vertex_of.end())
        << "pair (" << pair.image_id1 << ", " << pair.image_id2
        << ") has an image outside the graph";
    graph.AddEdge(it1->second, it2->second, pair.R, pair.num_inliers);
  }
  return graph;
}

RotationGraph RotationGraphFromViewGraph(const ViewGraph& view_graph,
                                         std::vector<image_t>* vertex_images) {
  return RotationGraphFromPairs(view_graph.image_names, view_graph.pairs,
                                vertex_images);
}

}  // namespace colmap_irav4
