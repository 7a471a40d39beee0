#include "colmap_irav4/rotation_averaging/cds.h"

#include <algorithm>
#include <queue>
#include <random>

namespace colmap_irav4 {
namespace {

enum Colour : char { kWhite = 0, kGray = 1, kBlack = 2 };

double EdgeScore(const RotationGraph& graph, int edge, bool weighted) {
  if (!weighted) return 1.0;
  const double w = graph.Edge(edge).weight;
  return w > 0 ? w : 1.0;
}

// Shared Guha-Khuller skeleton: `white_score[v]` is the (weighted) count of
// white neighbours of v, kept up to date as vertices leave white. `pick`
// chooses the next black vertex among gray ones with white neighbours.
template <typename Pick>
std::vector<int> GrowCds(const RotationGraph& graph, int start, bool weighted,
                         Pick pick) {
  const int n = graph.NumVertices();
  std::vector<char> colour(n, kWhite);
  std::vector<double> white_score(n, 0.0);
  for (int v = 0; v < n; ++v) {
    for (const auto& [u, e] : graph.Neighbors(v)) {
      if (u != v) white_score[v] += EdgeScore(graph, e, weighted);
    }
  }
  std::vector<int> gray;  // gray vertices (may hold stale black entries)
  auto leave_white = [&](int v) {
    for (const auto& [u, e] : graph.Neighbors(v)) {
      if (u != v) white_score[u] -= EdgeScore(graph, e, weighted);
    }
  };
  std::vector<int> black;
  auto make_black = [&](int v) {
    if (colour[v] == kWhite) leave_white(v);
    colour[v] = kBlack;
    black.push_back(v);
    for (const auto& [u, e] : graph.Neighbors(v)) {
      if (colour[u] == kWhite) {
        colour[u] = kGray;
        leave_white(u);
        gray.push_back(u);
      }
    }
  };
  make_black(start);
  while (true) {
    // Compact the gray list: drop black ones and those without white
    // neighbours (they never gain any).
    std::vector<int> candidates;
    candidates.reserve(gray.size());
    for (int v : gray) {
      if (colour[v] == kGray && white_score[v] > 1e-12) candidates.push_back(v);
    }
    if (candidates.empty()) break;
    const int next = pick(candidates, white_score);
    make_black(next);
    std::vector<int> kept;
    kept.reserve(gray.size());
    for (int v : gray) {
      if (colour[v] == kGray) kept.push_back(v);
    }
    gray.swap(kept);
  }
  std::sort(black.begin(), black.end());
  return black;
}

}  // namespace

std::vector<int> GreedyCds(const RotationGraph& graph, bool weighted) {
  const int n = graph.NumVertices();
  if (n == 0) return {};
  int start = 0;
  double best = -1;
  for (int v = 0; v < n; ++v) {
    double score = 0;
    for (const auto& [u, e] : graph.Neighbors(v)) {
      if (u != v) score += EdgeScore(graph, e, weighted);
    }
    if (score > best) {
      best = score;
      start = v;
    }
  }
  return GrowCds(
      graph, start, weighted,
      [](const std::vector<int>& candidates,
         const std::vector<double>& white_score) {
        int best_v = -1;
        for (int v : candidates) {
          if (best_v < 0 || white_score[v] > white_score[best_v] ||
              (white_score[v] == white_score[best_v] && v < best_v)) {
            best_v = v;
          }
        }
        return best_v;
      });
}

std::vector<int> RandomCds(const RotationGraph& graph, uint64_t seed) {
  const int n = graph.NumVertices();
  if (n == 0) return {};
  std::mt19937_64 rng(seed);
  // Start in a vertex with at least one neighbour if there is one.
  int start = static_cast<int>(rng() % static_cast<uint64_t>(n));
  for (int tries = 0; tries < n && graph.Degree(start) == 0; ++tries) {
    start = (start + 1) % n;
  }
  return GrowCds(graph, start, /*weighted=*/false,
                 [&rng](std::vector<int>& candidates,
                        const std::vector<double>& white_score) {
                   // Sorted so that the draw does not depend on list order.
                   std::sort(candidates.begin(), candidates.end());
                   double total = 0;
                   for (int v : candidates) total += white_score[v];
                   // uniform_real_distribution's output is not specified
                   // across standard libraries; derive it from raw bits.
                   const double u =
                       static_cast<double>(rng() >> 11) * 0x1.0p-53 * total;
                   double accum = 0;
                   for (int v : candidates) {
                     accum += white_score[v];
                     if (u < accum) return v;
                   }
                   return candidates.back();
                 });
}

std::vector<int> UnionOfRandomCds(const RotationGraph& graph, int num_cds,
                                  uint64_t seed) {
  std::vector<char> in(graph.NumVertices(), 0);
  std::mt19937_64 seeds(seed);
  for (int k = 0; k < num_cds; ++k) {
    for (int v : RandomCds(graph, seeds())) in[v] = 1;
  }
  std::vector<int> result;
  for (int v = 0; v < graph.NumVertices(); ++v) {
    if (in[v]) result.push_back(v);
  }
  return result;
}

bool IsConnectedSet(const RotationGraph& graph,
                    const std::vector<int>& vertices) {
  if (vertices.empty()) return true;
  std::vector<char> in(graph.NumVertices(), 0), seen(graph.NumVertices(), 0);
  for (int v : vertices) in[v] = 1;
  std::queue<int> queue;
  queue.push(vertices.front());
  seen[vertices.front()] = 1;
  size_t count = 0;
  while (!queue.empty()) {
    const int v = queue.front();
    queue.pop();
    ++count;
    for (const auto& [u, e] : graph.Neighbors(v)) {
      if (in[u] && !seen[u]) {
        seen[u] = 1;
        queue.push(u);
      }
    }
  }
  size_t distinct = 0;
  for (char c : in) distinct += c;
  return count == distinct;
}

bool IsDominatingSet(const RotationGraph& graph,
                     const std::vector<int>& vertices) {
  std::vector<char> dominated(graph.NumVertices(), 0);
  for (int v : vertices) {
    dominated[v] = 1;
    for (const auto& [u, e] : graph.Neighbors(v)) dominated[u] = 1;
  }
  return std::all_of(dominated.begin(), dominated.end(),
                     [](char c) { return c != 0; });
}

}  // namespace colmap_irav4
