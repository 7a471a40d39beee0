#include "colmap_irav4/rotation_averaging/ira.h"

#include <glog/logging.h>

#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

Ira::Ira(IraOptions options) : options_(std::move(options)) {
  options_.Check();
}

RotationAveragingResult Ira::Estimate(const RotationGraph& graph) {
  const int n = graph.NumVertices();
  RotationAveragingResult result;
  result.rotations.assign(n, Eigen::Matrix3d::Identity());
  result.estimated.assign(n, false);
  stats_ = IncrementalStats();
  if (n == 0) {
    LOG(WARNING) << "IRA: empty graph, nothing to estimate";
    return result;
  }
  Timer timer;
  const std::vector<std::vector<int>> components = graph.ConnectedComponents();
  const std::vector<int>& largest = components.front();
  if (components.size() > 1) {
    LOG(WARNING) << "IRA: the graph has " << components.size()
                 << " connected components; estimating the largest ("
                 << largest.size() << " of " << n << " vertices)";
  }
  std::vector<bool> allowed(n, false);
  for (int v : largest) allowed[v] = true;

  IncrementalEngine engine(graph, options_.engine, allowed);
  if (!engine.InitializeFromBestTriplet()) {
    int start = largest.front();
    for (int v : largest) {
      if (engine.Adjacency(v).size() > engine.Adjacency(start).size())
        start = v;
    }
    LOG(WARNING) << "IRA: no triangle passes the chaining check; growing "
                    "from the vertex of largest degree ("
                 << start << ")";
    CHECK(engine.InitializeFromVertex(start));
  }
  result.stage_seconds.emplace_back("seed", timer.ElapsedSeconds());
  timer.Restart();

  const int total = static_cast<int>(largest.size());
  int next_report = total / 10;
  engine.Grow([&]() {
    if (options_.progress && engine.NumSelected() >= next_report) {
      LOG(INFO) << "IRA: " << engine.NumSelected() << " / " << total
                << " vertices estimated";
      next_report += std::max(1, total / 10);
    }
    return false;
  });
  result.stage_seconds.emplace_back("growth", timer.ElapsedSeconds());
  timer.Restart();
  engine.GlobalOptimize();
  result.stage_seconds.emplace_back("final_global_optimization",
                                    timer.ElapsedSeconds());

  for (int v : engine.Selected()) {
    result.rotations[v] = engine.Rotation(v);
    result.estimated[v] = true;
  }
  stats_ = engine.Stats();
  CHECK_EQ(engine.NumSelected(), total)
      << "growth stalled on a connected component";
  return result;
}

}  // namespace colmap_irav4
