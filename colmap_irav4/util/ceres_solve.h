#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <ceres/ceres.h>
#include <glog/logging.h>

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

// Copies of a problem's parameter blocks in one array, in the order they are
// added, written back to the model on request. Ceres keeps each group of a
// linear_solver_ordering as a std::set<double*>, so it orders a group's
// blocks, and with them the solves' floating-point sums, by address: blocks
// solved in the model's own storage (map nodes) would follow the heap's
// layout, which differs between the mapper command and the Python module and
// under another allocator. Copies here are in address order as added.
class ParameterBlockCopies {
 public:
  // Room for `capacity` values: the addresses Add returns stay valid.
  explicit ParameterBlockCopies(size_t capacity);
  // A copy of the `size` values at `model` (written back by CopyToModel).
  double* Add(double* model, int size);
  // Writes every copy to its block of the model (after each solve).
  void CopyToModel() const;

 private:
  std::vector<double> values_;
  struct Block {
    double* model;
    int size;
  };
  std::vector<Block> blocks_;  // in the order of values_
};

// The block of `id` in `blocks`, sorted by id (copies of a model's points).
template <typename Id>
double* FindBlock(const std::vector<std::pair<Id, double*>>& blocks, Id id) {
  const auto it = std::lower_bound(blocks.begin(), blocks.end(), id,
                                   [](const std::pair<Id, double*>& entry,
                                      Id key) { return entry.first < key; });
  CHECK(it != blocks.end() && it->first == id) << "no block " << id;
  return it->second;
}

// The robust losses every stage offers (--*.loss_function): huber, cauchy
// (Ceres' losses at their scale) or trivial (least squares).
enum class LossFunctionType { kHuber, kCauchy, kTrivial };
template <>
const EnumNames<LossFunctionType>& NamesOf<LossFunctionType>();
// The loss of `type` at `scale` (nullptr for trivial). The caller (or the
// problem) owns the result.
ceres::LossFunction* CreateLossFunction(LossFunctionType type, double scale);

}  // namespace colmap_irav4
