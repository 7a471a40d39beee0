#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// Camera centres from relative translation directions with the rotations
// held fixed, an alternative to global positioning (BATA, Zhuang et al., CVPR
// 2018). Each pair (i, j) with t_ij (cam_j_from_cam_i, unit) gives the world
// direction of u = c_j - c_i, v_ij = -R_j^T t_ij. BATA minimises
// sum rho(|u d_ij - v_ij|) over centres and per-pair scales d_ij >= 0; with
// d_ij eliminated (d = max(<u, v>, 0) / |u|^2) the residual is
//     r_ij = v_ij - u max(<u, v_ij>, 0) / |u|^2,
// whose norm is the sine of the angle between u and v_ij (1 beyond 90 deg):
// bounded, so long and short baselines and wrong pairs weigh alike. Solved
// with Ceres under a robust loss (instead of BATA's IRLS) from a linear
// initialisation (v_ij x u = 0, smallest eigenvector). The result is
// scale-free: the scale is that of the initialisation (median baseline ~100);
// the first image's centre is the origin.
enum class TranslationAveragingCost { kBata, kChordal };
template <>
const EnumNames<TranslationAveragingCost>& NamesOf<TranslationAveragingCost>();

struct TranslationAveragingOptions {
  // bata (see above) or chordal (v_ij - u / |u|, as 1DSfM).
  TranslationAveragingCost cost = TranslationAveragingCost::kBata;
  // Robust loss on |r_ij| (a sine).
  LossFunctionType loss_function = LossFunctionType::kCauchy;
  double loss_scale = 0.1;
  // Linear initialisation (dense, up to 1500 images); else (or beyond) random
  // centres uniform in [-box, box]^3 (seeded).
  bool linear_initialization = true;
  double initialization_box = 100.0;
  uint64_t random_seed = 0;
  // Pairs whose direction disagrees with the result by more than this (deg)
  // are counted as outliers in the summary (0: not counted).
  double max_angular_error_deg = 5.0;
  // Ceres: 200 iterations, function tolerance 1e-7, parameter 1e-8.
  SolverOptions solver;

  TranslationAveragingOptions();
  // Throws InputError naming the offending option.
  void Check() const;
};

struct TranslationAveragingSummary {
  int num_images = 0;          // positioned
  int num_images_dropped = 0;  // in no usable pair (deleted from the model)
  int num_pairs = 0;
  int num_outlier_pairs = 0;  // over max_angular_error_deg after solving
  int num_iterations = 0;
  double seconds = 0;
};

// Reads the images' rotations from the model, writes their translations
// (t_i = -R_i c_i). Pairs with an image missing from the model or a zero
// translation are skipped; images in no pair are deleted. Points are not
// touched (triangulate them afterwards). Returns false if fewer than two
// images could be positioned or Ceres failed.
bool RunTranslationAveraging(const TranslationAveragingOptions& options,
                             const std::vector<ImagePairGeometry>& pairs,
                             Reconstruction* reconstruction,
                             TranslationAveragingSummary* summary = nullptr);

}  // namespace colmap_irav4
