// colmap_irav4 rotation_averager: absolute rotations from relative ones.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>

#include <glog/logging.h>

#include "colmap_irav4/eval/onedsfm.h"
#include "colmap_irav4/eval/relpose_io.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/rotation_averaging/rotation_averaging_summary.h"
#include "colmap_irav4/rotation_averaging/view_graph_rotations.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/threading.h"
#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

void PrintErrors(const std::string& label, const RotationErrors& errors) {
  int num_far = 0;
  for (double error : errors.errors_deg) num_far += error > 30.0;
  std::cout << std::fixed << std::setprecision(3) << "Rotation errors vs "
            << label << ": " << errors.num_compared << " cameras, median "
            << errors.median_deg << " deg, mean " << errors.mean_deg
            << " deg, max " << errors.max_deg << " deg, " << num_far
            << " cameras > 30 deg off" << std::endl;
}

// The epipolar graph of a COLMAP database as a rotation graph: vertices are
// the images in image id order, edge weights the inlier counts.
RotationGraph RotationGraphFromDatabase(
    const std::string& database_path,
    const ViewGraphBuilderOptions& builder_options) {
  const DatabaseContents database = ReadDatabase(database_path);
  ViewGraphSummary summary;
  const ViewGraph view_graph =
      BuildViewGraph(database, builder_options, &summary);
  summary.Print(std::cout);
  RotationGraph graph = RotationGraphFromViewGraph(view_graph);
  return graph;
}

// Ground-truth rotations by image name: a file of 'IMAGE_NAME QW QX QY QZ'
// lines, or a Strecha gt_cameras directory of <image>.camera files.
std::map<std::string, Eigen::Matrix3d> ReadGroundTruth(
    const std::string& gt_path) {
  std::map<std::string, Eigen::Matrix3d> truth;
  if (std::filesystem::is_directory(gt_path)) {
    for (const auto& [name, camera] : ReadStrechaGroundTruth(gt_path)) {
      truth[name] = camera.cam_from_world.rotation.toRotationMatrix();
    }
    if (truth.empty()) throw InputError(gt_path, "no .camera files");
  } else {
    for (auto& [name, R] : ReadAbsoluteRotations(gt_path)) truth[name] = R;
  }
  return truth;
}

// The command's own arguments: its files and the method.
struct CommandArguments {
  std::string relpose_path;
  std::string database_path;
  std::string eg_path;
  std::string method = "irav4";
  std::string output_path;
  std::string gt_path;
  std::string summary_path;
};

// Registers the arguments (in the order --help lists them).
void AddArguments(OptionManager* options, CommandArguments* arguments) {
  options->Add("relpose_path", &arguments->relpose_path, "relative poses file");
  options->Add("database_path", &arguments->database_path,
               "COLMAP database (opened read-only)");
  options->Add("eg_path", &arguments->eg_path, "1DSfM scene directory");
  options->Add("method", &arguments->method,
               "rotation averaging method: " + RotationAveragerMethodList());
  options->Add("output_path", &arguments->output_path,
               "absolute rotations file to write");
  options->Add("gt_path", &arguments->gt_path,
               "ground-truth rotations to evaluate against: a file of "
               "'IMAGE_NAME QW QX QY QZ' lines or a Strecha gt_cameras "
               "directory");
  options->Add("summary_path", &arguments->summary_path,
               "JSON run summary to write: method, cameras and edges used, "
               "seconds per stage, reference_size, cluster_sizes");
}

// Exactly one input.
void CheckOneInput(const CommandArguments& arguments) {
  const int num_inputs = !arguments.relpose_path.empty() +
                         !arguments.database_path.empty() +
                         !arguments.eg_path.empty();
  if (num_inputs != 1) {
    throw InputError("rotation_averager",
                     "give exactly one of --relpose_path, --database_path "
                     "and --eg_path");
  }
}

// Before any work: never an output over an input, nor both outputs in one
// file.
void CheckOutputs(const CommandArguments& arguments) {
  std::vector<std::string> inputs = {
      arguments.relpose_path, arguments.database_path, arguments.gt_path};
  if (!arguments.eg_path.empty()) {
    for (const char* name :
         {"EGs.txt", "list.txt", "cc.txt", "gt_bundle.out"}) {
      inputs.push_back(arguments.eg_path + "/" + name);
    }
  }
  if (!arguments.output_path.empty()) {
    CheckFileWritable(arguments.output_path, inputs);
  }
  if (!arguments.summary_path.empty()) {
    inputs.push_back(arguments.output_path);
    CheckFileWritable(arguments.summary_path, inputs);
  }
  if (arguments.output_path.empty() && arguments.gt_path.empty()) {
    LOG(WARNING) << "neither --output_path nor --gt_path given: the result is "
                    "neither written nor evaluated";
  }
}

// The graph to average, and for a 1DSfM scene the Bundler ground truth of
// its vertices.
struct InputGraph {
  RotationGraph graph;
  std::vector<Eigen::Matrix3d> bundler_truth;
  std::vector<bool> has_bundler_truth;
};

// Reads the one input given, reduced to its largest connected component.
InputGraph ReadInputGraph(const CommandArguments& arguments,
                          const ViewGraphBuilderOptions& builder_options) {
  InputGraph input;
  RotationGraph& graph = input.graph;
  std::vector<Eigen::Matrix3d>& bundler_truth = input.bundler_truth;
  std::vector<bool>& has_bundler_truth = input.has_bundler_truth;
  const std::string input_path =
      !arguments.relpose_path.empty()
          ? arguments.relpose_path
          : (!arguments.database_path.empty() ? arguments.database_path
                                              : arguments.eg_path);
  if (!arguments.relpose_path.empty()) {
    graph = ReadRelativePoses(arguments.relpose_path);
  } else if (!arguments.database_path.empty()) {
    graph = RotationGraphFromDatabase(arguments.database_path, builder_options);
  } else {
    OneDsfmScene scene = ReadOneDsfmScene(arguments.eg_path);
    graph = std::move(scene.graph);
    bundler_truth = std::move(scene.ground_truth);
    has_bundler_truth = std::move(scene.has_ground_truth);
  }
  if (graph.NumEdges() == 0) {
    throw InputError(input_path, "the graph has no edges");
  }
  const std::vector<std::vector<int>> components = graph.ConnectedComponents();
  if (components.size() > 1) {
    LOG(WARNING) << "the graph has " << components.size()
                 << " connected components; estimating the largest ("
                 << components[0].size() << " of " << graph.NumVertices()
                 << " images)";
    graph = graph.InducedSubgraph(components[0]);
    if (!bundler_truth.empty()) {
      std::vector<Eigen::Matrix3d> truth;
      std::vector<bool> has_truth;
      for (int v : components[0]) {
        truth.push_back(bundler_truth[v]);
        has_truth.push_back(has_bundler_truth[v]);
      }
      bundler_truth = std::move(truth);
      has_bundler_truth = std::move(has_truth);
    }
  }
  return input;
}

// Prints the estimate's errors against the ground truth of gt_path,
// matched by image name.
void EvaluateAgainstGroundTruth(const std::string& gt_path,
                                const RotationGraph& graph,
                                const RotationAveragingResult& result) {
  const std::map<std::string, Eigen::Matrix3d> truth = ReadGroundTruth(gt_path);
  std::map<std::string, Eigen::Matrix3d> estimate;
  for (int v = 0; v < graph.NumVertices(); ++v) {
    if (result.estimated[v]) estimate[graph.Name(v)] = result.rotations[v];
  }
  int num_unknown = 0;
  std::string first_unknown;
  for (const auto& [name, R] : truth) {
    if (estimate.count(name) == 0) {
      if (num_unknown++ == 0) first_unknown = name;
    }
  }
  LOG_IF(WARNING, num_unknown > 0)
      << gt_path << ": " << num_unknown
      << " images not estimated or not in the graph (e.g. '" << first_unknown
      << "'), not evaluated";
  const RotationErrors errors = EvaluateRotations(estimate, truth);
  if (errors.num_compared == 0) {
    throw InputError(gt_path, "no image in common with the estimate");
  }
  PrintErrors(gt_path, errors);
}

int RunRotationAverager(int argc, char** argv) {
  CommandArguments arguments;
  RotationAveragerOptions averager_options;
  averager_options.log_progress = true;
  ViewGraphBuilderOptions builder_options;
  OptionManager options(
      "rotation_averager",
      "Estimates absolute rotations (cam_from_world) from relative ones.\n"
      "Input: --relpose_path (lines 'IMG1 IMG2 QW QX QY QZ TX TY TZ "
      "[INLIERS]',\nq = cam2_from_cam1, as written by view_graph) or "
      "--eg_path (a 1DSfM scene\ndirectory: EGs.txt, list.txt, cc.txt, "
      "gt_bundle.out if present).\nOutput: 'IMAGE_NAME QW QX QY QZ' per "
      "line.");
  AddArguments(&options, &arguments);
  options.Add("log_progress", &averager_options.log_progress,
              "progress lines during long runs");
  // --database_path: the view graph's options (its threads are
  // --RotationAveraging.num_threads).
  AddViewGraphOptions(&options, &builder_options, "ViewGraph.min_num_inliers",
                      /*with_threads_and_components=*/false);
  AddRotationAveragerOptions(&options, &averager_options);
  if (!options.Parse(argc, argv)) return 0;
  // The user's thread count bounds every stage: the view graph's workers, the
  // Ceres solves and any BLAS / OpenMP runtime loaded with them.
  builder_options.num_threads = averager_options.irav4.engine.num_threads;
  LimitBlasThreads(averager_options.irav4.engine.num_threads);
  CheckOneInput(arguments);
  options.Check([&] {
    builder_options.Check();
    averager_options.Check();
  });
  CheckOutputs(arguments);
  // Validates the method and its options before any long reading.
  std::unique_ptr<RotationAverager> averager =
      CreateRotationAverager(arguments.method, averager_options);

  const InputGraph input = ReadInputGraph(arguments, builder_options);
  const RotationGraph& graph = input.graph;
  LOG(INFO) << "Rotation averaging (" << averager->Name()
            << "): " << graph.NumVertices() << " images, " << graph.NumEdges()
            << " pairs";
  Timer timer;
  const RotationAveragingResult result = averager->Estimate(graph);
  const double seconds = timer.ElapsedSeconds();
  std::cout << "Estimated " << result.NumEstimated() << " of "
            << graph.NumVertices() << " rotations with " << averager->Name()
            << " in " << std::fixed << std::setprecision(3) << seconds << " s"
            << std::endl;
  if (!result.stage_seconds.empty()) {
    std::cout << "Stages:";
    for (const auto& [stage, seconds] : result.stage_seconds) {
      std::cout << " " << stage << " " << seconds << " s;";
    }
    std::cout << std::endl;
  }
  if (!arguments.summary_path.empty()) {
    // Complete or absent (rotation_averaging_summary.h).
    WriteFileAtomically(arguments.summary_path,
                        SummarizeRotationAveraging(arguments.method, graph,
                                                   result, seconds, *averager)
                            .ToJson());
    LOG(INFO) << "Wrote " << arguments.summary_path;
  }
  if (!arguments.output_path.empty()) {
    WriteAbsoluteRotations(arguments.output_path, graph.Names(),
                           result.rotations, result.estimated);
    LOG(INFO) << "Wrote " << arguments.output_path;
  }

  if (!input.bundler_truth.empty()) {
    PrintErrors(arguments.eg_path + "/gt_bundle.out",
                EvaluateRotations(result, input.bundler_truth,
                                  input.has_bundler_truth));
  }
  if (!arguments.gt_path.empty()) {
    EvaluateAgainstGroundTruth(arguments.gt_path, graph, result);
  }
  return 0;
}

CommandRegistrar registrar("rotation_averager",
                           "Absolute rotations from relative poses "
                           "(IRA, L1-IRLS, spanning tree, ...)",
                           RunRotationAverager);

}  // namespace
}  // namespace colmap_irav4
