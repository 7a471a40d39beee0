#include "colmap_irav4/refinement/model_rigidity.h"

#include <algorithm>
#include <map>
#include <utility>

#include "colmap_irav4/scene/reconstruction_utils.h"

namespace colmap_irav4 {

ModelRigidity AnalyzeModelRigidity(const ModelRigidityOptions& options,
                                   const Reconstruction& reconstruction,
                                   int min_model_size) {
  const DenseImageIndex dense(reconstruction);
  const std::vector<image_t>& ids = dense.ids;
  const std::map<image_t, int>& index = dense.index;
  const int n = static_cast<int>(ids.size());

  // Tie graph: common points per image pair, counted per first image with
  // dense counters.
  std::vector<std::vector<int>> adjacency(n);
  std::map<std::pair<int, int>, int> weight;  // (i < j) -> common points
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
        weight[{i, j}] = count[j];
      }
      count[j] = 0;
    }
    touched.clear();
  }

  // Biconnected components (Tarjan, iterative; an edge stack).
  ModelRigidity result;
  std::vector<int> discovery(n, -1), low(n, 0);
  std::vector<std::pair<int, int>> edge_stack;
  std::vector<std::vector<int>> index_blocks;
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
    index_blocks.push_back(std::move(block));
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
  // An articulation image stays only in the block it shares the most
  // points with (the first of equal ones): there its pose is held by most of
  // its observations, in the other blocks by a few.
  std::vector<std::vector<int>> blocks_of(n);
  for (size_t b = 0; b < index_blocks.size(); ++b) {
    for (const int k : index_blocks[b]) blocks_of[k].push_back(b);
  }
  std::vector<std::vector<char>> keep(index_blocks.size());
  for (size_t b = 0; b < index_blocks.size(); ++b) {
    keep[b].assign(index_blocks[b].size(), 1);
  }
  for (int k = 0; k < n; ++k) {
    if (blocks_of[k].size() < 2) continue;
    std::vector<int> shared(blocks_of[k].size(), 0);
    for (size_t m = 0; m < blocks_of[k].size(); ++m) {
      for (const int other : index_blocks[blocks_of[k][m]]) {
        const auto it = weight.find({std::min(k, other), std::max(k, other)});
        if (it != weight.end()) shared[m] += it->second;
      }
    }
    const size_t best =
        std::max_element(shared.begin(), shared.end()) - shared.begin();
    for (size_t m = 0; m < blocks_of[k].size(); ++m) {
      if (m == best) continue;
      const std::vector<int>& block = index_blocks[blocks_of[k][m]];
      keep[blocks_of[k][m]]
          [std::find(block.begin(), block.end(), k) - block.begin()] = 0;
    }
  }
  for (size_t b = 0; b < index_blocks.size(); ++b) {
    std::vector<image_t> images;
    std::vector<image_t>& joined = result.joined_blocks.emplace_back();
    for (size_t m = 0; m < index_blocks[b].size(); ++m) {
      joined.push_back(ids[index_blocks[b][m]]);
      if (keep[b][m]) images.push_back(ids[index_blocks[b][m]]);
    }
    if (!images.empty()) result.blocks.push_back(std::move(images));
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
