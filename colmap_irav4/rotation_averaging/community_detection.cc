#include "colmap_irav4/rotation_averaging/community_detection.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <queue>
#include <unordered_map>

#include <glog/logging.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// A weighted graph for one Louvain level: simple (parallel edges summed),
// self-loops kept apart.
struct LevelGraph {
  std::vector<std::vector<std::pair<int, double>>> adjacency;
  std::vector<double> self_loop;  // weight of each node's self-loop, once
  double total_weight = 0;        // m: every edge once, self-loops included

  int NumNodes() const { return static_cast<int>(adjacency.size()); }
  // k_i: incident weight, self-loop counted twice.
  double Strength(int i) const {
    double k = 2 * self_loop[i];
    for (const auto& [j, w] : adjacency[i]) k += w;
    return k;
  }
};

LevelGraph BuildLevelGraph(const RotationGraph& graph) {
  const int n = graph.NumVertices();
  LevelGraph level;
  level.adjacency.resize(n);
  level.self_loop.assign(n, 0.0);
  std::vector<double> accum(n, 0.0);
  std::vector<int> touched;
  for (int i = 0; i < n; ++i) {
    touched.clear();
    for (const auto& [j, e] : graph.Neighbors(i)) {
      if (j == i) continue;
      if (accum[j] == 0.0) touched.push_back(j);
      // Weights must be positive for modularity; a zero weight counts as 1.
      const double w = graph.Edge(e).weight > 0 ? graph.Edge(e).weight : 1.0;
      accum[j] += w;
    }
    std::sort(touched.begin(), touched.end());
    for (int j : touched) {
      level.adjacency[i].emplace_back(j, accum[j]);
      if (j > i) level.total_weight += accum[j];
      accum[j] = 0.0;
    }
  }
  return level;
}

// One Louvain level: local moving in node index order until no node moves
// (or max_passes). Returns community labels (not renumbered).
std::vector<int> LocalMoving(const LevelGraph& level, double resolution,
                             int max_passes) {
  const int n = level.NumNodes();
  std::vector<int> community(n);
  std::iota(community.begin(), community.end(), 0);
  std::vector<double> strength(n), tot(n);
  for (int i = 0; i < n; ++i) tot[i] = strength[i] = level.Strength(i);
  const double two_m = 2 * level.total_weight;
  if (two_m <= 0) return community;

  std::vector<double> link(n, 0.0);  // weight from node i to each community
  std::vector<int> neighbour_communities;
  for (int pass = 0; pass < max_passes; ++pass) {
    int moves = 0;
    for (int i = 0; i < n; ++i) {
      const int old_c = community[i];
      neighbour_communities.clear();
      for (const auto& [j, w] : level.adjacency[i]) {
        const int c = community[j];
        if (link[c] == 0.0) neighbour_communities.push_back(c);
        link[c] += w;
      }
      tot[old_c] -= strength[i];
      const double k_i = strength[i];
      // Gain of inserting i into c, up to a constant: link - gamma tot k / 2m.
      double best_gain = link[old_c] - resolution * tot[old_c] * k_i / two_m;
      int best_c = old_c;
      for (int c : neighbour_communities) {
        const double gain = link[c] - resolution * tot[c] * k_i / two_m;
        if (gain > best_gain + 1e-12 ||
            (gain > best_gain - 1e-12 && c < best_c && best_c != old_c)) {
          best_gain = gain;
          best_c = c;
        }
      }
      tot[best_c] += k_i;
      community[i] = best_c;
      if (best_c != old_c) ++moves;
      for (int c : neighbour_communities) link[c] = 0.0;
      link[old_c] = 0.0;
    }
    if (moves == 0) break;
  }
  return community;
}

// Renumbers labels 0..k-1 in order of first appearance (smallest member).
int Renumber(std::vector<int>* labels) {
  std::unordered_map<int, int> mapping;
  for (int& label : *labels) {
    auto it = mapping.find(label);
    if (it == mapping.end()) {
      it = mapping.emplace(label, static_cast<int>(mapping.size())).first;
    }
    label = it->second;
  }
  return static_cast<int>(mapping.size());
}

LevelGraph Aggregate(const LevelGraph& level, const std::vector<int>& labels,
                     int num_communities) {
  LevelGraph next;
  next.adjacency.resize(num_communities);
  next.self_loop.assign(num_communities, 0.0);
  next.total_weight = level.total_weight;
  std::vector<std::map<int, double>> links(num_communities);
  for (int i = 0; i < level.NumNodes(); ++i) {
    const int ci = labels[i];
    next.self_loop[ci] += level.self_loop[i];
    for (const auto& [j, w] : level.adjacency[i]) {
      const int cj = labels[j];
      if (ci == cj) {
        if (j > i) next.self_loop[ci] += w;
      } else {
        links[ci][cj] += w;
      }
    }
  }
  for (int c = 0; c < num_communities; ++c) {
    next.adjacency[c].assign(links[c].begin(), links[c].end());
  }
  return next;
}

double LevelModularity(const LevelGraph& level, const std::vector<int>& labels,
                       double resolution) {
  const double two_m = 2 * level.total_weight;
  if (two_m <= 0) return 0;
  const int k =
      labels.empty() ? 0 : *std::max_element(labels.begin(), labels.end()) + 1;
  std::vector<double> in(k, 0.0), tot(k, 0.0);
  for (int i = 0; i < level.NumNodes(); ++i) {
    tot[labels[i]] += level.Strength(i);
    in[labels[i]] += 2 * level.self_loop[i];
    for (const auto& [j, w] : level.adjacency[i]) {
      if (labels[j] == labels[i]) in[labels[i]] += w;
    }
  }
  double q = 0;
  for (int c = 0; c < k; ++c) {
    q += in[c] / two_m - resolution * (tot[c] / two_m) * (tot[c] / two_m);
  }
  return q;
}

std::vector<std::vector<int>> Groups(const std::vector<int>& vertices,
                                     const std::vector<int>& labels) {
  const int k =
      labels.empty() ? 0 : *std::max_element(labels.begin(), labels.end()) + 1;
  std::vector<std::vector<int>> groups(k);
  for (size_t i = 0; i < labels.size(); ++i) {
    groups[labels[i]].push_back(vertices[i]);
  }
  return groups;
}

// Cuts a too-large community into connected pieces of at most max_size
// vertices by breadth-first search from its smallest vertex.
std::vector<std::vector<int>> BfsChunks(const RotationGraph& graph,
                                        const std::vector<int>& community,
                                        int max_size) {
  std::unordered_map<int, bool> in_set;
  for (int v : community) in_set[v] = false;  // false = not yet visited
  std::vector<std::vector<int>> chunks;
  std::vector<int> order;
  for (int root : community) {
    if (in_set[root]) continue;
    std::queue<int> queue;
    queue.push(root);
    in_set[root] = true;
    while (!queue.empty()) {
      const int v = queue.front();
      queue.pop();
      order.push_back(v);
      for (const auto& [u, e] : graph.Neighbors(v)) {
        auto it = in_set.find(u);
        if (it != in_set.end() && !it->second) {
          it->second = true;
          queue.push(u);
        }
      }
    }
  }
  for (size_t start = 0; start < order.size(); start += max_size) {
    const size_t end = std::min(order.size(), start + max_size);
    chunks.emplace_back(order.begin() + start, order.begin() + end);
    std::sort(chunks.back().begin(), chunks.back().end());
  }
  return chunks;
}

}  // namespace

void CommunityDetectionOptions::Check() const {
  if (!(resolution > 0)) {
    throw OptionError(&resolution, "CommunityDetectionOptions::resolution",
                      "must be > 0");
  }
  if (max_community_size < 0 ||
      (max_community_size > 0 && max_community_size < 3)) {
    throw OptionError(&max_community_size,
                      "RotationAveraging.max_community_size",
                      "must be 0 (no limit) or >= 3");
  }
  if (min_community_size < 0 ||
      (max_community_size > 0 && min_community_size > max_community_size)) {
    throw OptionError(&min_community_size,
                      "RotationAveraging.min_community_size",
                      "must be >= 0 and <= --RotationAveraging."
                      "max_community_size (unless that is 0)");
  }
  if (max_passes < 1) {
    throw OptionError(&max_passes, "CommunityDetectionOptions::max_passes",
                      "must be >= 1");
  }
}

std::vector<int> LouvainCommunities(const RotationGraph& graph,
                                    double resolution, int max_passes,
                                    double min_modularity_gain) {
  const int n = graph.NumVertices();
  std::vector<int> labels(n);
  std::iota(labels.begin(), labels.end(), 0);
  LevelGraph level = BuildLevelGraph(graph);
  std::vector<int> identity(level.NumNodes());
  std::iota(identity.begin(), identity.end(), 0);
  double modularity = LevelModularity(level, identity, resolution);
  while (true) {
    std::vector<int> level_labels = LocalMoving(level, resolution, max_passes);
    const int k = Renumber(&level_labels);
    if (k == level.NumNodes()) break;  // nothing merged
    const double new_modularity =
        LevelModularity(level, level_labels, resolution);
    for (int& label : labels) label = level_labels[label];
    level = Aggregate(level, level_labels, k);
    if (new_modularity - modularity < min_modularity_gain) break;
    modularity = new_modularity;
  }
  Renumber(&labels);
  return labels;
}

double Modularity(const RotationGraph& graph, const std::vector<int>& labels,
                  double resolution) {
  std::vector<int> renumbered = labels;
  Renumber(&renumbered);
  return LevelModularity(BuildLevelGraph(graph), renumbered, resolution);
}

bool ContainsTriangle(const RotationGraph& graph,
                      const std::vector<int>& vertices) {
  std::vector<int> index(graph.NumVertices(), -1);
  for (size_t k = 0; k < vertices.size(); ++k) index[vertices[k]] = k;
  std::vector<char> mark(graph.NumVertices(), 0);
  for (int i : vertices) {
    for (const auto& [j, e] : graph.Neighbors(i)) {
      if (index[j] >= 0) mark[j] = 1;
    }
    for (const auto& [j, e] : graph.Neighbors(i)) {
      if (index[j] < 0 || j <= i) continue;
      for (const auto& [k, e2] : graph.Neighbors(j)) {
        if (k != i && mark[k]) {
          return true;
        }
      }
    }
    for (const auto& [j, e] : graph.Neighbors(i)) mark[j] = 0;
  }
  return false;
}

std::vector<std::vector<int>> DetectCommunities(
    const RotationGraph& graph, const CommunityDetectionOptions& options) {
  options.Check();
  std::vector<int> all(graph.NumVertices());
  std::iota(all.begin(), all.end(), 0);
  std::vector<std::vector<int>> communities = Groups(
      all, LouvainCommunities(graph, options.resolution, options.max_passes,
                              options.min_modularity_gain));

  // Too large: Louvain inside (it finds the finer structure that the global
  // resolution limit hides), else connected BFS chunks.
  if (options.max_community_size > 0) {
    std::vector<std::vector<int>> pending = std::move(communities);
    communities.clear();
    while (!pending.empty()) {
      std::vector<int> community = std::move(pending.back());
      pending.pop_back();
      if (static_cast<int>(community.size()) <= options.max_community_size) {
        communities.push_back(std::move(community));
        continue;
      }
      const RotationGraph sub = graph.InducedSubgraph(community);
      std::vector<std::vector<int>> parts =
          Groups(community,
                 LouvainCommunities(sub, options.resolution, options.max_passes,
                                    options.min_modularity_gain));
      if (parts.size() <= 1) {
        parts = BfsChunks(graph, community, options.max_community_size);
        for (auto& part : parts) communities.push_back(std::move(part));
      } else {
        for (auto& part : parts) pending.push_back(std::move(part));
      }
    }
  }

  // Too small or no triangle: merge into the neighbour community sharing the
  // most edge weight, smallest first, until none is left (or only one).
  std::vector<int> label(graph.NumVertices(), -1);
  auto relabel = [&]() {
    for (size_t c = 0; c < communities.size(); ++c) {
      for (int v : communities[c]) label[v] = static_cast<int>(c);
    }
  };
  std::vector<char> stuck(graph.NumVertices(), 0);  // isolated pieces
  while (communities.size() > 1) {
    relabel();
    int worst = -1;
    for (size_t c = 0; c < communities.size(); ++c) {
      if (stuck[communities[c].front()]) continue;
      const bool too_small =
          static_cast<int>(communities[c].size()) < options.min_community_size;
      if (!too_small && ContainsTriangle(graph, communities[c])) continue;
      if (worst < 0 || communities[c].size() < communities[worst].size()) {
        worst = static_cast<int>(c);
      }
    }
    if (worst < 0) break;
    std::map<int, double> shared;
    for (int v : communities[worst]) {
      for (const auto& [u, e] : graph.Neighbors(v)) {
        if (label[u] != worst) {
          shared[label[u]] +=
              graph.Edge(e).weight > 0 ? graph.Edge(e).weight : 1.0;
        }
      }
    }
    int target = -1;
    double best = 0;
    for (const auto& [c, w] : shared) {
      if (w > best) {
        best = w;
        target = c;
      }
    }
    if (target < 0) {
      // A piece of another connected component: nothing to merge into.
      stuck[communities[worst].front()] = 1;
      continue;
    }
    communities[target].insert(communities[target].end(),
                               communities[worst].begin(),
                               communities[worst].end());
    std::sort(communities[target].begin(), communities[target].end());
    communities.erase(communities.begin() + worst);
  }
  std::sort(communities.begin(), communities.end(),
            [](const std::vector<int>& a, const std::vector<int>& b) {
              return a.front() < b.front();
            });
  return communities;
}

}  // namespace colmap_irav4
