#pragma once

#include <string>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/util/progress_bar.h"
#include "colmap_irav4/util/threading.h"

namespace colmap_irav4 {

// Advances a ProgressBar by the iterations of a Ceres solve (out of its
// max_num_iterations; finished when the solver stops early).
class CeresProgressCallback : public ceres::IterationCallback {
 public:
  explicit CeresProgressCallback(ProgressBar* bar) : bar_(bar) {}
  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& summary) override {
    bar_->Update(summary.iteration);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  ProgressBar* bar_;
};

// Solves `problem` with the linear solver already chosen in `solver_options`
// and the settings every stage's options struct shares (max_num_iterations,
// function/gradient/parameter_tolerance, num_threads, print_progress: Ceres'
// per-iteration log and full report; show_progress_bar: a progress bar named
// `label`).
template <typename StageOptions>
ceres::Solver::Summary SolveProblem(const std::string& label,
                                    const StageOptions& options,
                                    ceres::Solver::Options solver_options,
                                    ceres::Problem* problem) {
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.num_threads = ResolveNumThreads(options.num_threads);
  solver_options.minimizer_progress_to_stdout = options.print_progress;
  solver_options.logging_type =
      options.print_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  ProgressBar bar(label, options.max_num_iterations, options.show_progress_bar);
  CeresProgressCallback callback(&bar);
  if (options.show_progress_bar) solver_options.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem, &summary);
  bar.Finish();
  if (options.print_progress) LOG(INFO) << summary.FullReport();
  return summary;
}

}  // namespace colmap_irav4
