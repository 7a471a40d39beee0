#pragma once

#include <string>
#include <vector>

#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/refinement/schur_bundle_adjuster.h"
#include "colmap_irav4/scene/pose_prior.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"

namespace colmap_irav4 {

// Bundle adjustment of a whole model (Ceres): reprojection residuals in
// pixels through the camera models (scene/camera_models.h), poses as unit
// quaternion (Eigen order, EigenQuaternionManifold) + projection centre
// (parameterize_centers; or translation), one intrinsics block per camera
// (shared by its images), Schur elimination of the points, robust loss. Run
// in rounds: after each, observations with a reprojection error above
// max_reproj_error are unlinked, and the next round starts from the result
// (stops early when few were removed).
//
// Gauge: the first image's pose is held fixed and so is the component of the
// second image's centre (or translation) most sensitive to scale, as COLMAP
// does; with refine_poses off only the points (and intrinsics) move.
//
// Pose priors (RunBundleAdjustment's `priors`, for a model already in their
// frame): each position prior adds W (c - p), W^T W the inverse of its
// covariance (or pose_priors.position_std^-2 I), and each gravity prior the
// angle between its direction and the camera's down (0, 0, -1 in the
// priors' frame) over pose_priors.gravity_std_deg, both under least squares
// up to pose_priors.quadratic_std standard deviations and a Cauchy tail of
// pose_priors.loss_scale beyond (QuadraticCauchyTailLoss). With at least
// pose_priors.min_num_positions position priors they hold the gauge (no
// pose is fixed). Priors beyond pose_priors.gate_std in the model as it is
// handed in are left out (GatePosePriors, below).

enum class BundleAdjustmentLoss { kHuber, kHuberCeres, kCauchy, kTrivial };
template <>
const EnumNames<BundleAdjustmentLoss>& NamesOf<BundleAdjustmentLoss>();
enum class BundleAdjustmentLinearSolver {
  kAuto,
  kSparseSchur,
  kDenseSchur,
  kIterativeSchur
};
template <>
const EnumNames<BundleAdjustmentLinearSolver>&
NamesOf<BundleAdjustmentLinearSolver>();

enum class BundleAdjustmentSolverBackend { kAuto, kCeres, kSchur };
template <>
const EnumNames<BundleAdjustmentSolverBackend>&
NamesOf<BundleAdjustmentSolverBackend>();
template <>
const EnumNames<SchurLinearSolver>& NamesOf<SchurLinearSolver>();

struct BundleAdjustmentOptions {
  // Intrinsics to refine (COLMAP's ba_refine_* options).
  bool refine_focal_length = true;
  bool refine_principal_point = false;
  bool refine_extra_params = true;
  bool refine_poses = true;
  bool refine_points = true;
  // A prior on each refined focal length (one focal length models) at its
  // value when the adjustment starts, f0: the residual (f - f0) / (std f0),
  // std relative; for cameras with a focal length prior
  // (has_prior_focal_length) and for the others (guessed); 0: none.
  double focal_prior_std = 0;
  double guessed_focal_prior_std = 0;
  // A camera whose images have fewer observations than this in the
  // adjustment (of points in front of them) has its intrinsics held; its
  // images' poses are refined (0: none held).
  int min_num_intrinsics_observations = 0;
  // An image with fewer observations than this (of points in front of it)
  // is left out of the adjustment: its observations weigh nothing, its pose
  // (and a camera no other image of the adjustment uses) is held; the
  // filters after it judge its observations against the adjusted points
  // (0: none left out). An image of a few points is all but free (its focal
  // length trades against their depth, its pose turns about them):
  // Levenberg-Marquardt crawls along it for dozens of iterations while the
  // rest has settled (the photo scenes' focal length collapsing 1,031 -> 44
  // px on an image of 11 observations); held in place instead, its
  // observations, often false, pull their points
  // (docs/notes/2026-12-04-photo-ba-crawl.md). COLMAP registers no image of
  // fewer than 30 inliers. Counted again in each adjustment: an image left
  // out of one is adjusted in the next once retriangulation has given it
  // observations. The gauge is held by images adjusted.
  int min_num_image_observations = 0;
  // Hold the gauge (see above); off: LM's damping alone handles the 7
  // degrees of freedom.
  bool fix_gauge = true;
  // Robust loss on the reprojection error: huber (iteratively reweighted:
  // weights min(1, loss_scale / error) fixed during each solve, updated by
  // the rounds; converges like least squares), huber_ceres (Ceres'
  // HuberLoss: Levenberg-Marquardt crawls when many residuals are in its
  // linear region), cauchy (Ceres) or trivial.
  BundleAdjustmentLoss loss_function = BundleAdjustmentLoss::kHuber;
  double loss_scale = 1.0;  // px
  // Rounds of (solve, filter); observations over max_reproj_error px are
  // removed after each round (0: no filtering, a single round).
  int num_rounds = 3;
  double max_reproj_error = 4.0;
  // Another round only if the filter removed at least this fraction of the
  // observations (fountain-P11: 1 round instead of 3, 5.5 s -> 3.7 s for the
  // stages after rotation averaging, same accuracy).
  double min_filtered_fraction = 0.01;
  // auto: by the size and density of the reduced camera system (the
  // Schur complement of the points; ChooseLinearSolver): DENSE_SCHUR below
  // 50 images (COLMAP's rule), ITERATIVE_SCHUR (Schur-Jacobi
  // preconditioner) from iterative_schur_min_num_images or when at least
  // iterative_schur_min_density of its image pairs share a point (sparse
  // Cholesky fills a nearly dense system in at a dense one's cost, and its
  // memory grows as the square of the images), SPARSE_SCHUR otherwise; or
  // sparse_schur, dense_schur, iterative_schur whatever the size.
  // The size threshold lies beyond the sizes measured: ITERATIVE_SCHUR was
  // 7-8x slower at 300-1,000 images of the sparse courtyard
  // (docs/notes/2026-12-01-results-2b39f55.md).
  BundleAdjustmentLinearSolver linear_solver =
      BundleAdjustmentLinearSolver::kAuto;
  // Who solves: ceres (the problem above), schur (SchurBundleAdjuster: the
  // same Levenberg-Marquardt without a stored Jacobian or residual blocks;
  // one thread) or auto: schur from schur_min_num_observations
  // observations, where it was measured to reach the same models with less
  // CPU time and half the peak memory (300 and 1,000 images,
  // docs/notes/2026-12-03-schur-bundle-adjustment.md), and less CPU time
  // with pose priors or not from 20,786 observations (30-100 images,
  // docs/notes/2026-12-03-priors-speed.md). The huber_ceres and cauchy
  // losses go to Ceres whatever this says (ChooseSchurBackend; the reason is
  // in the log and summary.json).
  BundleAdjustmentSolverBackend solver_backend =
      BundleAdjustmentSolverBackend::kAuto;
  int schur_min_num_observations = 20000;
  // The Schur solver's linear solver (SchurLinearSolver): auto (iterative
  // when the Cholesky factor would exceed schur_max_factor_mib or its
  // factorisation schur_max_factor_gflops, else supernodal once the factor
  // is dense: photo collections), simplicial,
  // supernodal, iterative (conjugate gradients, Schur-Jacobi preconditioner:
  // no factor; docs/notes/2026-12-05-iterative-schur.md).
  SchurLinearSolver schur_linear_solver = SchurLinearSolver::kAuto;
  // auto: iterative above this estimated factor size (MiB; a dense factor of
  // 40,000 parameters, 5,000 photo images, would take 6,100; the 5,000-image
  // photo scene's true tracks give 474).
  double schur_max_factor_mib = 1024;
  // auto: iterative above this estimated factorisation cost (GFlop, one per
  // iteration; SchurSolverOptions::max_factor_gflops).
  double schur_max_factor_gflops = 50;
  // The Schur solver's per-point cell tables (SchurSolverOptions): at most
  // this many MiB; the points beyond search their cells at each iteration.
  double schur_max_cell_table_mib = 256;
  // The Schur solver keeps the observations' Jacobians from each elimination
  // in at most this many MiB (SchurSolverOptions::max_jacobian_store_mib):
  // the back-substitution and tries after a rejected step do not evaluate
  // them again (the same result to the bit); 0: none kept.
  double schur_max_jacobian_store_mib = 256;
  // The Schur solver eliminates the points in an order that keeps
  // consecutive points' cells together from this size of its reduced
  // system (MiB; SchurSolverOptions::locality_order_min_mib).
  double schur_locality_order_min_mib = 16;
  // The Schur solver lists each point's pair updates and prefetches their
  // cells from this size of its reduced system (MiB;
  // SchurSolverOptions::prefetch_updates_min_mib; the same result).
  double schur_prefetch_updates_min_mib = 16;
  // Iterative: conjugate gradients stop at a residual of min(eta, sqrt(|b| /
  // |b_0|)) |b| (inexact Newton; SchurSolverOptions) or after this many.
  double schur_iterative_eta = 1e-3;
  int schur_max_cg_iterations = 500;
  // Iterative: ... or once the quadratic model's relative decrease per
  // iteration, times the iteration count, is below this
  // (SchurBundleAdjuster::Solve's model_tolerance; 0: off), in adjustments of
  // at least schur_iterative_model_min_num_images images (those the adjustment
  // holds, counted as for stall_min_num_images). On the photo
  // scenes of 1,000 images forced iterative (seeds 1 and 2) it took 43-63%
  // off the conjugate gradients and 3-47% off the run's CPU with the same
  // medians; on the 300-image one it moved the centre median 22% (0.0372 ->
  // 0.0453 m; its bundle adjustment 1 at the 100-iteration cap either way)
  // (docs/notes/2026-12-07-cg-model-rule.md).
  double schur_iterative_model_tolerance = 1e-3;
  int schur_iterative_model_min_num_images = 800;
  // Iterative: the preconditioner's coarse level, images in clusters of
  // about this many moving as rigid bodies with a scale
  // (SchurSolverOptions::coarse_cluster_size; 0: Schur-Jacobi alone), in
  // at most schur_coarse_max_clusters clusters.
  int schur_coarse_cluster_size = 10;
  int schur_coarse_max_clusters = 512;
  // Iterative: from this size of the reduced system (MiB), the conjugate
  // gradients multiply by it without forming it, from every observation's
  // kept Jacobians (SchurSolverOptions::implicit_min_mib; 0: always).
  double schur_implicit_min_mib = 256;
  // Implicit: the product from a single-precision copy of the Jacobians
  // (SchurSolverOptions::implicit_single_precision).
  bool schur_implicit_single_precision = true;
  // ... multiplied with AVX2 and FMA when the processor has them
  // (SchurSolverOptions::implicit_avx2).
  bool schur_implicit_avx2 = true;
  // Our Schur solver: after a rejected step or failed factorisation, while
  // the radius is at least this, the next try re-damps the cameras of the
  // same reduced system instead of eliminating the points again
  // (SchurSolverOptions::reuse_min_radius); 0: off.
  double schur_reuse_min_radius = 0;
  // Our Schur solver: embedded point iterations after each step
  // (SchurSolverOptions::point_iterations); 0: off.
  int schur_point_iterations = 0;
  // Each solve stops once its last stall_num_iterations accepted steps
  // together lowered the cost by less than stall_relative_decrease of it
  // (CostStall: a few ill-determined cameras crawling while the rest has
  // settled); a stopped solve counts as converged. 0: off. The mapper
  // applies it to its adjustments before the last only (bundle adjustment 1
  // and the two-view check's). At 100-300 photo images it saved time on
  // some scenes, cost it on others, and mostly lost accuracy, the crawl
  // moving to the last adjustment (docs/notes/2026-12-05-ba-stall.md).
  // Hence it acts only in adjustments of at least stall_min_num_images
  // images: on the 1,000-image photo scenes
  // (seeds 1 and 2, adjustments of 948-993 images) it took 16% and 46% off
  // the run's CPU with the same rotation and centre medians
  // (docs/notes/2026-12-06-scale-ba.md); nothing was measured between 300
  // and 948 images.
  int stall_num_iterations = 5;
  double stall_relative_decrease = 0.005;
  int stall_min_num_images = 800;
  // The same rule for the mapper's last adjustment, with its own window and
  // threshold (0: off, the last adjustment runs to its tolerances). Its
  // crawl (photo scenes, stall_num_iterations on: a few narrow-field
  // cameras of groups tied to the rest by few points, and falsely
  // registered images of 3-4 observations, creeping for 50-90 iterations at
  // 0.001-0.01% a step; docs/notes/2026-12-06-ba-crawl-cameras.md).
  // Parts of the model tied to the rest by fewer points than this (shared
  // by one pair of images, or through one image only: ModelRigidity's rule)
  // hold a gauge of their own, as parts sharing no point do: their pose and
  // scale relative to the rest are held where the adjustment found them.
  // The mapper writes such parts as separate models (its rigidity check,
  // 15 points), so their relative placement is never used; refining it
  // lets a part hanging on a few (often false) points pivot about them for
  // dozens of steps (photo 100 s2: a 6-image part tied by 7 false points
  // turned 12 deg in bundle adjustment 2's last 60 steps;
  // docs/notes/2026-12-06-ba-crawl-cameras.md). 1: parts sharing no point
  // and parts joined through one image only (the exact gauge freedoms).
  int gauge_min_shared_points = 1;
  // The same for the mapper's last adjustment only (0:
  // gauge_min_shared_points).
  int last_gauge_min_shared_points = 0;
  // The gauge's scale (one coordinate of an image's centre) held on the
  // image farthest from the held first image; false: on the second image,
  // as before session 43. Held on two neighbours of a kilometre-long model,
  // the rest sways about them and Gauss-Newton's steps fail far away: the
  // 10,000-image courtyard's adjustments crawled and stopped at 0.30 deg
  // of rotation error instead of 0.047
  // (docs/notes/2026-12-07-gauge-on-the-longest-baseline.md).
  bool gauge_scale_farthest = true;
  int last_stall_num_iterations = 0;
  double last_stall_relative_decrease = 1e-4;
  int iterative_schur_min_num_images = 10000;
  double iterative_schur_min_density = 0.5;
  // Ceres: 100 iterations per solve, function tolerance 1e-5, parameter
  // 1e-8; Levenberg-Marquardt's initial trust region 1e16 (Ceres' largest):
  // Gauss-Newton steps, damped only after a rejected step, because the
  // damping smothers the slow bends of a long camera path
  // (docs/notes/2026-12-01-bundle-adjustment-gauss-newton.md).
  SolverOptions solver;
  // Our Schur solver only (Ceres' minimizer has no hook for its radius):
  // once a step is rejected or a factorisation fails before a solve's first
  // accepted step, Ceres' cuts of the radius (/ 2, / 4, / 8, ...) down to
  // this radius are made at once instead of each being tried: from 1e16 the
  // steps above it repeat the rejected one (too little damping to change
  // it), and a system singular without damping rarely factorises with the
  // next cut's, a full pass over the observations each (6 tries skipped; 175
  // CPU s a try at 10,000 photo images). The radii tried are a subset of
  // Ceres'; 0: every cut tried (docs/notes/2026-12-04-lm-start.md). 1e9
  // (was 1e10) also skips Ceres' next cut, 4.8e9, which repeated the
  // rejected step or failed in every solve logged at 300-10,000 images
  // (docs/notes/2026-12-07-part-merge-agreement.md).
  double rejected_start_trust_region_radius = 1e9;
  // Poses as rotation + projection centre (residual R (X - C)) instead of
  // rotation + translation (R X + t), whose rotation steps drag each centre
  // by the angle times its distance from the origin, so that Gauss-Newton
  // steps are rejected far from it; the same optimum either way
  // (docs/notes/2026-12-01-poses-by-centres.md).
  bool parameterize_centers = true;
  // Weigh each observation by the inverse of the reprojection noise of
  // keypoints of its scale (Point2D::scale, from the database's keypoint
  // shapes): before each solve the observations are split into
  // kNumKeypointScaleBins bins of equal count by scale, and each bin's noise
  // is its median reprojection error. A detector localises a keypoint found
  // at a coarser scale less precisely, and least squares is the
  // maximum-likelihood estimate only when each residual is divided by its
  // own noise (docs/notes/2026-12-02-keypoint-scale-weighting.md). Models
  // without scales (or with one scale throughout) are adjusted as before.
  bool weight_by_keypoint_scale = true;
  // With the observations weighed by scale, the reprojection filter's
  // threshold (max_reproj_error) is in units of each scale bin's noise: a
  // keypoint of a bin twice as noisy as the median is kept up to twice the
  // threshold. The summary passes the bins on (keypoint_noise) for the
  // mapper's filters and triangulation.
  bool filter_by_keypoint_noise = true;
  // Weights of the pose priors (used only when priors are given).
  PosePriorOptions pose_priors;

  BundleAdjustmentOptions();
  // Throws InputError naming the offending option.
  void Check() const;
};

struct BundleAdjustmentSummary {
  int num_rounds = 0;
  int num_images = 0;
  // Parts of the model sharing no point, and parts joined to the rest
  // through one image only: each adjusted in its own gauge.
  int num_pieces = 0;
  int num_joints = 0;
  // Solves that failed from the options' trust region radius and were
  // started again damped (RunBundleAdjustment).
  int num_damped_restarts = 0;
  // Solves stopped as the cost stalled (stall_num_iterations).
  int num_stalled_solves = 0;
  // Images left out for too few observations (min_num_image_observations).
  int num_images_left_out = 0;
  // Cameras with a focal length prior (focal_prior_std, above).
  int num_focal_priors = 0;
  // Cameras held for few observations (min_num_intrinsics_observations).
  int num_intrinsics_held = 0;
  int num_points = 0;                 // after the last round
  int num_observations = 0;           // after the last round
  int num_observations_filtered = 0;  // over all rounds
  int num_iterations = 0;             // over all rounds
  // The Schur solver's conjugate gradient iterations (iterative), all rounds.
  int num_linear_iterations = 0;
  double initial_mean_reproj_error = 0;  // px, before the first round
  double final_mean_reproj_error = 0;    // px, after filtering
  double seconds = 0;
  // Of seconds: building the Ceres problems (our code), Ceres' preprocessing
  // (program, ordering, linear solver structure) and its linear solves,
  // over all solves.
  double problem_seconds = 0;
  double preprocessor_seconds = 0;
  double linear_solver_seconds = 0;
  int num_solves = 0;
  std::string linear_solver;  // Ceres' name, of the last solve
  // The backend that solved (ceres or schur) and why (ChooseBackend).
  std::string backend;
  std::string backend_reason;
  // Why it was chosen (ChooseLinearSolver), and the fraction of the image
  // pairs of the problem that share a point (-1: not computed).
  std::string linear_solver_reason;
  double schur_density = -1;
  bool converged = false;  // last round reached a tolerance
  // weight_by_keypoint_scale: the keypoint scale bins' inner edges (px) and
  // each bin's noise (median reprojection error, px) when the last solve
  // started, finest first; empty when the observations were not weighed.
  std::vector<double> scale_bin_edges_px;
  std::vector<double> scale_bin_noise_px;
  // filter_by_keypoint_noise: the bins' relative noise the filter used (empty
  // when the observations were not weighed).
  KeypointScaleNoise keypoint_noise;
  // Prior residuals in the problem (see above).
  int num_position_priors = 0;
  int num_gravity_priors = 0;
  // The images whose position or gravity prior was left out (beyond the
  // gate: GatePosePriors), sorted.
  std::vector<image_t> rejected_position_priors;
  std::vector<image_t> rejected_gravity_priors;
};

// The priors a bundle adjustment leaves out (PosePriorOptions::gate_std).
// r: a prior's whitened residual in the model as it is (position: |W (c -
// p)|, gravity: the angle between the camera's down and the measured
// direction over gravity_std_deg); s: the median r of that kind of prior
// over the median of valid ones (chi with 3 and 2 degrees of freedom: 1.538,
// 1.177). A prior is left out when r > gate_std max(1, s). Why the spread:
// when the model is not yet where the priors put it (shifted or turned as a
// whole), or their covariances are smaller than the fixes' real noise, every
// residual is large, and a gate in covariance units would leave out valid
// priors with the outliers; scaled by the median (which fewer than half
// outliers do not move far) it widens, and the robust loss decides as
// before. The gate is made again from each model it is handed, so a prior
// left out of one adjustment comes back in the next once the model agrees
// with it. No position prior is left out when fewer than
// min_num_positions would remain (they hold the gauge).
struct PosePriorGate {
  // The priors with those left out cleared (NaN).
  PosePriors kept;
  std::vector<image_t> rejected_positions;  // sorted
  std::vector<image_t> rejected_gravity;    // sorted
  // s above (0 when there is no such prior).
  double position_spread = 0;
  double gravity_spread = 0;
};
PosePriorGate GatePosePriors(const Reconstruction& reconstruction,
                             const PosePriors& priors,
                             const PosePriorOptions& options);

// Sets the linear solver (and preconditioner) of a bundle adjustment of
// `num_images` images in `ceres_options` (options.linear_solver, above);
// `schur_density`: the fraction of the images' pairs that share a point
// (the reduced camera system's off-diagonal blocks; negative: unknown).
// Returns the reason, e.g. "sparse_schur: 1000 images, 3.1% of pairs share
// a point".
std::string ChooseLinearSolver(const BundleAdjustmentOptions& options,
                               int num_images, double schur_density,
                               ceres::Solver::Options* ceres_options);
// Whether `options.solver_backend` sends a bundle adjustment of
// `num_observations` observations to the Schur solver (pose priors or not:
// both backends hold them); `reason` (may be null): why, e.g. "schur:
// 2270000 observations (auto from 20000)".
bool ChooseSchurBackend(const BundleAdjustmentOptions& options,
                        size_t num_observations, std::string* reason);

// Returns false if Ceres failed (no usable solution). `priors` (by image id,
// may be null): pose priors of a model in their frame (see above).
bool RunBundleAdjustment(const BundleAdjustmentOptions& options,
                         Reconstruction* reconstruction,
                         BundleAdjustmentSummary* summary = nullptr,
                         const PosePriors* priors = nullptr);

}  // namespace colmap_irav4
