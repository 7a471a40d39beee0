#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "colmap_irav4/refinement/coarse_space.h"
#include "colmap_irav4/refinement/implicit_product.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// The solve of the reduced camera system: a Cholesky factorisation,
// simplicial (Eigen's SimplicialLLT, AMD: one column at a time) or
// supernodal (CHOLMOD: dense blocks of columns through BLAS, the faster once
// the factor is dense: photo collections); iterative (preconditioned
// conjugate gradients on the accumulated matrix, the Schur-Jacobi
// preconditioner: no factor, its memory the matrix's nonzero blocks); or
// auto: iterative when the factor would take more than
// SchurSolverOptions::max_factor_mib or its factorisation more than
// SchurSolverOptions::max_factor_gflops (both estimated before anything is
// allocated, from the symbolic analysis of the system's block pattern), else
// supernodal when
// CHOLMOD's analysis counts at least
// SchurBundleAdjuster::kSupernodalMinFlopsPerEntry flops per factor entry
// (CHOLMOD's own switch; tiny or very sparse systems stay simplicial).
enum class SchurLinearSolver { kAuto, kSimplicial, kSupernodal, kIterative };

struct SchurSolverOptions {
  SchurLinearSolver linear_solver = SchurLinearSolver::kAuto;
  // auto: iterative when the Cholesky factor of the reduced system would
  // take more than this many MiB (8 bytes a factor entry, the count
  // estimated from the block pattern's symbolic analysis).
  double max_factor_mib = 1024;
  // auto: iterative when a factorisation of the reduced system would take
  // more than this many GFlop (estimated as the factor's size): the
  // factorisation runs at every iteration, and beyond this the formed
  // system and its factorisation cost more than the conjugate gradients on
  // the implicit system (a 5,300-image landmark: 3.8e11 flops, 79 CPU s an
  // iteration supernodal against 12 iterative).
  double max_factor_gflops = 50;
  // The points' cell tables (SchurBundleAdjuster::SetUseCellTables) take at
  // most this many MiB: 4 bytes a pair of a point's pose and camera blocks,
  // 157 MiB for the 1,000-image photo scene's bundle adjustment, past 1 GiB
  // at 5,000 (tracks of 30 images: 1,830 pairs a point); the points beyond
  // it search their cells at every iteration instead.
  double max_cell_table_mib = 256;
  // From this size of the reduced system's values (MiB), the points are
  // eliminated in an order that keeps consecutive points' cells together
  // (each point's updates scatter over the system; in order of their
  // largest blocks consecutive points share most cells): with the cell
  // layout and huge pages, 1.6x less CPU an iteration on the 5,000-image
  // photo scene's true model (294 MiB); the order alone about 1.35x on the
  // 1,000-image one's (24 MiB); below, the points' own order (not measured
  // under 24 MiB).
  double locality_order_min_mib = 16;
  // From this size of the reduced system's values (MiB), each point's pair
  // updates S -= Q_k W_l^T are listed first and run with the cells of the
  // update a few ahead prefetched (and each observation's diagonal cells
  // prefetched as it is linearised): the cells scatter over a system out of
  // the caches. Below, each update runs as it is found (a system in the
  // caches: the list and the prefetches are overhead). The same updates in
  // the same order either way: the same result to the bit.
  double prefetch_updates_min_mib = 16;
  // A refined camera of a single refined pose (one camera per image, as
  // COLMAP's feature extractor makes by default) is one block with its
  // pose: one contiguous cell and one cell search per pair of its
  // observations instead of four, and a quarter of the cell tables; the
  // same system, its cells grouped differently.
  bool join_own_camera_blocks = true;
  // Iterative: conjugate gradients stop once the residual is at most
  // eta_k |b| (b: the reduced system's right-hand side), eta_k = min(eta,
  // sqrt(|b| / |b_0|)) with b_0 the solve's first right-hand side: an
  // inexact Newton step whose forcing term shrinks as Levenberg-Marquardt
  // converges; or after max_cg_iterations. Ceres' eta is 0.1 (on its
  // quadratic model's decrease): with 0.1 here the 300-image photo scene's
  // weakest model came out 24% worse in rotation (the solves stop on the
  // function tolerance short of the optimum), with 1e-3 as the
  // factorisation's (docs/notes/2026-12-05-iterative-schur.md).
  double eta = 1e-3;
  int max_cg_iterations = 500;
  // Iterative: the preconditioner's second level (coarse_space.h): the
  // images in clusters of about this many that share the most points, the
  // clusters' rigid motions with a scale (7 values each) solved exactly at
  // every conjugate gradient iteration besides Schur-Jacobi's image
  // blocks. 0: Schur-Jacobi alone.
  int coarse_cluster_size = 10;
  // ... in at most this many clusters (larger ones past it): the coarse
  // system is dense, 7 rows a cluster (512: 100 MiB, 1.5e10 flops a
  // factorisation).
  int coarse_max_clusters = 512;
  // Iterative: from this size of the reduced system's values (MiB),
  // conjugate gradients multiply by it without forming it (an implicit
  // Schur complement, as Ceres' ITERATIVE_SCHUR): S x = sum_k A_k^T (A_k x
  // - B_k V_p^-1 sum_l B_l^T A_l x) over each point p's observations k, l,
  // plus the damping and the pose residuals, from the Jacobians of every
  // observation kept from the elimination (96 bytes an observation with a
  // camera per image in single precision, whatever max_jacobian_store_mib
  // says); the elimination forms only the diagonal blocks the Schur-Jacobi
  // preconditioner takes. An elimination then costs a pass over the
  // observations instead of the sum over points of m (m + 1) / 2 block-pair
  // updates, a conjugate gradient iteration a pass over the kept Jacobians
  // instead of one over the system: 10,000 photo images (1,507 MiB), an
  // iteration 15-33 CPU s instead of 180-210; 1,000 (24 MiB, in the caches)
  // 5x slower (docs/notes/2026-12-06-implicit-schur.md). 0: always.
  double implicit_min_mib = 256;
  // Implicit: every observation's Jacobians are kept in floats (96 bytes
  // an observation with a camera per image instead of 192), and the
  // conjugate gradients multiply by them in floats (four lanes to a vector
  // where doubles take two), the sums over observations in double. The
  // back-substitution and the tries after a rejected step read the rounded
  // values (1e-7 relative: the steps of an inexact Newton method); the
  // costs are evaluated in double. Half the kept memory and a conjugate
  // gradient iteration 1.2-1.4x cheaper (photo scenes of 1,000 and 4,907
  // images, docs/notes/2026-12-06-implicit-schur.md).
  bool implicit_single_precision = true;
  // Implicit in single precision: when the processor has AVX2 and FMA
  // (Avx2ProductAvailable), the product runs a kernel for them (eight
  // float lanes, fused multiply-adds; implicit_product.h) instead of the
  // portable code (SSE2, the build's target): the same sums to float
  // rounding, in another order. False: the portable code everywhere (the
  // same bits on every x86-64 processor).
  bool implicit_avx2 = true;
  // After a rejected step or a failed factorisation, while the radius is at
  // least this, the next step is solved from the same reduced system with
  // only its camera damping changed (the points keep the damping they were
  // eliminated with), instead of linearising every observation and
  // eliminating every point again for a point damping 1/radius of a few
  // percent at most: a rejected try costs a factorisation and one pass over
  // the observations instead of a whole iteration. 0: off (Ceres' steps).
  double reuse_min_radius = 0;
  // The observations' linearisations (residual and Jacobians, 8 + 2 x the
  // reduced columns doubles each: 192 bytes with a camera per image) are
  // kept from each elimination in at most this many MiB, point by point:
  // the back-substitution and a try after a rejected step read them instead
  // of evaluating the Jacobians again (the same values: the same result to
  // the bit). 0: none kept.
  double max_jacobian_store_mib = 256;
  // Embedded point iterations: after each step, every point takes up to
  // this many Gauss-Newton steps of its own with the candidate cameras held
  // (each kept when it lowers the point's cost) before the step's cost is
  // evaluated: the points' nonlinearity (depth along the rays of narrow
  // baselines) no longer limits the step. 0: off.
  int point_iterations = 0;
};

// Stops a solve whose cost has settled while a few ill-determined
// parameters still crawl (a camera's focal length collapsing over dozens of
// steps, each lowering the cost by 0.05%: Ceres' function tolerance, 1e-5 a
// step, never sees it; docs/notes/2026-12-05-ba-stall.md): stalled once the
// last `num_steps` accepted steps together lowered the cost by less than
// `relative_decrease` of it. num_steps 0: never.
class CostStall {
 public:
  CostStall(int num_steps, double relative_decrease);
  // The cost at the start, then after each accepted step; true once stalled.
  bool Add(double cost);

 private:
  const int num_steps_;
  const double relative_decrease_;
  std::deque<double> costs_;  // the last num_steps_ + 1
};

// One weighted least-squares bundle adjustment solve without Ceres' problem:
// Levenberg-Marquardt as Ceres' trust region minimizer runs it (the same
// radius updates, initial radius, tolerances and damping diag(J^T J) /
// radius), where each iteration loops over the points, evaluates each
// observation's residual and Jacobian on the fly (LinearizeReprojection: the
// chain rule, Ceres' Jets in the projection only; rotation steps in the tangent
// space of ceres::EigenQuaternionManifold), eliminates the point's 3x3 block
// while it accumulates the reduced camera system (poses and refined intrinsics)
// in a block-sparse matrix, factors that with a sparse Cholesky
// (SchurLinearSolver: Eigen's simplicial LLT or CHOLMOD's supernodal one, the
// pattern analysed once per adjuster), and back-substitutes the points (their
// Jacobians kept from the elimination within
// SchurSolverOptions::max_jacobian_store_mib, the others evaluated again).
// Stored per observation: its image and keypoint (8 bytes) and its weight
// (8, read when a solve starts); no residual block objects, no per-point
// chunks; per point, the cells of the reduced system its pairs of blocks
// fill (found once per adjuster: 4 bytes per pair of the point's m pose and
// camera blocks, m (m + 1) / 2 pairs), so that the accumulation, half an
// iteration's time on dense photo collections, searches no cell; on a
// reduced system out of the caches, the updates of a point's pairs run
// with the cells of those a few ahead prefetched (they scatter over it).
//
// The parameter blocks are the caller's (e.g. ParameterBlockCopies); the
// solve reads them when it starts and writes the result back when it ends.
// Residuals are each observation's weight (read when the solve starts; 0:
// not in this solve) times its reprojection error; a point with fewer than
// two weighed observations is held in that solve (its step would be along
// its rays alone). Residuals on one pose alone (AddPoseResidual: pose priors)
// go straight into the reduced system's diagonal blocks, their loss applied
// as Ceres applies one (the corrector of Triggs et al.).
class SchurBundleAdjuster {
 public:
  // `center`: poses as rotation and projection centre (R (X - C)).
  explicit SchurBundleAdjuster(
      bool center, SchurLinearSolver linear_solver = SchurLinearSolver::kAuto);
  SchurBundleAdjuster(bool center, const SchurSolverOptions& options);
  ~SchurBundleAdjuster();

  // SchurLinearSolver auto: supernodal from this many flops per factor entry
  // (CHOLMOD's own switch between its two kinds of factorisation).
  static constexpr double kSupernodalMinFlopsPerEntry = 40;

  // A camera's intrinsics (model_id's parameters at `params`), all refined
  // unless SetCameraConstant says otherwise. Returns its index.
  int AddCamera(double* params, int model_id);
  // Holds the parameters of camera `camera` at indexes `constant`.
  void SetCameraConstant(int camera, const std::vector<int>& constant);
  // A quadratic prior on parameter `param` of camera `camera` (e.g. its
  // focal length): the residual (params[param] - value) / std, least
  // squares as a Ceres residual block on the camera with no loss. A held
  // parameter's prior adds its cost only.
  void SetCameraPrior(int camera, int param, double value, double std);
  // An image's pose (quaternion x, y, z, w and centre or translation) seen
  // through camera `camera` (AddCamera's index), its keypoints and their
  // weights (by keypoint index; both must outlive the solves), refined unless
  // SetPoseConstant says otherwise. Returns its index.
  int AddPose(double* rotation, double* position, int camera,
              const std::vector<Point2D>* points2D,
              const std::vector<double>* weights);
  // `constant`: the pose is held; `fixed_coordinate` (0-2, or -1): one
  // coordinate of the position held (the gauge's scale). Before the first
  // solve.
  void SetPoseConstant(int pose, bool constant, int fixed_coordinate);
  // A point (3 values at xyz; `constant`: held) and its observations (pose
  // index, keypoint index).
  void AddPoint(double* xyz, bool constant,
                const std::vector<std::pair<int, point2D_t>>& observations);

  // The blocks of a pose a pose residual takes, in this order.
  enum class PoseArguments { kRotation, kPosition, kRotationAndPosition };
  // A residual on pose `pose` alone (e.g. a pose prior): `cost` takes the
  // pose's quaternion (x, y, z, w) and / or its position as `arguments`
  // says; `loss` (not owned, outlives the solves; null: squared norm) is
  // applied as Ceres' residual blocks apply it.
  void AddPoseResidual(int pose, PoseArguments arguments,
                       std::unique_ptr<ceres::CostFunction> cost,
                       const ceres::LossFunction* loss);

  size_t NumObservations() const { return observations_.size(); }

  // How the accumulation of the reduced camera system finds a block pair's
  // cell: in its point's cell table (true, the default: the value indexes of
  // the point's block pairs, found once when the structure is built, for
  // the points up to SchurSolverOptions::max_cell_table_mib), or by
  // searching the cell's column at every iteration (false: no tables; the
  // points beyond the budget). Both add the same products in the same
  // order: the same solution to the bit.
  void SetUseCellTables(bool use) { use_cell_tables_ = use; }
  // The cell tables' size in bytes (0 before the first solve).
  size_t CellTableBytes() const;
  // Whether the points' pair updates are listed and prefetched
  // (SchurSolverOptions::prefetch_updates_min_mib; false before the first
  // solve).
  bool PrefetchesUpdates() const { return prefetch_updates_; }
  // Whether the points are eliminated in the locality order
  // (SchurSolverOptions::locality_order_min_mib; false before the first
  // solve).
  bool OrdersPointsForLocality() const { return !point_order_.empty(); }

  struct Summary {
    ceres::TerminationType termination = ceres::NO_CONVERGENCE;
    std::string message;
    int num_iterations = 0;   // as Ceres counts them (iteration 0 included)
    double initial_cost = 0;  // 1/2 the sum of squared weighted residuals
    double final_cost = 0;
    double linear_solver_seconds = 0;  // factorisations and solves
    int num_reduced_parameters = 0;    // size of the reduced camera system
    size_t num_reduced_nonzeros = 0;   // its stored (upper block) entries
    bool supernodal = false;           // CHOLMOD's supernodal factorisation
    bool iterative = false;            // conjugate gradients
    bool implicit = false;  // ... without the reduced system (implicit)
    // ... preconditioned with a coarse level of this many clusters
    // (SchurSolverOptions::coarse_cluster_size; 0: none).
    int num_coarse_clusters = 0;
    int num_linear_iterations = 0;  // conjugate gradients' (all solves)
    // Tries solved from the last elimination's reduced system, re-damped
    // (SchurSolverOptions::reuse_min_radius).
    int num_reused_eliminations = 0;
    // The Jacobians kept from the eliminations
    // (SchurSolverOptions::max_jacobian_store_mib), bytes, and the
    // eliminations that read them (tries after a rejected step).
    size_t jacobian_store_bytes = 0;
    // ... in single precision (SchurSolverOptions::implicit_single_precision).
    bool jacobian_store_single = false;
    // ... multiplied by the AVX2 kernel (SchurSolverOptions::implicit_avx2).
    bool implicit_avx2 = false;
    int num_eliminations_from_kept_jacobians = 0;
    // Stopped as the cost stalled (CostStall).
    bool stalled = false;
    // The Cholesky factor's size estimated from the block pattern (auto and
    // iterative; 0: not estimated), bytes.
    double factor_bytes_estimate = 0;
    // ... and its factorisation's flops (the same estimate; 0: not
    // estimated).
    double factor_flops_estimate = 0;
    // The factorisation and why, e.g. "supernodal (CHOLMOD): factor 1.2e+07
    // entries, 2.1e+10 flops, 1750 per entry (auto: from 40)", or "iterative
    // (conjugate gradients, Schur-Jacobi): factor ~6100 MiB (auto: from
    // 1024 MiB)".
    std::string linear_solver_reason;
  };
  // Reads max_num_iterations, function/gradient/parameter_tolerance,
  // initial/max/min_trust_region_radius, min_relative_decrease,
  // min/max_lm_diagonal and max_num_consecutive_invalid_steps.
  // `rejected_start_radius`: after a step rejected or a factorisation failed
  // before any step of the solve was accepted, Ceres' cuts (radius / 2, / 4,
  // / 8, ...) are made at once, without trying a step, until the radius is
  // at most this; 0: each cut tried (Ceres).
  // `stall`: the solve stops (CONVERGENCE, `stalled`) once the cost has
  // stalled (CostStall; 0 steps: never).
  // `model_tolerance` (iterative): conjugate gradients also stop once
  // i (Q_i - Q_{i-1}) / Q_i is below it, Q_i the quadratic model's value at
  // iteration i (Nash and Sofer's truncated Newton rule, Ceres'
  // q_tolerance): the step has taken nearly all of the model's decrease,
  // what is left lies along the reduced system's weak directions. 0: off
  // (the residual rule alone).
  Summary Solve(const ceres::Solver::Options& options,
                double rejected_start_radius = 0, int stall_num_steps = 0,
                double stall_relative_decrease = 0, double model_tolerance = 0);

 private:
  struct CameraBlock {
    double* params;
    int model_id;
    int num_params;
    std::vector<int> free;  // indexes of the refined parameters
    // SetCameraPrior's (prior_param -1: none).
    int prior_param = -1;
    double prior_value = 0;
    double prior_std = 1;
  };
  struct PoseBlock {
    double* rotation;
    double* position;
    int camera;
    const std::vector<Point2D>* points2D;
    const std::vector<double>* weights;
    std::vector<int> free;  // tangent indexes refined: 0-2 rotation, 3-5
  };
  struct Observation {
    uint32_t pose;
    uint32_t point2D_idx;
  };
  struct Linearization;
  struct PoseResidual {
    int pose;
    PoseArguments arguments;
    std::unique_ptr<ceres::CostFunction> cost;
    const ceres::LossFunction* loss;
  };
  // One pose residual linearised: its cost 1/2 rho(|r|^2), and (for a
  // refined pose) its residual and Jacobian by the pose's free tangent
  // variables, both corrected for the loss.
  struct PoseLinearization {
    double cost = 0;
    Eigen::VectorXd r;
    Eigen::MatrixXd A;
  };

  // Variable blocks of the reduced camera system: the poses' (index = pose
  // index when it has free parameters), then the cameras'; -1: held.
  void NumberBlocks();
  // The block structure of the reduced camera system (upper block triangle)
  // for the observations weighed now, and its scalar column layout: the
  // cells every point's pairs of blocks fill, or with `local_only` those of
  // single observations only (the diagonal blocks and each observation's
  // pose and camera blocks: what the implicit solver forms).
  void BuildStructure(bool local_only);
  // The values of the structure just built (zeros, in the cell layout), the
  // points' cell tables and elimination order (none with `local_only`).
  void LayOutValues(bool local_only);
  // Observation k's weight (weights_).
  double Weight(size_t k) const { return weights_[k]; }
  // The columns of an observation's Jacobian by the reduced system's
  // variables (its pose's free ones, then its camera's; held blocks none).
  int NumColumns(const Observation& observation) const;
  // The blocks of an observation of pose `pose` (its pose's, then its
  // camera's unless held or joined to the pose's) and each one's first
  // column in its A.
  struct ObservationBlocks {
    int count = 0;
    int block[2];
    int col[2];
  };
  ObservationBlocks Blocks(uint32_t pose) const;
  // An observation's blocks and their columns in `lin` (A sized, not set).
  void Describe(const Observation& observation, Linearization* lin) const;
  // Residual (and, with `lin`, Jacobians) of observation k at `x`.
  bool Evaluate(size_t k, const double* point, const std::vector<double>& poses,
                const std::vector<double>& cameras, double residual[2],
                Linearization* lin) const;
  // A pose residual at `poses`: its cost and, with `lin`, its linearisation.
  bool EvaluatePoseResidual(const PoseResidual& residual,
                            const std::vector<double>& poses, double* cost,
                            PoseLinearization* lin) const;
  // A camera prior's residual at `cameras` (SetCameraPrior).
  double CameraPriorResidual(int camera,
                             const std::vector<double>& cameras) const;
  // The column of a camera prior's parameter in its camera's block of the
  // reduced system, -1 when the camera or the parameter is held.
  int CameraPriorColumn(int camera) const;
  // Adds 1/2 the squared residuals of point p's weighed observations at
  // `point` (its 3 coordinates) and the given poses and cameras to *cost,
  // one observation at a time; false (*cost partly summed) when one is not
  // finite.
  bool AddPointCost(size_t p, const double* point,
                    const std::vector<double>& poses,
                    const std::vector<double>& cameras, double* cost) const;
  // 1/2 the sum of squared residuals (pose residuals through their loss) at
  // the given parameters.
  double Cost(const std::vector<double>& poses,
              const std::vector<double>& cameras,
              const std::vector<double>& points) const;
  // The offset of cell (row_block, col_block) in its column's values, -1
  // when the pattern has no such cell.
  int FindCell(int row_block, int col_block) const;
  // The index in values_ of an existing cell.
  size_t ValueIndex(int row_block, int col_block) const;
  // Chooses the factorisation of the structure just built (CHOLMOD's
  // symbolic analysis, kept for the supernodal one).
  void AnalyzeReducedSystem();
  // Factorises the reduced system and solves it for `rhs` (supernodal).
  bool SolveSupernodal(const Eigen::VectorXd& rhs, Eigen::VectorXd* step);
  // The scalar CSC pattern of the reduced system (the factorisations').
  void BuildScalarPattern();
  // values_ from the cell layout into the scalar CSC layout of outer_ and
  // inner_, column by column in place (the next accumulation starts from
  // zeros, in the cell layout again).
  void ToScalarLayout();
  // The Cholesky factor of the structure just built, estimated from the
  // symbolic analysis (fill-reducing ordering and column counts, CHOLMOD) of
  // its block pattern: each block column's rows counted at the mean block
  // size. Its entries and the flops of a factorisation (the sum of the
  // squared column counts, as CHOLMOD counts them).
  struct FactorEstimate {
    double entries = 0;
    double flops = 0;
  };
  FactorEstimate EstimateFactor() const;
  // y = S x for the reduced system's upper block triangle S (the upper
  // triangles of its diagonal blocks).
  void MultiplyReduced(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
  // The preconditioner's groups of blocks: a pose with its own camera (one
  // no other refined pose uses: a photo collection's image, whose focal
  // length and pose are strongly coupled), every other block alone.
  void BuildPreconditionerGroups();
  // Conjugate gradients on the reduced system preconditioned by the inverses
  // of its groups' diagonal blocks (Schur-Jacobi, by image); false when the
  // system is not positive definite.
  // `relative_tolerance`: on |r| / |rhs|; `iterations`: those run;
  // `multiply`: y = S x (MultiplyReduced, or the implicit product).
  // `coarse` (or null): adds the coarse level's correction of a residual
  // to its Schur-Jacobi preconditioned one.
  using VectorFunction =
      std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>;
  bool SolveIterative(const Eigen::VectorXd& rhs, double relative_tolerance,
                      const VectorFunction& multiply,
                      const VectorFunction* coarse, Eigen::VectorXd* step,
                      int* iterations) const;
  // The coarse level's clusters of refined poses (coarse_cluster_): their
  // coupling is the number of points two images share (from at most 16 of
  // a point's observations, scaled), over the square root of the product of
  // their numbers of observations.
  void BuildCoarseClusters();
  // The coarse system from the formed reduced system's cells.
  void AddCellsToCoarseSystem(const std::vector<CoarsePose>& coarse_poses,
                              CoarseSystem* system) const;

  const bool center_;
  const SchurSolverOptions solver_options_;
  double model_tolerance_ = 0;  // Solve's, for SolveIterative
  bool iterative_ = false;      // the reduced system solved by SolveIterative
  // ... without forming it (SchurSolverOptions::implicit_min_mib); the
  // structure then holds the local cells only (BuildStructure).
  bool implicit_ = false;
  // BuildPreconditionerGroups': (block, its partner or -1), each block once.
  std::vector<std::pair<int, int>> preconditioner_groups_;
  // BuildCoarseClusters': by pose, its cluster (-1: none); 0 clusters: no
  // coarse level.
  std::vector<int> coarse_cluster_;
  int num_coarse_clusters_ = 0;
  double factor_bytes_estimate_ = 0;
  double factor_flops_estimate_ = 0;
  std::vector<CameraBlock> cameras_;
  std::vector<PoseBlock> poses_;
  std::vector<double*> point_blocks_;
  std::vector<bool> point_constant_;
  std::vector<uint32_t> point_begin_ = {0};  // observations by point (CSR)
  std::vector<Observation> observations_;
  // By observation: its weight, read from its image's weights when a solve
  // starts (a pointer chase into each image's array, three times per
  // observation and iteration, was a tenth of a 1,000-image photo run).
  std::vector<double> weights_;
  std::vector<PoseResidual> pose_residuals_;

  // Reduced camera system: block b's size, scalar offset, and the column
  // layout (upper block triangle, full diagonal blocks) by block column.
  std::vector<int> pose_block_, camera_block_;  // -1: held
  // By camera: its first column in its block (after the pose's when joined
  // to its pose's block, else 0).
  std::vector<int> camera_column_;
  std::vector<int> block_size_, block_offset_;
  int num_scalars_ = 0;
  // By block: the first value of its column and the rows stored in it. A
  // column's cells are accumulated each as one contiguous column-major
  // block (leading dimension: its rows; row offset r -> values r x the
  // column's width in), because the Schur updates of a point scatter over
  // cells: in the scalar layout each cell column is a separate cache line
  // (a stride of the column's height apart). ToScalarLayout() rearranges
  // each column in place into the scalar CSC layout for the
  // factorisations.
  std::vector<size_t> column_begin_;
  size_t num_values_ = 0;  // the structure's (BuildStructure)
  std::vector<int> column_height_;
  // (column block << 32 | row block) -> row offset within the block
  // column, sorted; column_cells_: each column's first cell in it.
  std::vector<std::pair<uint64_t, int>> cell_offset_;
  std::vector<size_t> column_cells_;
  // CSC of the scalar matrix (the factorisations only).
  std::vector<int> outer_, inner_;
  // Per point eliminated when the structure was built (while within
  // SchurSolverOptions::max_cell_table_mib): its blocks (sorted, CSR by point)
  // and the value index of the cell of each pair of them (by local index i <= j
  // at j (j + 1) / 2 + i), so that the accumulation searches no cell; m blocks
  // take m (m + 1) / 2 entries. Empty for the others.
  std::vector<size_t> point_block_ids_begin_, point_cells_begin_;
  std::vector<int> point_block_ids_;
  // The order the points are eliminated in (empty: their own; see
  // SchurSolverOptions::locality_order_min_mib).
  std::vector<uint32_t> point_order_;
  std::vector<uint32_t> point_cells_;
  bool use_cell_tables_ = true;
  // SchurSolverOptions::prefetch_updates_min_mib reached (BuildStructure).
  bool prefetch_updates_ = false;
  // The observations' linearisations kept from the last elimination
  // (SchurSolverOptions::max_jacobian_store_mib), point by point: point p's
  // from jacobian_store_[jacobian_store_begin_[p]] when jacobian_stored_[p].
  // Laid out at each solve (the weights may change between solves), the
  // values allocated at the largest size any solve took and not zeroed
  // (each point's are written by the elimination before they are read):
  // allocated and zeroed at every solve, their page faults and zeroing
  // were a cost of every solve.
  std::unique_ptr<double[]> jacobian_store_;
  size_t jacobian_store_capacity_ = 0;
  std::vector<size_t> jacobian_store_begin_;
  std::vector<char> jacobian_stored_;
  // ... in floats (SchurSolverOptions::implicit_single_precision), the same
  // layout.
  std::unique_ptr<float[]> jacobian_store_single_;
  size_t jacobian_store_single_capacity_ = 0;
  // Implicit: the weighed observations' poses point by point (CSR), the
  // store's order, so that the product reads neither observations_ nor
  // weights_.
  std::vector<size_t> product_poses_begin_;
  std::vector<uint32_t> product_poses_;
  // The reduced system, in the cell layout while accumulated (above).
  std::vector<double> values_;
  // CHOLMOD's workspace and supernodal factor (null: simplicial).
  struct Cholmod;
  std::unique_ptr<Cholmod> cholmod_;
  std::string linear_solver_reason_;
};

}  // namespace colmap_irav4
