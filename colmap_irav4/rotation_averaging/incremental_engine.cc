#include "colmap_irav4/rotation_averaging/incremental_engine.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <tuple>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <glog/logging.h>
#include <Eigen/Geometry>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/cluster_alignment.h"
#include "colmap_irav4/rotation_averaging/l1_irls.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/interrupt.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

void IncrementalOptions::Check() const {
  const auto fail = [](const void* field, const std::string& name,
                       const std::string& problem) {
    throw OptionError(field, "RotationAveraging." + name, problem);
  };
  if (!(theta_deg > 0.0 && theta_deg < 180.0)) {
    fail(&theta_deg, "theta_deg",
         "must be in (0, 180), got " + std::to_string(theta_deg));
  }
  if (!(global_growth_ratio >= 0.0)) {
    fail(&global_growth_ratio, "global_growth_ratio",
         "must be >= 0, got " + std::to_string(global_growth_ratio));
  }
  if (max_num_iterations < 1)
    fail(&max_num_iterations, "max_num_iterations", "must be >= 1");
  if (max_num_local_iterations < 1) {
    fail(&max_num_local_iterations, "max_num_local_iterations", "must be >= 1");
  }
  if (!(function_tolerance > 0.0))
    fail(&function_tolerance, "function_tolerance", "must be > 0");
  if (max_seed_triplets < 0)
    fail(&max_seed_triplets, "max_seed_triplets", "must be >= 0");
  if (max_precomputations < 0)
    fail(&max_precomputations, "max_precomputations", "must be >= 0");
  if (max_direct_solver_vertices < 0) {
    fail(&max_direct_solver_vertices, "max_direct_solver_vertices",
         "must be >= 0");
  }
  if (num_threads < 1) fail(&num_threads, "num_threads", "must be >= 1");
  if (intermediate_global_iterations < 1) {
    fail(&intermediate_global_iterations, "intermediate_global_iterations",
         "must be >= 1");
  }
  if (!(global_step_tolerance_deg >= 0.0)) {
    // Not registered as a flag: named as the member.
    throw OptionError(&global_step_tolerance_deg,
                      "IncrementalOptions::global_step_tolerance_deg",
                      "must be >= 0");
  }
}

namespace {

// cos d(A, B) = (tr(B A^T) - 1) / 2 = (<A, B>_F - 1) / 2.
inline double CosDistance(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const double c = ((A.array() * B.array()).sum() - 1.0) * 0.5;
  return std::clamp(c, -1.0, 1.0);
}

// R_{from,to} R without copying the (possibly transposed) measurement.
inline Eigen::Matrix3d Chain(const RotationGraph& graph, int edge_idx, int from,
                             const Eigen::Matrix3d& R) {
  const RelativeRotation& edge = graph.Edge(edge_idx);
  if (edge.i == from) return edge.R_ij * R;
  return edge.R_ij.transpose() * R;
}

// cos d(R_{from,to}, X).
inline double CosToEdge(const RotationGraph& graph, int edge_idx, int from,
                        const Eigen::Matrix3d& X) {
  const RelativeRotation& edge = graph.Edge(edge_idx);
  const double dot = edge.i == from
                         ? (edge.R_ij.array() * X.array()).sum()
                         : (edge.R_ij.transpose().array() * X.array()).sum();
  return std::clamp((dot - 1.0) * 0.5, -1.0, 1.0);
}

// Residual of an edge: the angle-axis vector of R_ij^T R_j R_i^T, so that the
// squared norm is d^2(R_ij, R_j R_i^T). Quaternions in Eigen's (x, y, z, w)
// storage, kept unit by ceres::EigenQuaternionManifold.
struct RelativeRotationError {
  explicit RelativeRotationError(const Eigen::Matrix3d& R_ij)
      : q_ij_inverse(Eigen::Quaterniond(R_ij).conjugate()) {}
  template <typename T>
  bool operator()(const T* q_i, const T* q_j, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Q_i(q_i);
    const Eigen::Map<const Eigen::Quaternion<T>> Q_j(q_j);
    const Eigen::Quaternion<T> E =
        q_ij_inverse.template cast<T>() * Q_j * Q_i.conjugate();
    const T wxyz[4] = {E.w(), E.x(), E.y(), E.z()};
    ceres::QuaternionToAngleAxis(wxyz, residual);
    return true;
  }
  Eigen::Quaterniond q_ij_inverse;
};

// The same with R_i fixed (local optimisation of R_j, Eq. 10): the angle-axis
// vector of R_ij^T R_j R_i^T.
struct FixedNeighborError {
  FixedNeighborError(const Eigen::Matrix3d& R_ij, const Eigen::Matrix3d& R_i)
      : q_ij_inverse(Eigen::Quaterniond(R_ij).conjugate()),
        q_i_inverse(Eigen::Quaterniond(R_i).conjugate()) {}
  template <typename T>
  bool operator()(const T* q_j, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Q_j(q_j);
    const Eigen::Quaternion<T> E =
        q_ij_inverse.template cast<T>() * Q_j * q_i_inverse.template cast<T>();
    const T wxyz[4] = {E.w(), E.x(), E.y(), E.z()};
    ceres::QuaternionToAngleAxis(wxyz, residual);
    return true;
  }
  Eigen::Quaterniond q_ij_inverse;
  Eigen::Quaterniond q_i_inverse;
};

Eigen::Vector4d ToQuaternionStorage(const Eigen::Matrix3d& R) {
  return Eigen::Quaterniond(R).normalized().coeffs();  // x, y, z, w
}

Eigen::Matrix3d FromQuaternionStorage(const Eigen::Vector4d& coeffs) {
  return Eigen::Quaterniond(coeffs(3), coeffs(0), coeffs(1), coeffs(2))
      .normalized()
      .toRotationMatrix();
}

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

int FindRoot(std::vector<int>* parent, int v) {
  while ((*parent)[v] != v) {
    (*parent)[v] = (*parent)[(*parent)[v]];
    v = (*parent)[v];
  }
  return v;
}

}  // namespace

std::shared_ptr<const IncrementalEngine::AdjacencyList>
IncrementalEngine::BuildAdjacency(const RotationGraph& graph) {
  auto adjacency = std::make_shared<AdjacencyList>(graph.NumVertices());
  for (int v = 0; v < graph.NumVertices(); ++v) {
    std::vector<std::pair<int, int>> neighbors = graph.Neighbors(v);
    // Duplicate pairs: keep the heaviest edge, ties the smaller index.
    std::sort(neighbors.begin(), neighbors.end(),
              [&](const std::pair<int, int>& a, const std::pair<int, int>& b) {
                if (a.first != b.first) return a.first < b.first;
                const double wa = graph.Edge(a.second).weight;
                const double wb = graph.Edge(b.second).weight;
                if (wa != wb) return wa > wb;
                return a.second < b.second;
              });
    auto& list = (*adjacency)[v];
    for (const auto& neighbor : neighbors) {
      if (list.empty() || list.back().first != neighbor.first) {
        list.push_back(neighbor);
      }
    }
    list.shrink_to_fit();
  }
  return adjacency;
}

IncrementalEngine::IncrementalEngine(
    const RotationGraph& graph, const IncrementalOptions& options,
    std::vector<bool> allowed, std::shared_ptr<const AdjacencyList> adjacency)
    : graph_(graph),
      options_(options),
      cos_theta_(std::cos(DegToRad(options.theta_deg))),
      allowed_(std::move(allowed)),
      adjacency_(adjacency ? std::move(adjacency) : BuildAdjacency(graph)) {
  options_.Check();
  const int n = graph_.NumVertices();
  if (allowed_.empty()) allowed_.assign(n, true);
  CHECK_EQ(static_cast<int>(allowed_.size()), n);
  CHECK_EQ(static_cast<int>(adjacency_->size()), n);
  selected_.assign(n, false);
  excluded_.assign(n, false);
  rotations_.assign(n, Eigen::Matrix3d::Identity());
  in_frontier_.assign(n, false);
  candidates_.resize(n);
}

int IncrementalEngine::FindEdge(int u, int v) const {
  const auto& adjacency = (*adjacency_)[u];
  const auto it = std::lower_bound(
      adjacency.begin(), adjacency.end(), std::make_pair(v, -1),
      [](const std::pair<int, int>& a, const std::pair<int, int>& b) {
        return a.first < b.first;
      });
  return it != adjacency.end() && it->first == v ? it->second : -1;
}

void IncrementalEngine::SelectVertex(int v, const Eigen::Matrix3d& R) {
  CHECK(CanSelect(v)) << v;
  RemoveCandidate(v);
  selected_[v] = true;
  rotations_[v] = R;
  selected_list_.push_back(v);
}

void IncrementalEngine::AfterSeed() {
  size_at_last_global_ = NumSelected();
  for (int s : selected_list_) {
    for (const auto& [q, e] : (*adjacency_)[s]) {
      if (CanSelect(q) && !in_frontier_[q]) {
        in_frontier_[q] = true;
        frontier_list_.push_back(q);
      }
    }
  }
  for (int p : frontier_list_) {
    if (!in_frontier_[p]) continue;
    RecomputeCandidate(p);
    PushCandidate(p);
  }
}

double IncrementalEngine::OptimizeTriplet(int i, int j, int k, int e_ij,
                                          int e_ik, int e_jk,
                                          Eigen::Matrix3d* R_i,
                                          Eigen::Matrix3d* R_j,
                                          Eigen::Matrix3d* R_k) {
  // Eq. 1: R_i = I, R_j = R_ij, R_k = R_ik.
  const Eigen::Matrix3d R_ij = graph_.RotationFrom(e_ij, i);
  const Eigen::Matrix3d R_ik = graph_.RotationFrom(e_ik, i);
  const Eigen::Matrix3d R_jk = graph_.RotationFrom(e_jk, j);
  if (!options_.use_ceres) {
    // Eq. 3 by Gauss-Newton on the three edges, R_i held for the gauge.
    const int n = graph_.NumVertices();
    std::vector<Eigen::Matrix3d>& R = scratch_rotations_;
    std::vector<bool>& fixed = scratch_fixed_;
    if (static_cast<int>(R.size()) != n) {
      R.assign(n, Eigen::Matrix3d::Identity());
      fixed.assign(n, false);
    }
    R[i] = Eigen::Matrix3d::Identity();
    R[j] = R_ij;
    R[k] = R_ik;
    fixed[i] = true;
    OptimizeRotationsOnEdges(graph_, {e_ij, e_ik, e_jk}, {i, j, k}, fixed,
                             L1IrlsOptions(), options_.max_num_local_iterations,
                             options_.global_step_tolerance_deg, &R);
    fixed[i] = false;
    *R_i = R[i];
    *R_j = R[j];
    *R_k = R[k];
  } else {
    Eigen::Vector4d q_i = ToQuaternionStorage(Eigen::Matrix3d::Identity());
    Eigen::Vector4d q_j = ToQuaternionStorage(R_ij);
    Eigen::Vector4d q_k = ToQuaternionStorage(R_ik);
    // Eq. 3 with R_i held for the gauge.
    ceres::EigenQuaternionManifold manifold;
    ceres::Problem problem(ProblemOptions());
    using Cost = ceres::AutoDiffCostFunction<RelativeRotationError, 3, 4, 4>;
    problem.AddResidualBlock(new Cost(new RelativeRotationError(R_ij)), nullptr,
                             q_i.data(), q_j.data());
    problem.AddResidualBlock(new Cost(new RelativeRotationError(R_ik)), nullptr,
                             q_i.data(), q_k.data());
    problem.AddResidualBlock(new Cost(new RelativeRotationError(R_jk)), nullptr,
                             q_j.data(), q_k.data());
    for (double* q : {q_i.data(), q_j.data(), q_k.data()}) {
      problem.SetManifold(q, &manifold);
    }
    problem.SetParameterBlockConstant(q_i.data());
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options_.max_num_local_iterations;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    *R_i = FromQuaternionStorage(q_i);
    *R_j = FromQuaternionStorage(q_j);
    *R_k = FromQuaternionStorage(q_k);
  }
  // Eq. 4.
  return CosDistance(R_ij, *R_j * R_i->transpose()) +
         CosDistance(R_ik, *R_k * R_i->transpose()) +
         CosDistance(R_jk, *R_k * R_j->transpose());
}

bool IncrementalEngine::InitializeFromBestTriplet(
    const std::vector<bool>& restrict_to) {
  CHECK(selected_list_.empty()) << "engine already initialised";
  CHECK(restrict_to.empty() ||
        static_cast<int>(restrict_to.size()) == graph_.NumVertices());
  const Timer timer;
  const auto ok = [&](int v) {
    return CanSelect(v) && (restrict_to.empty() || restrict_to[v]);
  };
  // Every triangle once (i < j < k) by intersecting the sorted adjacency
  // lists of each edge's ends; the cheap chaining check (Eq. 2) first, and
  // the best `max_seed_triplets` by cycle error kept in a bounded max-heap.
  struct Triangle {
    double score;  // 1 - cos(cycle error): smaller is better
    int i, j, k, e_ij, e_ik, e_jk;
    bool operator<(const Triangle& o) const {
      return std::tie(score, i, j, k) < std::tie(o.score, o.i, o.j, o.k);
    }
  };
  const size_t max_kept = options_.max_seed_triplets == 0
                              ? std::numeric_limits<size_t>::max()
                              : static_cast<size_t>(options_.max_seed_triplets);
  std::priority_queue<Triangle> kept;  // worst on top
  const int n = graph_.NumVertices();
  for (int i = 0; i < n; ++i) {
    if (!ok(i)) continue;
    const auto& adj_i = (*adjacency_)[i];
    for (size_t a = 0; a < adj_i.size(); ++a) {
      const auto [j, e_ij] = adj_i[a];
      if (j <= i || !ok(j)) continue;
      const Eigen::Matrix3d R_ij = graph_.RotationFrom(e_ij, i);
      const auto& adj_j = (*adjacency_)[j];
      // Both lists sorted by neighbour: walk them for common k > j.
      size_t x = a + 1;
      size_t y =
          std::upper_bound(adj_j.begin(), adj_j.end(),
                           std::make_pair(j, std::numeric_limits<int>::max())) -
          adj_j.begin();
      while (x < adj_i.size() && y < adj_j.size()) {
        const int k_i = adj_i[x].first;
        const int k_j = adj_j[y].first;
        if (k_i < k_j) {
          ++x;
        } else if (k_j < k_i) {
          ++y;
        } else {
          const int k = k_i;
          if (ok(k)) {
            ++stats_.num_triangles;
            const int e_ik = adj_i[x].second;
            const int e_jk = adj_j[y].second;
            // Eq. 2: d(R_jk, R_ik R_ij^T) < theta.
            const Eigen::Matrix3d chained =
                Chain(graph_, e_ik, i, R_ij.transpose());
            const double c = CosToEdge(graph_, e_jk, j, chained);
            if (c > cos_theta_) {
              ++stats_.num_triangles_passed;
              const Triangle t{1.0 - c, i, j, k, e_ij, e_ik, e_jk};
              if (kept.size() < max_kept) {
                kept.push(t);
              } else if (t < kept.top()) {
                kept.pop();
                kept.push(t);
              }
            }
          }
          ++x;
          ++y;
        }
      }
    }
  }
  std::vector<Triangle> best;
  best.reserve(kept.size());
  while (!kept.empty()) {
    best.push_back(kept.top());
    kept.pop();
  }
  std::reverse(best.begin(), best.end());  // best pre-score first
  double best_reward = -std::numeric_limits<double>::infinity();
  Eigen::Matrix3d R[3];
  int winner[3] = {-1, -1, -1};
  for (const Triangle& t : best) {
    Eigen::Matrix3d R_i, R_j, R_k;
    const double reward = OptimizeTriplet(t.i, t.j, t.k, t.e_ij, t.e_ik, t.e_jk,
                                          &R_i, &R_j, &R_k);
    ++stats_.num_triangles_optimized;
    if (reward > best_reward) {  // strict: ties keep the better pre-score
      best_reward = reward;
      winner[0] = t.i;
      winner[1] = t.j;
      winner[2] = t.k;
      R[0] = R_i;
      R[1] = R_j;
      R[2] = R_k;
    }
  }
  stats_.seed_seconds += timer.ElapsedSeconds();
  if (winner[0] < 0) return false;
  for (int s = 0; s < 3; ++s) SelectVertex(winner[s], R[s]);
  last_added_ = winner[2];
  AfterSeed();
  return true;
}

bool IncrementalEngine::InitializeFromTriplet(int i, int j, int k) {
  CHECK(selected_list_.empty()) << "engine already initialised";
  const int n = graph_.NumVertices();
  for (int v : {i, j, k}) {
    if (v < 0 || v >= n || !CanSelect(v)) return false;
  }
  if (i == j || j == k || i == k) return false;
  const int e_ij = FindEdge(i, j);
  const int e_ik = FindEdge(i, k);
  const int e_jk = FindEdge(j, k);
  if (e_ij < 0 || e_ik < 0 || e_jk < 0) return false;
  const Eigen::Matrix3d chained =
      graph_.RotationFrom(e_ik, i) * graph_.RotationFrom(e_ij, i).transpose();
  if (CosDistance(graph_.RotationFrom(e_jk, j), chained) <= cos_theta_) {
    return false;
  }
  Eigen::Matrix3d R_i, R_j, R_k;
  OptimizeTriplet(i, j, k, e_ij, e_ik, e_jk, &R_i, &R_j, &R_k);
  ++stats_.num_triangles_optimized;
  SelectVertex(i, R_i);
  SelectVertex(j, R_j);
  SelectVertex(k, R_k);
  last_added_ = k;
  AfterSeed();
  return true;
}

bool IncrementalEngine::InitializeFromVertex(int v) {
  CHECK(selected_list_.empty()) << "engine already initialised";
  if (v < 0 || v >= graph_.NumVertices() || !CanSelect(v)) return false;
  SelectVertex(v, Eigen::Matrix3d::Identity());
  last_added_ = v;
  AfterSeed();
  return true;
}

bool IncrementalEngine::InitializeFromRotations(
    const std::vector<int>& vertices,
    const std::vector<Eigen::Matrix3d>& rotations) {
  CHECK(selected_list_.empty()) << "engine already initialised";
  CHECK_EQ(static_cast<int>(rotations.size()), graph_.NumVertices());
  if (vertices.empty()) return false;
  for (int v : vertices) {
    if (v < 0 || v >= graph_.NumVertices() || !CanSelect(v)) return false;
  }
  for (int v : vertices) SelectVertex(v, rotations[v]);
  last_added_ = vertices.back();
  AfterSeed();
  return true;
}

void IncrementalEngine::RemoveCandidate(int p) {
  if (!in_frontier_[p]) return;
  in_frontier_[p] = false;
  CandidateState& state = candidates_[p];
  std::vector<Precomputation>().swap(state.precomputations);
  state.best = -1;
  ++state.version;
}

void IncrementalEngine::RecomputeCandidate(int p) {
  CandidateState& state = candidates_[p];
  auto& pre = state.precomputations;
  pre.clear();
  for (const auto& [m, e] : (*adjacency_)[p]) {
    if (!selected_[m]) continue;
    Precomputation entry;
    entry.m = m;
    entry.weight = graph_.Edge(e).weight;
    entry.P = Chain(graph_, e, m, rotations_[m]);  // Eq. 5
    pre.push_back(entry);
  }
  const int D = static_cast<int>(pre.size());
  const int cap = options_.max_precomputations;
  if (cap == 0 || D <= cap) {
    // Eq. 6-7 for every pre-computation: each pair once; the edge e_mp
    // supports its own pre-computation (cos 0 = 1).
    for (auto& entry : pre) {
      entry.evaluated = true;
      entry.reward = 1.0;
    }
    for (int a = 0; a < D; ++a) {
      for (int b = a + 1; b < D; ++b) {
        const double c = CosDistance(pre[a].P, pre[b].P);
        if (c > cos_theta_) {
          pre[a].reward += c;
          pre[b].reward += c;
        }
      }
    }
  } else {
    std::vector<int> order(D);
    std::iota(order.begin(), order.end(), 0);
    std::partial_sort(order.begin(), order.begin() + cap, order.end(),
                      [&](int a, int b) {
                        if (pre[a].weight != pre[b].weight) {
                          return pre[a].weight > pre[b].weight;
                        }
                        return pre[a].m < pre[b].m;
                      });
    for (int r = 0; r < cap; ++r) {
      Precomputation& entry = pre[order[r]];
      entry.evaluated = true;
      entry.reward = 1.0;
      for (int b = 0; b < D; ++b) {
        if (b == order[r]) continue;
        const double c = CosDistance(entry.P, pre[b].P);
        if (c > cos_theta_) entry.reward += c;
      }
    }
  }
  // Eq. 8, first line: entries are in neighbour order, strict > keeps the
  // smaller index on ties.
  state.best = -1;
  for (int a = 0; a < D; ++a) {
    if (pre[a].evaluated &&
        (state.best < 0 || pre[a].reward > pre[state.best].reward)) {
      state.best = a;
    }
  }
  state.epoch = epoch_;
  ++stats_.num_full_reward_computations;
}

void IncrementalEngine::UpdateCandidate(int p, int x, int edge_idx) {
  CandidateState& state = candidates_[p];
  auto& pre = state.precomputations;
  // Stale pre-computations (older rotations) would not support the new one
  // even where they should: a candidate touched after a global optimisation
  // is recomputed in full once, then updated incrementally again.
  if (pre.empty() || state.epoch != epoch_) {
    RecomputeCandidate(p);
    return;
  }
  Precomputation added;
  added.m = x;
  added.weight = graph_.Edge(edge_idx).weight;
  added.P = Chain(graph_, edge_idx, x, rotations_[x]);
  added.evaluated = true;
  added.reward = 1.0;
  for (Precomputation& entry : pre) {
    const double c = CosDistance(entry.P, added.P);
    if (c > cos_theta_) {
      if (entry.evaluated) entry.reward += c;
      added.reward += c;
    }
  }
  pre.push_back(added);
  state.best = -1;
  for (int a = 0; a < static_cast<int>(pre.size()); ++a) {
    if (!pre[a].evaluated) continue;
    if (state.best < 0 || pre[a].reward > pre[state.best].reward ||
        (pre[a].reward == pre[state.best].reward &&
         pre[a].m < pre[state.best].m)) {
      state.best = a;
    }
  }
  ++stats_.num_incremental_reward_updates;
}

void IncrementalEngine::PushCandidate(int p) {
  CandidateState& state = candidates_[p];
  ++state.version;
  if (state.best < 0) return;
  queue_.push({state.precomputations[state.best].reward, p, state.version});
}

void IncrementalEngine::RecomputeAllCandidates() {
  std::priority_queue<QueueEntry>().swap(queue_);
  std::vector<int> frontier;
  frontier.reserve(frontier_list_.size());
  for (int p : frontier_list_) {
    if (in_frontier_[p]) frontier.push_back(p);
  }
  std::sort(frontier.begin(), frontier.end());
  frontier.erase(std::unique(frontier.begin(), frontier.end()), frontier.end());
  frontier_list_ = frontier;
  for (int p : frontier) {
    RecomputeCandidate(p);
    PushCandidate(p);
  }
  full_recompute_epoch_ = epoch_;
}

IncrementalEngine::Candidate IncrementalEngine::BestCandidate() {
  Candidate candidate;
  if (selected_list_.empty()) return candidate;
  if (!options_.lazy_reward_recomputation && full_recompute_epoch_ != epoch_) {
    const Timer timer;
    RecomputeAllCandidates();
    stats_.reward_seconds += timer.ElapsedSeconds();
  }
  while (!queue_.empty()) {
    const QueueEntry top = queue_.top();
    const CandidateState& state = candidates_[top.vertex];
    if (!in_frontier_[top.vertex] || top.version != state.version ||
        state.best < 0) {
      queue_.pop();
      continue;
    }
    if (state.epoch != epoch_) {
      // Stale since a global optimisation: recompute and re-queue.
      queue_.pop();
      const Timer timer;
      RecomputeCandidate(top.vertex);
      PushCandidate(top.vertex);
      stats_.reward_seconds += timer.ElapsedSeconds();
      continue;
    }
    const Precomputation& best = state.precomputations[state.best];
    candidate.vertex = top.vertex;
    candidate.via = best.m;
    candidate.reward = best.reward;
    candidate.R_init = best.P;
    return candidate;
  }
  return candidate;
}

void IncrementalEngine::LocalOptimize(int p,
                                      const std::vector<int>& inlier_edges) {
  // One inlier edge (the chaining edge itself): the initialisation is
  // already the minimiser.
  if (inlier_edges.size() < 2) return;
  if (!options_.use_ceres) {
    // Eq. 10's minimiser: sum_n d^2(R_p, R_np R_n) is minimised by the
    // geodesic (Karcher) mean of the chained predictions.
    std::vector<Eigen::Matrix3d> predictions;
    predictions.reserve(inlier_edges.size());
    for (int e : inlier_edges) {
      const int n = graph_.OtherEnd(e, p);
      predictions.push_back(Chain(graph_, e, n, rotations_[n]));
    }
    rotations_[p] = GeodesicMean(predictions, rotations_[p],
                                 options_.max_num_local_iterations);
    ++stats_.num_local_optimizations;
    return;
  }
  Eigen::Vector4d q_p = ToQuaternionStorage(rotations_[p]);
  ceres::EigenQuaternionManifold manifold;
  ceres::Problem problem(ProblemOptions());
  using Cost = ceres::AutoDiffCostFunction<FixedNeighborError, 3, 4>;
  for (int e : inlier_edges) {
    const int n = graph_.OtherEnd(e, p);
    problem.AddResidualBlock(new Cost(new FixedNeighborError(
                                 graph_.RotationFrom(e, n), rotations_[n])),
                             nullptr, q_p.data());
  }
  problem.SetManifold(q_p.data(), &manifold);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options_.max_num_local_iterations;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  rotations_[p] = FromQuaternionStorage(q_p);
  ++stats_.num_local_optimizations;
}

void IncrementalEngine::AddVertex(const Candidate& candidate) {
  const int p = candidate.vertex;
  CHECK(p >= 0 && p < graph_.NumVertices()) << p;
  CHECK(!selected_list_.empty()) << "engine not initialised";
  const Timer timer;
  // Eq. 9: inliers of the initialisation R_p^{m*} among the selected
  // neighbours: d(R_np, R_p R_n^T) = d(R_np R_n, R_p).
  std::vector<int> inlier_edges;
  for (const auto& [n, e] : (*adjacency_)[p]) {
    if (!selected_[n]) continue;
    const double c =
        CosDistance(Chain(graph_, e, n, rotations_[n]), candidate.R_init);
    if (c > cos_theta_) inlier_edges.push_back(e);
  }
  SelectVertex(p, candidate.R_init);
  last_added_ = p;
  LocalOptimize(p, inlier_edges);  // Eq. 10
  stats_.local_seconds += timer.ElapsedSeconds();

  const bool global =
      NumSelected() >= static_cast<double>(size_at_last_global_) *
                           (1.0 + options_.global_growth_ratio);
  if (global) GlobalOptimize(false);  // makes every candidate stale

  const Timer reward_timer;
  for (const auto& [q, e] : (*adjacency_)[p]) {
    if (!CanSelect(q)) continue;
    if (!in_frontier_[q]) {
      in_frontier_[q] = true;
      frontier_list_.push_back(q);
    }
    // A stale candidate is recomputed here (UpdateCandidate); one not
    // touched stays stale until it reaches the top of the queue.
    UpdateCandidate(q, p, e);
    PushCandidate(q);
  }
  stats_.reward_seconds += reward_timer.ElapsedSeconds();
}

void IncrementalEngine::Exclude(int vertex) {
  CHECK(!selected_[vertex]) << "cannot exclude a selected vertex " << vertex;
  excluded_[vertex] = true;
  RemoveCandidate(vertex);
}

void IncrementalEngine::Allow(int vertex) {
  if (allowed_[vertex]) return;
  allowed_[vertex] = true;
  if (!CanSelect(vertex) || selected_list_.empty()) return;
  for (const auto& [u, e] : (*adjacency_)[vertex]) {
    if (!selected_[u]) continue;
    in_frontier_[vertex] = true;
    frontier_list_.push_back(vertex);
    RecomputeCandidate(vertex);
    PushCandidate(vertex);
    break;
  }
}

void IncrementalEngine::GlobalOptimize(bool converge) {
  if (selected_list_.size() < 2) return;
  const Timer timer;
  const int n = graph_.NumVertices();
  // Eq. 11: the edges within the set whose current residual is below theta.
  std::vector<int> local_index(n, -1);
  for (size_t s = 0; s < selected_list_.size(); ++s) {
    local_index[selected_list_[s]] = static_cast<int>(s);
  }
  std::vector<std::pair<int, int>> inliers;  // (edge, from vertex)
  int num_edges = 0;
  for (int v : selected_list_) {
    for (const auto& [u, e] : (*adjacency_)[v]) {
      if (u <= v || !selected_[u]) continue;
      ++num_edges;
      if (CosDistance(Chain(graph_, e, v, rotations_[v]), rotations_[u]) >
          cos_theta_) {
        inliers.emplace_back(e, v);
      }
    }
  }
  stats_.last_global_num_edges = num_edges;
  stats_.last_global_num_inliers = static_cast<int>(inliers.size());
  if (options_.use_ceres) {
    GlobalOptimizeCeres(inliers, local_index, converge);
  } else if (!inliers.empty()) {
    // Eq. 12 by Gauss-Newton in the tangent space (the sparse block
    // Laplacian of the inlier edges, symbolic analysis once per call), warm
    // started. Gauge: one vertex held per connected component of the inlier
    // graph (the first selected of each), so every component is well posed.
    const int num_selected = NumSelected();
    std::vector<int> parent(num_selected);
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<bool> used(num_selected, false);
    std::vector<int> edges;
    edges.reserve(inliers.size());
    for (const auto& [e, v] : inliers) {
      const int a = local_index[v];
      const int b = local_index[graph_.OtherEnd(e, v)];
      edges.push_back(e);
      used[a] = used[b] = true;
      const int ra = FindRoot(&parent, a);
      const int rb = FindRoot(&parent, b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
    std::vector<int> vertices;
    std::vector<bool> fixed(n, false);
    std::vector<bool> fixed_root(num_selected, false);
    for (int s = 0; s < num_selected; ++s) {
      if (!used[s]) continue;
      vertices.push_back(selected_list_[s]);
      const int root = FindRoot(&parent, s);
      if (!fixed_root[root]) {
        fixed_root[root] = true;
        fixed[selected_list_[s]] = true;
      }
    }
    const int num_iterations = converge
                                   ? options_.max_num_iterations
                                   : options_.intermediate_global_iterations;
    OptimizeRotationsOnEdges(graph_, edges, vertices, fixed, L1IrlsOptions(),
                             num_iterations, options_.global_step_tolerance_deg,
                             &rotations_);
    VLOG(2) << "global optimisation: " << vertices.size() << " vertices, "
            << inliers.size() << "/" << num_edges << " inlier edges";
  }
  size_at_last_global_ = NumSelected();
  ++epoch_;
  ++stats_.num_global_optimizations;
  stats_.global_seconds += timer.ElapsedSeconds();
}

void IncrementalEngine::GlobalOptimizeCeres(
    const std::vector<std::pair<int, int>>& inliers,
    const std::vector<int>& local_index, bool converge) {
  const int num_selected = NumSelected();
  std::vector<Eigen::Vector4d> q(num_selected);
  for (int s = 0; s < num_selected; ++s) {
    q[s] = ToQuaternionStorage(rotations_[selected_list_[s]]);
  }
  // Gauge: one vertex held per connected component of the inlier graph (the
  // first selected of each), so that every component is well posed.
  std::vector<int> parent(num_selected);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<bool> used(num_selected, false);
  ceres::EigenQuaternionManifold manifold;
  ceres::Problem problem(ProblemOptions());
  using Cost = ceres::AutoDiffCostFunction<RelativeRotationError, 3, 4, 4>;
  for (const auto& [e, v] : inliers) {
    const int u = graph_.OtherEnd(e, v);
    const int a = local_index[v];
    const int b = local_index[u];
    problem.AddResidualBlock(
        new Cost(new RelativeRotationError(graph_.RotationFrom(e, v))), nullptr,
        q[a].data(), q[b].data());
    used[a] = used[b] = true;
    const int ra = FindRoot(&parent, a);
    const int rb = FindRoot(&parent, b);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  int num_used = 0;
  std::vector<bool> fixed_root(num_selected, false);
  for (int s = 0; s < num_selected; ++s) {
    if (!used[s]) continue;
    ++num_used;
    problem.SetManifold(q[s].data(), &manifold);
    const int root = FindRoot(&parent, s);
    if (!fixed_root[root]) {
      fixed_root[root] = true;
      problem.SetParameterBlockConstant(q[s].data());
    }
  }
  if (!inliers.empty()) {
    ceres::Solver::Options solver_options;
    // The previous engine: every global optimisation to convergence.
    (void)converge;
    solver_options.max_num_iterations = options_.max_num_iterations;
    solver_options.function_tolerance = options_.function_tolerance;
    solver_options.gradient_tolerance = 1e-12;
    solver_options.parameter_tolerance = 1e-10;
    solver_options.num_threads = options_.num_threads;
    solver_options.logging_type = ceres::SILENT;
    if (options_.max_direct_solver_vertices == 0 ||
        num_used <= options_.max_direct_solver_vertices) {
      solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
      solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    } else {
      solver_options.linear_solver_type = ceres::CGNR;
      solver_options.preconditioner_type = ceres::JACOBI;
    }
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    VLOG(2) << "global optimisation: " << num_used << " vertices, "
            << inliers.size() << "/" << stats_.last_global_num_edges
            << " inlier edges, " << summary.BriefReport();
    for (int s = 0; s < num_selected; ++s) {
      if (used[s]) rotations_[selected_list_[s]] = FromQuaternionStorage(q[s]);
    }
  }
}

int IncrementalEngine::Grow(const std::function<bool()>& stop) {
  int num_added = 0;
  while (true) {
    ThrowIfInterrupted();  // a checkpoint per vertex (util/interrupt.h)
    const Candidate candidate = BestCandidate();
    if (candidate.vertex < 0) break;
    AddVertex(candidate);
    ++num_added;
    if (stop && stop()) break;
  }
  return num_added;
}

}  // namespace colmap_irav4
