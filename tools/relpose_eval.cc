// Relative pose accuracy of the epipolar graph against ground truth, per
// scene, with and without the refinement of the relative poses:
//   relpose_eval [--verbose] [--refine_max_num_matches N] [--num_threads N]
//                SCENE_DIR [SCENE_DIR ...]
// A scene directory holds database.db and either gt_cameras/ (the Strecha
// layout of ../shared/data/strecha/<scene>) or gt/, a COLMAP model of the
// ground truth (scene_generator's layout). Prints pairs, rotation error median
// / mean / max / count over 5 deg, and the same for the translation direction;
// --verbose lists the pairs with a rotation error over 1 deg.

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/eval/relative_pose_eval.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"

using namespace colmap_irav4;

namespace {

// Pairs whose rotation error exceeds 1 degree, with their configuration and
// the source of the chosen relative pose.
void PrintWorstPairs(const DatabaseContents& database,
                     const ViewGraph& view_graph,
                     const std::map<std::string, Rigid3d>& gt,
                     const ViewGraphBuilderOptions& options) {
  std::map<image_pair_t, const TwoViewGeometry*> geometries;
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    geometries[ImagePairToPairId(geometry.image_id1, geometry.image_id2)] =
        &geometry;
  }
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    ViewGraph single;
    single.image_names = view_graph.image_names;
    single.pairs = {pair};
    const RelativePoseErrors e = EvaluateRelativePoses(single, gt);
    if (e.rotation_errors_deg.empty() || e.rotation_errors_deg[0] <= 1) {
      continue;
    }
    const TwoViewGeometry& geometry =
        *geometries.at(ImagePairToPairId(pair.image_id1, pair.image_id2));
    const RelativePose pose = EstimateRelativePose(
        geometry,
        database.cameras.at(database.images.at(pair.image_id1).camera_id),
        database.cameras.at(database.images.at(pair.image_id2).camera_id),
        database.keypoints.at(pair.image_id1),
        database.keypoints.at(pair.image_id2), options.relative_pose);
    std::printf(
        "    %s %s: R error %.3f deg, t error %.3f deg, %s, %d inliers, "
        "%d supporting, pose from %s%s, median tri angle %.2f deg\n",
        view_graph.image_names.at(pair.image_id1).c_str(),
        view_graph.image_names.at(pair.image_id2).c_str(),
        e.rotation_errors_deg[0],
        e.translation_errors_deg.empty() ? -1.0 : e.translation_errors_deg[0],
        TwoViewConfigName(geometry.config).c_str(), pair.num_inliers,
        pose.num_supporting, RelativePoseSourceName(pose.source).c_str(),
        pose.refined ? " (refined)" : "", pose.median_tri_angle_deg);
  }
}

}  // namespace

int main(int argc, char** argv) {
  google::InitGoogleLogging(argv[0]);
  if (argc < 2) {
    std::cerr << "Usage: relpose_eval [--verbose] [--refine_max_num_matches N] "
                 "[--num_threads N] SCENE_DIR [SCENE_DIR ...]\n"
                 "  SCENE_DIR holds database.db and gt_cameras/ or gt/\n";
    return 1;
  }
  bool verbose = false;
  int refine_max_num_matches = RelativePoseOptions().refine_max_num_matches;
  int num_threads = 1;
  std::vector<std::string> scene_dirs;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--verbose") {
      verbose = true;
    } else if (std::string(argv[i]) == "--refine_max_num_matches" &&
               i + 1 < argc) {
      refine_max_num_matches = std::atoi(argv[++i]);
    } else if (std::string(argv[i]) == "--num_threads" && i + 1 < argc) {
      num_threads = std::atoi(argv[++i]);
    } else {
      scene_dirs.push_back(argv[i]);
    }
  }
  try {
    std::printf(
        "%-16s %-9s %5s %5s | %8s %8s %8s %5s | %8s %8s %8s %5s | %6s\n",
        "scene", "refine", "pairs", "no_t", "R_med", "R_mean", "R_max", ">5deg",
        "t_med", "t_mean", "t_max", ">5deg", "time_s");
    for (const std::string& scene_dir : scene_dirs) {
      std::string name = scene_dir;
      while (!name.empty() && name.back() == '/') name.pop_back();
      name = name.substr(name.find_last_of('/') + 1);
      const DatabaseContents database =
          ReadDatabase(scene_dir + "/database.db");
      std::map<std::string, Rigid3d> gt;
      if (std::filesystem::is_directory(scene_dir + "/gt_cameras")) {
        for (const auto& [image_name, camera] :
             ReadStrechaGroundTruth(scene_dir + "/gt_cameras")) {
          gt[image_name] = camera.cam_from_world;
        }
      } else {
        for (const auto& [image_id, image] :
             ReadReconstruction(scene_dir + "/gt").images) {
          gt[image.name] = image.cam_from_world;
        }
      }
      for (const bool refine : {false, true}) {
        ViewGraphBuilderOptions options;
        options.relative_pose.refine = refine;
        options.relative_pose.refine_max_num_matches = refine_max_num_matches;
        options.num_threads = num_threads;
        Timer timer;
        ViewGraphSummary summary;
        const ViewGraph view_graph =
            BuildViewGraph(database, options, &summary);
        const double seconds = timer.ElapsedSeconds();
        const RelativePoseErrors e = EvaluateRelativePoses(view_graph, gt);
        std::printf(
            "%-16s %-9s %5d %5d | %8.4f %8.4f %8.4f %5d | %8.4f %8.4f %8.4f "
            "%5d | %6.2f\n",
            name.c_str(), refine ? "on" : "off", e.num_pairs,
            e.num_pairs - static_cast<int>(e.translation_errors_deg.size()),
            e.rotation_median_deg, e.rotation_mean_deg, e.rotation_max_deg,
            e.num_rotation_over_5deg, e.translation_median_deg,
            e.translation_mean_deg, e.translation_max_deg,
            e.num_translation_over_5deg, seconds);
        if (verbose) PrintWorstPairs(database, view_graph, gt, options);
      }
    }
    std::printf(
        "(degrees; R: d(R_ij, R_j R_i^T); t: angle of unit t_ij to the "
        "ground-truth direction; no_t: pairs without translation)\n");
  } catch (const InputError& error) {
    std::cerr << "ERROR: " << error.what() << std::endl;
    return 1;
  }
  return 0;
}
