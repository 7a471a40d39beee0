#include "colmap_irav4/rotation_averaging/l1_irls.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include <glog/logging.h>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/spanning_tree.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/interrupt.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

template <>
const EnumNames<L1IrlsLinearSolver>& NamesOf<L1IrlsLinearSolver>() {
  static const EnumNames<L1IrlsLinearSolver> names = {
      {L1IrlsLinearSolver::kAuto, "auto"},
      {L1IrlsLinearSolver::kCholesky, "cholesky"},
      {L1IrlsLinearSolver::kCg, "cg"}};
  return names;
}

void L1IrlsOptions::Check() const {
  auto require = [](bool condition, const void* field, const std::string& name,
                    const std::string& problem) {
    if (!condition) {
      throw OptionError(field, "RotationAveraging." + name, problem);
    }
  };
  require(l1_max_iterations >= 0, &l1_max_iterations, "l1_max_iterations",
          "must be >= 0");
  require(l1_step_tolerance_deg >= 0, &l1_step_tolerance_deg,
          "l1_step_tolerance_deg", "must be >= 0");
  require(l1_epsilon_deg > 0, &l1_epsilon_deg, "l1_epsilon_deg", "must be > 0");
  require(irls_max_iterations >= 0, &irls_max_iterations, "irls_max_iterations",
          "must be >= 0");
  require(irls_step_tolerance_deg >= 0, &irls_step_tolerance_deg,
          "irls_step_tolerance_deg", "must be >= 0");
  require(gm_sigma_deg > 0, &gm_sigma_deg, "gm_sigma_deg", "must be > 0");
  require(max_cholesky_flops >= 0, &max_cholesky_flops, "max_cholesky_flops",
          "must be >= 0");
  // Not registered as flags: named as the members.
  if (!(cg_tolerance > 0)) {
    throw OptionError(&cg_tolerance, "L1IrlsOptions::cg_tolerance",
                      "must be > 0");
  }
  if (cg_max_iterations <= 0) {
    throw OptionError(&cg_max_iterations, "L1IrlsOptions::cg_max_iterations",
                      "must be > 0");
  }
}

namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;

// Sparse LDL^T that reports the cost of its numeric factorisation after the
// symbolic analysis (column counts of L from the elimination tree).
class AnalyzedLdlt : public Eigen::SimplicialLDLT<SparseMatrix> {
 public:
  double FactorizationFlops() const {
    double flops = 0.0;
    for (Eigen::Index k = 0; k < m_nonZerosPerCol.size(); ++k) {
      flops += static_cast<double>(m_nonZerosPerCol[k]) * m_nonZerosPerCol[k];
    }
    return flops;
  }
};

// The weighted Laplacian of the component without the gauge vertex, with
// fixed sparsity: values are rewritten in place for each set of weights.
class TangentSystem {
 public:
  TangentSystem(const RotationGraph& graph, const std::vector<int>& edges,
                const std::vector<int>& unknown_index, int num_unknowns,
                const L1IrlsOptions& options)
      : graph_(graph),
        edges_(edges),
        unknown_index_(unknown_index),
        options_(options) {
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(4 * edges_.size() + num_unknowns);
    for (int u = 0; u < num_unknowns; ++u) triplets.emplace_back(u, u, 1.0);
    for (int e : edges_) {
      const int ui = unknown_index_[graph_.Edge(e).i];
      const int uj = unknown_index_[graph_.Edge(e).j];
      if (ui >= 0 && uj >= 0) {
        triplets.emplace_back(ui, uj, 1.0);
        triplets.emplace_back(uj, ui, 1.0);
      }
    }
    matrix_.resize(num_unknowns, num_unknowns);
    matrix_.setFromTriplets(triplets.begin(), triplets.end());
    matrix_.makeCompressed();
    // Value slots of every edge's four entries (-1 when absent: gauge).
    slots_.resize(edges_.size());
    for (size_t k = 0; k < edges_.size(); ++k) {
      const int ui = unknown_index_[graph_.Edge(edges_[k]).i];
      const int uj = unknown_index_[graph_.Edge(edges_[k]).j];
      slots_[k] = {Slot(ui, ui), Slot(uj, uj), Slot(ui, uj), Slot(uj, ui)};
    }
    use_cholesky_ = options_.linear_solver != L1IrlsLinearSolver::kCg;
    if (use_cholesky_) {
      cholesky_ = std::make_unique<AnalyzedLdlt>();
      cholesky_->analyzePattern(matrix_);
      if (options_.linear_solver == L1IrlsLinearSolver::kAuto &&
          cholesky_->FactorizationFlops() > options_.max_cholesky_flops) {
        use_cholesky_ = false;
        cholesky_.reset();
      }
    }
    if (!use_cholesky_) {
      cg_ = std::make_unique<Eigen::ConjugateGradient<
          SparseMatrix, Eigen::Lower | Eigen::Upper>>();
      cg_->setTolerance(options_.cg_tolerance);
      cg_->setMaxIterations(options_.cg_max_iterations);
    }
  }

  // Solves min sum_e weight_e |b_e - (w_j - w_i)|^2 for the unknowns' w.
  // Returns false if the solver failed.
  bool UsesCholesky() const { return use_cholesky_; }

  bool Solve(const std::vector<double>& weights,
             const std::vector<Eigen::Vector3d>& b, Eigen::MatrixX3d* x) {
    const int n = matrix_.rows();
    std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
    Eigen::MatrixX3d rhs = Eigen::MatrixX3d::Zero(n, 3);
    double* values = matrix_.valuePtr();
    for (size_t k = 0; k < edges_.size(); ++k) {
      const double w = weights[k];
      const int ui = unknown_index_[graph_.Edge(edges_[k]).i];
      const int uj = unknown_index_[graph_.Edge(edges_[k]).j];
      const std::array<int, 4>& s = slots_[k];
      if (s[0] >= 0) values[s[0]] += w;
      if (s[1] >= 0) values[s[1]] += w;
      if (s[2] >= 0) values[s[2]] -= w;
      if (s[3] >= 0) values[s[3]] -= w;
      if (ui >= 0) rhs.row(ui) -= w * b[k].transpose();
      if (uj >= 0) rhs.row(uj) += w * b[k].transpose();
    }
    if (use_cholesky_) {
      cholesky_->factorize(matrix_);
      if (cholesky_->info() != Eigen::Success) return false;
      *x = cholesky_->solve(rhs);
      return cholesky_->info() == Eigen::Success;
    }
    cg_->compute(matrix_);
    x->resize(n, 3);
    for (int c = 0; c < 3; ++c) {
      x->col(c) = cg_->solve(rhs.col(c));
      if (cg_->info() == Eigen::NumericalIssue) return false;
    }
    return true;
  }

 private:
  int Slot(int row, int col) const {
    if (row < 0 || col < 0) return -1;
    const int* begin = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[col];
    const int* end = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[col + 1];
    const int* it = std::lower_bound(begin, end, row);
    CHECK(it != end && *it == row);
    return static_cast<int>(it - matrix_.innerIndexPtr());
  }

  const RotationGraph& graph_;
  const std::vector<int>& edges_;
  const std::vector<int>& unknown_index_;
  bool use_cholesky_ = false;
  const L1IrlsOptions& options_;
  SparseMatrix matrix_;
  std::vector<std::array<int, 4>> slots_;
  std::unique_ptr<AnalyzedLdlt> cholesky_;
  std::unique_ptr<
      Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper>>
      cg_;
};

// The unknowns and edges of a tangent problem over `order` (vertices to
// estimate; the `gauge` ones stay fixed) and the IRL1 / Geman-McClure stages
// that both L1IrlsAverager and RefineRotationsIrls run on it.
class TangentProblem {
 public:
  TangentProblem(const RotationGraph& graph, const std::vector<int>& order,
                 const std::vector<bool>& gauge, const L1IrlsOptions& options,
                 std::vector<Eigen::Matrix3d>* rotations)
      : graph_(graph),
        order_(order),
        options_(options),
        rotations_(*rotations) {
    std::vector<bool> member(graph.NumVertices(), false);
    unknown_index_.assign(graph.NumVertices(), -1);
    for (int v : order_) {
      member[v] = true;
      if (!gauge[v]) unknown_index_[v] = num_unknowns_++;
    }
    for (int e = 0; e < graph.NumEdges(); ++e) {
      if (member[graph.Edge(e).i] && member[graph.Edge(e).j]) {
        edges_.push_back(e);
      }
    }
    Finish();
  }
  // With the edges given (each between two members of `order`).
  TangentProblem(const RotationGraph& graph, const std::vector<int>& order,
                 const std::vector<bool>& gauge, std::vector<int> edges,
                 const L1IrlsOptions& options,
                 std::vector<Eigen::Matrix3d>* rotations)
      : graph_(graph),
        order_(order),
        options_(options),
        rotations_(*rotations),
        edges_(std::move(edges)) {
    unknown_index_.assign(graph.NumVertices(), -1);
    for (int v : order_) {
      if (!gauge[v]) unknown_index_[v] = num_unknowns_++;
    }
    Finish();
  }

  // Plain least squares (the cost of Eq. 12 on the given edges): Gauss-
  // Newton steps; the gradient is exact (J_r(r) r = r for the log map), so
  // its fixed points are those of Eq. 12. Returns the iterations run.
  int RunLeastSquares(int max_iterations, double step_tolerance_deg) {
    Timer timer;
    Timer progress_timer;
    return Run("least squares", max_iterations, step_tolerance_deg, timer,
               &progress_timer, [](double) { return 1.0; });
  }

  void Finish() {
    system_ = std::make_unique<TangentSystem>(graph_, edges_, unknown_index_,
                                              num_unknowns_, options_);
    residuals_.resize(edges_.size());
    weights_.resize(edges_.size());
  }

  int NumUnknowns() const { return num_unknowns_; }
  size_t NumEdges() const { return edges_.size(); }
  bool UsesCholesky() const { return system_->UsesCholesky(); }

  // Relinearised IRLS-L1 steps; returns the number of iterations run.
  int RunL1(const Timer& timer, Timer* progress_timer) {
    const double epsilon = DegToRad(options_.l1_epsilon_deg);
    return Run("L1", options_.l1_max_iterations, options_.l1_step_tolerance_deg,
               timer, progress_timer, [epsilon](double r2) {
                 return 1.0 / std::max(std::sqrt(r2), epsilon);
               });
  }

  // Geman-McClure IRLS; returns the number of iterations run.
  int RunGemanMcClure(const Timer& timer, Timer* progress_timer) {
    const double sigma_squared =
        DegToRad(options_.gm_sigma_deg) * DegToRad(options_.gm_sigma_deg);
    return Run("IRLS", options_.irls_max_iterations,
               options_.irls_step_tolerance_deg, timer, progress_timer,
               [sigma_squared](double r2) {
                 const double ratio = r2 / sigma_squared;
                 return 1.0 / ((1.0 + ratio) * (1.0 + ratio));
               });
  }

 private:
  template <typename WeightOfSquaredResidual>
  int Run(const char* stage, int max_iterations, double step_tolerance_deg,
          const Timer& timer, Timer* progress_timer,
          const WeightOfSquaredResidual& weight_of) {
    if (num_unknowns_ == 0) return 0;
    int num_iterations = 0;
    for (int iteration = 0; iteration < max_iterations; ++iteration) {
      ThrowIfInterrupted();  // a checkpoint per iteration (util/interrupt.h)
      for (size_t k = 0; k < edges_.size(); ++k) {
        const RelativeRotation& e = graph_.Edge(edges_[k]);
        residuals_[k] = RotationToAngleAxis(rotations_[e.j].transpose() *
                                            e.R_ij * rotations_[e.i]);
        weights_[k] = weight_of(residuals_[k].squaredNorm());
      }
      if (!system_->Solve(weights_, residuals_, &step_)) {
        LOG(WARNING) << "L1-IRLS: linear solver failed in the " << stage
                     << " stage";
        break;
      }
      double sum = 0.0;
      for (int v : order_) {
        const int u = unknown_index_[v];
        if (u < 0) continue;
        const Eigen::Vector3d w = step_.row(u).transpose();
        rotations_[v] = rotations_[v] * AngleAxisToRotation(w);
        sum += w.norm();
      }
      const double mean_step = sum / num_unknowns_;
      ++num_iterations;
      if (options_.log_progress && progress_timer->ElapsedSeconds() >= 1.0) {
        progress_timer->Restart();
        LOG(INFO) << "L1-IRLS: " << stage << " iteration " << iteration + 1
                  << ", mean step " << RadToDeg(mean_step) << " deg, "
                  << timer.ElapsedSeconds() << " s";
      }
      if (RadToDeg(mean_step) < step_tolerance_deg) break;
    }
    return num_iterations;
  }

  const RotationGraph& graph_;
  const std::vector<int>& order_;
  const L1IrlsOptions& options_;
  std::vector<Eigen::Matrix3d>& rotations_;
  std::vector<int> unknown_index_;
  int num_unknowns_ = 0;
  std::vector<int> edges_;
  std::unique_ptr<TangentSystem> system_;
  std::vector<Eigen::Vector3d> residuals_;
  std::vector<double> weights_;
  Eigen::MatrixX3d step_;
};

}  // namespace

int RefineRotationsIrls(const RotationGraph& graph,
                        const L1IrlsOptions& options,
                        const std::vector<bool>& estimated, int root,
                        std::vector<Eigen::Matrix3d>* rotations,
                        bool run_l1_stage) {
  options.Check();
  const int n = graph.NumVertices();
  CHECK_EQ(static_cast<int>(estimated.size()), n);
  CHECK_EQ(static_cast<int>(rotations->size()), n);
  // One gauge vertex per connected part of the estimated sub-graph keeps
  // every part's Laplacian block non-singular. Parts in BFS order from
  // `root` first, then from the smallest unvisited vertex.
  std::vector<int> order;
  std::vector<bool> gauge(n, false);
  std::vector<bool> visited(n, false);
  auto visit_part = [&](int start) {
    gauge[start] = true;
    visited[start] = true;
    size_t head = order.size();
    order.push_back(start);
    while (head < order.size()) {
      const int v = order[head++];
      for (const auto& [u, e] : graph.Neighbors(v)) {
        if (estimated[u] && !visited[u]) {
          visited[u] = true;
          order.push_back(u);
        }
      }
    }
  };
  if (root >= 0 && root < n && estimated[root]) visit_part(root);
  for (int v = 0; v < n; ++v) {
    if (estimated[v] && !visited[v]) visit_part(v);
  }
  TangentProblem problem(graph, order, gauge, options, rotations);
  Timer timer;
  Timer progress_timer;
  int num_iterations = 0;
  if (run_l1_stage) num_iterations += problem.RunL1(timer, &progress_timer);
  num_iterations += problem.RunGemanMcClure(timer, &progress_timer);
  LOG_IF(INFO, options.log_progress)
      << "IRLS refinement: " << num_iterations << " iterations, "
      << timer.ElapsedSeconds() << " s (" << order.size() << " cameras, "
      << problem.NumEdges() << " edges, "
      << (problem.UsesCholesky() ? "sparse Cholesky" : "conjugate gradients")
      << ")";
  return num_iterations;
}

int OptimizeRotationsOnEdges(const RotationGraph& graph,
                             const std::vector<int>& edges,
                             const std::vector<int>& vertices,
                             const std::vector<bool>& fixed,
                             const L1IrlsOptions& options, int max_iterations,
                             double step_tolerance_deg,
                             std::vector<Eigen::Matrix3d>* rotations) {
  if (edges.empty() || max_iterations <= 0) return 0;
  TangentProblem problem(graph, vertices, fixed, edges, options, rotations);
  return problem.RunLeastSquares(max_iterations, step_tolerance_deg);
}

L1IrlsAverager::L1IrlsAverager(const L1IrlsOptions& options)
    : options_(options) {
  options_.Check();
}

RotationAveragingResult L1IrlsAverager::Estimate(const RotationGraph& graph) {
  Timer timer;
  const SpanningTree tree = MaximumSpanningTree(graph);
  RotationAveragingResult result = ChainRotationsAlongTree(graph, tree);
  result.stage_seconds.emplace_back("spanning_tree", timer.ElapsedSeconds());
  if (tree.order.size() < 2) return result;

  // Unknowns: the component's vertices except the gauge (the tree's root).
  std::vector<bool> gauge(graph.NumVertices(), false);
  gauge[tree.root] = true;
  Timer stage_timer;
  TangentProblem problem(graph, tree.order, gauge, options_, &result.rotations);
  // Progress lines at most once a second, and one per stage.
  Timer progress_timer;
  int num_iterations = problem.RunL1(timer, &progress_timer);
  result.stage_seconds.emplace_back("l1", stage_timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "L1-IRLS: L1 stage done, " << num_iterations << " iterations, "
      << stage_timer.ElapsedSeconds() << " s (" << problem.NumUnknowns() + 1
      << " cameras, " << problem.NumEdges() << " edges, "
      << (problem.UsesCholesky() ? "sparse Cholesky" : "conjugate gradients")
      << ")";

  stage_timer.Restart();
  num_iterations = problem.RunGemanMcClure(timer, &progress_timer);
  result.stage_seconds.emplace_back("irls", stage_timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "L1-IRLS: IRLS stage done, " << num_iterations << " iterations, "
      << stage_timer.ElapsedSeconds() << " s";
  return result;
}

}  // namespace colmap_irav4
