#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"
#include "colmap_irav4/util/enum_names.h"

namespace colmap_irav4 {

// L1-IRLS rotation averaging (Chatterjee and Govindu, TPAMI 2018): maximum
// spanning tree initialisation, robust L1 refinement, then iteratively
// reweighted least squares with the Geman-McClure loss.
//
// Both stages solve the same linearised tangent system. With the update
// R_i <- R_i exp([w_i]_x) (a perturbation in the world frame),
//   R_j exp(w_j) exp(-w_i) R_i^T = R_ij  gives  w_j - w_i = log(R_j^T R_ij R_i)
// to first order. Every edge's three rows share one weight (the weight of its
// residual norm), so the normal matrix is (weighted graph Laplacian) x I_3:
// one (n-1)x(n-1) system with three right-hand sides, gauge vertex removed.
// The sparsity pattern and its symbolic factorisation are built once.
// The linear solver of every L1-IRLS step: auto, cholesky or cg.
enum class L1IrlsLinearSolver { kAuto, kCholesky, kCg };
template <>
const EnumNames<L1IrlsLinearSolver>& NamesOf<L1IrlsLinearSolver>();

struct L1IrlsOptions {
  // Relinearised IRLS-L1 steps (weights 1 / max(|r_e|, l1_epsilon)).
  int l1_max_iterations = 20;
  // The L1 stage stops when the mean step |w_i| falls below this (deg).
  double l1_step_tolerance_deg = 1e-3;
  // Residual floor in the L1 weights (deg): keeps the system well conditioned.
  double l1_epsilon_deg = 0.01;
  // Geman-McClure IRLS iterations.
  int irls_max_iterations = 50;
  // IRLS stops when the mean step |w_i| falls below this (deg).
  double irls_step_tolerance_deg = 1e-5;
  // Geman-McClure scale sigma (deg): weight (1 + r^2 / sigma^2)^-2.
  double gm_sigma_deg = 5.0;
  // Linear solver: "auto", "cholesky" (sparse LDL^T, symbolic analysis
  // reused) or "cg" (Jacobi-preconditioned conjugate gradients). Dense,
  // random-like graphs fill the Cholesky factor completely (O(n^3) per
  // factorisation), where CG on the well-conditioned Laplacian converges in
  // few iterations; sparse, elongated graphs (sequences) are the opposite.
  // auto runs the symbolic analysis and picks Cholesky when the
  // factorisation's cost sum_k nnz(L_k)^2 is at most max_cholesky_flops.
  L1IrlsLinearSolver linear_solver = L1IrlsLinearSolver::kAuto;
  double max_cholesky_flops = 5e7;
  // CG relative residual tolerance and iteration cap per solve.
  double cg_tolerance = 1e-10;
  int cg_max_iterations = 1000;
  // Log one progress line per iteration.
  bool log_progress = false;

  // Throws InputError naming the offending option.
  void Check() const;
};

// The Geman-McClure IRLS stage of L1-IRLS alone (no spanning tree, no L1
// stage), from the given rotations: refines every vertex v with estimated[v]
// over all edges between two estimated vertices, with options' irls_* and
// gm_sigma_deg and linear solver settings. One vertex per connected part of
// the estimated sub-graph stays fixed as the gauge (`root` for its part, if
// estimated; else the part's first vertex). With `run_l1_stage`, the L1
// stage (l1_* options) runs first, as in L1IrlsAverager. Deterministic.
// Returns the number of iterations run (both stages).
int RefineRotationsIrls(const RotationGraph& graph,
                        const L1IrlsOptions& options,
                        const std::vector<bool>& estimated, int root,
                        std::vector<Eigen::Matrix3d>* rotations,
                        bool run_l1_stage = false);

// Least squares on the given edges (Eq. 12 of the IRAv4 paper: squared
// angles of R_ij^T R_j R_i^T), by Gauss-Newton steps on the tangent system
// above (sparse Laplacian, symbolic analysis once per call, warm start from
// `rotations`). `vertices`: every vertex an edge touches, each once;
// `fixed[v]`: held for the gauge (at least one per connected part of the
// edges). Stops after max_iterations or when the mean step is below
// step_tolerance_deg. Uses options' linear solver settings. Deterministic.
// Returns the iterations run.
int OptimizeRotationsOnEdges(const RotationGraph& graph,
                             const std::vector<int>& edges,
                             const std::vector<int>& vertices,
                             const std::vector<bool>& fixed,
                             const L1IrlsOptions& options, int max_iterations,
                             double step_tolerance_deg,
                             std::vector<Eigen::Matrix3d>* rotations);

class L1IrlsAverager : public RotationAverager {
 public:
  explicit L1IrlsAverager(const L1IrlsOptions& options = L1IrlsOptions());
  std::string Name() const override { return "l1_irls"; }
  // Estimates the largest connected component; other vertices stay
  // unestimated.
  RotationAveragingResult Estimate(const RotationGraph& graph) override;

 private:
  L1IrlsOptions options_;
};

}  // namespace colmap_irav4
