// IRA on the paper's synthetic protocol: median / mean error and seconds per
// (sigma, outlier ratio), on the graph structure of a 1DSfM scene (its
// measurements are replaced by the protocol's) or on a connected random graph.
//   ira_bench --eg_path ../shared/data/1dsfm/Madrid_Metropolis
//   /usr/bin/time -v ira_bench --num_vertices 5000 --num_edges 700000
//       --sigmas 5 --outlier_ratios 0.3   (one command line)
// The side-by-side comparison with the baselines is tools/rotation_benchmark.

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/rotation_averaging/ira.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"

using namespace colmap_irav4;

namespace {

std::vector<double> ParseList(const std::string& option,
                              const std::string& text) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      values.push_back(std::stod(item));
    } catch (const std::exception&) {
      throw InputError(option, "not a number: '" + item + "'");
    }
  }
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
  std::string eg_path;
  int num_vertices = 5000;
  int num_edges = 700000;
  std::string sigmas = "5,10";
  std::string outlier_ratios = "0,0.1,0.2,0.3,0.4,0.5";
  int seed = 1;
  IraOptions ira_options;
  OptionManager options("ira_bench", "IRA on the paper's synthetic protocol");
  options.Add("eg_path", &eg_path,
              "1DSfM scene directory whose graph structure is used (else a "
              "random graph)");
  options.Add("num_vertices", &num_vertices, "random graph: vertices");
  options.Add("num_edges", &num_edges, "random graph: edges");
  options.Add("sigmas", &sigmas, "noise sigmas (deg), comma separated");
  options.Add("outlier_ratios", &outlier_ratios,
              "outlier fractions, comma separated");
  options.Add("seed", &seed, "random seed");
  options.Add("Ira.theta_deg", &ira_options.engine.theta_deg,
              "outlier threshold (deg)");
  options.Add("Ira.max_precomputations",
              &ira_options.engine.max_precomputations,
              "pre-computations evaluated per candidate on recomputation");
  options.Add("Ira.max_direct_solver_vertices",
              &ira_options.engine.max_direct_solver_vertices,
              "above: CGNR instead of sparse Cholesky");
  options.Add("Ira.progress", &ira_options.progress, "progress lines");
  try {
    if (!options.Parse(argc, argv)) return 0;
    RotationGraph structure;
    std::string graph_name;
    if (!eg_path.empty()) {
      structure = ReadOneDsfmScene(eg_path).graph;
      graph_name = eg_path;
    } else {
      const Timer timer;
      const auto edges = RandomConnectedGraph(num_vertices, num_edges,
                                              static_cast<uint64_t>(seed));
      structure = RotationGraph(num_vertices);
      for (const auto& [i, j] : edges) {
        structure.AddEdge(i, j, Eigen::Matrix3d::Identity());
      }
      graph_name = "random";
      std::printf("random graph generated in %.2f s\n", timer.ElapsedSeconds());
    }
    std::printf("graph %s: %d vertices, %d edges\n", graph_name.c_str(),
                structure.NumVertices(), structure.NumEdges());
    std::printf("%6s %5s %6s %10s %10s %10s %8s %8s %8s %8s\n", "sigma", "p",
                "n", "median", "mean", "max", "seconds", "seed_s", "growth_s",
                "final_s");
    for (double sigma : ParseList("--sigmas", sigmas)) {
      for (double p : ParseList("--outlier_ratios", outlier_ratios)) {
        SyntheticOptions synthetic;
        synthetic.noise_sigma_deg = sigma;
        synthetic.outlier_ratio = p;
        synthetic.seed = static_cast<uint64_t>(seed);
        const SyntheticProblem problem =
            MakeSyntheticProblem(structure, synthetic);
        Ira ira(ira_options);
        const Timer timer;
        const RotationAveragingResult result = ira.Estimate(problem.graph);
        const double seconds = timer.ElapsedSeconds();
        const RotationErrors errors =
            EvaluateRotations(result, problem.ground_truth);
        std::printf(
            "%6.1f %5.2f %6d %10.4f %10.4f %10.4f %8.2f %8.2f %8.2f %8.2f\n",
            sigma, p, errors.num_compared, errors.median_deg, errors.mean_deg,
            errors.max_deg, seconds, result.stage_seconds[0].second,
            result.stage_seconds[1].second, result.stage_seconds[2].second);
        const IncrementalStats& s = ira.LastStats();
        std::printf(
            "       triangles %lld passed %lld; global opts %d (%.2f s), "
            "local %.2f s, rewards %.2f s (full %lld, incr %lld); "
            "final inliers %d / %d\n",
            static_cast<long long>(s.num_triangles),
            static_cast<long long>(s.num_triangles_passed),
            s.num_global_optimizations, s.global_seconds, s.local_seconds,
            s.reward_seconds,
            static_cast<long long>(s.num_full_reward_computations),
            static_cast<long long>(s.num_incremental_reward_updates),
            s.last_global_num_inliers, s.last_global_num_edges);
        std::fflush(stdout);
      }
    }
  } catch (const InputError& error) {
    std::fprintf(stderr, "ERROR: %s\n", error.what());
    return 1;
  }
  return 0;
}
