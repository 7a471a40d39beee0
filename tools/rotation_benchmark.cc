// rotation_benchmark: the paper's synthetic protocol (section 5.2.1) for
// several rotation averaging methods side by side, on the same measurements.
//
//   rotation_benchmark --graph madrid --methods irav4,ira,l1_irls,spanning_tree
//   rotation_benchmark --graph madrid --methods irav4,irav4_paper,ira,l1_irls
//   rotation_benchmark --graph random --num_vertices 5000 --num_edges 700000
//                      --methods l1_irls --sigmas 5 --outlier_ratios 0
//
// One row per setting (graph, sigma, outlier percentage); per method the
// median and mean rotation error (deg, after the geodesic L1 alignment), the
// number of cameras off by more than 10 deg (the tail) and the run time in
// seconds. irav4_paper is IRAv4 without the final refinement (the paper). The process's peak memory is printed at the end.
// Methods come from the rotation averager factory, so a new method is
// available here as soon as it is registered there.

#include <sys/resource.h>

#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

std::vector<std::string> SplitList(const std::string& option,
                                   const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  if (items.empty()) throw InputError("--" + option, "empty list");
  return items;
}

std::vector<double> ParseNumberList(const std::string& option,
                                    const std::string& text) {
  std::vector<double> numbers;
  for (const std::string& item : SplitList(option, text)) {
    size_t end = 0;
    double value = 0.0;
    try {
      value = std::stod(item, &end);
    } catch (const std::exception&) {
      end = 0;
    }
    if (end != item.size()) {
      throw InputError("--" + option, "'" + item + "' is not a number");
    }
    numbers.push_back(value);
  }
  return numbers;
}

double PeakMemoryMb() {
  rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // Linux: kilobytes
}

// Resets the kernel's peak resident set size of this process to its current
// size (Linux >= 4.0), so that each method's own peak can be read after it.
bool ResetPeakMemory() {
  FILE* file = std::fopen("/proc/self/clear_refs", "w");
  if (file == nullptr) return false;
  const bool ok = std::fputs("5", file) >= 0;
  return std::fclose(file) == 0 && ok;
}

// VmHWM (peak resident set size since the last reset), MB; -1 if unknown.
double PeakResidentMb() {
  FILE* file = std::fopen("/proc/self/status", "r");
  if (file == nullptr) return -1.0;
  char line[256];
  double kb = -1.0;
  while (std::fgets(line, sizeof(line), file) != nullptr) {
    if (std::sscanf(line, "VmHWM: %lf kB", &kb) == 1) break;
  }
  std::fclose(file);
  return kb < 0 ? -1.0 : kb / 1024.0;
}

int Run(int argc, char** argv) {
  std::string graph_type = "madrid";
  std::string eg_path = "../shared/data/1dsfm/Madrid_Metropolis";
  int num_vertices = 1000;
  int num_edges = 20000;
  std::string methods_text = "irav4,ira,l1_irls";
  std::string sigmas_text = "5,10";
  std::string outliers_text = "0,10,20,30,40,50";
  int seed = 1;
  RotationAveragerOptions averager_options;
  OptionManager options(
      "rotation_benchmark",
      "The paper's synthetic rotation averaging protocol, methods side by "
      "side.");
  options.Add("graph", &graph_type,
              "madrid (the structure of --eg_path's EGs.txt) or random");
  options.Add("eg_path", &eg_path, "1DSfM scene directory for --graph madrid");
  options.Add("num_vertices", &num_vertices, "random graph: cameras");
  options.Add("num_edges", &num_edges, "random graph: edges");
  options.Add("methods", &methods_text,
              "comma-separated, from: " + RotationAveragerMethodList());
  options.Add("sigmas", &sigmas_text, "noise sigmas (deg), comma-separated");
  options.Add("outlier_ratios", &outliers_text,
              "outlier percentages, comma-separated");
  options.Add("seed", &seed, "seed of the measurements (and random graph)");
  options.Add("log_progress", &averager_options.log_progress,
              "progress lines from the methods");
  AddRotationAveragerOptions(&options, &averager_options);
  if (!options.Parse(argc, argv)) return 0;

  const std::vector<std::string> methods =
      SplitList("methods", methods_text);
  for (const std::string& method : methods) {
    CreateRotationAverager(method, averager_options);  // validates the name
  }
  const std::vector<double> sigmas = ParseNumberList("sigmas", sigmas_text);
  const std::vector<double> outlier_percentages =
      ParseNumberList("outlier_ratios", outliers_text);

  Timer total_timer;
  RotationGraph structure;
  std::string graph_label;
  if (graph_type == "madrid") {
    structure = ReadOneDsfmScene(eg_path).graph;
    graph_label = "madrid";
  } else if (graph_type == "random") {
    structure = RotationGraph(num_vertices);
    for (const auto& [i, j] :
         RandomConnectedGraph(num_vertices, num_edges, seed)) {
      structure.AddEdge(i, j, Eigen::Matrix3d::Identity());
    }
    graph_label = "random";
  } else {
    throw InputError("--graph", "expected madrid or random, got '" +
                                    graph_type + "'");
  }
  std::printf("# graph %s: %d cameras, %d edges; seed %d\n",
              graph_label.c_str(), structure.NumVertices(),
              structure.NumEdges(), seed);
  std::printf(
      "# per method: median / mean rotation error (deg), cameras off by more "
      "than 10 deg, seconds, peak resident memory during the method (MB, "
      "whole process)\n");
  std::printf("%-7s %5s %4s", "graph", "sigma", "p%");
  for (const std::string& method : methods) {
    std::printf(" | %-39s", method.c_str());
  }
  std::printf("\n");
  std::fflush(stdout);

  for (double sigma : sigmas) {
    for (double percentage : outlier_percentages) {
      SyntheticOptions synthetic;
      synthetic.noise_sigma_deg = sigma;
      synthetic.outlier_ratio = percentage / 100.0;
      synthetic.seed = seed;
      synthetic.Check();
      const SyntheticProblem problem =
          MakeSyntheticProblem(structure, synthetic);
      std::printf("%-7s %5g %4g", graph_label.c_str(), sigma, percentage);
      for (const std::string& method : methods) {
        std::unique_ptr<RotationAverager> averager =
            CreateRotationAverager(method, averager_options);
        const bool reset = ResetPeakMemory();
        Timer timer;
        const RotationAveragingResult result =
            averager->Estimate(problem.graph);
        const double seconds = timer.ElapsedSeconds();
        const RotationErrors errors =
            EvaluateRotations(result, problem.ground_truth);
        const double peak_mb = reset ? PeakResidentMb() : -1.0;
        int num_far = 0;
        for (double error : errors.errors_deg) num_far += error > 10.0;
        char cell[80];
        std::snprintf(cell, sizeof(cell), "%7.3f / %7.3f %4d %7.2fs %6.0fMB",
                      errors.median_deg, errors.mean_deg, num_far, seconds,
                      peak_mb);
        std::printf(" | %-39s", cell);
        std::fflush(stdout);
      }
      std::printf("\n");
    }
  }
  std::printf("# total %.1f s, peak memory (getrusage maxrss) %.1f MB\n",
              total_timer.ElapsedSeconds(), PeakMemoryMb());
  return 0;
}

}  // namespace
}  // namespace colmap_irav4

int main(int argc, char** argv) {
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
  try {
    return colmap_irav4::Run(argc, argv);
  } catch (const colmap_irav4::InputError& error) {
    std::cerr << "ERROR: " << error.what() << std::endl;
    return 1;
  }
}
