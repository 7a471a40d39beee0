#include "colmap_irav4/rotation_averaging/l1_irls.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/spanning_tree.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

void L1IrlsOptions::Check() const {
  auto require = [](bool condition, const std::string& name,
                    const std::string& problem) {
    if (!condition) {
      throw InputError("--RotationAveraging." + name, problem);
    }
  };
  require(l1_max_iterations >= 0, "l1_max_iterations", "must be >= 0");
  require(l1_step_tolerance_deg >= 0, "l1_step_tolerance_deg",
          "must be >= 0");
  require(l1_epsilon_deg > 0, "l1_epsilon_deg", "must be > 0");
  require(irls_max_iterations >= 0, "irls_max_iterations", "must be >= 0");
  require(irls_step_tolerance_deg >= 0, "irls_step_tolerance_deg",
          "must be >= 0");
  require(gm_sigma_deg > 0, "gm_sigma_deg", "must be > 0");
  require(linear_solver == "auto" || linear_solver == "cholesky" ||
              linear_solver == "cg",
          "linear_solver", "must be auto, cholesky or cg, got '" +
                               linear_solver + "'");
  require(max_cholesky_flops >= 0, "max_cholesky_flops", "must be >= 0");
  require(cg_tolerance > 0, "cg_tolerance", "must be > 0");
  require(cg_max_iterations > 0, "cg_max_iterations", "must be > 0");
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
    use_cholesky_ = options_.linear_solver != "cg";
    if (use_cholesky_) {
      cholesky_ = std::make_unique<AnalyzedLdlt>();
      cholesky_->analyzePattern(matrix_);
      if (options_.linear_solver == "auto" &&
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
    std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(),
              0.0);
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

}  // namespace

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
  std::vector<int> unknown_index(graph.NumVertices(), -1);
  int num_unknowns = 0;
  for (int v : tree.order) {
    if (v != tree.root) unknown_index[v] = num_unknowns++;
  }
  std::vector<int> edges;
  for (int e = 0; e < graph.NumEdges(); ++e) {
    if (result.estimated[graph.Edge(e).i]) edges.push_back(e);
  }
  Timer stage_timer;
  TangentSystem system(graph, edges, unknown_index, num_unknowns, options_);
  const bool use_cholesky = system.UsesCholesky();
  std::vector<Eigen::Matrix3d>& rotations = result.rotations;

  std::vector<Eigen::Vector3d> residuals(edges.size());
  std::vector<double> weights(edges.size());
  auto compute_residuals = [&]() {
    for (size_t k = 0; k < edges.size(); ++k) {
      const RelativeRotation& e = graph.Edge(edges[k]);
      residuals[k] = RotationToAngleAxis(rotations[e.j].transpose() * e.R_ij *
                                         rotations[e.i]);
    }
  };
  // Solves for the step and applies it; returns the mean step (rad), or a
  // negative value if the solver failed.
  Eigen::MatrixX3d step;
  auto solve_and_update = [&]() -> double {
    if (!system.Solve(weights, residuals, &step)) return -1.0;
    double sum = 0.0;
    for (int v : tree.order) {
      const int u = unknown_index[v];
      if (u < 0) continue;
      const Eigen::Vector3d w = step.row(u).transpose();
      rotations[v] = rotations[v] * AngleAxisToRotation(w);
      sum += w.norm();
    }
    return sum / num_unknowns;
  };

  // Progress lines at most once a second, and one per stage.
  Timer progress_timer;
  int num_iterations = 0;
  const double l1_epsilon = DegToRad(options_.l1_epsilon_deg);
  for (int iteration = 0; iteration < options_.l1_max_iterations;
       ++iteration) {
    compute_residuals();
    for (size_t k = 0; k < edges.size(); ++k) {
      weights[k] = 1.0 / std::max(residuals[k].norm(), l1_epsilon);
    }
    const double mean_step = solve_and_update();
    if (mean_step < 0) {
      LOG(WARNING) << "L1-IRLS: linear solver failed in the L1 stage";
      break;
    }
    ++num_iterations;
    if (options_.log_progress && progress_timer.ElapsedSeconds() >= 1.0) {
      progress_timer.Restart();
      LOG(INFO) << "L1-IRLS: L1 iteration " << iteration + 1
                << ", mean step " << RadToDeg(mean_step) << " deg, "
                << timer.ElapsedSeconds() << " s";
    }
    if (RadToDeg(mean_step) < options_.l1_step_tolerance_deg) break;
  }
  result.stage_seconds.emplace_back("l1", stage_timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "L1-IRLS: L1 stage done, " << num_iterations << " iterations, "
      << stage_timer.ElapsedSeconds() << " s (" << num_unknowns + 1
      << " cameras, " << edges.size() << " edges, "
      << (use_cholesky ? "sparse Cholesky" : "conjugate gradients") << ")";

  stage_timer.Restart();
  num_iterations = 0;
  const double sigma_squared =
      DegToRad(options_.gm_sigma_deg) * DegToRad(options_.gm_sigma_deg);
  for (int iteration = 0; iteration < options_.irls_max_iterations;
       ++iteration) {
    compute_residuals();
    for (size_t k = 0; k < edges.size(); ++k) {
      const double ratio = residuals[k].squaredNorm() / sigma_squared;
      weights[k] = 1.0 / ((1.0 + ratio) * (1.0 + ratio));
    }
    const double mean_step = solve_and_update();
    if (mean_step < 0) {
      LOG(WARNING) << "L1-IRLS: linear solver failed in the IRLS stage";
      break;
    }
    ++num_iterations;
    if (options_.log_progress && progress_timer.ElapsedSeconds() >= 1.0) {
      progress_timer.Restart();
      LOG(INFO) << "L1-IRLS: IRLS iteration " << iteration + 1
                << ", mean step " << RadToDeg(mean_step) << " deg, "
                << timer.ElapsedSeconds() << " s";
    }
    if (RadToDeg(mean_step) < options_.irls_step_tolerance_deg) break;
  }
  result.stage_seconds.emplace_back("irls", stage_timer.ElapsedSeconds());
  LOG_IF(INFO, options_.log_progress)
      << "L1-IRLS: IRLS stage done, " << num_iterations << " iterations, "
      << stage_timer.ElapsedSeconds() << " s";
  return result;
}

}  // namespace colmap_irav4
