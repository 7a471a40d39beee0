#include "colmap_irav4/util/ceres_solve.h"

#include <algorithm>

#include <glog/logging.h>

#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/interrupt.h"
#include "colmap_irav4/util/progress_bar.h"
#include "colmap_irav4/util/threading.h"

namespace colmap_irav4 {
namespace {

// Advances a ProgressBar by the iterations of a Ceres solve (out of its
// max_num_iterations; finished when the solver stops early).
class CeresProgressCallback : public ceres::IterationCallback {
 public:
  explicit CeresProgressCallback(ProgressBar* bar) : bar_(bar) {}
  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& summary) override {
    bar_->Update(summary.iteration);
    // An interrupt (util/interrupt.h) stops the solve at this iteration;
    // SolveProblem then throws.
    return InterruptRequested() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  ProgressBar* bar_;
};

}  // namespace

SolverOptions::SolverOptions() { ceres.num_threads = -1; }

void SolverOptions::Check(const std::string& prefix) const {
  if (ceres.max_num_iterations < 1) {
    throw OptionError(&ceres.max_num_iterations, prefix + "max_num_iterations",
                      "must be positive");
  }
  if (!(ceres.function_tolerance >= 0)) {
    throw OptionError(&ceres.function_tolerance, prefix + "function_tolerance",
                      "must be >= 0");
  }
  if (!(ceres.gradient_tolerance >= 0)) {
    throw OptionError(&ceres.gradient_tolerance, prefix + "gradient_tolerance",
                      "must be >= 0");
  }
  if (!(ceres.parameter_tolerance >= 0)) {
    throw OptionError(&ceres.parameter_tolerance,
                      prefix + "parameter_tolerance", "must be >= 0");
  }
  if (!(ceres.initial_trust_region_radius > 0)) {
    throw OptionError(&ceres.initial_trust_region_radius,
                      prefix + "initial_trust_region_radius",
                      "must be positive");
  }
  if (ceres.num_threads == 0 || ceres.num_threads < -1) {
    // Set from the command's threads flag: named as the member.
    throw OptionError(&ceres.num_threads, "SolverOptions::ceres.num_threads",
                      "must be -1 (all cores) or > 0");
  }
}

ParameterBlockCopies::ParameterBlockCopies(size_t capacity) {
  values_.reserve(capacity);
}

double* ParameterBlockCopies::Add(double* model, int size) {
  CHECK_LE(values_.size() + size, values_.capacity())
      << "the copies would move";
  const size_t offset = values_.size();
  values_.insert(values_.end(), model, model + size);
  blocks_.push_back({model, size});
  return values_.data() + offset;
}

void ParameterBlockCopies::CopyToModel() const {
  const double* value = values_.data();
  for (const Block& block : blocks_) {
    std::copy(value, value + block.size, block.model);
    value += block.size;
  }
}

ceres::Solver::Summary SolveProblem(const std::string& label,
                                    const SolverOptions& options,
                                    ceres::Problem* problem) {
  ceres::Solver::Options solver_options = options.ceres;
  solver_options.num_threads = ResolveNumThreads(options.ceres.num_threads);
  const bool print_progress = options.ceres.minimizer_progress_to_stdout;
  solver_options.logging_type =
      print_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  ProgressBar bar(label, solver_options.max_num_iterations,
                  options.show_progress_bar);
  CeresProgressCallback callback(&bar);
  // Always: the callback is also the interrupt's checkpoint.
  solver_options.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem, &summary);
  ThrowIfInterrupted();
  bar.Finish();
  if (print_progress) LOG(INFO) << summary.FullReport();
  return summary;
}

template <>
const EnumNames<LossFunctionType>& NamesOf<LossFunctionType>() {
  static const EnumNames<LossFunctionType> names = {
      {LossFunctionType::kHuber, "huber"},
      {LossFunctionType::kCauchy, "cauchy"},
      {LossFunctionType::kTrivial, "trivial"}};
  return names;
}

ceres::LossFunction* CreateLossFunction(LossFunctionType type, double scale) {
  if (type == LossFunctionType::kHuber) return new ceres::HuberLoss(scale);
  if (type == LossFunctionType::kCauchy) return new ceres::CauchyLoss(scale);
  return nullptr;
}

}  // namespace colmap_irav4
