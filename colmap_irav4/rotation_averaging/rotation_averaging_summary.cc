#include "colmap_irav4/rotation_averaging/rotation_averaging_summary.h"

#include <iomanip>
#include <sstream>

#include "colmap_irav4/rotation_averaging/irav4.h"
#include "colmap_irav4/util/run_summary.h"

namespace colmap_irav4 {

RotationAveragingSummary SummarizeRotationAveraging(
    const std::string& method, const RotationGraph& graph,
    const RotationAveragingResult& result, double seconds,
    const RotationAverager& averager) {
  RotationAveragingSummary summary;
  summary.method = method;
  summary.num_cameras = graph.NumVertices();
  summary.num_edges = graph.NumEdges();
  summary.num_cameras_estimated = result.NumEstimated();
  for (const RelativeRotation& edge : graph.Edges()) {
    summary.num_edges_used +=
        result.estimated[edge.i] && result.estimated[edge.j];
  }
  summary.seconds = seconds;
  summary.stage_seconds = result.stage_seconds;
  if (const auto* irav4 = dynamic_cast<const Irav4*>(&averager)) {
    summary.reference_size = irav4->LastReport().n_ref;
    summary.cluster_sizes = irav4->LastReport().cluster_sizes;
  }
  return summary;
}

std::string RotationAveragingSummary::ToJson() const {
  std::ostringstream json;
  json << std::setprecision(6);
  json << "{\n  \"method\": " << JsonString(method)
       << ",\n  \"num_cameras\": " << num_cameras
       << ",\n  \"num_edges\": " << num_edges
       << ",\n  \"num_cameras_estimated\": " << num_cameras_estimated
       << ",\n  \"num_edges_used\": " << num_edges_used
       << ",\n  \"seconds\": " << seconds << ",\n  \"stage_seconds\": {";
  for (size_t k = 0; k < stage_seconds.size(); ++k) {
    json << (k ? ", " : "") << JsonString(stage_seconds[k].first) << ": "
         << stage_seconds[k].second;
  }
  json << "},\n  \"reference_size\": " << reference_size
       << ",\n  \"cluster_sizes\": [";
  for (size_t k = 0; k < cluster_sizes.size(); ++k) {
    json << (k ? ", " : "") << cluster_sizes[k];
  }
  json << "]\n}\n";
  return json.str();
}

}  // namespace colmap_irav4
