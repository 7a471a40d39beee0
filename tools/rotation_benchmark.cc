// rotation_benchmark: the paper's synthetic protocol (section 5.2.1) and the
// structured-outlier protocol (mirrored twins, rotation_averaging/synthetic)
// for several rotation averaging methods side by side, on the same
// measurements, over several seeds.
//
//   rotation_benchmark --graph madrid --methods irav4,irav4_paper,ira,l1_irls
//       --protocols paper,structured --sigmas 5 --outlier_ratios 30
//       --num_seeds 5
//   rotation_benchmark --graph random --num_vertices 1000,2500,5000
//       --edges_per_vertex 140 --methods irav4,l1_irls --sigmas 5
//       --outlier_ratios 30     (scaling: ratio and growth exponent)
//
//   rotation_benchmark --graph madrid --methods irav4,ira,l1_irls,spanning_tree
//   rotation_benchmark --graph madrid --methods irav4,irav4_paper,ira,l1_irls
//   rotation_benchmark --graph random --num_vertices 5000 --num_edges 700000
//                      --methods l1_irls --sigmas 5 --outlier_ratios 0
//
// One row per setting (protocol, sigma, outlier percentage); per method the
// mean over seeds of the median rotation error (deg, after the geodesic L1
// alignment), of the number of cameras off by more than 30 and 10 deg, and
// of the run time in seconds. irav4_paper is IRAv4 without the final refinement
// (the paper). The process's peak memory is printed at the end. Methods come
// from the rotation averager factory, so a new method is available here as soon
// as it is registered there.

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/statistics.h"
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

// CPU seconds (user + system) of this process so far: on a loaded machine
// the fair measure of single-threaded methods side by side.
double CpuSeconds() {
  rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 +
         usage.ru_stime.tv_sec + usage.ru_stime.tv_usec * 1e-6;
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

struct Cell {
  std::vector<double> medians, means, num_far30, num_far10, seconds,
      cpu_seconds, peak_mb;
};

int Run(int argc, char** argv) {
  std::string graph_type = "madrid";
  std::string eg_path = "../shared/data/1dsfm/Madrid_Metropolis";
  std::string num_vertices_text = "1000";
  int num_edges = 20000;
  int edges_per_vertex = 0;
  std::string methods_text = "irav4,ira,l1_irls";
  std::string protocols_text = "paper";
  std::string sigmas_text = "5,10";
  std::string outliers_text = "0,10,20,30,40,50";
  double structured_ratio = 0.25;
  double twin_overlap_deg = 60.0;
  int seed = 1;
  int num_seeds = 1;
  bool per_seed = false;
  RotationAveragerOptions averager_options;
  OptionManager options(
      "rotation_benchmark",
      "The paper's synthetic rotation averaging protocol and the "
      "structured-outlier protocol, methods side by side.");
  options.Add("graph", &graph_type,
              "madrid (the structure of --eg_path's EGs.txt) or random");
  options.Add("eg_path", &eg_path, "1DSfM scene directory for --graph madrid");
  options.Add("num_vertices", &num_vertices_text,
              "random graph: cameras (comma-separated for a scaling run)");
  options.Add("num_edges", &num_edges, "random graph: edges");
  options.Add("edges_per_vertex", &edges_per_vertex,
              "random graph: edges = this x cameras (overrides num_edges; "
              "140 = 5,000 cameras / 700,000 edges)");
  options.Add("methods", &methods_text,
              "comma-separated, from: " + RotationAveragerMethodList());
  options.Add("protocols", &protocols_text,
              "comma-separated: paper (random outliers) and/or structured "
              "(mirrored-twin outliers, on top of the random ones)");
  options.Add("sigmas", &sigmas_text, "noise sigmas (deg), comma-separated");
  options.Add("outlier_ratios", &outliers_text,
              "random outlier percentages, comma-separated");
  options.Add("structured_ratio", &structured_ratio,
              "structured protocol: fraction of the twin pairs that carry "
              "the mirrored twin's relative rotation");
  options.Add("twin_overlap_deg", &twin_overlap_deg,
              "structured protocol: twin pair when a camera's viewing "
              "direction is within this of the other's mirrored twin's");
  options.Add("seed", &seed, "first seed of the measurements (and graph)");
  options.Add("num_seeds", &num_seeds,
              "seeds seed, seed+1, ...: each setting averaged over them");
  options.Add("per_seed", &per_seed, "also print a row per seed");
  options.Add("log_progress", &averager_options.log_progress,
              "progress lines from the methods");
  AddRotationAveragerOptions(&options, &averager_options);
  if (!options.Parse(argc, argv)) return 0;

  const std::vector<std::string> methods = SplitList("methods", methods_text);
  for (const std::string& method : methods) {
    CreateRotationAverager(method, averager_options);  // validates the name
  }
  const std::vector<std::string> protocols =
      SplitList("protocols", protocols_text);
  for (const std::string& protocol : protocols) {
    if (protocol != "paper" && protocol != "structured") {
      throw InputError("--protocols",
                       "expected paper or structured, got '" + protocol + "'");
    }
  }
  if (num_seeds < 1) throw InputError("--num_seeds", "must be >= 1");
  const std::vector<double> sigmas = ParseNumberList("sigmas", sigmas_text);
  const std::vector<double> outlier_percentages =
      ParseNumberList("outlier_ratios", outliers_text);
  std::vector<int> sizes;
  for (double v : ParseNumberList("num_vertices", num_vertices_text)) {
    sizes.push_back(static_cast<int>(v));
  }
  if (graph_type == "madrid") sizes = {0};
  if (graph_type != "madrid" && graph_type != "random") {
    throw InputError("--graph",
                     "expected madrid or random, got '" + graph_type + "'");
  }

  Timer total_timer;
  std::printf(
      "# per method: mean over %d seed(s) of the median rotation error "
      "(deg, after the geodesic L1 alignment), mean number of cameras off "
      "by more than 30 deg (and 10 deg), mean wall and CPU seconds, max peak "
      "resident memory during the method (MB, whole process)\n",
      num_seeds);
  // Per method and size, mean seconds (the scaling summary).
  std::vector<std::vector<double>> size_seconds(
      methods.size(), std::vector<double>(sizes.size(), 0.0));
  std::vector<std::vector<double>> size_peak(
      methods.size(), std::vector<double>(sizes.size(), 0.0));
  std::vector<int> size_edges(sizes.size(), 0);
  for (size_t z = 0; z < sizes.size(); ++z) {
    RotationGraph structure;
    std::string graph_label;
    if (graph_type == "madrid") {
      structure = ReadOneDsfmScene(eg_path).graph;
      graph_label = "madrid";
    } else {
      const int n = sizes[z];
      const int64_t m = edges_per_vertex > 0
                            ? static_cast<int64_t>(edges_per_vertex) * n
                            : num_edges;
      structure = RotationGraph(n);
      for (const auto& [i, j] : RandomConnectedGraph(n, m, seed)) {
        structure.AddEdge(i, j, Eigen::Matrix3d::Identity());
      }
      graph_label = "random";
    }
    size_edges[z] = structure.NumEdges();
    std::printf("# graph %s: %d cameras, %d edges\n", graph_label.c_str(),
                structure.NumVertices(), structure.NumEdges());
    std::printf("%-10s %5s %4s", "protocol", "sigma", "p%");
    for (const std::string& method : methods) {
      std::printf(" | %-48s",
                  (method + ": median >30 >10 wall cpu MB").c_str());
    }
    std::printf("\n");
    std::fflush(stdout);
    for (const std::string& protocol : protocols) {
      for (double sigma : sigmas) {
        for (double percentage : outlier_percentages) {
          std::vector<Cell> cells(methods.size());
          int twin_pairs = 0, structured_edges = 0;
          for (int s = 0; s < num_seeds; ++s) {
            SyntheticOptions synthetic;
            synthetic.noise_sigma_deg = sigma;
            synthetic.outlier_ratio = percentage / 100.0;
            synthetic.seed = static_cast<uint64_t>(seed + s);
            if (protocol == "structured") {
              synthetic.structured_outlier_ratio = structured_ratio;
              synthetic.twin_overlap_deg = twin_overlap_deg;
            }
            synthetic.Check();
            const SyntheticProblem problem =
                MakeSyntheticProblem(structure, synthetic);
            twin_pairs += problem.num_twin_pairs;
            for (bool b : problem.edge_is_structured_outlier) {
              structured_edges += b;
            }
            if (per_seed) {
              std::printf("%-10s %5g %4g seed %d:", protocol.c_str(), sigma,
                          percentage, seed + s);
            }
            for (size_t k = 0; k < methods.size(); ++k) {
              std::unique_ptr<RotationAverager> averager =
                  CreateRotationAverager(methods[k], averager_options);
              const bool reset = ResetPeakMemory();
              Timer timer;
              const double cpu_start = CpuSeconds();
              const RotationAveragingResult result =
                  averager->Estimate(problem.graph);
              const double seconds = timer.ElapsedSeconds();
              const double cpu_seconds = CpuSeconds() - cpu_start;
              const RotationErrors errors =
                  EvaluateRotations(result, problem.ground_truth);
              const double peak_mb = reset ? PeakResidentMb() : -1.0;
              int far30 = 0, far10 = 0;
              for (double error : errors.errors_deg) {
                far30 += error > 30.0;
                far10 += error > 10.0;
              }
              // A camera not estimated counts as off.
              far30 += problem.graph.NumVertices() - errors.num_compared;
              far10 += problem.graph.NumVertices() - errors.num_compared;
              cells[k].medians.push_back(errors.median_deg);
              cells[k].means.push_back(errors.mean_deg);
              cells[k].num_far30.push_back(far30);
              cells[k].num_far10.push_back(far10);
              cells[k].seconds.push_back(seconds);
              cells[k].cpu_seconds.push_back(cpu_seconds);
              cells[k].peak_mb.push_back(peak_mb);
              if (per_seed) {
                std::printf(" %s %.3f %d %.2fs;", methods[k].c_str(),
                            errors.median_deg, far30, seconds);
                std::fflush(stdout);
              }
            }
            if (per_seed) std::printf("\n");
          }
          std::printf("%-10s %5g %4g", protocol.c_str(), sigma, percentage);
          for (size_t k = 0; k < methods.size(); ++k) {
            double peak = 0.0;
            for (double p : cells[k].peak_mb) peak = std::max(peak, p);
            char cell[96];
            std::snprintf(cell, sizeof(cell),
                          "%7.3f %6.1f %6.1f %7.2fs %7.2fs %6.0fMB",
                          Mean(cells[k].medians), Mean(cells[k].num_far30),
                          Mean(cells[k].num_far10), Mean(cells[k].seconds),
                          Mean(cells[k].cpu_seconds), peak);
            std::printf(" | %-48s", cell);
            size_seconds[k][z] += Mean(cells[k].cpu_seconds);
            size_peak[k][z] = std::max(size_peak[k][z], peak);
          }
          if (protocol == "structured") {
            std::printf("  (twin pairs %.0f, structured outliers %.0f)",
                        static_cast<double>(twin_pairs) / num_seeds,
                        static_cast<double>(structured_edges) / num_seeds);
          }
          std::printf("\n");
          std::fflush(stdout);
        }
      }
    }
  }
  if (sizes.size() > 1) {
    // Time per size summed over the settings; growth exponent = slope of
    // log(seconds) against log(cameras), least squares.
    std::printf("\n# scaling (CPU seconds summed over the settings above)\n");
    std::printf("%-8s %9s", "cameras", "edges");
    for (const std::string& method : methods) {
      std::printf(" | %-22s", (method + ": cpu s, MB").c_str());
    }
    if (methods.size() >= 2) {
      std::printf(" | %s/%s", methods[0].c_str(), methods[1].c_str());
    }
    std::printf("\n");
    for (size_t z = 0; z < sizes.size(); ++z) {
      std::printf("%-8d %9d", sizes[z], size_edges[z]);
      for (size_t k = 0; k < methods.size(); ++k) {
        char cell[64];
        std::snprintf(cell, sizeof(cell), "%8.2f %7.0f", size_seconds[k][z],
                      size_peak[k][z]);
        std::printf(" | %-22s", cell);
      }
      if (methods.size() >= 2 && size_seconds[1][z] > 0) {
        std::printf(" | %.2f", size_seconds[0][z] / size_seconds[1][z]);
      }
      std::printf("\n");
    }
    for (size_t k = 0; k < methods.size(); ++k) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      const double count = static_cast<double>(sizes.size());
      for (size_t z = 0; z < sizes.size(); ++z) {
        const double x = std::log(static_cast<double>(sizes[z]));
        const double y = std::log(std::max(size_seconds[k][z], 1e-9));
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
      }
      const double slope = (count * sxy - sx * sy) / (count * sxx - sx * sx);
      std::printf(
          "# %s: time grows as cameras^%.2f (least squares on "
          "log-log)\n",
          methods[k].c_str(), slope);
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
