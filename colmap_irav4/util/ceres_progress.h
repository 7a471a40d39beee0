#pragma once

#include <ceres/iteration_callback.h>

#include "colmap_irav4/util/progress_bar.h"

namespace colmap_irav4 {

// Advances a ProgressBar by the iterations of a Ceres solve (out of its
// max_num_iterations; the bar is finished when the solver stops early).
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

}  // namespace colmap_irav4
