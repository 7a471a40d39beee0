#include "colmap_irav4/refinement/model_rigidity.h"

#include <algorithm>
#include <map>
#include <utility>

namespace colmap_irav4 {

ModelRigidity AnalyzeModelRigidity(const ModelRigidityOptions& options,
                                   const Reconstruction& reconstruction,
                                   int min_model_size) {
  // Dense image indices.
  std::vector<image_t> ids;
  std::map<image_t, int> index;
  for (const auto& [image_id, image] : reconstruction.images) {
    index[image_id] = static_cast<int>(ids.size());
    ids.push_back(image_id);
  }
  const int n = static_cast<int>(ids.size());

  // Tie graph: common points per image pair, counted per first image with
  // dense counters.
  std::vector<std::vector<int>> adjacency(n);
  std::vector<int> count(n, 0);
  std::vector<int> touched;
  for (int i = 0; i < n; ++i) {
    const Image& image = reconstruction.images.at(ids[i]);
    for (const Point2D& point2D : image.points2D) {
      if (point2D.point3D_id == kInvalidPoint3DId) continue;
      const auto point = reconstruction.points3D.find(point2D.point3D_id);
      if (point == reconstruction.points3D.end()) continue;
      for (const TrackElement& element : point->second.track) {
        const auto other = index.find(element.image_id);
        if (other == index.end() || other->second <= i) continue;
        if (count[other->second]++ == 0) touched.push_back(other->second);
      }
    }
    for (const int j : touched) {
      if (count[j] >= options.min_shared_points) {
        adjacency[i].push_back(j);
        adjacency[j].push_back(i);
      }
      count[j] = 0;
    }
    touched.clear();
  }

  // Biconnected components (Tarjan, iterative; an edge stack).
  ModelRigidity result;
  std::vector<int> discovery(n, -1), low(n, 0);
  std::vector<std::pair<int, int>> edge_stack;
  int time = 0;
  struct Frame {
    int vertex;
    int parent;
    size_t next;
  };
  auto pop_block = [&](int u, int v) {
    std::vector<int> block;
    while (!edge_stack.empty()) {
      const std::pair<int, int> edge = edge_stack.back();
      edge_stack.pop_back();
      block.push_back(edge.first);
      block.push_back(edge.second);
      if (edge.first == u && edge.second == v) break;
    }
    std::sort(block.begin(), block.end());
    block.erase(std::unique(block.begin(), block.end()), block.end());
    std::vector<image_t> images;
    for (const int k : block) images.push_back(ids[k]);
    result.blocks.push_back(std::move(images));
  };
  for (int root = 0; root < n; ++root) {
    if (discovery[root] >= 0) continue;
    std::vector<Frame> stack = {{root, -1, 0}};
    discovery[root] = low[root] = time++;
    while (!stack.empty()) {
      Frame& frame = stack.back();
      const int u = frame.vertex;
      if (frame.next < adjacency[u].size()) {
        const int v = adjacency[u][frame.next++];
        if (discovery[v] < 0) {
          edge_stack.emplace_back(u, v);
          discovery[v] = low[v] = time++;
          stack.push_back({v, u, 0});
        } else if (v != frame.parent && discovery[v] < discovery[u]) {
          edge_stack.emplace_back(u, v);
          low[u] = std::min(low[u], discovery[v]);
        }
        continue;
      }
      const int parent = frame.parent;
      stack.pop_back();
      if (parent < 0) continue;
      low[parent] = std::min(low[parent], low[u]);
      if (low[u] >= discovery[parent]) pop_block(parent, u);
    }
  }
  // Largest first; ties by smallest image id (blocks are sorted by id).
  std::sort(result.blocks.begin(), result.blocks.end(),
            [](const auto& a, const auto& b) {
              return a.size() != b.size() ? a.size() > b.size() : a < b;
            });
  for (const auto& block : result.blocks) {
    result.num_large_blocks +=
        static_cast<int>(block.size()) >= min_model_size ? 1 : 0;
  }
  return result;
}

}  // namespace colmap_irav4
