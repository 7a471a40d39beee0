#include "colmap_irav4/rotation_averaging/irav4.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/cds.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/threading.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

std::vector<bool> MaskOf(int n, const std::vector<int>& vertices) {
  std::vector<bool> mask(n, false);
  for (int v : vertices) mask[v] = true;
  return mask;
}

int MaxDegreeVertex(const RotationGraph& graph) {
  int best = 0;
  for (int v = 1; v < graph.NumVertices(); ++v) {
    if (graph.Degree(v) > graph.Degree(best)) best = v;
  }
  return best;
}

// Copies an engine's selected rotations into a per-vertex table.
void ExportEngine(const IncrementalEngine& engine, int n,
                  std::vector<Eigen::Matrix3d>* rotations,
                  std::vector<bool>* selected) {
  rotations->assign(n, Eigen::Matrix3d::Identity());
  selected->assign(n, false);
  for (int v : engine.Selected()) {
    (*rotations)[v] = engine.Rotation(v);
    (*selected)[v] = true;
  }
}

// The IRAv4 task-specific CDS: the engine on the whole graph from the best
// triplet, with the Guha-Khuller rules applied to the candidates as well as
// to the stop: a vertex may join only while it has a neighbour that is not
// yet dominated (a "gray vertex with white neighbours"), the highest reward
// among those joins (Eq. 5-8), and growth stops when every vertex is
// selected or adjacent to a selected one. Stopping alone is not enough:
// reward-ordered growth fills the dense core before the low-degree vertices
// are dominated (measured: 333-371 of Madrid's 394 vertices). Selected sets
// are connected by construction (each vertex joins through an edge), and
// growth never stalls on a connected graph: an edge from the dominated set
// to an undominated vertex starts at a dominated, unselected vertex, which
// is adjacent to the set and still eligible.
AlignmentReference TaskSpecificReference(const RotationGraph& graph,
                                         const Irav4Options& options) {
  const int n = graph.NumVertices();
  AlignmentReference reference;
  IncrementalEngine engine(graph, options.engine);
  if (!engine.InitializeFromBestTriplet() &&
      !engine.InitializeFromVertex(MaxDegreeVertex(graph))) {
    return reference;
  }
  // Per vertex, how many distinct neighbours are not dominated yet; a vertex
  // whose count reaches 0 can no longer join (excluded for good: domination
  // only grows).
  const auto& adjacency = *engine.SharedAdjacency();
  std::vector<int> undominated_neighbors(n);
  for (int v = 0; v < n; ++v) {
    undominated_neighbors[v] = static_cast<int>(adjacency[v].size());
  }
  std::vector<char> dominated(n, 0);
  int num_dominated = 0;
  auto mark = [&](int v) {
    if (dominated[v]) return;
    dominated[v] = 1;
    ++num_dominated;
    for (const auto& [u, e] : adjacency[v]) {
      if (--undominated_neighbors[u] == 0 && !engine.IsSelected(u) &&
          !engine.IsExcluded(u)) {
        engine.Exclude(u);
      }
    }
  };
  auto dominate = [&](int v) {
    mark(v);
    for (const auto& [u, e] : adjacency[v]) mark(u);
  };
  for (int v : engine.Selected()) dominate(v);
  if (num_dominated < n) {
    engine.Grow([&]() {
      dominate(engine.LastAdded());
      return num_dominated == n;
    });
  }
  // The paper's growth ends with a global optimisation of the set.
  engine.GlobalOptimize();
  ExportEngine(engine, n, &reference.rotations, &reference.selected);
  reference.vertices = engine.Selected();
  std::sort(reference.vertices.begin(), reference.vertices.end());
  reference.is_cds = num_dominated == n;
  return reference;
}

// A given vertex set (a task-independent CDS) estimated by the engine
// restricted to it (IRA on the CDS-induced sub-graph).
AlignmentReference EstimateVertexSet(const RotationGraph& graph,
                                     const Irav4Options& options,
                                     const std::vector<int>& vertices) {
  const int n = graph.NumVertices();
  AlignmentReference reference;
  IncrementalEngine engine(graph, options.engine, MaskOf(n, vertices));
  if (!engine.InitializeFromBestTriplet()) {
    LOG(WARNING) << "The CDS (" << vertices.size()
                 << " vertices) holds no consistent triangle; using the "
                    "task-specific reference instead";
    return TaskSpecificReference(graph, options);
  }
  engine.Grow([]() { return false; });
  engine.GlobalOptimize();
  ExportEngine(engine, n, &reference.rotations, &reference.selected);
  reference.vertices = engine.Selected();
  std::sort(reference.vertices.begin(), reference.vertices.end());
  reference.is_cds = IsConnectedDominatingSet(graph, reference.vertices);
  return reference;
}

// sum over edges between estimated vertices of rho(r) = r^2 / (r^2 + s^2),
// r the residual angle (Geman-McClure, scale s in radians).
double GemanMcClureCost(const RotationGraph& graph,
                        const std::vector<bool>& estimated,
                        const std::vector<Eigen::Matrix3d>& rotations,
                        double sigma) {
  double cost = 0.0;
  const double s2 = sigma * sigma;
  for (const RelativeRotation& e : graph.Edges()) {
    if (!estimated[e.i] || !estimated[e.j]) continue;
    const double r = RotationAngle(e.R_ij.transpose() * rotations[e.j] *
                                   rotations[e.i].transpose());
    cost += r * r / (r * r + s2);
  }
  return cost;
}

}  // namespace

int PlaceRemainingVertices(const RotationGraph& graph, double theta_deg,
                           std::vector<bool>* estimated,
                           std::vector<Eigen::Matrix3d>* rotations) {
  const int n = graph.NumVertices();
  const double min_trace = 1.0 + 2.0 * std::cos(DegToRad(theta_deg));
  int num_placed = 0;
  std::vector<Eigen::Matrix3d> predictions;
  bool changed = true;
  while (changed) {
    changed = false;
    std::vector<int> placed_now;
    for (int p = 0; p < n; ++p) {
      if ((*estimated)[p]) continue;
      predictions.clear();
      for (const auto& [m, e] : graph.Neighbors(p)) {
        if ((*estimated)[m]) {
          predictions.push_back(graph.RotationFrom(e, m) * (*rotations)[m]);
        }
      }
      if (predictions.empty()) continue;
      int best = 0;
      double best_support = -1.0;
      for (size_t a = 0; a < predictions.size(); ++a) {
        double support = 0.0;
        for (const Eigen::Matrix3d& P : predictions) {
          const double trace = (predictions[a].transpose() * P).trace();
          if (trace > min_trace) support += (trace - 1.0) * 0.5;
        }
        if (support > best_support) {
          best_support = support;
          best = static_cast<int>(a);
        }
      }
      (*rotations)[p] = predictions[best];
      placed_now.push_back(p);
    }
    // Marked after the round so that the order of placement within a round
    // does not matter.
    for (int p : placed_now) (*estimated)[p] = true;
    num_placed += static_cast<int>(placed_now.size());
    changed = !placed_now.empty();
  }
  return num_placed;
}

template <>
const EnumNames<ReferenceMethod>& NamesOf<ReferenceMethod>() {
  static const EnumNames<ReferenceMethod> names = {
      {ReferenceMethod::kIrav4, "irav4"},
      {ReferenceMethod::kGreedyCds, "greedy_cds"},
      {ReferenceMethod::kRandomCds, "random_cds"}};
  return names;
}

template <>
const EnumNames<Irav4FinalRefinement>& NamesOf<Irav4FinalRefinement>() {
  static const EnumNames<Irav4FinalRefinement> names = {
      {Irav4FinalRefinement::kNone, "none"},
      {Irav4FinalRefinement::kIrls, "irls"},
      {Irav4FinalRefinement::kL1Irls, "l1_irls"},
      {Irav4FinalRefinement::kGuarded, "guarded"}};
  return names;
}

void Irav4Options::Check() const {
  engine.Check();
  communities.Check();
  if (num_random_cds < 1) {
    throw OptionError(&num_random_cds, "RotationAveraging.num_random_cds",
                      "must be >= 1");
  }
  if (max_cluster_size < 0) {
    throw OptionError(&max_cluster_size, "RotationAveraging.max_cluster_size",
                      "must be >= 0");
  }
  if (consensus_min_support < 1) {
    throw OptionError(&consensus_min_support,
                      "RotationAveraging.consensus_min_support",
                      "must be >= 1");
  }
  if (num_final_rounds < 0) {
    throw OptionError(&num_final_rounds, "RotationAveraging.num_final_rounds",
                      "must be >= 0");
  }
  if (!(reseed_threshold_deg > 0 && reseed_threshold_deg < 180)) {
    throw OptionError(&reseed_threshold_deg,
                      "RotationAveraging.reseed_threshold_deg",
                      "must be in (0, 180)");
  }
  if (!(reseed_support_fraction >= 0 && reseed_support_fraction <= 1)) {
    throw OptionError(&reseed_support_fraction,
                      "RotationAveraging.reseed_support_fraction",
                      "must be in [0, 1]");
  }
  refinement.Check();
}

int ReseedBadlySupportedVertices(const RotationGraph& graph,
                                 const Irav4Options& options,
                                 const std::vector<bool>& estimated,
                                 std::vector<Eigen::Matrix3d>* rotations) {
  const double cos_threshold = std::cos(DegToRad(options.reseed_threshold_deg));
  // angle(A, B) < threshold  <=>  trace(A^T B) > 1 + 2 cos(threshold).
  const double min_trace = 1.0 + 2.0 * cos_threshold;
  auto agree = [&](const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
    return (a.transpose() * b).trace() > min_trace;
  };
  std::vector<Eigen::Matrix3d> predictions;
  int num_reseeded = 0;
  for (int p = 0; p < graph.NumVertices(); ++p) {
    if (!estimated[p]) continue;
    // Pre-computations R_p^m = R_mp R_m (R_mp = R_pm^T for edges stored as
    // (p, m)), one per estimated neighbour edge.
    predictions.clear();
    for (const auto& [m, e] : graph.Neighbors(p)) {
      if (!estimated[m]) continue;
      const RelativeRotation& edge = graph.Edge(e);
      const Eigen::Matrix3d R_mp =
          edge.i == m ? edge.R_ij : Eigen::Matrix3d(edge.R_ij.transpose());
      predictions.push_back(R_mp * (*rotations)[m]);
    }
    if (predictions.size() < 2) continue;
    int current_support = 0;
    for (const Eigen::Matrix3d& P : predictions) {
      current_support += agree(P, (*rotations)[p]);
    }
    if (current_support >=
        options.reseed_support_fraction * predictions.size()) {
      continue;
    }
    int best_support = current_support;
    int best = -1;
    for (size_t a = 0; a < predictions.size(); ++a) {
      int support = 0;
      for (const Eigen::Matrix3d& P : predictions) {
        support += agree(P, predictions[a]);
      }
      if (support > best_support) {
        best_support = support;
        best = static_cast<int>(a);
      }
    }
    if (best >= 0) {
      (*rotations)[p] = predictions[best];
      ++num_reseeded;
    }
  }
  return num_reseeded;
}

AlignmentReference BuildAlignmentReference(const RotationGraph& graph,
                                           const Irav4Options& options,
                                           ReferenceMethod method) {
  switch (method) {
    case ReferenceMethod::kIrav4:
      return TaskSpecificReference(graph, options);
    case ReferenceMethod::kGreedyCds:
      return EstimateVertexSet(graph, options,
                               GreedyCds(graph, options.weighted_greedy_cds));
    case ReferenceMethod::kRandomCds:
      return EstimateVertexSet(
          graph, options,
          UnionOfRandomCds(graph, options.num_random_cds,
                           static_cast<uint64_t>(options.seed)));
  }
  return {};
}

Irav4::Irav4(const Irav4Options& options) : options_(options) {
  options_.Check();
}

// The clusters of one Estimate (steps 1 and 2) and what they grow in.
struct Irav4::Clusters {
  std::vector<std::vector<int>> communities;
  std::vector<int> label;  // the community of each vertex
  std::vector<std::unique_ptr<IncrementalEngine>> engines;
  std::vector<int> community;    // of each cluster's seed (-1: none)
  std::vector<bool> affiliated;  // the vertices some cluster holds
  std::shared_ptr<const IncrementalEngine::AdjacencyList> adjacency;
  // potential[c][v]: whether cluster c may take vertex v.
  std::vector<std::vector<bool>> potential;
};

RotationAveragingResult Irav4::Estimate(const RotationGraph& input) {
  report_ = Irav4Report();
  RotationAveragingResult result;
  const int num_input = input.NumVertices();
  result.rotations.assign(num_input, Eigen::Matrix3d::Identity());
  result.estimated.assign(num_input, false);
  if (num_input == 0) return result;

  // Work on the largest connected component (domination is per component).
  Timer timer;
  const std::vector<std::vector<int>> components = input.ConnectedComponents();
  const bool whole =
      components.front().size() == static_cast<size_t>(num_input);
  RotationGraph component_graph;
  if (!whole) component_graph = input.InducedSubgraph(components.front());
  const RotationGraph& graph = whole ? input : component_graph;
  auto to_input = [&](int v) { return whole ? v : components.front()[v]; };
  const int n = graph.NumVertices();
  report_.num_vertices = n;
  const int num_threads = ResolveNumThreads(options_.engine.num_threads);

  // 1. Communities and one seed triplet each (Eq. 1-4 inside the community).
  Clusters run;
  if (!SeedClusters(graph, num_threads, &run)) return result;
  result.stage_seconds.emplace_back("communities_and_seeds",
                                    timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "IRAv4: " << report_.num_communities << " communities, "
      << report_.num_clusters << " cluster seeds ("
      << result.stage_seconds.back().second << " s)";

  // 2 and 3 side by side (with num_threads >= 2): the reference depends on
  // the graph only, not on the clusters, so both results are the same for
  // any thread count. 2. On-the-fly clustering; 3. the alignment reference.
  double clustering_seconds = 0.0;
  AlignmentReference reference;
  double reference_seconds = 0.0;
  ParallelFor(std::min(num_threads, 2), 2, [&](size_t task) {
    if (task == 0) {
      clustering_seconds = GrowClusters(num_threads, &run);
    } else {
      Timer reference_timer;
      reference =
          BuildAlignmentReference(graph, options_, options_.reference_method);
      reference_seconds = reference_timer.ElapsedSeconds();
    }
  });
  result.stage_seconds.emplace_back("on_the_fly_clustering",
                                    clustering_seconds);
  report_.n_ref = static_cast<int>(reference.vertices.size());
  result.stage_seconds.emplace_back("reference", reference_seconds);
  LOG_IF(INFO, options_.log_progress)
      << "IRAv4: " << EnumName(options_.reference_method)
      << " reference n_ref = " << report_.n_ref
      << (reference.is_cds ? " (connected dominating)" : "") << " ("
      << reference_seconds << " s)";

  // 4. Common-vertex-guided alignment of each cluster and global alignment.
  timer.Restart();
  std::vector<Eigen::Matrix3d> rotations(n, Eigen::Matrix3d::Identity());
  std::vector<bool> estimated(n, false);
  AlignClusters(graph, reference, &run, &rotations, &estimated);
  result.stage_seconds.emplace_back("alignment", timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "IRAv4: aligned " << report_.num_clusters << " clusters ("
      << report_.num_vertex_guided_alignments << " by common vertices)";

  // 5. Final optimisation over the inlier edges of the whole graph.
  timer.Restart();
  std::vector<int> estimated_vertices;
  for (int v = 0; v < n; ++v) {
    if (estimated[v]) estimated_vertices.push_back(v);
  }
  OptimizeOverInlierEdges(graph, estimated_vertices, &rotations);
  result.stage_seconds.emplace_back("global_optimization",
                                    timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "IRAv4: final optimisation on " << report_.num_final_inlier_edges
      << " inlier edges (" << result.stage_seconds.back().second << " s)";

  // 6. Optional robust refinement over all edges.
  if (options_.final_refinement != Irav4FinalRefinement::kNone &&
      estimated_vertices.size() >= 2) {
    timer.Restart();
    RefineOverAllEdges(graph, estimated, estimated_vertices.front(),
                       &rotations);
    result.stage_seconds.emplace_back("irls_refinement",
                                      timer.ElapsedSeconds());
  }

  for (int v = 0; v < n; ++v) {
    result.rotations[to_input(v)] = rotations[v];
    result.estimated[to_input(v)] = estimated[v];
  }
  report_.reference.selected.assign(num_input, false);
  report_.reference.rotations.assign(num_input, Eigen::Matrix3d::Identity());
  report_.reference.is_cds = reference.is_cds;
  for (int v : reference.vertices) {
    report_.reference.vertices.push_back(to_input(v));
    report_.reference.selected[to_input(v)] = true;
    report_.reference.rotations[to_input(v)] = reference.rotations[v];
  }
  return result;
}

bool Irav4::SeedClusters(const RotationGraph& graph, int num_threads,
                         Clusters* run) {
  const int n = graph.NumVertices();
  run->communities = DetectCommunities(graph, options_.communities);
  const std::vector<std::vector<int>>& communities = run->communities;
  report_.num_communities = static_cast<int>(communities.size());
  run->label.assign(n, -1);
  std::vector<int>& label = run->label;
  for (size_t k = 0; k < communities.size(); ++k) {
    for (int v : communities[k]) label[v] = static_cast<int>(k);
  }
  std::vector<std::unique_ptr<IncrementalEngine>>& clusters = run->engines;
  std::vector<int>& cluster_community = run->community;
  run->affiliated.assign(n, false);
  std::vector<bool>& affiliated = run->affiliated;
  run->adjacency = IncrementalEngine::BuildAdjacency(graph);
  const std::shared_ptr<const IncrementalEngine::AdjacencyList>& adjacency =
      run->adjacency;
  // The communities' seeds are independent: found in parallel, collected in
  // community order (the same clusters for any thread count).
  std::vector<std::unique_ptr<IncrementalEngine>> seeded(communities.size());
  ParallelFor(num_threads, communities.size(), [&](size_t k) {
    if (communities[k].size() < 3) return;
    // All vertices allowed for now; the potential clusters are set below,
    // once it is known which communities seeded a cluster.
    auto cluster = std::make_unique<IncrementalEngine>(
        graph, options_.engine, std::vector<bool>(), adjacency);
    if (cluster->InitializeFromBestTriplet(MaskOf(n, communities[k]))) {
      seeded[k] = std::move(cluster);
    }
  });
  for (size_t k = 0; k < communities.size(); ++k) {
    if (!seeded[k]) continue;
    for (int v : seeded[k]->Selected()) affiliated[v] = true;
    clusters.push_back(std::move(seeded[k]));
    cluster_community.push_back(static_cast<int>(k));
  }
  if (clusters.empty()) {
    // No community could seed (e.g. very few, inconsistent triangles): one
    // cluster from the best triplet of the whole graph.
    auto cluster = std::make_unique<IncrementalEngine>(
        graph, options_.engine, std::vector<bool>(), adjacency);
    if (!cluster->InitializeFromBestTriplet() &&
        !cluster->InitializeFromVertex(MaxDegreeVertex(graph))) {
      return false;
    }
    for (int v : cluster->Selected()) affiliated[v] = true;
    clusters.push_back(std::move(cluster));
    cluster_community.push_back(-1);
  }
  const int num_clusters = static_cast<int>(clusters.size());
  report_.num_clusters = num_clusters;
  for (int c = 0; c < num_clusters; ++c) {
    for (int d = 0; d < num_clusters; ++d) {
      if (d == c) continue;
      for (int v : clusters[d]->Selected()) clusters[c]->Exclude(v);
    }
  }

  // IRAv3's potential cluster and vertex pre-selection: cluster c may take
  // the vertices of its own community, and boundary vertices whose edge
  // weight into c's community is at least their weight into their own (and
  // every vertex whose community seeded no cluster). Rebuilt as engines
  // restricted to their potential clusters; the seeds are kept.
  std::vector<int> cluster_of_community(communities.size(), -1);
  for (int c = 0; c < num_clusters; ++c) {
    if (cluster_community[c] >= 0)
      cluster_of_community[cluster_community[c]] = c;
  }
  // potential[c][v]; edges_into_potential[c][v] = v's edges into it.
  run->potential.assign(num_clusters, std::vector<bool>(n, false));
  std::vector<std::vector<bool>>& potential = run->potential;
  if (options_.preselect_clusters && num_clusters > 1) {
    std::vector<double> weight_into(communities.size(), 0.0);
    std::vector<int> touched;
    for (int v = 0; v < n; ++v) {
      const int own_cluster = cluster_of_community[label[v]];
      if (own_cluster < 0) {
        for (int c = 0; c < num_clusters; ++c) potential[c][v] = true;
        continue;
      }
      potential[own_cluster][v] = true;
      touched.clear();
      for (const auto& [u, e] : (*adjacency)[v]) {
        if (weight_into[label[u]] == 0.0) touched.push_back(label[u]);
        weight_into[label[u]] += graph.Edge(e).weight;
      }
      const double own = weight_into[label[v]];
      for (int k : touched) {
        const int c = cluster_of_community[k];
        if (c >= 0 && weight_into[k] >= own) potential[c][v] = true;
      }
      for (int k : touched) weight_into[k] = 0.0;
    }
  } else {
    for (auto& mask : potential) mask.assign(n, true);
  }
  for (int c = 0; c < num_clusters; ++c) {
    for (int v : clusters[c]->Selected()) potential[c][v] = true;
    for (int v = 0; v < n; ++v) {
      if (!potential[c][v] && !clusters[c]->IsSelected(v)) {
        clusters[c]->Exclude(v);
      }
    }
  }
  return true;
}

double Irav4::GrowClusters(int num_threads, Clusters* run) {
  const int n = static_cast<int>(run->affiliated.size());
  const int num_clusters = static_cast<int>(run->engines.size());
  std::vector<std::unique_ptr<IncrementalEngine>>& clusters = run->engines;
  std::vector<bool>& affiliated = run->affiliated;
  std::vector<std::vector<bool>>& potential = run->potential;
  // Normaliser of a candidate's reward in cluster c: its edges into c's
  // potential cluster (so a vertex that has met one edge of a cluster it is
  // strongly tied to waits until more of the cluster has grown, and clusters
  // of different sizes compete on equal terms).
  auto edges_into_potential = [&](int c, int v) {
    int count = 0;
    for (const auto& [u, e] : (*run->adjacency)[v]) {
      count += run->potential[c][u];
    }
    return std::max(count, 1);
  };
  Timer clustering_timer;
  std::vector<IncrementalEngine::Candidate> best(num_clusters);
  std::vector<double> best_score(num_clusters, 0.0);
  std::vector<bool> stale(num_clusters, true);
  int num_affiliated = 0;
  for (bool a : affiliated) num_affiliated += a;
  const int max_size = options_.max_cluster_size;
  for (int pass = 0; pass < 2 && num_affiliated < n; ++pass) {
    const bool fallback = pass == 1;
    if (fallback) {
      for (int c = 0; c < num_clusters; ++c) {
        for (int v = 0; v < n; ++v) {
          if (!affiliated[v]) {
            clusters[c]->Allow(v);
            potential[c][v] = true;
          }
        }
        stale[c] = true;
      }
    }
    while (num_affiliated < n) {
      int chosen = -1;
      for (int c = 0; c < num_clusters; ++c) {
        if (!fallback && max_size > 0 &&
            clusters[c]->NumSelected() >= max_size) {
          continue;
        }
        if (stale[c]) {
          best[c] = clusters[c]->BestCandidate();
          best_score[c] =
              best[c].vertex < 0
                  ? 0.0
                  : best[c].reward / edges_into_potential(c, best[c].vertex);
          stale[c] = false;
        }
        if (best[c].vertex < 0) continue;
        if (chosen < 0 || best_score[c] > best_score[chosen]) chosen = c;
      }
      if (chosen < 0) break;  // nothing reachable in this pass
      const IncrementalEngine::Candidate candidate = best[chosen];
      CHECK(!affiliated[candidate.vertex]);
      clusters[chosen]->AddVertex(candidate);
      affiliated[candidate.vertex] = true;
      ++num_affiliated;
      LOG_IF(INFO,
             options_.log_progress && num_affiliated % ((n + 9) / 10) == 0)
          << "IRAv4: on-the-fly clustering " << num_affiliated << " / " << n
          << " vertices (" << clustering_timer.ElapsedSeconds() << " s)";
      stale[chosen] = true;
      for (int c = 0; c < num_clusters; ++c) {
        if (c == chosen) continue;
        if (!clusters[c]->IsExcluded(candidate.vertex)) {
          clusters[c]->Exclude(candidate.vertex);
        }
        if (best[c].vertex == candidate.vertex) stale[c] = true;
      }
    }
    if (!fallback) report_.num_fallback_vertices = n - num_affiliated;
  }
  // Each cluster's last optimisation touches only its own engine.
  ParallelFor(num_threads, clusters.size(),
              [&](size_t c) { clusters[c]->GlobalOptimize(); });
  for (auto& cluster : clusters) {
    report_.cluster_sizes.push_back(
        static_cast<int>(cluster->Selected().size()));
  }
  const double clustering_seconds = clustering_timer.ElapsedSeconds();
  if (options_.log_progress) {
    std::string sizes;
    for (int size : report_.cluster_sizes) {
      sizes += " " + std::to_string(size);
    }
    LOG(INFO) << "IRAv4: cluster sizes" << sizes << " ("
              << report_.num_fallback_vertices << " placed by the fallback "
              << "pass, " << clustering_seconds << " s)";
  }
  return clustering_seconds;
}

void Irav4::AlignClusters(const RotationGraph& graph,
                          const AlignmentReference& reference, Clusters* run,
                          std::vector<Eigen::Matrix3d>* rotations,
                          std::vector<bool>* estimated) {
  const int n = graph.NumVertices();
  ClusterAlignmentOptions alignment_options;
  alignment_options.theta_deg = options_.engine.theta_deg;
  std::vector<Eigen::Matrix3d> cluster_rotations;
  std::vector<bool> in_cluster;
  // A cluster that does not align to the reference is tried again against
  // the reference plus the clusters aligned so far; what still fails is
  // placed vertex by vertex (below), so that no camera is lost.
  std::vector<int> pending;
  for (int c = 0; c < static_cast<int>(run->engines.size()); ++c)
    pending.push_back(c);
  for (int round = 0; round < 2 && !pending.empty(); ++round) {
    std::vector<int> failed;
    for (int c : pending) {
      ExportEngine(*run->engines[c], n, &cluster_rotations, &in_cluster);
      ClusterAlignment alignment;
      if (std::none_of(estimated->begin(), estimated->end(),
                       [](bool b) { return b; }) &&
          (round == 1 || reference.vertices.empty())) {
        // No reference at all, or nothing aligned to it: this cluster's
        // frame stands in for it.
        alignment.success = true;
      } else if (round == 0) {
        alignment = AlignClusterToReference(
            graph, cluster_rotations, in_cluster, reference.rotations,
            reference.selected, alignment_options);
      } else {
        alignment =
            AlignClusterToReference(graph, cluster_rotations, in_cluster,
                                    *rotations, *estimated, alignment_options);
      }
      if (!alignment.success) {
        failed.push_back(c);
        continue;
      }
      report_.num_vertex_guided_alignments += alignment.used_vertex_guidance;
      for (int v : run->engines[c]->Selected()) {
        (*rotations)[v] = cluster_rotations[v] * alignment.A;
        (*estimated)[v] = true;
      }
    }
    pending = failed;
  }
  report_.num_failed_alignments = static_cast<int>(pending.size());
  if (options_.consensus_check && run->engines.size() > 1) {
    std::vector<int> cluster_of(n, -1);
    std::vector<bool> failed(run->engines.size(), false);
    for (int c : pending) failed[c] = true;
    for (int c = 0; c < static_cast<int>(run->engines.size()); ++c) {
      if (failed[c]) continue;
      for (int v : run->engines[c]->Selected()) cluster_of[v] = c;
    }
    report_.consensus = CheckAlignmentByClusterConsensus(
        graph, cluster_of, static_cast<int>(run->engines.size()),
        options_.engine.theta_deg, options_.consensus_min_support,
        alignment_options.max_vote_candidates, rotations);
    LOG_IF(INFO,
           options_.log_progress || report_.consensus.num_moved_clusters > 0)
        << "IRAv4: cluster consensus check: "
        << report_.consensus.num_contradicted << " of "
        << report_.consensus.num_relations
        << " cluster relations contradict the alignment; "
        << report_.consensus.num_moved_clusters << " clusters moved, "
        << report_.consensus.inliers_before << " -> "
        << report_.consensus.inliers_after << " inlier edges: "
        << (report_.consensus.applied ? "applied" : "not applied");
  }
  for (int c : pending) {
    LOG(WARNING) << "IRAv4: cluster " << c << " ("
                 << run->engines[c]->Selected().size()
                 << " vertices) did not align; its vertices are placed one "
                    "by one from their aligned neighbours";
  }
  report_.num_individually_placed = PlaceRemainingVertices(
      graph, options_.engine.theta_deg, estimated, rotations);
  run->engines.clear();  // release the engines before the final problem
}

void Irav4::OptimizeOverInlierEdges(const RotationGraph& graph,
                                    const std::vector<int>& estimated_vertices,
                                    std::vector<Eigen::Matrix3d>* rotations) {
  if (options_.num_final_rounds > 0 && estimated_vertices.size() >= 2) {
    // Eq. 11-12 on all vertices: the engine seeded with the aligned
    // rotations (same inlier selection and Ceres problem as the growth).
    IncrementalEngine final_engine(graph, options_.engine);
    CHECK(final_engine.InitializeFromRotations(estimated_vertices, *rotations));
    for (int round = 0; round < options_.num_final_rounds; ++round) {
      final_engine.GlobalOptimize();
    }
    report_.num_final_inlier_edges =
        final_engine.Stats().last_global_num_inliers;
    for (int v : estimated_vertices) {
      (*rotations)[v] = final_engine.Rotation(v);
    }
  }
}

void Irav4::RefineOverAllEdges(const RotationGraph& graph,
                               const std::vector<bool>& estimated, int root,
                               std::vector<Eigen::Matrix3d>* rotations) {
  // The truncated least squares of step 5 ignores every edge beyond theta
  // (so a vertex placed via outlier edges can never come back) and weighs
  // the inliers uniformly (at sigma 5 deg many inliers lie beyond theta = 3
  // deg); L1 then a smooth redescending loss on all edges fixes both.
  L1IrlsOptions refinement = options_.refinement;
  refinement.log_progress = refinement.log_progress || options_.log_progress;
  if (options_.final_refinement == Irav4FinalRefinement::kGuarded) {
    // L1 then IRLS from IRAv4's rotations, kept only if it lowers the
    // Geman-McClure cost over all edges below that of IRAv4's own
    // rotations. The L1 stage recovers cameras placed through random
    // outliers, but it is global: under structured outliers (mirrored
    // twins, mutually consistent) it can move a group of correct cameras
    // into the false basin; IRLS alone from there cannot come back, and the
    // cost says so. Otherwise IRLS alone refines IRAv4's rotations (local:
    // it stays in their basin). One cost evaluation, O(E), in the usual
    // case.
    const double sigma = DegToRad(options_.refinement.gm_sigma_deg);
    std::vector<Eigen::Matrix3d> unrefined = *rotations;
    const double cost_before =
        GemanMcClureCost(graph, estimated, *rotations, sigma);
    report_.num_refinement_iterations =
        RefineRotationsIrls(graph, refinement, estimated, root, rotations,
                            /*run_l1_stage=*/true);
    const double cost_after =
        GemanMcClureCost(graph, estimated, *rotations, sigma);
    report_.refinement_used_l1 = cost_after <= cost_before;
    if (!report_.refinement_used_l1) {
      rotations->swap(unrefined);
      report_.num_refinement_iterations += RefineRotationsIrls(
          graph, refinement, estimated, root, rotations, false);
    }
    LOG_IF(INFO, options_.log_progress)
        << "IRAv4: guarded refinement, Geman-McClure cost " << cost_before
        << " before, " << cost_after << " after L1 + IRLS: "
        << (report_.refinement_used_l1 ? "kept" : "rejected, IRLS only");
  } else {
    report_.refinement_used_l1 =
        options_.final_refinement == Irav4FinalRefinement::kL1Irls;
    report_.num_refinement_iterations =
        RefineRotationsIrls(graph, refinement, estimated, root, rotations,
                            report_.refinement_used_l1);
  }
  if (options_.reseed_vertices) {
    report_.num_reseeded_vertices =
        ReseedBadlySupportedVertices(graph, options_, estimated, rotations);
    if (report_.num_reseeded_vertices > 0) {
      report_.num_refinement_iterations +=
          RefineRotationsIrls(graph, refinement, estimated, root, rotations);
    }
    LOG_IF(INFO, options_.log_progress)
        << "IRAv4: re-seeded " << report_.num_reseeded_vertices
        << " badly supported vertices";
  }
}

}  // namespace colmap_irav4
