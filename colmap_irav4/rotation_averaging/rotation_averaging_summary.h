#pragma once

// The figures of one rotation averaging run: the rotation_averager command's
// --summary_path JSON and the Python module's summary dict.

#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

struct RotationAveragingSummary {
  std::string method;
  int num_cameras = 0;
  int num_edges = 0;
  int num_cameras_estimated = 0;
  int num_edges_used = 0;  // edges with both cameras estimated
  double seconds = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;
  // IRAv4's reference size and cluster sizes (0 and empty for the others).
  int reference_size = 0;
  std::vector<int> cluster_sizes;

  std::string ToJson() const;
};

RotationAveragingSummary SummarizeRotationAveraging(
    const std::string& method, const RotationGraph& graph,
    const RotationAveragingResult& result, double seconds,
    const RotationAverager& averager);

}  // namespace colmap_irav4
