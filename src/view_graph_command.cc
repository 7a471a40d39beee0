// colmap_irav4 view_graph: reads a COLMAP database (read-only), builds the
// epipolar graph and writes one line per kept pair:
//   IMAGE_NAME1 IMAGE_NAME2 QW QX QY QZ TX TY TZ INLIERS
// with (q, t) = cam2_from_cam1 (the relative pose format GLOMAP's rotation
// averager reads, plus the inlier count). t is 0 0 0 for pure rotations.

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

void WriteRelativePoses(const ViewGraph& view_graph, const std::string& path) {
  // Written to a temporary name and renamed when complete, so that a reader
  // never sees a partial file.
  std::ostringstream file;
  file << std::setprecision(17);
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    const Eigen::Vector4d q = RotationToQuaternion(pair.R);
    file << view_graph.image_names.at(pair.image_id1) << " "
         << view_graph.image_names.at(pair.image_id2) << " " << q(0) << " "
         << q(1) << " " << q(2) << " " << q(3) << " " << pair.t(0) << " "
         << pair.t(1) << " " << pair.t(2) << " " << pair.num_inliers << "\n";
  }
  WriteFileAtomically(path, file.str());
}

int RunViewGraph(int argc, char** argv) {
  std::string database_path;
  std::string output_path;
  ViewGraphBuilderOptions options;
  OptionManager manager(
      "view_graph",
      "Builds the epipolar graph of a COLMAP database and writes the relative\n"
      "poses: IMAGE_NAME1 IMAGE_NAME2 QW QX QY QZ TX TY TZ INLIERS\n"
      "(cam2_from_cam1; t = 0 0 0 for pure rotations).");
  manager.AddRequired("database_path", &database_path,
                      "COLMAP database (opened read-only)");
  manager.AddRequired("output_path", &output_path, "relative poses file");
  AddViewGraphOptions(&manager, &options);
  if (!manager.Parse(argc, argv)) return 0;
  manager.Check([&] { options.Check(); });
  CheckFileWritable(output_path, {database_path});  // before any work

  Timer timer;
  const DatabaseContents database = ReadDatabase(database_path);
  std::cout << "Read " << database_path << " (" << database.schema.Description()
            << " schema) in " << std::fixed << std::setprecision(2)
            << timer.ElapsedSeconds() << " s" << std::endl;
  timer.Restart();
  ViewGraphSummary summary;
  const ViewGraph view_graph = BuildViewGraph(database, options, &summary);
  summary.Print(std::cout);
  std::cout << "Built in " << timer.ElapsedSeconds() << " s" << std::endl;
  if (view_graph.pairs.empty()) {
    std::cout << "WARNING: " << database_path
              << ": no verified image pair survives (no matches?); the "
                 "relative pose file is empty"
              << std::endl;
  }
  WriteRelativePoses(view_graph, output_path);
  std::cout << "Wrote " << view_graph.pairs.size() << " relative poses to "
            << output_path << std::endl;
  return 0;
}

static CommandRegistrar registrar(
    "view_graph",
    "Builds the epipolar graph of a database, writes the relative poses",
    RunViewGraph);

}  // namespace
}  // namespace colmap_irav4
