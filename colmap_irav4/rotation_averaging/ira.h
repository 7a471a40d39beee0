#pragma once

#include <string>

#include "colmap_irav4/rotation_averaging/incremental_engine.h"
#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

struct IraOptions {
  IncrementalOptions engine;
  // Log a progress line every 10% of the vertices (long runs).
  bool progress = false;
  void Check() const { engine.Check(); }
};

// IRA (Gao et al., IJCV 2021; the paper's section 3): the incremental engine
// on the largest connected component from the best triplet until every vertex
// is estimated, then a final global optimisation (Eq. 11-12). Vertices outside
// the largest component are not estimated. If no triangle passes the chaining
// check (e.g. a tree), the growth starts from the vertex of largest degree.
class Ira : public RotationAverager {
 public:
  explicit Ira(IraOptions options = {});
  std::string Name() const override { return "ira"; }
  RotationAveragingResult Estimate(const RotationGraph& graph) override;
  // Statistics of the last Estimate's engine.
  const IncrementalStats& LastStats() const { return stats_; }

 private:
  IraOptions options_;
  IncrementalStats stats_;
};

}  // namespace colmap_irav4
