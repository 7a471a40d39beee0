// Times the stages after rotation averaging (tracks, global positioning,
// bundle adjustment, retriangulation, filtering) and prints their accuracy.
//   refinement_benchmark strecha DATA_DIR/strecha/fountain-P11
//       COLMAP 3.8 database + ground-truth rotations (perturbed by 0.05 deg);
//       COLMAP's incremental model is measured the same way beside ours.
//   refinement_benchmark synthetic NUM_IMAGES NUM_POINTS
//       synthetic 180 deg arc, 1 px noise, 0.1% wrong matches, rotations
//       perturbed by 0.1 deg.

#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <random>
#include <string>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

using namespace colmap_irav4;

namespace {

void PrintComparison(const std::string& label, const Reconstruction& model,
                     const std::map<std::string, Rigid3d>& reference,
                     double unit_scale, const std::string& unit) {
  PoseComparison comparison;
  if (!ComparePoses(PosesByName(model), reference, SimilarityRansacOptions(),
                    &comparison)) {
    std::cout << label << ": alignment failed\n";
    return;
  }
  std::cout << std::left << std::setw(28) << label << " images "
            << model.images.size() << "  rotation err median/max "
            << comparison.rotation_error_median_deg << " / "
            << comparison.rotation_error_max_deg
            << " deg  centre err median/max "
            << unit_scale * comparison.center_error_median << " / "
            << unit_scale * comparison.center_error_max << " " << unit << "\n";
}

// Runs the stages on `reconstruction` (cameras, images with rotations and
// keypoints) and prints one line per stage.
void RunStages(const std::vector<ImagePairMatches>& pairs,
               Reconstruction* reconstruction) {
  Timer total;
  Timer timer;
  TrackBuilderStats track_stats;
  const std::vector<Track> tracks = BuildTracks(
      TrackBuilderOptions(), pairs, reconstruction->images, &track_stats);
  AddTracksToReconstruction(tracks, reconstruction);
  std::cout << "tracks            " << std::setw(8) << timer.ElapsedSeconds()
            << " s  " << tracks.size() << " tracks, "
            << track_stats.num_inconsistent << " inconsistent\n";
  GlobalPositionerSummary positioning;
  if (!RunGlobalPositioning(GlobalPositionerOptions(), reconstruction,
                            &positioning)) {
    std::cout << "positioning failed\n";
    return;
  }
  std::cout << "positioning       " << std::setw(8) << positioning.seconds
            << " s  " << positioning.num_images << " images, "
            << positioning.num_points << " points, "
            << positioning.num_observations << " observations, "
            << positioning.num_iterations << " iterations\n";
  BundleAdjustmentSummary ba;
  RunBundleAdjustment(BundleAdjustmentOptions(), reconstruction, &ba);
  std::cout << "bundle adjustment " << std::setw(8) << ba.seconds << " s  "
            << ba.initial_mean_reproj_error << " -> "
            << ba.final_mean_reproj_error << " px, " << ba.num_rounds
            << " rounds, " << ba.num_iterations << " iterations, "
            << ba.num_observations_filtered << " observations filtered\n";
  timer.Restart();
  const TriangulationSummary triangulation =
      TriangulateTracks(TriangulationOptions(), tracks, reconstruction);
  std::cout << "retriangulation   " << std::setw(8) << timer.ElapsedSeconds()
            << " s  " << triangulation.num_points_added << " points\n";
  RunBundleAdjustment(BundleAdjustmentOptions(), reconstruction, &ba);
  std::cout << "bundle adjustment " << std::setw(8) << ba.seconds << " s  "
            << ba.final_mean_reproj_error << " px, " << ba.num_iterations
            << " iterations\n";
  timer.Restart();
  const FilterSummary filtering = RunFiltering(FilterOptions(), reconstruction);
  std::cout << "filtering         " << std::setw(8) << timer.ElapsedSeconds()
            << " s  " << filtering.num_observations_filtered
            << " observations, " << filtering.num_points_filtered
            << " points\n";
  std::cout << "total             " << std::setw(8) << total.ElapsedSeconds()
            << " s  " << reconstruction->images.size() << " images, "
            << reconstruction->points3D.size() << " points, mean track "
            << MeanTrackLength(*reconstruction) << ", reprojection "
            << UpdateReprojectionErrors(reconstruction) << " px\n";
}

int RunStrecha(const std::string& dir) {
  const DatabaseContents database = ReadDatabase(dir + "/database.db");
  const auto gt = ReadStrechaGroundTruth(dir + "/gt_cameras");
  Reconstruction reconstruction;
  reconstruction.cameras = database.cameras;
  std::mt19937_64 rng(1);
  for (const auto& [image_id, db_image] : database.images) {
    Image image;
    image.image_id = image_id;
    image.name = db_image.name;
    image.camera_id = db_image.camera_id;
    auto it = gt.find(db_image.name);
    if (it == gt.end())
      throw InputError(dir + "/gt_cameras", "no camera for " + db_image.name);
    image.cam_from_world.rotation =
        Eigen::Quaterniond(RandomRotationWithAngle(DegToRad(0.05), &rng)) *
        it->second.cam_from_world.rotation;
    for (const Eigen::Vector2f& xy : database.keypoints.at(image_id)) {
      Point2D point2D;
      point2D.xy = xy.cast<double>();
      image.points2D.push_back(point2D);
    }
    reconstruction.images[image_id] = image;
  }
  std::vector<ImagePairMatches> pairs;
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    ImagePairMatches pair{geometry.image_id1, geometry.image_id2, {}};
    for (const FeatureMatch& match : geometry.inlier_matches) {
      pair.matches.emplace_back(match.point2D_idx1, match.point2D_idx2);
    }
    pairs.push_back(std::move(pair));
  }
  std::cout << dir << ": " << database.images.size() << " images, "
            << pairs.size() << " verified pairs\n";
  RunStages(pairs, &reconstruction);
  std::map<std::string, Rigid3d> reference;
  for (const auto& [name, camera] : gt) reference[name] = camera.cam_from_world;
  PrintComparison("ours vs ground truth", reconstruction, reference, 1000,
                  "mm");
  PrintComparison("COLMAP 3.8 vs ground truth",
                  ReadReconstruction(dir + "/colmap38_incremental"), reference,
                  1000, "mm");
  return 0;
}

int RunSynthetic(int num_images, int num_points) {
  SyntheticSceneOptions options;
  options.num_images = num_images;
  options.num_points = num_points;
  options.arc_angle_deg = 180;
  options.visibility = 0.1;  // tracks of ~10 images: merged ones rarely survive
  options.noise_px = 1.0;
  options.outlier_match_ratio = 0.001;
  Timer timer;
  const SyntheticScene scene = GenerateSyntheticScene(options);
  std::cout << "synthetic: " << num_images << " images, "
            << scene.truth.points3D.size() << " points, "
            << NumObservations(scene.truth) << " observations, "
            << scene.matches.size() << " pairs (generated in "
            << timer.ElapsedSeconds() << " s)\n";
  Reconstruction reconstruction = StripPoints(scene.truth);
  std::mt19937_64 rng(2);
  for (auto& [image_id, image] : reconstruction.images) {
    image.cam_from_world.rotation =
        Eigen::Quaterniond(RandomRotationWithAngle(DegToRad(0.1), &rng)) *
        image.cam_from_world.rotation;
    image.cam_from_world.translation.setZero();
  }
  RunStages(scene.matches, &reconstruction);
  PrintComparison("ours vs truth", reconstruction, PosesByName(scene.truth), 1,
                  "(radius 10)");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::string(argv[1]) == "strecha")
      return RunStrecha(argv[2]);
    if (argc == 4 && std::string(argv[1]) == "synthetic") {
      return RunSynthetic(std::atoi(argv[2]), std::atoi(argv[3]));
    }
  } catch (const InputError& error) {
    std::cerr << error.what() << "\n";
    return 1;
  }
  std::cerr << "usage: refinement_benchmark strecha SCENE_DIR\n"
               "       refinement_benchmark synthetic NUM_IMAGES NUM_POINTS\n";
  return 2;
}
