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
    throw OptionError(
        &outlier_ratio, "outlier_ratios",
        "must be in [0, 1], got " + std::to_string(outlier_ratio));
  }
  if (!(structured_outlier_ratio >= 0.0 && structured_outlier_ratio <= 1.0)) {
    throw InputError(
        "SyntheticOptions::structured_outlier_ratio",
        "must be in [0, 1], got " + std::to_string(structured_outlier_ratio));
  }
  if (!(twin_overlap_deg > 0.0 && twin_overlap_deg <= 180.0)) {
    throw InputError(
        "SyntheticOptions::twin_overlap_deg",
        "must be in (0, 180], got " + std::to_string(twin_overlap_deg));
  }
  if (!(upright_sigma_deg >= 0.0)) {
    throw InputError("SyntheticOptions::upright_sigma_deg", "must be >= 0");
  }
}

Eigen::Matrix3d MirrorRotation() {
  return Eigen::Vector3d(-1.0, 1.0, -1.0).asDiagonal();
}

namespace {

// cam_from_world of an upright camera: heading uniform about the vertical y
// axis, then a small tilt.
Eigen::Matrix3d UprightRotation(double tilt_sigma_rad, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> heading(0.0, 2.0 * M_PI);
  const Eigen::Matrix3d yaw =
      AngleAxisToRotation(Eigen::Vector3d(0.0, heading(*rng), 0.0));
  std::normal_distribution<double> tilt(0.0, 1.0);
  const double angle = tilt_sigma_rad > 0 ? tilt_sigma_rad * tilt(*rng) : 0.0;
  return RandomRotationWithAngle(angle, rng) * yaw;
}

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
  const bool structured = options.structured_outlier_ratio > 0.0;
  for (int v = 0; v < n; ++v) {
    problem->ground_truth[v] =
        structured ? UprightRotation(DegToRad(options.upright_sigma_deg), &rng)
                   : RandomRotation(&rng);
  }

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

  problem->edge_is_outlier.assign(num_edges, false);
  problem->edge_is_structured_outlier.assign(num_edges, false);
  problem->num_twin_pairs = 0;
  if (structured) {
    // Twin pairs: camera i's viewing direction (third row of R_i) within
    // twin_overlap_deg of that of j's twin R_j M, and symmetrically (the
    // relation is symmetric: M d_j vs d_i  <=>  M d_i vs d_j).
    const Eigen::Matrix3d M = MirrorRotation();
    const double cos_overlap = std::cos(DegToRad(options.twin_overlap_deg));
    std::vector<int64_t> twins;
    for (int64_t e = 0; e < num_edges; ++e) {
      const auto [i, j] = edges[e];
      const Eigen::Vector3d d_i = problem->ground_truth[i].row(2).transpose();
      const Eigen::Vector3d d_j = problem->ground_truth[j].row(2).transpose();
      if (d_i.dot(M * d_j) > cos_overlap) twins.push_back(e);
    }
    problem->num_twin_pairs = static_cast<int>(twins.size());
    const int64_t num_structured = std::llround(
        options.structured_outlier_ratio * static_cast<double>(twins.size()));
    for (int64_t k = 0; k < num_structured; ++k) {
      std::uniform_int_distribution<int64_t> pick(
          k, static_cast<int64_t>(twins.size()) - 1);
      std::swap(twins[k], twins[pick(rng)]);
      problem->edge_is_structured_outlier[twins[k]] = true;
      problem->edge_is_outlier[twins[k]] = true;
    }
    for (int64_t e = 0; e < num_edges; ++e) {
      if (!problem->edge_is_structured_outlier[e]) continue;
      const auto [i, j] = edges[e];
      const double angle = sigma > 0 ? noise_angle(rng) : 0.0;
      measurements[e] = RandomRotationWithAngle(angle, &rng) *
                        problem->ground_truth[j] * M.transpose() *
                        problem->ground_truth[i].transpose();
    }
  }
  // Exactly round(p |E'|) random outliers among the edges E' that are not
  // structured outliers (all edges in the paper's protocol): partial
  // Fisher-Yates over their indices.
  std::vector<int64_t> order;
  order.reserve(num_edges);
  for (int64_t e = 0; e < num_edges; ++e) {
    if (!problem->edge_is_structured_outlier[e]) order.push_back(e);
  }
  const int64_t num_candidates = static_cast<int64_t>(order.size());
  const int64_t num_outliers =
      std::llround(options.outlier_ratio * static_cast<double>(num_candidates));
  for (int64_t k = 0; k < num_outliers; ++k) {
    std::uniform_int_distribution<int64_t> pick(k, num_candidates - 1);
    std::swap(order[k], order[pick(rng)]);
    problem->edge_is_outlier[order[k]] = true;
  }
  // Random rotations drawn in edge order so that the result does not depend
  // on the order in which outliers were picked.
  for (int64_t e = 0; e < num_edges; ++e) {
    if (problem->edge_is_outlier[e] &&
        !problem->edge_is_structured_outlier[e]) {
      measurements[e] = RandomRotation(&rng);
    }
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
