#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <queue>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Parameters of the incremental growth engine (the paper's Eq. 1-12), with
// the paper's values as defaults.
struct IncrementalOptions {
  // Outlier threshold theta (deg): chaining check (Eq. 2), supporting sets
  // (Eq. 6), local and global inlier sets (Eq. 9, 11).
  double theta_deg = 3.0;
  // A global optimisation (Eq. 11-12) runs whenever the selected set has
  // grown by this ratio since the last one.
  double global_growth_ratio = 0.05;
  // Ceres iterations of a global (Eq. 12) and of a local (Eq. 10) problem.
  int max_num_iterations = 50;
  int max_num_local_iterations = 20;
  // Ceres function tolerance of the global problems (relative cost change).
  double function_tolerance = 1e-8;
  // Seed triplets: every triangle passing the chaining check (Eq. 2) is
  // scored by its cycle error (cheap); only the best `max_seed_triplets` are
  // optimised with Ceres (Eq. 3) and ranked by Eq. 4. On a triangle the
  // optimum spreads the cycle error over the three edges, so Eq. 4's reward
  // is (very nearly) a decreasing function of the cycle error and the
  // winner is among them; bounding the count keeps graphs with millions of
  // consistent triangles cheap. 0 = optimise them all (the paper).
  int max_seed_triplets = 100;
  // Bound on the pre-computations R_p^m (Eq. 5) whose reward (Eq. 7) is
  // evaluated when a candidate's rewards are recomputed from scratch (after a
  // global optimisation): the `max_precomputations` with the largest edge
  // weights (ties: smaller vertex index). Every pre-computation still counts
  // as a supporter; incremental updates always evaluate the new one. Keeps
  // a recomputation O(K deg) instead of O(deg^2). 0 = unlimited.
  int max_precomputations = 256;
  // With use_ceres: global problems over more vertices than this use Ceres'
  // iterative CGNR
  // (Jacobi preconditioner) instead of SPARSE_NORMAL_CHOLESKY (SuiteSparse):
  // on dense view graphs the Cholesky factor fills in completely, O((3n)^3)
  // per iteration (measured: 1,000-2,000 vertices of a 5,000 x 700,000
  // random graph took seconds per factorisation), while the Laplacian of a
  // dense rotation graph is well conditioned for CG. 400 vertices keep a
  // dense factor under ~1e9 flops. 0 = always direct.
  int max_direct_solver_vertices = 400;
  // Threads: IRAv4 finds its cluster seeds, grows its clusters beside its
  // reference and optimises its clusters in parallel (the same result for
  // any count); Ceres threads with use_ceres (1 keeps its output
  // bit-identical from run to run).
  int num_threads = 1;
  // The problems of Eq. 3, 10 and 12 with Ceres (autodiff, the previous
  // engine: 6-10x slower on dense graphs) instead of Gauss-Newton in the
  // tangent space on the sparse Laplacian (Eq. 12, 3) and the geodesic mean
  // of the chained predictions (Eq. 10, its exact minimiser).
  bool use_ceres = false;
  // Gauss-Newton steps of an intermediate global optimisation (each 5% of
  // growth), warm-started from the current rotations; the final ones (and
  // GlobalOptimize() called from outside) run to convergence.
  int intermediate_global_iterations = 2;
  // After a global optimisation, recompute a candidate's rewards only when it
  // reaches the top of the queue (its stale reward orders it meanwhile; the
  // chosen candidate's reward is always fresh). false: recompute every
  // candidate (exact Eq. 8 argmax, the previous behaviour, O(frontier x K x
  // deg) per global optimisation).
  bool lazy_reward_recomputation = true;
  // A converged global optimisation stops when the mean step is below this.
  double global_step_tolerance_deg = 1e-6;
  void Check() const;  // throws OptionError naming the option
};

struct IncrementalStats {
  int64_t num_triangles = 0;         // enumerated (all vertices allowed)
  int64_t num_triangles_passed = 0;  // passed the chaining check (Eq. 2)
  int num_triangles_optimized = 0;   // optimised with Ceres (Eq. 3)
  int num_local_optimizations = 0;
  int num_global_optimizations = 0;
  int64_t num_full_reward_computations = 0;  // candidates recomputed
  int64_t num_incremental_reward_updates = 0;
  int last_global_num_inliers = 0;  // inlier edges of the last Eq. 12
  int last_global_num_edges = 0;    // edges within the set at that time
  double seed_seconds = 0.0;
  double reward_seconds = 0.0;
  double local_seconds = 0.0;
  double global_seconds = 0.0;
};

// The incremental parameter-estimation engine of the IRA series: a seed
// triplet (Eq. 1-4), then the next-best vertex by support reward (Eq. 5-8),
// initialised by chaining, locally optimised on its inlier edges (Eq. 9-10),
// and the whole set globally optimised on its inlier edges (Eq. 11-12) every
// `global_growth_ratio` of growth. The stopping rule is the caller's, so that
// IRA (all vertices), the IRAv4 reference (dominating) and cluster growth
// share it. Rotations are in the set's local frame (seed vertex = identity).
//
// Rewards are maintained incrementally: each candidate keeps its
// pre-computations R_p^m = R_mp R_m and their rewards; adding vertex x only
// touches x's unselected neighbours (O(deg_s) each). A global optimisation
// changes every rotation of the set, so every candidate's pre-computations
// become stale; a stale candidate is recomputed only when it reaches the top
// of the queue (its stale reward orders it meanwhile). The next best vertex
// comes from a priority queue with lazy invalidation (versions, epochs).
// Deterministic: ties are broken by vertex index; no hash iteration; Ceres
// single-threaded by default.
class IncrementalEngine {
 public:
  // Per vertex, (neighbour, edge index) pairs sorted by neighbour, one edge
  // per neighbour (the heaviest; ties: the smaller edge index).
  using AdjacencyList = std::vector<std::vector<std::pair<int, int>>>;
  static std::shared_ptr<const AdjacencyList> BuildAdjacency(
      const RotationGraph& graph);

  // `allowed`: vertices this engine may ever select (empty = all).
  // `adjacency`: BuildAdjacency(graph), to share one O(E) copy between the
  // many engines of a clustering (built here when null).
  IncrementalEngine(const RotationGraph& graph,
                    const IncrementalOptions& options,
                    std::vector<bool> allowed = {},
                    std::shared_ptr<const AdjacencyList> adjacency = nullptr);

  // Eq. 1-4 over every triangle with all three vertices allowed (and, if
  // `restrict_to` is non-empty, all three in it); false if none passes.
  bool InitializeFromBestTriplet(const std::vector<bool>& restrict_to = {});
  // Eq. 1-3 for a given triangle: false if it is not a triangle of allowed,
  // non-excluded vertices or fails the chaining check (Eq. 2).
  bool InitializeFromTriplet(int i, int j, int k);
  // Degenerate seed for graphs without any consistent triangle: the single
  // vertex `v` with the identity rotation.
  bool InitializeFromVertex(int v);
  // Seeds the set with rotations estimated elsewhere (`rotations` indexed by
  // vertex), e.g. IRAv4's aligned clusters, so that GlobalOptimize() runs
  // Eq. 11-12 on them. False if a vertex is not selectable or none given.
  bool InitializeFromRotations(const std::vector<int>& vertices,
                               const std::vector<Eigen::Matrix3d>& rotations);

  struct Candidate {
    int vertex = -1;  // v_p*, -1 if none
    int via = -1;     // v_m*
    double reward = 0.0;
    Eigen::Matrix3d R_init = Eigen::Matrix3d::Identity();  // R_{m*p*} R_{m*}
  };
  // Eq. 5-8 over allowed unselected, non-excluded vertices adjacent to the
  // set; vertex -1 if none. Does not change the selection.
  Candidate BestCandidate();
  // Adds candidate.vertex initialised with candidate.R_init, locally
  // optimises it (Eq. 9-10), and globally optimises the set (Eq. 11-12) when
  // it has grown by global_growth_ratio since the last one.
  void AddVertex(const Candidate& candidate);
  // The vertex was taken by another cluster: never a candidate again.
  void Exclude(int vertex);
  // Makes a vertex selectable that the constructor's `allowed` left out (a
  // cluster's fallback pass); a candidate at once if adjacent to the set.
  void Allow(int vertex);
  // Eq. 11-12 on the selected set; `converge` false: only
  // intermediate_global_iterations Gauss-Newton steps.
  void GlobalOptimize(bool converge = true);
  // Grows until stop() returns true (checked after each addition) or no
  // candidate is left. Returns the number of vertices added. Does not run the
  // final global optimisation: call GlobalOptimize() when done.
  int Grow(const std::function<bool()>& stop);

  bool IsSelected(int v) const { return selected_[v]; }
  bool IsExcluded(int v) const { return excluded_[v]; }
  bool IsAllowed(int v) const { return allowed_[v]; }
  const std::vector<int>& Selected() const { return selected_list_; }
  int NumSelected() const { return static_cast<int>(selected_list_.size()); }
  const Eigen::Matrix3d& Rotation(int v) const { return rotations_[v]; }
  int LastAdded() const { return last_added_; }
  const IncrementalStats& Stats() const { return stats_; }
  const RotationGraph& Graph() const { return graph_; }
  const IncrementalOptions& Options() const { return options_; }
  // Deduplicated adjacency (see AdjacencyList).
  const std::vector<std::pair<int, int>>& Adjacency(int v) const {
    return (*adjacency_)[v];
  }
  const std::shared_ptr<const AdjacencyList>& SharedAdjacency() const {
    return adjacency_;
  }

 private:
  struct Precomputation {
    int m = -1;     // selected neighbour
    double weight;  // edge weight, for the bounded recomputation
    bool evaluated = false;
    double reward = 0.0;  // Eq. 7, valid if evaluated
    Eigen::Matrix3d P;    // R_p^m = R_mp R_m (Eq. 5)
  };
  struct CandidateState {
    std::vector<Precomputation> precomputations;
    int version = 0;
    int epoch = -1;  // epoch_ of the rotations its pre-computations used
    int best = -1;   // index into precomputations
  };
  struct QueueEntry {
    double reward;
    int vertex;
    int version;
    bool operator<(const QueueEntry& other) const {
      // max-heap on reward; ties: the smaller vertex index first.
      if (reward != other.reward) return reward < other.reward;
      return vertex > other.vertex;
    }
  };

  bool CanSelect(int v) const {
    return allowed_[v] && !selected_[v] && !excluded_[v];
  }
  void SelectVertex(int v, const Eigen::Matrix3d& R);
  void AfterSeed();
  // Eq. 3 on a triangle, from Eq. 1's initialisation; returns Eq. 4's reward.
  double OptimizeTriplet(int i, int j, int k, int e_ij, int e_ik, int e_jk,
                         Eigen::Matrix3d* R_i, Eigen::Matrix3d* R_j,
                         Eigen::Matrix3d* R_k);
  void LocalOptimize(int p, const std::vector<int>& inlier_neighbors);
  void GlobalOptimizeCeres(const std::vector<std::pair<int, int>>& inliers,
                           const std::vector<int>& local_index, bool converge);
  // Rebuilds a candidate's pre-computations and rewards from scratch.
  void RecomputeCandidate(int p);
  // Adds the newly selected x to candidate p's pre-computations.
  void UpdateCandidate(int p, int x, int edge_idx);
  void PushCandidate(int p);
  void RecomputeAllCandidates();
  void RemoveCandidate(int p);
  int FindEdge(int u, int v) const;  // -1 if none

  const RotationGraph& graph_;
  const IncrementalOptions options_;
  const double cos_theta_;
  std::vector<bool> allowed_;
  std::shared_ptr<const AdjacencyList> adjacency_;
  std::vector<bool> selected_;
  std::vector<bool> excluded_;
  std::vector<int> selected_list_;
  std::vector<Eigen::Matrix3d> rotations_;
  int last_added_ = -1;
  int size_at_last_global_ = 0;

  // Candidates: allowed, unselected, non-excluded vertices adjacent to the
  // set. `in_frontier_` marks them; `frontier_list_` may hold stale entries.
  std::vector<bool> in_frontier_;
  std::vector<int> frontier_list_;
  std::vector<CandidateState> candidates_;
  std::priority_queue<QueueEntry> queue_;
  // Incremented by each global optimisation: a candidate whose epoch differs
  // has pre-computations from older rotations; it is recomputed only when it
  // reaches the top of the queue (lazy: rewards change little with a global
  // optimisation, so only the few best are recomputed).
  int epoch_ = 0;
  int full_recompute_epoch_ = 0;  // !lazy_reward_recomputation

  // Scratch of the Gauss-Newton triplet problems (one entry per vertex).
  std::vector<Eigen::Matrix3d> scratch_rotations_;
  std::vector<bool> scratch_fixed_;

  IncrementalStats stats_;
};

}  // namespace colmap_irav4
