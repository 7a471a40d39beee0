#pragma once

#include <cstdint>
#include <string>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/ceres_solve.h"

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
  double initial_cost = 0;
  double final_cost = 0;
  double seconds = 0;
  bool converged = false;
};

// Reads cameras, the images' cam_from_world rotations, their keypoints and
// the points' tracks; writes cam_from_world translations (t_i = -R_i c_i) and
// point positions. Images that no kept track observes are deleted from the
// model. Returns false if fewer than two images could be positioned or Ceres
// failed.
bool RunGlobalPositioning(const GlobalPositionerOptions& options,
                          Reconstruction* reconstruction,
                          GlobalPositionerSummary* summary = nullptr);

}  // namespace colmap_irav4
