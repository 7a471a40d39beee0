#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>

#include <ceres/ceres.h>

#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/scene/pose_prior.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/enum_names.h"

namespace colmap_irav4 {

// Joint estimation of camera centres and points from fixed rotations and
// tracks (GLOMAP-style global positioning). Each observation of point X_k in
// image i gives the world-frame bearing d_ik = R_i^T normalise(K^-1 x_ik) and
// the residual
//     r_ik = s_ik d_ik - (X_k - c_i),   s_ik >= 1 (a scale per observation),
// under a robust loss. The scales are eliminated in closed form
// (s_ik = max(1, <d_ik, X_k - c_i>), variable projection), so that Ceres sees
// only centres and points and Schur-eliminates the points. The gauge: the first
// image's centre is held at the origin, the rotations fix the orientation and
// the lower bound of the scales fixes the scale (the nearest points end up
// about one unit from a camera). Initialisation is random in a box (seeded), so
// no prior poses are needed.
//
// With position priors (GPS) the model is then placed in the priors' frame:
// a similarity from the centres to the priors (RANSAC, then least squares on
// the priors within 4 standard deviations; where images have gravity priors the
// similarity's tilt comes from them, its heading, scale and offset from the
// positions), then a second solve with every prior as a residual in standard
// deviations under least squares with a Cauchy tail (PosePriorOptions), so
// that an outlier 50 m off barely pulls, and the result mapped into the
// priors' frame (metric).
// The linear solver of global positioning's Levenberg-Marquardt steps.
enum class PositioningLinearSolver {
  kAuto,
  kSparseSchur,
  kDenseSchur,
  kIterativeSchur
};
template <>
const EnumNames<PositioningLinearSolver>& NamesOf<PositioningLinearSolver>();

struct GlobalPositionerOptions {
  // Tracks with fewer observations in the model's images are left out (and
  // their points deleted: retriangulation recovers them later).
  int min_track_length = 3;
  // Robust loss on ||r_ik||: "huber", "cauchy" or "trivial".
  // Cauchy: wrong observations left in tracks barely pull (Huber's linear
  // tail still biases the centres by ~1% of the scene with 10% of them).
  LossFunctionType loss_function = LossFunctionType::kCauchy;
  // Scale of the robust loss, in the units of the scale lower bound.
  double loss_scale = 0.1;
  // Random initial centres and points uniform in [-box, box]^3; else the
  // model's current translations and points are the initial values.
  bool random_initialization = true;
  double initialization_box = 100.0;
  uint64_t random_seed = 0;
  // After solving, observations whose bearing disagrees with the estimated
  // camera-to-point direction by more than this (deg) are unlinked; 0: keep.
  double max_angular_error_deg = 5.0;
  // Ceres: 200 iterations; loose tolerances (function 1e-3, parameter 1e-4),
  // as this is the initialisation of bundle adjustment: on fountain-P11 they
  // take 9 iterations instead of 39 (1.3 s instead of 4.7 s) and give the
  // same model after bundle adjustment.
  SolverOptions solver;
  // auto: by the size and density of the reduced camera system (the Schur
  // complement of the points; ChoosePositioningLinearSolver): DENSE_SCHUR
  // below 50 images, ITERATIVE_SCHUR (Schur-Jacobi preconditioner, implicit
  // Schur products: neither the reduced system nor a factor is stored) from
  // iterative_schur_min_num_images images or from
  // iterative_schur_dense_min_num_images when at least
  // iterative_schur_min_density of the image pairs share a point or each
  // image shares points with iterative_schur_min_pairs_per_image others on
  // average, or when its tracks are long (forming the reduced system costs
  // more than the conjugate gradients, below), SPARSE_SCHUR otherwise; or
  // sparse_schur, dense_schur,
  // iterative_schur whatever the size. A dense view graph (photo collections)
  // fills the sparse Cholesky factor of the reduced system in: at 4,953 photo
  // images (8.8% of the pairs share a point, 6.7 M observations) 65 CPU s per
  // iteration and a 5.3 GB peak; at 990 (16.3%) SPARSE_SCHUR is still cheap
  // (docs/notes/2026-12-05-positioning-density.md). The size rule starts
  // where the density is no longer counted (30,000 images): the sparse
  // 10,000-image courtyard was measured with SPARSE_SCHUR (8.2 GB peak),
  // not with ITERATIVE_SCHUR. The density threshold lies between the
  // courtyards (4.0% at 1,000 images, 1.4% at 3,000: it falls as 1 / n)
  // and the 5,000-image photo scene re-mapped after its fold cut (4.97%,
  // where SPARSE_SCHUR sat over 9 minutes in its first iteration). The
  // fraction falls as 1 / n on a photo collection too: the 10,000-image
  // photo scene re-mapped after its fold cut (9,904 images, 3.7%: 366 pairs
  // an image) sat 48 minutes in SPARSE_SCHUR's first 20 iterations (the
  // first positioning, ITERATIVE_SCHUR at 6.5%: 400 s), hence the pairs per
  // image: a courtyard's ~40 at every size, a photo collection's 250-650.
  PositioningLinearSolver linear_solver = PositioningLinearSolver::kAuto;
  int iterative_schur_min_num_images = 30000;
  int iterative_schur_dense_min_num_images = 2000;
  double iterative_schur_min_density = 0.04;
  double iterative_schur_min_pairs_per_image = 100;
  // ... or at any size from this many 3x3 camera-block products an
  // observation (SchurProductsPerObservation; 0: off): forming the reduced
  // system takes m (m + 1) / 2 block products for a point of m
  // observations, a conjugate gradient iteration a few operations an
  // observation; long tracks make the first the larger. Measured one
  // thread (docs/notes/2026-12-08-positioning-long-tracks.md): photo 1,000
  // (12.7 and 10.0 an observation) SPARSE_SCHUR 46 CPU s for both
  // positionings, ITERATIVE_SCHUR 317; one 2,000-image landmark (1,992
  // images under the 2,000 of the density rule; 45.9) 754.5 against 105.4.
  // Courtyards 3-9, photo 300 5-6, one landmark of 3,000 / 5,400 images
  // 46 / 72.
  double iterative_schur_min_products_per_observation = 20;
  // Weights of the pose priors (used only when priors are given).
  PosePriorOptions pose_priors;

  GlobalPositionerOptions();
  // Throws InputError naming the offending option.
  void Check() const;
};

struct GlobalPositionerSummary {
  int num_images = 0;          // images positioned
  int num_images_dropped = 0;  // images without usable observations (deleted)
  int num_points = 0;          // points positioned
  int num_points_dropped = 0;  // tracks too short (deleted)
  int num_observations = 0;    // residuals
  int num_observations_filtered = 0;  // unlinked by max_angular_error_deg
  int num_iterations = 0;
  // Ceres' name of the linear solver and why (ChoosePositioningLinearSolver);
  // the fraction of the image pairs sharing a point (-1: not computed).
  std::string linear_solver;
  std::string linear_solver_reason;
  double schur_density = -1;
  // SchurProductsPerObservation of the problem (-1: not computed).
  double schur_products_per_observation = -1;
  double initial_cost = 0;
  double final_cost = 0;
  double seconds = 0;
  bool converged = false;
  // Pose priors: images of the model with a position prior, those within 3
  // standard deviations of the placed model, with a gravity prior; whether
  // the model was placed in the priors' frame (else as without priors).
  int num_position_priors = 0;
  int num_position_prior_inliers = 0;
  int num_gravity_priors = 0;
  bool in_prior_frame = false;
  // At least 10 position priors, fewer than 80% of them within 3 standard
  // deviations: the priors are poorer than their covariance says, or part of
  // the model is turned (a fold the images did not settle). Logged as a
  // warning; GPS with 5% outliers keeps about 95%.
  bool priors_disagree = false;
  // Why it was not placed ("" when it was or no priors were given).
  std::string prior_problem;
};

// Sets the linear solver (and preconditioner) of a global positioning of
// `num_images` images in `ceres_options` (options.linear_solver, above);
// `schur_density`: the fraction of the images' pairs that share a point
// (negative: unknown). Returns the reason, e.g. "ITERATIVE_SCHUR: dense
// reduced camera system (5000 images, 31.0% of pairs share a point)".
std::string ChoosePositioningLinearSolver(
    const GlobalPositionerOptions& options, int num_images,
    double schur_density, ceres::Solver::Options* ceres_options,
    double products_per_observation = -1);

// The camera-block products of forming the reduced camera system (the sum of
// m (m + 1) / 2 over the points, m: a point's observations in the model's
// images) over the observations (0 without any).
double SchurProductsPerObservation(const Reconstruction& reconstruction);

// SchurDensity of the model's points: the fraction of the pairs of the
// images observing them that share a point.
double PositioningSchurDensity(const Reconstruction& reconstruction,
                               int max_num_images = 30000);

// Reads cameras, the images' cam_from_world rotations, their keypoints and
// the points' tracks; writes cam_from_world translations (t_i = -R_i c_i) and
// point positions. Images that no kept track observes are deleted from the
// model. Returns false if fewer than two images could be positioned or Ceres
// failed. With `priors` (by image id), the model is placed in their frame
// when at least pose_priors.min_num_positions of its images have a position
// prior and a similarity could be found (summary->in_prior_frame).
// `schur_density` >= 0: the density the automatic linear solver is chosen
// by, instead of that of the model's points (whose tracks may be thinned).
bool RunGlobalPositioning(const GlobalPositionerOptions& options,
                          Reconstruction* reconstruction,
                          GlobalPositionerSummary* summary = nullptr,
                          const PosePriors* priors = nullptr,
                          double schur_density = -1);

// The similarity mapping camera centres (by image id) onto their position
// priors: RANSAC (inliers within 3 median standard deviations, at most the
// priors' median spread), then least squares on the priors within 4 of
// their own standard deviations, repeated until those no longer change; where
// at least 3 images have gravity priors, the rotation's tilt maps the mean
// world down of the images (their cam_from_world rotations applied to their
// gravity) onto -z, and the heading, scale and offset are fitted to the inliers
// with it. False when fewer than min_num_positions priors or no similarity
// (collinear centres).
bool EstimatePriorFrameFromModel(
    const std::map<image_t, Eigen::Vector3d>& centers,
    const std::map<image_t, Eigen::Matrix3d>& cam_from_world_rotations,
    const PosePriors& priors, const PosePriorOptions& options, uint64_t seed,
    Sim3d* prior_from_model, std::set<image_t>* inliers, std::string* problem);

}  // namespace colmap_irav4
