#include "colmap_irav4/rotation_averaging/synthetic.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <unordered_set>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

void SyntheticOptions::Check() const {
  if (!(noise_sigma_deg >= 0.0)) {
    throw OptionError(&noise_sigma_deg, "sigmas",
                     "must be >= 0, got " + std::to_string(noise_sigma_deg));
  }
  if (!(outlier_ratio >= 0.0 && outlier_ratio <= 1.0)) {
    throw OptionError(&outlier_ratio, "outlier_ratios",
                     "must be in [0, 1], got " + std::to_string(outlier_ratio));
  }
}

namespace {

// Fills the measurements of `problem->graph`, whose structure is set and
// whose vertex count is final.
void DrawMeasurements(const std::vector<std::pair<int, int>>& edges,
                      const std::vector<double>& weights,
                      const SyntheticOptions& options,
                      SyntheticProblem* problem) {
  options.Check();
  std::mt19937_64 rng(options.seed);
  const int n = problem->graph.NumVertices();
  problem->ground_truth.resize(n);
  for (int v = 0; v < n; ++v) problem->ground_truth[v] = RandomRotation(&rng);

  const double sigma = DegToRad(options.noise_sigma_deg);
  std::normal_distribution<double> noise_angle(0.0, sigma > 0 ? sigma : 1.0);
  const int64_t num_edges = static_cast<int64_t>(edges.size());
  std::vector<Eigen::Matrix3d> measurements(num_edges);
  for (int64_t e = 0; e < num_edges; ++e) {
    const auto [i, j] = edges[e];
    const Eigen::Matrix3d R_ij =
        problem->ground_truth[j] * problem->ground_truth[i].transpose();
    const double angle = sigma > 0 ? noise_angle(rng) : 0.0;
    measurements[e] = RandomRotationWithAngle(angle, &rng) * R_ij;
  }

  // Exactly round(p |E|) outliers: partial Fisher-Yates over edge indices.
  const int64_t num_outliers =
      std::llround(options.outlier_ratio * static_cast<double>(num_edges));
  std::vector<int64_t> order(num_edges);
  std::iota(order.begin(), order.end(), 0);
  problem->edge_is_outlier.assign(num_edges, false);
  for (int64_t k = 0; k < num_outliers; ++k) {
    std::uniform_int_distribution<int64_t> pick(k, num_edges - 1);
    std::swap(order[k], order[pick(rng)]);
    problem->edge_is_outlier[order[k]] = true;
  }
  // Random rotations drawn in edge order so that the result does not depend
  // on the order in which outliers were picked.
  for (int64_t e = 0; e < num_edges; ++e) {
    if (problem->edge_is_outlier[e]) measurements[e] = RandomRotation(&rng);
  }
  for (int64_t e = 0; e < num_edges; ++e) {
    problem->graph.AddEdge(edges[e].first, edges[e].second, measurements[e],
                           weights.empty() ? 1.0 : weights[e]);
  }
}

}  // namespace

SyntheticProblem MakeSyntheticProblem(const RotationGraph& structure,
                                      const SyntheticOptions& options) {
  SyntheticProblem problem;
  for (int v = 0; v < structure.NumVertices(); ++v) {
    problem.graph.AddVertex(structure.Name(v));
  }
  std::vector<std::pair<int, int>> edges;
  std::vector<double> weights;
  edges.reserve(structure.NumEdges());
  weights.reserve(structure.NumEdges());
  for (const RelativeRotation& e : structure.Edges()) {
    edges.emplace_back(e.i, e.j);
    weights.push_back(e.weight);
  }
  DrawMeasurements(edges, weights, options, &problem);
  return problem;
}

SyntheticProblem MakeSyntheticProblem(
    int num_vertices, const std::vector<std::pair<int, int>>& edges,
    const SyntheticOptions& options) {
  SyntheticProblem problem;
  problem.graph = RotationGraph(num_vertices);
  for (const auto& [i, j] : edges) {
    if (i < 0 || j < 0 || i >= num_vertices || j >= num_vertices || i == j) {
      throw InputError("synthetic edge list",
                       "invalid edge " + std::to_string(i) + " " +
                           std::to_string(j) + " for " +
                           std::to_string(num_vertices) + " vertices");
    }
  }
  DrawMeasurements(edges, {}, options, &problem);
  return problem;
}

std::vector<std::pair<int, int>> RandomConnectedGraph(int num_vertices,
                                                      int64_t num_edges,
                                                      uint64_t seed) {
  const int64_t n = num_vertices;
  if (n < 1 || num_edges < n - 1 || num_edges > n * (n - 1) / 2) {
    throw InputError("RandomConnectedGraph",
                     "need num_vertices >= 1 and num_vertices-1 <= num_edges "
                     "<= num_vertices(num_vertices-1)/2, got " +
                         std::to_string(num_vertices) + " vertices, " +
                         std::to_string(num_edges) + " edges");
  }
  std::mt19937_64 rng(seed);
  std::vector<std::pair<int, int>> edges;
  edges.reserve(num_edges);
  // Membership only (never iterated), so hashing cannot affect the output.
  std::unordered_set<uint64_t> present;
  present.reserve(2 * num_edges);
  const auto add = [&](int a, int b) {
    if (a > b) std::swap(a, b);
    const uint64_t key = (static_cast<uint64_t>(a) << 32) | b;
    if (!present.insert(key).second) return false;
    edges.emplace_back(a, b);
    return true;
  };
  std::vector<int> order(num_vertices);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  for (int k = 1; k < num_vertices; ++k) {
    std::uniform_int_distribution<int> parent(0, k - 1);
    add(order[k], order[parent(rng)]);
  }
  std::uniform_int_distribution<int> vertex(0, num_vertices - 1);
  // Rejection sampling is fine while the graph is sparse-ish; dense requests
  // (more than half of all pairs) fall back to enumerating and shuffling.
  if (num_edges * 2 > n * (n - 1) / 2) {
    std::vector<std::pair<int, int>> rest;
    for (int a = 0; a < num_vertices; ++a) {
      for (int b = a + 1; b < num_vertices; ++b) {
        if (!present.count((static_cast<uint64_t>(a) << 32) | b)) {
          rest.emplace_back(a, b);
        }
      }
    }
    std::shuffle(rest.begin(), rest.end(), rng);
    for (size_t k = 0; static_cast<int64_t>(edges.size()) < num_edges; ++k) {
      edges.push_back(rest[k]);
    }
    return edges;
  }
  while (static_cast<int64_t>(edges.size()) < num_edges) {
    const int a = vertex(rng);
    const int b = vertex(rng);
    if (a != b) add(a, b);
  }
  return edges;
}

}  // namespace colmap_irav4
