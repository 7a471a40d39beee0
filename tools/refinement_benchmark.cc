// Times the stages after rotation averaging (tracks, global positioning,
// bundle adjustment, retriangulation, filtering) and prints their accuracy.
//   refinement_benchmark strecha DATA_DIR/strecha/fountain-P11
//       COLMAP 3.8 database + ground-truth rotations (perturbed by 0.05 deg);
//       COLMAP's incremental model is measured the same way beside ours.
//   refinement_benchmark synthetic NUM_IMAGES NUM_POINTS
//       synthetic 180 deg arc, 1 px noise, 0.1% wrong matches, rotations
//       perturbed by 0.1 deg.
//   refinement_benchmark implicit_product NUM_IMAGES NUM_POINTS TRACK WIDTH
//       The implicit Schur product (implicit_product.h) on random records
//       in single precision (TRACK observations a point of distinct
//       images, each a pose with its own camera of WIDTH reduced columns),
//       the portable code and the AVX2 kernel in turn, five rounds: CPU ms
//       a product each and their ratio, measured side by side.
//   refinement_benchmark final_ba --model MODEL --gt GT [--poses MODEL2]
//       [--intrinsics_from_poses 0|1] [--num_rounds N] [--tight 0|1]
//       [--per_image CSV] [--truth MODEL] [--min_track_length N]
//       [--restrict_to MODEL] [--half_samples N] [--half_sample_seed S]
//       [--half_pairs 0|1] [--database_path DB] [--retriangulate 0|1]
//       [--BundleAdjustment.* as the mapper's]
//       The "swap" experiment: the mapper's last bundle adjustment and final
//       filtering (GlobalMapperOptions' defaults, one round) on MODEL's
//       observation set (points, tracks, intrinsics), started from MODEL's
//       poses or from MODEL2's (similarity-aligned by camera centres), e.g.
//       our final bundle adjustment on COLMAP's model (--retriangulate 1:
//       MODEL's points placed again from MODEL2's poses). GT: a model
//       directory or a Strecha gt_cameras directory (errors in mm, both
//       metric). Prints the observation statistics and the errors before
//       and after; --per_image writes each image's centre error; --truth
//       (a synthetic scene's exact model) counts the wrong observations;
//       --min_track_length deletes shorter tracks and --restrict_to the
//       observations (image name, keypoint) another model does not use,
//       before the adjustment. --half_samples N repeats the adjustment on N
//       random halves of the points (--half_sample_seed S): the spread of
//       the errors over the halves shows how much the figure depends on
//       which observations a model keeps (about 1.4x the spread of
//       resampling the whole set, for errors that average over points).
//       --half_pairs 1 also adjusts each half's complement and prints how
//       far the two halves' cameras are apart (after a similarity): the
//       adjustment's own spread, which the ground truth's errors do not
//       blur. --database_path reads the keypoint scales of MODEL's images (by
//       name) from DB, for --BundleAdjustment.weight_by_keypoint_scale.

#include <algorithm>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/refinement/implicit_product.h"
#include "colmap_irav4/refinement/model_statistics.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/statistics.h"
#include "colmap_irav4/util/timer.h"

using namespace colmap_irav4;

namespace {

// Every point of `model` placed again from its observations and the model's
// poses (multi-view midpoint, then RefinePointPosition), its track kept: the
// points of MODEL follow the poses --poses transferred, which a similarity
// alone cannot do when the two models differ by more than one (a bend).
// Points whose rays are parallel keep their place. Returns those placed.
size_t RetriangulatePoints(Reconstruction* model) {
  size_t num_placed = 0;
  for (auto& [point_id, point] : model->points3D) {
    std::vector<Eigen::Vector3d> centers;
    std::vector<Eigen::Vector3d> directions;
    std::vector<NormalizedObservation> observations;
    for (const TrackElement& element : point.track) {
      const Image& image = model->images.at(element.image_id);
      const Camera& camera = model->cameras.at(image.camera_id);
      Eigen::Vector2d normalized;
      Eigen::Vector3d direction;
      if (!ObservationRay(camera, image,
                          image.points2D.at(element.point2D_idx).xy,
                          &normalized, &direction)) {
        continue;
      }
      centers.push_back(image.ProjectionCenter());
      directions.push_back(direction);
      observations.push_back({image.cam_from_world.rotation.toRotationMatrix(),
                              image.cam_from_world.translation, normalized,
                              CameraMeanFocalLength(camera)});
    }
    Eigen::Vector3d xyz;
    if (centers.size() < 2 || !TriangulateMidpoint(centers, directions, &xyz)) {
      continue;
    }
    RefinePointPosition(observations, &xyz);
    point.xyz = xyz;
    ++num_placed;
  }
  return num_placed;
}

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
  StrechaStart start = MakeStrechaStart(database, gt, dir + "/gt_cameras",
                                        /*rotation_noise_deg=*/0.05,
                                        /*seed=*/1);
  Reconstruction& reconstruction = start.reconstruction;
  const std::vector<ImagePairMatches>& pairs = start.pairs;
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

void PrintStatistics(const std::string& label, const Reconstruction& model) {
  const ObservationStatistics stats = ComputeObservationStatistics(model);
  std::cout << label << ": " << stats.num_images << " images, "
            << stats.num_points << " points, " << stats.num_observations
            << " observations, track " << stats.mean_track_length
            << ", two-view points " << stats.two_view_point_fraction
            << ", observations per image median "
            << stats.median_observations_per_image << " min "
            << stats.min_observations_per_image << ", reprojection "
            << stats.mean_reproj_error << " px, triangulation angle median "
            << stats.median_tri_angle_deg << " deg, 4x4 grid coverage "
            << stats.mean_grid_coverage << "\n";
  for (const auto& [camera_id, camera] : model.cameras) {
    std::cout << "  camera " << camera_id << " params";
    for (const double p : camera.params) std::cout << " " << p;
    std::cout << "\n";
  }
}

// Errors of `model` against `reference`; fills `per_image` (name -> centre
// error in mm) when given.
void PrintErrors(const std::string& label, const Reconstruction& model,
                 const std::map<std::string, Rigid3d>& reference,
                 std::map<std::string, double>* per_image) {
  PoseComparison comparison;
  if (!ComparePoses(PosesByName(model), reference, SimilarityRansacOptions(),
                    &comparison)) {
    std::cout << label << ": alignment failed\n";
    return;
  }
  double mean = 0;
  for (const double e : comparison.center_errors) mean += e;
  mean /= std::max<size_t>(1, comparison.center_errors.size());
  std::cout << std::left << std::setw(34) << label << " rotation median "
            << comparison.rotation_error_median_deg << " deg, centre median "
            << 1000 * comparison.center_error_median << " mm (mean "
            << 1000 * mean << ", max " << 1000 * comparison.center_error_max
            << ")\n";
  if (per_image != nullptr) {
    for (size_t k = 0; k < comparison.names.size(); ++k) {
      (*per_image)[comparison.names[k]] = 1000 * comparison.center_errors[k];
    }
  }
}

std::map<std::string, Rigid3d> ReadGroundTruth(const std::string& path) {
  if (ExistsBinaryModel(path) || ExistsTextModel(path)) {
    return PosesByName(ReadReconstruction(path));
  }
  std::map<std::string, Rigid3d> reference;
  for (const auto& [name, camera] : ReadStrechaGroundTruth(path)) {
    reference[name] = camera.cam_from_world;
  }
  return reference;
}

int RunFinalBundleAdjustment(int argc, char** argv) {
  std::map<std::string, std::string> args;
  // --BundleAdjustment.* flags, under the mapper's names (parsed below).
  std::vector<char*> ba_argv = {argv[1]};
  for (int k = 2; k + 1 < argc; k += 2) {
    const std::string key = argv[k];
    if (key.rfind("--", 0) != 0) throw InputError(key, "expected --option");
    if (key.rfind("--BundleAdjustment.", 0) == 0) {
      ba_argv.push_back(argv[k]);
      ba_argv.push_back(argv[k + 1]);
      continue;
    }
    args[key.substr(2)] = argv[k + 1];
  }
  for (const auto& [key, value] : args) {
    if (key != "model" && key != "gt" && key != "poses" &&
        key != "intrinsics_from_poses" && key != "num_rounds" &&
        key != "tight" && key != "per_image" && key != "truth" &&
        key != "min_track_length" && key != "restrict_to" &&
        key != "half_samples" && key != "half_sample_seed" &&
        key != "database_path" && key != "half_pairs" &&
        key != "retriangulate") {
      throw InputError("--" + key, "unknown option");
    }
  }
  if (!args.count("model") || !args.count("gt")) {
    throw InputError("final_ba", "--model and --gt are required");
  }
  // The mapper's last bundle adjustment (after retriangulation): one round,
  // then the filtering.
  const GlobalMapperOptions mapper_options;
  BundleAdjustmentOptions ba = mapper_options.bundle_adjustment;
  ba.num_rounds = args.count("num_rounds") ? std::stoi(args["num_rounds"]) : 1;
  if (args["tight"] == "1") {
    ba.solver.ceres.function_tolerance = 0;
    ba.solver.ceres.parameter_tolerance = 0;
    ba.solver.ceres.gradient_tolerance = 0;
    ba.solver.ceres.max_num_iterations = 500;
  }
  // Given flags override the above.
  OptionManager ba_flags("refinement_benchmark final_ba");
  AddBundleAdjustmentOptions(&ba_flags, &ba);
  ba_flags.Parse(static_cast<int>(ba_argv.size()), ba_argv.data());
  const std::map<std::string, Rigid3d> reference = ReadGroundTruth(args["gt"]);
  Reconstruction model = ReadReconstruction(args["model"]);
  std::map<std::string, double> before;
  std::map<std::string, double> after;
  if (args.count("database_path")) {
    // Keypoint scales (a model file has none), matched by image name.
    const Database database(args["database_path"]);
    std::map<std::string, image_t> database_ids;
    for (const DatabaseImage& image : database.ReadAllImages()) {
      database_ids[image.name] = image.image_id;
    }
    for (auto& [image_id, image] : model.images) {
      const auto it = database_ids.find(image.name);
      if (it == database_ids.end()) {
        throw InputError(args["database_path"],
                         "has no image '" + image.name + "'");
      }
      std::vector<float> scales;
      database.ReadKeypoints(it->second, &scales);
      if (scales.size() != image.points2D.size()) {
        throw InputError(
            args["database_path"],
            "image '" + image.name + "' has " + std::to_string(scales.size()) +
                " keypoint scales, the model " +
                std::to_string(image.points2D.size()) + " points2D");
      }
      for (size_t k = 0; k < scales.size(); ++k) {
        image.points2D[k].scale = scales[k];
      }
    }
  }
  PrintStatistics("observations (" + args["model"] + ")", model);
  PrintErrors("model as read", model, reference, &before);
  std::unique_ptr<Reconstruction> truth;
  if (args.count("truth")) {
    truth = std::make_unique<Reconstruction>(ReadReconstruction(args["truth"]));
    const TrackCorrectness check = CompareTracksWithTruth(model, *truth);
    std::cout << "against the truth: " << check.num_wrong << " of "
              << check.num_observations << " observations wrong ("
              << check.num_points_with_wrong << " of " << check.num_points
              << " points), " << check.num_truth_missing
              << " truth observations unused\n";
  }
  if (args.count("restrict_to")) {
    // Only the observations (image name, keypoint) the other model uses.
    const Reconstruction other = ReadReconstruction(args["restrict_to"]);
    std::map<std::string, const Image*> other_by_name;
    for (const auto& [image_id, image] : other.images) {
      other_by_name[image.name] = &image;
    }
    std::vector<std::pair<image_t, point2D_t>> unused;
    for (const auto& [image_id, image] : model.images) {
      const auto it = other_by_name.find(image.name);
      for (point2D_t k = 0; k < image.points2D.size(); ++k) {
        if (image.points2D[k].point3D_id == kInvalidPoint3DId) continue;
        if (it == other_by_name.end() || k >= it->second->points2D.size() ||
            it->second->points2D[k].point3D_id == kInvalidPoint3DId) {
          unused.emplace_back(image_id, k);
        }
      }
    }
    for (const auto& [image_id, k] : unused) {
      DeleteObservation(image_id, k, &model);
    }
    std::cout << unused.size() << " observations " << args["restrict_to"]
              << " does not use deleted\n";
  }
  if (args.count("min_track_length")) {
    const size_t num =
        DeleteShortTracks(std::stoi(args["min_track_length"]), &model);
    std::cout << num << " points with tracks shorter than "
              << args["min_track_length"] << " deleted\n";
  }
  if (args.count("poses")) {
    const Reconstruction poses = ReadReconstruction(args["poses"]);
    const int num =
        TransferPoses(poses, args["intrinsics_from_poses"] == "1", &model);
    std::cout << num << " poses from " << args["poses"] << "\n";
    if (args["retriangulate"] == "1") {
      std::cout << RetriangulatePoints(&model)
                << " points placed again from the transferred poses\n";
    }
    PrintErrors("start (poses transferred)", model, reference, &before);
  }
  const int num_half_samples =
      args.count("half_samples") ? std::stoi(args["half_samples"]) : 0;
  const Reconstruction prepared =
      num_half_samples > 0 ? model : Reconstruction();
  BundleAdjustmentSummary summary;
  if (!RunBundleAdjustment(ba, &model, &summary)) {
    std::cout << "bundle adjustment failed\n";
    return 1;
  }
  const FilterSummary filtering =
      RunFiltering(mapper_options.filtering, &model, &summary.keypoint_noise);
  std::cout << "bundle adjustment: " << summary.num_iterations
            << " iterations, " << summary.initial_mean_reproj_error << " -> "
            << summary.final_mean_reproj_error << " px, "
            << summary.num_observations_filtered << " + "
            << filtering.num_observations_filtered
            << " observations filtered, converged " << summary.converged
            << "\n";
  if (!summary.scale_bin_noise_px.empty()) {
    // "scale range: noise" per bin, e.g. "2.45-2.63 px: 0.249 px".
    const std::vector<double>& edges = summary.scale_bin_edges_px;
    const std::vector<double>& noise = summary.scale_bin_noise_px;
    std::cout << "keypoint noise (median reprojection error) by scale:";
    for (size_t b = 0; b < noise.size(); ++b) {
      std::cout << (b == 0 ? " " : "; ");
      if (b == 0) {
        std::cout << "< " << edges.front();
      } else if (b + 1 == noise.size()) {
        std::cout << ">= " << edges.back();
      } else {
        std::cout << edges[b - 1] << "-" << edges[b];
      }
      std::cout << " px: " << noise[b] << " px";
    }
    std::cout << "\n";
  }
  PrintStatistics("after", model);
  PrintErrors("after our final bundle adjustment", model, reference, &after);
  if (args.count("per_image")) {
    std::ofstream csv(args["per_image"]);
    csv << "image,center_error_before_mm,center_error_after_mm\n";
    for (const auto& [name, error] : after) {
      csv << name << "," << before[name] << "," << error << "\n";
    }
    if (!csv) throw InputError(args["per_image"], "cannot write");
  }
  const uint64_t seed = args.count("half_sample_seed")
                            ? std::stoull(args["half_sample_seed"])
                            : 0;
  // The mapper's last bundle adjustment and filtering on one half.
  auto adjust = [&](int k, const char* which, Reconstruction* half) {
    BundleAdjustmentSummary half_summary;
    if (!RunBundleAdjustment(ba, half, &half_summary)) {
      std::cout << which << " " << k << ": bundle adjustment failed\n";
      return false;
    }
    RunFiltering(mapper_options.filtering, half, &half_summary.keypoint_noise);
    return true;
  };
  const bool half_pairs = args["half_pairs"] == "1";
  std::vector<double> medians, disagreements;
  for (int k = 0; k < num_half_samples; ++k) {
    Reconstruction half = prepared;
    // Drawn by point id, so that runs of one model with different options
    // (--min_track_length 3, say) keep the same points: paired halves.
    std::vector<point3D_t> deleted, kept;
    for (const auto& [point3D_id, point] : half.points3D) {
      std::seed_seq draw{seed, static_cast<uint64_t>(k),
                         static_cast<uint64_t>(point3D_id)};
      std::mt19937_64 rng(draw);
      (rng() & 1 ? deleted : kept).push_back(point3D_id);
    }
    for (const point3D_t point3D_id : deleted) DeletePoint3D(point3D_id, &half);
    if (!adjust(k, "half", &half)) continue;
    PoseComparison comparison;
    if (!ComparePoses(PosesByName(half), reference, SimilarityRansacOptions(),
                      &comparison)) {
      std::cout << "half " << k << ": alignment failed\n";
      continue;
    }
    medians.push_back(1000 * comparison.center_error_median);
    std::cout << "half " << k << ": " << half.points3D.size()
              << " points, rotation median "
              << comparison.rotation_error_median_deg << " deg, centre median "
              << medians.back() << " mm\n";
    if (!half_pairs) continue;
    // The other half: the two are independent estimates, so their
    // disagreement measures the adjustment's own spread, free of the
    // ground truth's errors (in mm through the other half's scale to it).
    Reconstruction complement = prepared;
    for (const point3D_t point3D_id : kept) {
      DeletePoint3D(point3D_id, &complement);
    }
    if (!adjust(k, "complement", &complement)) continue;
    PoseComparison to_truth, between;
    if (!ComparePoses(PosesByName(complement), reference,
                      SimilarityRansacOptions(), &to_truth) ||
        !ComparePoses(PosesByName(half), PosesByName(complement),
                      SimilarityRansacOptions(), &between)) {
      std::cout << "complement " << k << ": alignment failed\n";
      continue;
    }
    disagreements.push_back(1000 * to_truth.estimate_to_reference.scale *
                            between.center_error_median);
    std::cout << "complement " << k << ": centre median "
              << 1000 * to_truth.center_error_median
              << " mm; the two halves disagree by a median of "
              << disagreements.back() << " mm, "
              << between.rotation_error_median_deg << " deg\n";
  }
  auto print = [](const std::string& what, std::vector<double> values) {
    if (values.empty()) return;
    const double mean = Mean(values);
    const double deviation = StandardDeviation(values);
    std::sort(values.begin(), values.end());
    std::cout << what << " over " << values.size() << " halves: mean " << mean
              << " mm, standard deviation " << deviation << " mm, range "
              << values.front() << " - " << values.back() << " mm\n";
  };
  print("halves: centre median", medians);
  print("half pairs: disagreement median", disagreements);
  return 0;
}
}  // namespace

int RunImplicitProduct(int num_images, int num_points, int track, int width) {
  if (num_images < track || num_points < 1 || track < 2 || width < 1 ||
      width > 18) {
    throw InputError("implicit_product",
                     "needs NUM_IMAGES >= TRACK >= 2, NUM_POINTS >= 1, "
                     "WIDTH 1..18");
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(-1, 1);
  std::vector<ProductColumns> pose_columns(num_images);
  for (int i = 0; i < num_images; ++i) {
    pose_columns[i].count = 1;
    pose_columns[i].offset[0] = i * width;
    pose_columns[i].size[0] = width;
    pose_columns[i].num_cols = width;
  }
  const size_t record = 8 + 2 * width;
  std::vector<float> store(static_cast<size_t>(num_points) * track * record);
  for (float& value : store) value = uniform(rng);
  std::vector<uint32_t> poses(static_cast<size_t>(num_points) * track);
  std::uniform_int_distribution<int> image(0, num_images - 1);
  for (int p = 0; p < num_points; ++p) {
    std::vector<uint32_t> seen;
    while (static_cast<int>(seen.size()) < track) {
      const uint32_t i = image(rng);
      if (std::find(seen.begin(), seen.end(), i) == seen.end()) {
        seen.push_back(i);
      }
    }
    std::copy(seen.begin(), seen.end(), poses.begin() + p * track);
  }
  const Eigen::Matrix3d v_inv = Eigen::Matrix3d::Identity() * 0.01;
  Eigen::VectorXd x(num_images * width);
  for (int i = 0; i < x.size(); ++i) x[i] = uniform(rng);
  const Eigen::VectorXf x_float = x.cast<float>();
  const bool avx2 = Avx2ProductAvailable();
  std::vector<Eigen::Vector2d> ax;
  auto product = [&](bool vectorised, Eigen::VectorXd* y) {
    y->setZero(x.size());
    const std::clock_t start = std::clock();
    for (int p = 0; p < num_points; ++p) {
      const float* at = &store[static_cast<size_t>(p) * track * record];
      const uint32_t* point_poses = &poses[static_cast<size_t>(p) * track];
      if (vectorised) {
        MultiplyPointAvx2(at, point_poses, track, pose_columns.data(), &v_inv,
                          x.data(), x_float.data(), y->data(), &ax);
      } else {
        MultiplyPoint(at, point_poses, track, pose_columns.data(), &v_inv,
                      x.data(), x_float.data(), y->data(), &ax);
      }
    }
    return 1000.0 * (std::clock() - start) / CLOCKS_PER_SEC;
  };
  std::cout << num_points << " points of " << track << " observations, "
            << num_images << " images of " << width
            << " columns: " << store.size() * sizeof(float) / 1048576.0
            << " MiB kept\n";
  if (!avx2) std::cout << "AVX2 kernel: not available here\n";
  Eigen::VectorXd y_portable, y_avx2;
  for (int round = 0; round < 5; ++round) {
    const double portable = product(false, &y_portable);
    std::cout << "round " << round << ": portable " << portable << " ms";
    if (avx2) {
      const double vectorised = product(true, &y_avx2);
      std::cout << ", AVX2 " << vectorised << " ms, ratio "
                << portable / vectorised << ", |y difference| / |y| "
                << (y_portable - y_avx2).norm() / y_portable.norm();
    }
    std::cout << "\n";
  }
  return 0;
}

int main(int argc, char** argv) {
  try {
    if (argc == 6 && std::string(argv[1]) == "implicit_product") {
      return RunImplicitProduct(std::atoi(argv[2]), std::atoi(argv[3]),
                                std::atoi(argv[4]), std::atoi(argv[5]));
    }
    if (argc == 3 && std::string(argv[1]) == "strecha")
      return RunStrecha(argv[2]);
    if (argc >= 2 && std::string(argv[1]) == "final_ba") {
      return RunFinalBundleAdjustment(argc, argv);
    }
    if (argc == 4 && std::string(argv[1]) == "synthetic") {
      return RunSynthetic(std::atoi(argv[2]), std::atoi(argv[3]));
    }
  } catch (const InputError& error) {
    std::cerr << error.what() << "\n";
    return 1;
  }
  std::cerr << "usage: refinement_benchmark strecha SCENE_DIR\n"
               "       refinement_benchmark implicit_product NUM_IMAGES "
               "NUM_POINTS TRACK WIDTH\n"
               "       refinement_benchmark synthetic NUM_IMAGES NUM_POINTS\n"
               "       refinement_benchmark final_ba --model MODEL --gt GT "
               "[--poses MODEL2] [--intrinsics_from_poses 0|1] "
               "[--num_rounds N] [--tight 0|1] [--per_image CSV] "
               "[--truth MODEL] [--min_track_length N] [--restrict_to MODEL] "
               "[--half_samples N] [--half_sample_seed S] "
               "[--half_pairs 0|1] [--database_path DB] [--retriangulate 0|1] "
               "[--BundleAdjustment.* as the mapper's]\n";
  return 2;
}
