#pragma once

#include <string>

#include <ceres/ceres.h>

#include "colmap_irav4/util/enum_names.h"

namespace colmap_irav4 {

// The Ceres settings of a stage that solves with Ceres (bundle adjustment,
// global positioning, translation averaging): one member of each stage's
// options struct, as COLMAP's and GLOMAP's solver_options, registered once
// per stage prefix (pipeline/option_registration) and checked here.
struct SolverOptions {
  // Ceres' defaults, except num_threads = -1 (all cores).
  SolverOptions();

  // Ceres' own options. The stages read max_num_iterations,
  // function/gradient/parameter_tolerance, initial_trust_region_radius,
  // num_threads (-1: all cores, resolved when solving) and
  // minimizer_progress_to_stdout (Ceres' per-iteration log and full report);
  // each stage chooses the linear solver and ordering itself.
  ceres::Solver::Options ceres;
  // A progress bar over the iterations.
  bool show_progress_bar = false;

  // Throws OptionError naming `prefix` + the option (e.g.
  // "BundleAdjustment.max_num_iterations").
  void Check(const std::string& prefix) const;
};

// Solves `problem` with `options` (a progress bar named `label` with
// show_progress_bar). Returns Ceres' summary.
ceres::Solver::Summary SolveProblem(const std::string& label,
                                    const SolverOptions& options,
                                    ceres::Problem* problem);

// The robust losses every stage offers (--*.loss_function): huber, cauchy
// (Ceres' losses at their scale) or trivial (least squares).
enum class LossFunctionType { kHuber, kCauchy, kTrivial };
template <>
const EnumNames<LossFunctionType>& NamesOf<LossFunctionType>();
// The loss of `type` at `scale` (nullptr for trivial). The caller (or the
// problem) owns the result.
ceres::LossFunction* CreateLossFunction(LossFunctionType type, double scale);

}  // namespace colmap_irav4
