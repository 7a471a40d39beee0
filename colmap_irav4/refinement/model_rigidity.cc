#include "colmap_irav4/refinement/model_rigidity.h"

#include <algorithm>
#include <map>
#include <utility>

#include "colmap_irav4/scene/reconstruction_utils.h"

namespace colmap_irav4 {
namespace {

// The 2-connected blocks of a graph (Tarjan, iterative; an edge stack), each
// as sorted vertex numbers, in the order the search closes them.
std::vector<std::vector<int>> FindBlocks(
    const std::vector<std::vector<int>>& adjacency) {
  const int n = static_cast<int>(adjacency.size());
  std::vector<int> discovery(n, -1), low(n, 0);
  std::vector<std::pair<int, int>> edge_stack;
  std::vector<std::vector<int>> blocks;
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
    blocks.push_back(std::move(block));
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
  return blocks;
}

// Two blocks that share an image (they meet at that articulation image) and
// the points tying them: points observed both by an image of the one block
// and by an image of the other, neither the shared image. One such point
// fixes the scale of one block about the shared image relative to the other
// (its two rays must meet), so enough of them make the two blocks one rigid
// piece even when no single image pair of theirs shares enough points to be
// tied on its own.
struct JointTie {
  int block1 = -1;
  int block2 = -1;
  int joint = -1;  // the shared image
  int num_points = 0;
};

std::vector<JointTie> CountJointTies(
    const std::vector<std::vector<int>>& blocks,
    const std::vector<std::vector<int>>& point_images, int n) {
  std::vector<std::vector<int>> blocks_of(n);
  for (size_t b = 0; b < blocks.size(); ++b) {
    for (const int k : blocks[b]) blocks_of[k].push_back(static_cast<int>(b));
  }
  // Blocks share at most one image (else they would be one block).
  std::map<std::pair<int, int>, JointTie> ties;  // (block1 < block2)
  for (int k = 0; k < n; ++k) {
    for (size_t m = 0; m < blocks_of[k].size(); ++m) {
      for (size_t l = m + 1; l < blocks_of[k].size(); ++l) {
        JointTie tie;
        tie.block1 = std::min(blocks_of[k][m], blocks_of[k][l]);
        tie.block2 = std::max(blocks_of[k][m], blocks_of[k][l]);
        tie.joint = k;
        ties[{tie.block1, tie.block2}] = tie;
      }
    }
  }
  if (!ties.empty()) {
    std::vector<std::pair<int, int>> entries;  // (block, image) of a point
    std::vector<int> touched;                  // its blocks
    for (const std::vector<int>& images : point_images) {
      entries.clear();
      for (const int k : images) {
        for (const int b : blocks_of[k]) entries.emplace_back(b, k);
      }
      std::sort(entries.begin(), entries.end());
      touched.clear();
      for (const auto& entry : entries) {
        if (touched.empty() || touched.back() != entry.first) {
          touched.push_back(entry.first);
        }
      }
      for (size_t m = 0; m < touched.size(); ++m) {
        for (size_t l = m + 1; l < touched.size(); ++l) {
          const auto it = ties.find({touched[m], touched[l]});
          if (it == ties.end()) continue;
          // Seen by an image of `block` other than the shared one.
          auto seen_apart = [&](int block) {
            for (const auto& entry : entries) {
              if (entry.first == block && entry.second != it->second.joint) {
                return true;
              }
            }
            return false;
          };
          if (seen_apart(touched[m]) && seen_apart(touched[l])) {
            ++it->second.num_points;
          }
        }
      }
    }
  }
  std::vector<JointTie> result;
  for (const auto& entry : ties) result.push_back(entry.second);
  return result;
}

// AnalyzeModelRigidity's rule on the tie graph (`adjacency`, `weight`: the
// image pairs sharing at least min_shared_points points and how many) and
// the points' images (dense numbers, sorted, two or more a point).
// Ties of image i to the images `touched` (count[j] points shared with
// each): those of at least min_shared_points enter the tie graph; the
// counters are reset for the next image.
void AddTies(int i, int min_shared_points, std::vector<int>* count,
             std::vector<int>* touched,
             std::vector<std::vector<int>>* adjacency,
             std::map<std::pair<int, int>, int>* weight) {
  for (const int j : *touched) {
    if ((*count)[j] >= min_shared_points) {
      (*adjacency)[i].push_back(j);
      (*adjacency)[j].push_back(i);
      (*weight)[{i, j}] = (*count)[j];
    }
    (*count)[j] = 0;
  }
  touched->clear();
}

ModelRigidity RigidityOfTies(const ModelRigidityOptions& options,
                             const std::vector<image_t>& ids,
                             const std::vector<std::vector<int>>& point_images,
                             std::vector<std::vector<int>> adjacency,
                             const std::map<std::pair<int, int>, int>& weight,
                             int min_model_size) {
  const int n = static_cast<int>(ids.size());
  // Blocks joined at an image and tied by enough points seen from both
  // (CountJointTies) are one rigid piece: an edge between an image of
  // each, other than the shared one, closes a cycle through the shared
  // image and merges the two blocks. Repeated, since a merged block may be
  // tied to a further block by points no block of it had enough of alone.
  // With ties of one point (the bundle adjustment's gauges) a point across
  // a joint is itself an edge that makes the two blocks one: nothing to do.
  std::vector<std::vector<int>> index_blocks = FindBlocks(adjacency);
  if (options.min_shared_points > 1) {
    while (true) {
      bool merged = false;
      for (const JointTie& tie :
           CountJointTies(index_blocks, point_images, n)) {
        if (tie.num_points < options.min_shared_points) continue;
        // Each block holds an image other than the shared one.
        auto other_than_joint = [&](int block) {
          const std::vector<int>& images = index_blocks[block];
          return images[0] != tie.joint ? images[0] : images[1];
        };
        const int u = other_than_joint(tie.block1);
        const int v = other_than_joint(tie.block2);
        adjacency[u].push_back(v);
        adjacency[v].push_back(u);
        merged = true;
      }
      if (!merged) break;
      index_blocks = FindBlocks(adjacency);
    }
  }

  ModelRigidity result;
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

}  // namespace

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
    AddTies(i, options.min_shared_points, &count, &touched, &adjacency,
            &weight);
  }

  std::vector<std::vector<int>> point_images;
  if (options.min_shared_points > 1) {
    point_images.reserve(reconstruction.points3D.size());
    for (const auto& [point3D_id, point3D] : reconstruction.points3D) {
      std::vector<int>& images = point_images.emplace_back();
      for (const TrackElement& element : point3D.track) {
        const auto it = index.find(element.image_id);
        if (it != index.end()) images.push_back(it->second);
      }
      std::sort(images.begin(), images.end());
      images.erase(std::unique(images.begin(), images.end()), images.end());
      if (images.size() < 2) point_images.pop_back();
    }
  }
  return RigidityOfTies(options, ids, point_images, std::move(adjacency),
                        weight, min_model_size);
}

ModelRigidity AnalyzeTieRigidity(
    const ModelRigidityOptions& options, const std::vector<image_t>& images,
    const std::vector<std::vector<image_t>>& point_images, int min_model_size) {
  std::vector<image_t> ids = images;
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::map<image_t, int> index;
  for (size_t k = 0; k < ids.size(); ++k) {
    index[ids[k]] = static_cast<int>(k);
  }
  const int n = static_cast<int>(ids.size());
  std::vector<std::vector<int>> dense_points;
  dense_points.reserve(point_images.size());
  for (const std::vector<image_t>& point : point_images) {
    std::vector<int>& dense = dense_points.emplace_back();
    for (const image_t image_id : point) {
      const auto it = index.find(image_id);
      if (it != index.end()) dense.push_back(it->second);
    }
    std::sort(dense.begin(), dense.end());
    dense.erase(std::unique(dense.begin(), dense.end()), dense.end());
    if (dense.size() < 2) dense_points.pop_back();
  }
  // Tie graph as AnalyzeModelRigidity's, from each image's points.
  std::vector<std::vector<int>> points_of(n);
  for (size_t p = 0; p < dense_points.size(); ++p) {
    for (const int k : dense_points[p]) {
      points_of[k].push_back(static_cast<int>(p));
    }
  }
  std::vector<std::vector<int>> adjacency(n);
  std::map<std::pair<int, int>, int> weight;
  std::vector<int> count(n, 0);
  std::vector<int> touched;
  for (int i = 0; i < n; ++i) {
    for (const int p : points_of[i]) {
      for (const int j : dense_points[p]) {
        if (j <= i) continue;
        if (count[j]++ == 0) touched.push_back(j);
      }
    }
    AddTies(i, options.min_shared_points, &count, &touched, &adjacency,
            &weight);
  }
  if (options.min_shared_points <= 1) dense_points.clear();
  return RigidityOfTies(options, ids, dense_points, std::move(adjacency),
                        weight, min_model_size);
}

}  // namespace colmap_irav4
