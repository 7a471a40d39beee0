#include "colmap_irav4/view_graph/view_graph.h"

#include <utility>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {

std::vector<ImagePairGeometry> PairsWithin(
    const std::vector<ImagePairGeometry>& pairs,
    const std::set<image_t>& images) {
  std::vector<ImagePairGeometry> kept;
  for (const ImagePairGeometry& pair : pairs) {
    if (images.count(pair.image_id1) && images.count(pair.image_id2)) {
      kept.push_back(pair);
    }
  }
  return kept;
}

std::vector<std::vector<image_t>> PairComponents(
    const std::vector<ImagePairGeometry>& pairs) {
  // Vertices: the images in ascending id order, so that the components'
  // order (by their smallest vertex) is that of their smallest image id.
  std::map<image_t, int> index;
  for (const ImagePairGeometry& pair : pairs) {
    index.emplace(pair.image_id1, 0);
    index.emplace(pair.image_id2, 0);
  }
  std::vector<image_t> ids;
  ids.reserve(index.size());
  for (auto& [image_id, vertex] : index) {
    vertex = static_cast<int>(ids.size());
    ids.push_back(image_id);
  }
  std::vector<std::pair<int, int>> edges;
  edges.reserve(pairs.size());
  for (const ImagePairGeometry& pair : pairs) {
    edges.emplace_back(index.at(pair.image_id1), index.at(pair.image_id2));
  }
  std::vector<std::vector<image_t>> components;
  for (const std::vector<int>& vertices :
       ConnectedComponents(static_cast<int>(ids.size()), edges)) {
    std::vector<image_t> component;
    component.reserve(vertices.size());
    for (const int vertex : vertices) component.push_back(ids[vertex]);
    components.push_back(std::move(component));
  }
  return components;
}

double RelativeRotationErrorDeg(const ImagePairGeometry& pair,
                                const Eigen::Matrix3d& R1,
                                const Eigen::Matrix3d& R2) {
  return AngularDistanceDeg(pair.R, R2 * R1.transpose());
}

}  // namespace colmap_irav4
