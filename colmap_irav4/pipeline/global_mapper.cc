#include "colmap_irav4/pipeline/global_mapper.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <set>
#include <unistd.h>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/fold_resolution.h"
#include "colmap_irav4/scene/point_colors.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {
namespace {

// The images of the model with their rotations and all their keypoints.
Reconstruction MakeReconstruction(
    const DatabaseContents& database,
    const std::map<camera_t, Camera>& cameras,
    const std::map<image_t, Eigen::Matrix3d>& rotations) {
  Reconstruction reconstruction;
  for (const auto& [image_id, R] : rotations) {
    const DatabaseImage& database_image = database.images.at(image_id);
    Image& image = reconstruction.images[image_id];
    image.image_id = image_id;
    image.name = database_image.name;
    image.camera_id = database_image.camera_id;
    image.cam_from_world.rotation = Eigen::Quaterniond(R).normalized();
    const auto keypoints = database.keypoints.find(image_id);
    if (keypoints != database.keypoints.end()) {
      image.points2D.resize(keypoints->second.size());
      for (size_t k = 0; k < keypoints->second.size(); ++k) {
        image.points2D[k].xy = keypoints->second[k].cast<double>();
      }
    }
    reconstruction.cameras[image.camera_id] = cameras.at(image.camera_id);
  }
  return reconstruction;
}

// Removes cameras no image uses any more.
void RemoveUnusedCameras(Reconstruction* reconstruction) {
  std::set<camera_t> used;
  for (const auto& [image_id, image] : reconstruction->images) {
    used.insert(image.camera_id);
  }
  for (auto it = reconstruction->cameras.begin();
       it != reconstruction->cameras.end();) {
    it = used.count(it->first) ? std::next(it)
                               : reconstruction->cameras.erase(it);
  }
}

// The longest tracks first, each kept while one of its images has fewer
// than `per_image` observations from the tracks kept so far: every image
// gets enough constraints, long (well-triangulated) tracks are preferred.
std::vector<Track> SelectTracksForPositioning(const std::vector<Track>& tracks,
                                              int per_image) {
  if (per_image <= 0) return tracks;
  std::vector<size_t> order(tracks.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return tracks[a].size() > tracks[b].size();
  });
  std::map<image_t, int> count;
  std::vector<char> selected(tracks.size(), 0);
  for (const size_t k : order) {
    bool needed = false;
    for (const TrackElement& element : tracks[k]) {
      if (count[element.image_id] < per_image) needed = true;
    }
    if (!needed) continue;
    selected[k] = 1;
    for (const TrackElement& element : tracks[k]) ++count[element.image_id];
  }
  std::vector<Track> subset;
  for (size_t k = 0; k < tracks.size(); ++k) {
    if (selected[k]) subset.push_back(tracks[k]);
  }
  return subset;
}

}  // namespace

GlobalMapper::GlobalMapper(const GlobalMapperOptions& options,
                           const DatabaseContents& database,
                           const std::map<camera_t, Camera>& cameras,
                           std::vector<image_t> images,
                           std::vector<ImagePairGeometry> pairs,
                           std::string log_prefix)
    : options_(options.ForStages(database.images.size())),
      database_(database),
      cameras_(cameras),
      images_(std::move(images)),
      num_component_pairs_(pairs.size()),
      log_prefix_(std::move(log_prefix)),
      pairs_(std::move(pairs)),
      retriangulated_(options.skip_retriangulation) {}

bool GlobalMapper::Fail(const std::string& reason) {
  failure_ = reason;
  return false;
}

void GlobalMapper::AddModelFigures(StageTimer* stage) {
  const double error = UpdateReprojectionErrors(&reconstruction_);
  stage->Add("registered images",
             static_cast<double>(reconstruction_.images.size()));
  stage->Add("points", static_cast<double>(reconstruction_.points3D.size()));
  stage->Add("mean reprojection error px", error);
}

bool GlobalMapper::Run() {
  return RotationAveraging() && RotationFilter() && BuildTracks() &&
         Positioning() && IterativeBundleAdjustment() && Finalize();
}

bool GlobalMapper::RotationAveraging() {
  StageTimer stage("rotation averaging (" + options_.rotation_method + ")");
  RotationGraph graph;
  std::map<image_t, int> vertex;
  for (const image_t image_id : images_) {
    vertex[image_id] = graph.AddVertex(database_.images.at(image_id).name);
  }
  for (const ImagePairGeometry& pair : pairs_) {
    graph.AddEdge(vertex.at(pair.image_id1), vertex.at(pair.image_id2), pair.R,
                  pair.num_inliers);
  }
  const std::unique_ptr<RotationAverager> averager = CreateRotationAverager(
      options_.rotation_method, options_.rotation_averaging);
  const RotationAveragingResult result = averager->Estimate(graph);
  rotations_.clear();
  for (const image_t image_id : images_) {
    const int v = vertex.at(image_id);
    if (result.estimated[v]) rotations_[image_id] = result.rotations[v];
  }
  stage.Add("images", static_cast<double>(graph.NumVertices()));
  stage.Add("pairs", static_cast<double>(graph.NumEdges()));
  stage.Add("rotations", static_cast<double>(rotations_.size()));
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::RotationFilter() {
  StageTimer stage(options_.skip_rotation_filter ? "rotation filter (skipped)"
                                                 : "rotation filter");
  const size_t num_pairs = pairs_.size();
  pairs_ = FilterPairsByRotation(
      pairs_, rotations_,
      options_.skip_rotation_filter
          ? 180.0
          : options_.rotation_filter.max_rotation_error_deg);
  // The largest connected part remains.
  const std::vector<std::vector<image_t>> components = PairComponents(pairs_);
  std::set<image_t> kept_images;
  if (!components.empty()) {
    kept_images.insert(components[0].begin(), components[0].end());
  }
  const size_t num_consistent = pairs_.size();
  pairs_.erase(std::remove_if(pairs_.begin(), pairs_.end(),
                              [&](const ImagePairGeometry& pair) {
                                return !kept_images.count(pair.image_id1);
                              }),
               pairs_.end());
  for (auto it = rotations_.begin(); it != rotations_.end();) {
    it = kept_images.count(it->first) ? std::next(it) : rotations_.erase(it);
  }
  stage.Add("pairs kept", static_cast<double>(pairs_.size()));
  stage.Add("pairs dropped (rotation)",
            static_cast<double>(num_pairs - num_consistent));
  stage.Add("images", static_cast<double>(kept_images.size()));
  stage.Finish(log_prefix_, &stages_);
  if (static_cast<int>(rotations_.size()) < options_.min_model_size) {
    return Fail("only " + std::to_string(rotations_.size()) +
                " images with consistent rotations");
  }
  // A pure rotation (panorama): every pair has a zero translation, the
  // cameras share one centre and no point can be triangulated.
  if (std::all_of(pairs_.begin(), pairs_.end(),
                  [](const ImagePairGeometry& pair) {
                    return !(pair.t.squaredNorm() > 0);
                  })) {
    return Fail("pure rotation (panorama): all " +
                std::to_string(pairs_.size()) +
                " pairs have no translation, the cameras share one centre "
                "and no 3D point can be triangulated");
  }
  return true;
}

bool GlobalMapper::BuildTracks() {
  StageTimer stage("tracks");
  reconstruction_ = MakeReconstruction(database_, cameras_, rotations_);
  // The inlier matches of the kept pairs, in the pairs' order.
  std::map<image_pair_t, const TwoViewGeometry*> geometries;
  for (const TwoViewGeometry& geometry : database_.two_view_geometries) {
    geometries[ImagePairToPairId(geometry.image_id1, geometry.image_id2)] =
        &geometry;
  }
  std::vector<ImagePairMatches> matches;
  matches.reserve(pairs_.size());
  for (const ImagePairGeometry& pair : pairs_) {
    const TwoViewGeometry& geometry =
        *geometries.at(ImagePairToPairId(pair.image_id1, pair.image_id2));
    ImagePairMatches pair_matches;
    pair_matches.image_id1 = geometry.image_id1;
    pair_matches.image_id2 = geometry.image_id2;
    pair_matches.matches.reserve(geometry.inlier_matches.size());
    for (const FeatureMatch& match : geometry.inlier_matches) {
      pair_matches.matches.emplace_back(match.point2D_idx1,
                                        match.point2D_idx2);
    }
    matches.push_back(std::move(pair_matches));
  }
  TrackBuilderStats track_stats;
  tracks_ = colmap_irav4::BuildTracks(options_.tracks, matches,
                                      reconstruction_.images, &track_stats);
  const bool global_positioning =
      options_.positioning_method == "global_positioning";
  size_t num_positioning_tracks = 0;
  if (global_positioning) {
    // Global positioning needs only enough tracks to tie every camera down;
    // the others are triangulated from the refined poses afterwards.
    const std::vector<Track> positioning_tracks =
        !options_.skip_retriangulation
            ? SelectTracksForPositioning(
                  tracks_, options_.positioning_tracks_per_image)
            : tracks_;
    AddTracksToReconstruction(positioning_tracks, &reconstruction_);
    num_positioning_tracks = positioning_tracks.size();
  }
  stage.Add("tracks", static_cast<double>(track_stats.num_tracks));
  stage.Add("tracks for positioning",
            static_cast<double>(num_positioning_tracks));
  stage.Add("dropped inconsistent",
            static_cast<double>(track_stats.num_inconsistent));
  stage.Add("dropped short", static_cast<double>(track_stats.num_too_short));
  stage.Add("dropped long", static_cast<double>(track_stats.num_too_long));
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::Positioning() {
  StageTimer stage(options_.positioning_method);
  if (options_.positioning_method == "global_positioning") {
    GlobalPositionerSummary positioner_summary;
    if (!RunGlobalPositioning(options_.global_positioning, &reconstruction_,
                              &positioner_summary)) {
      return Fail("global positioning failed");
    }
    stage.Add("iterations",
              static_cast<double>(positioner_summary.num_iterations));
    stage.Add("observations filtered",
              static_cast<double>(positioner_summary.num_observations_filtered));
  } else {
    TranslationAveragingSummary averaging_summary;
    if (!RunTranslationAveraging(options_.translation_averaging, pairs_,
                                 &reconstruction_, &averaging_summary)) {
      return Fail("translation averaging failed");
    }
    const TriangulationSummary triangulation =
        TriangulateTracks(options_.triangulation, tracks_, &reconstruction_);
    stage.Add("iterations",
              static_cast<double>(averaging_summary.num_iterations));
    stage.Add("outlier pairs",
              static_cast<double>(averaging_summary.num_outlier_pairs));
    stage.Add("points triangulated",
              static_cast<double>(triangulation.num_points_added));
  }
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::IterativeBundleAdjustment() {
  const int num_ba =
      options_.skip_bundle_adjustment ? 0 : options_.num_ba_iterations;
  for (int iteration = 0; iteration < std::max(num_ba, 1); ++iteration) {
    if (iteration < num_ba) {
      StageTimer stage("bundle adjustment " + std::to_string(iteration + 1));
      // After retriangulation the model is nearly clean: the last bundle
      // adjustment is one solve (a second one for the few observations its
      // filter removes changes nothing); the filtering below follows it.
      BundleAdjustmentOptions round_options = options_.bundle_adjustment;
      if (retriangulated_ && iteration + 1 == num_ba) {
        round_options.num_rounds = 1;
      }
      BundleAdjustmentSummary ba_summary;
      if (!RunBundleAdjustment(round_options, &reconstruction_, &ba_summary)) {
        return Fail("bundle adjustment failed");
      }
      const FilterSummary filter_summary =
          RunFiltering(options_.filtering, &reconstruction_);
      stage.Add("iterations", static_cast<double>(ba_summary.num_iterations));
      stage.Add("observations filtered",
                static_cast<double>(ba_summary.num_observations_filtered +
                                    filter_summary.num_observations_filtered));
      stage.Add("points filtered (angle)",
                static_cast<double>(filter_summary.num_points_filtered));
      AddModelFigures(&stage);
      stage.Finish(log_prefix_, &stages_);
    }
    // Every track is triangulated once, after the first round: then the
    // poses are good enough.
    if (!retriangulated_ && !Retriangulation()) return false;
  }
  return true;
}

bool GlobalMapper::Retriangulation() {
  StageTimer stage("retriangulation");
  const TriangulationSummary triangulation =
      TriangulateTracks(options_.triangulation, tracks_, &reconstruction_);
  retriangulated_ = true;
  stage.Add("tracks tried", static_cast<double>(triangulation.num_tracks_tried));
  stage.Add("points added", static_cast<double>(triangulation.num_points_added));
  stage.Add("observations added",
            static_cast<double>(triangulation.num_observations_added));
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::Finalize() {
  if (!options_.skip_filtering) {
    StageTimer stage("final filtering");
    const FilterSummary filter_summary =
        RunFiltering(options_.filtering, &reconstruction_);
    stage.Add("observations filtered",
              static_cast<double>(filter_summary.num_observations_filtered));
    stage.Add("points filtered (angle)",
              static_cast<double>(filter_summary.num_points_filtered));
    stage.Add("images filtered",
              static_cast<double>(filter_summary.num_images_filtered));
    AddModelFigures(&stage);
    stage.Finish(log_prefix_, &stages_);
  }
  RemoveUnusedCameras(&reconstruction_);
  if (static_cast<int>(reconstruction_.images.size()) <
      options_.min_model_size) {
    return Fail("only " + std::to_string(reconstruction_.images.size()) +
                " images left after refinement");
  }
  if (!options_.skip_normalization) {
    StageTimer stage("normalisation");
    NormalizeReconstruction(options_.normalization, &reconstruction_);
    stage.Finish(log_prefix_, &stages_);
  }
  return true;
}

int GlobalMapper::ColorPoints(const std::string& image_path) {
  StageTimer stage("colours");
  int num_missing = 0;
  if (!image_path.empty() && !options_.skip_colors) {
    num_missing =
        ColorPointsFromImages(image_path, &reconstruction_,
                              options_.color_image_downscale,
                              options_.num_threads);
    stage.Add("images read", static_cast<double>(
                                 reconstruction_.images.size() - num_missing));
    stage.Add("images missing", static_cast<double>(num_missing));
  } else {
    for (auto& [point3D_id, point] : reconstruction_.points3D) {
      point.color.setConstant(128);
    }
    stage.report().name += " (grey: no --image_path)";
  }
  stage.Finish(log_prefix_, &stages_);
  return num_missing;
}

void RotationFilterOptions::Check() const {
  if (!(max_rotation_error_deg > 0 && max_rotation_error_deg <= 180)) {
    throw InputError("--RotationFilter.max_rotation_error_deg",
                     "must be in (0, 180]");
  }
}

std::string DefaultRotationMethod() {
  const std::vector<std::string> methods = RotationAveragerMethods();
  for (const char* preferred : {"irav4", "ira", "l1_irls"}) {
    if (std::find(methods.begin(), methods.end(), preferred) != methods.end()) {
      return preferred;
    }
  }
  return methods.empty() ? "" : methods.front();
}

GlobalMapperOptions::GlobalMapperOptions()
    : rotation_method(DefaultRotationMethod()) {
  // COLMAP's mapper default (min_num_matches = 15).
  view_graph.min_num_inliers = 15;
  view_graph.keep_largest_component = false;
  // Squared loss as COLMAP's bundle adjustment: the filtering between rounds
  // removes the outliers, and plain least squares converges in a few
  // iterations where a robust loss creeps for dozens.
  bundle_adjustment.loss_function = "trivial";
}

void GlobalMapperOptions::Check() const {
  if (min_model_size < 3) {
    throw InputError("--Mapper.min_model_size", "must be >= 3");
  }
  const std::vector<std::string> methods = RotationAveragerMethods();
  if (std::find(methods.begin(), methods.end(), rotation_method) ==
      methods.end()) {
    throw InputError("--Mapper.rotation_method",
                     "unknown method '" + rotation_method + "' (one of " +
                         RotationAveragerMethodList() + ")");
  }
  if (positioning_method != "global_positioning" &&
      positioning_method != "translation_averaging") {
    throw InputError("--Mapper.positioning_method",
                     "unknown method '" + positioning_method +
                         "' (global_positioning or translation_averaging)");
  }
  if (num_threads == 0 || num_threads < -1) {
    throw InputError("--Mapper.num_threads", "must be -1 (all cores) or > 0");
  }
  if (progress < -1 || progress > 1) {
    throw InputError("--Mapper.progress", "must be -1 (auto), 0 or 1");
  }
  if (color_image_downscale != 1 && color_image_downscale != 2 &&
      color_image_downscale != 4 && color_image_downscale != 8) {
    throw InputError("--Mapper.color_image_downscale", "must be 1, 2, 4 or 8");
  }
  if (num_ba_iterations < 0) {
    throw InputError("--Mapper.num_ba_iterations", "must be >= 0");
  }
  view_graph.Check();
  rotation_averaging.Check();
  rotation_filter.Check();
  tracks.Check();
  global_positioning.Check();
  translation_averaging.Check();
  triangulation.Check();
  if (positioning_tracks_per_image < 0) {
    throw InputError("--Mapper.positioning_tracks_per_image", "must be >= 0");
  }
  bundle_adjustment.Check();
  filtering.Check();
  normalization.Check();
  fold.Check();
}

GlobalMapperOptions GlobalMapperOptions::ForStages(size_t num_images) const {
  GlobalMapperOptions stages = *this;
  stages.view_graph.num_threads = num_threads;
  stages.global_positioning.num_threads = num_threads;
  stages.bundle_adjustment.num_threads = num_threads;
  stages.translation_averaging.num_threads = num_threads;
  const bool show_progress =
      progress == 1 ||
      (progress == -1 && (isatty(fileno(stderr)) || num_images >= 100));
  stages.global_positioning.show_progress_bar = show_progress;
  stages.bundle_adjustment.show_progress_bar = show_progress;
  stages.translation_averaging.show_progress_bar = show_progress;
  stages.bundle_adjustment.refine_focal_length = ba_refine_focal_length;
  stages.bundle_adjustment.refine_principal_point = ba_refine_principal_point;
  stages.bundle_adjustment.refine_extra_params = ba_refine_extra_params;
  return stages;
}

void AddGlobalMapperOptions(OptionManager* manager,
                            GlobalMapperOptions* options) {
  GlobalMapperOptions& o = *options;
  manager->Add("Mapper.min_num_matches", &o.view_graph.min_num_inliers,
               "minimum inlier matches of an image pair");
  manager->Add("Mapper.min_model_size", &o.min_model_size,
               "components with fewer images give no model");
  manager->Add("Mapper.rotation_method", &o.rotation_method,
               "rotation averaging: " + RotationAveragerMethodList());
  manager->Add("Mapper.positioning_method", &o.positioning_method,
               "global_positioning or translation_averaging");
  manager->Add("Mapper.ba_refine_focal_length", &o.ba_refine_focal_length,
               "refine focal lengths in bundle adjustment");
  manager->Add("Mapper.ba_refine_principal_point",
               &o.ba_refine_principal_point,
               "refine principal points in bundle adjustment");
  manager->Add("Mapper.ba_refine_extra_params", &o.ba_refine_extra_params,
               "refine distortion parameters in bundle adjustment");
  manager->Add("Mapper.reset_invalid_cameras", &o.reset_invalid_cameras,
               "start cameras with invalid intrinsics from a default focal "
               "(refined) instead of failing");
  manager->Add("Mapper.num_threads", &o.num_threads,
               "threads of every stage (-1: all cores)");
  manager->Add("Mapper.progress", &o.progress,
               "progress bars: 1 on, 0 off, -1 on a terminal or >= 100 "
               "images");
  manager->Add("Mapper.num_ba_iterations", &o.num_ba_iterations,
               "rounds of bundle adjustment + filtering");
  manager->Add("Mapper.positioning_tracks_per_image",
               &o.positioning_tracks_per_image,
               "global positioning uses the longest tracks until each image "
               "has this many observations (0: all tracks)");
  manager->Add("Mapper.skip_rotation_filter", &o.skip_rotation_filter,
               "skip the rotation-consistency filter");
  manager->Add("Mapper.skip_bundle_adjustment", &o.skip_bundle_adjustment,
               "skip bundle adjustment");
  manager->Add("Mapper.skip_retriangulation", &o.skip_retriangulation,
               "skip retriangulation");
  manager->Add("Mapper.skip_filtering", &o.skip_filtering,
               "skip the final filtering");
  manager->Add("Mapper.skip_normalization", &o.skip_normalization,
               "skip normalising the scene's centre and scale");
  manager->Add("Mapper.color_image_downscale", &o.color_image_downscale,
               "images are decoded at 1/1, 1/2, 1/4 or 1/8 of their size for "
               "the point colours");
  manager->Add("Mapper.skip_colors", &o.skip_colors,
               "do not read images for point colours (grey)");

  manager->Add("ViewGraph.min_inlier_ratio", &o.view_graph.min_inlier_ratio,
               "minimum inliers / raw matches (where raw matches are stored)");
  manager->Add("ViewGraph.drop_configs", &o.view_graph.drop_configs,
               "comma-separated two-view configurations to drop");
  AddFocalCalibrationOptions(manager, &o.view_graph.focal_calibration);
  RelativePoseOptions& rp = o.view_graph.relative_pose;
  manager->Add("RelativePose.max_error_px", &rp.max_error_px,
               "epipolar error threshold of a supporting match (pixels)");
  manager->Add("RelativePose.refine", &rp.refine,
               "refine each relative pose on its inliers");
  manager->Add("RelativePose.refine_max_rotation_std_deg",
               &rp.refine_max_rotation_std_deg,
               "refine only poses whose rotation the inliers determine to "
               "this standard deviation (deg)");
  manager->Add("RelativePose.min_tri_angle_deg", &rp.min_tri_angle_deg,
               "median triangulation angle below which t is undefined (deg)");

  AddRotationAveragerOptions(manager, &o.rotation_averaging);
  manager->Add("RotationFilter.max_rotation_error_deg",
               &o.rotation_filter.max_rotation_error_deg,
               "drop pairs disagreeing with the averaged rotations (deg)");

  manager->Add("Tracks.min_track_length", &o.tracks.min_track_length,
               "shorter tracks are dropped");
  manager->Add("Tracks.max_track_length", &o.tracks.max_track_length,
               "longer tracks are dropped");
  manager->Add("Tracks.max_duplicate_distance",
               &o.tracks.max_duplicate_distance,
               "two observations of a track in one image closer than this "
               "(px) are merged, farther: the track is dropped");

  GlobalPositionerOptions& gp = o.global_positioning;
  manager->Add("GlobalPositioning.min_track_length", &gp.min_track_length,
               "tracks positioned (shorter: retriangulated later)");
  manager->Add("GlobalPositioning.loss_function", &gp.loss_function,
               "huber, cauchy or trivial");
  manager->Add("GlobalPositioning.loss_scale", &gp.loss_scale,
               "robust loss scale");
  manager->Add("GlobalPositioning.max_angular_error_deg",
               &gp.max_angular_error_deg,
               "observations disagreeing more are unlinked (deg)");
  manager->Add("GlobalPositioning.max_num_iterations", &gp.max_num_iterations,
               "Ceres iterations");
  manager->Add("GlobalPositioning.function_tolerance", &gp.function_tolerance,
               "Ceres function tolerance");
  manager->Add("GlobalPositioning.print_progress", &gp.print_progress,
               "print Ceres' iterations");

  TranslationAveragingOptions& ta = o.translation_averaging;
  manager->Add("TranslationAveraging.cost", &ta.cost, "bata or chordal");
  manager->Add("TranslationAveraging.loss_function", &ta.loss_function,
               "huber, cauchy or trivial");
  manager->Add("TranslationAveraging.loss_scale", &ta.loss_scale,
               "robust loss scale");
  manager->Add("Triangulation.max_reproj_error",
               &o.triangulation.max_reproj_error,
               "inlier threshold of (re)triangulation (px)");
  manager->Add("Triangulation.min_tri_angle", &o.triangulation.min_tri_angle,
               "minimum triangulation angle (deg)");

  BundleAdjustmentOptions& ba = o.bundle_adjustment;
  manager->Add("BundleAdjustment.loss_function", &ba.loss_function,
               "huber, cauchy or trivial");
  manager->Add("BundleAdjustment.loss_scale", &ba.loss_scale,
               "robust loss scale (px)");
  manager->Add("BundleAdjustment.num_rounds", &ba.num_rounds,
               "solve + filter rounds per bundle adjustment");
  manager->Add("BundleAdjustment.max_reproj_error", &ba.max_reproj_error,
               "observations over this error are removed between rounds (px)");
  manager->Add("BundleAdjustment.max_num_iterations", &ba.max_num_iterations,
               "Ceres iterations per round");
  manager->Add("BundleAdjustment.linear_solver", &ba.linear_solver,
               "auto, sparse_schur, dense_schur or iterative_schur");
  manager->Add("BundleAdjustment.function_tolerance", &ba.function_tolerance,
               "Ceres function tolerance");
  manager->Add("BundleAdjustment.initial_trust_region_radius",
               &ba.initial_trust_region_radius,
               "Levenberg-Marquardt's initial trust region");
  manager->Add("BundleAdjustment.print_progress", &ba.print_progress,
               "print Ceres' iterations");

  manager->Add("Filter.max_reproj_error", &o.filtering.max_reproj_error,
               "observations over this reprojection error are removed (px)");
  manager->Add("Filter.min_tri_angle", &o.filtering.min_tri_angle,
               "points with a smaller largest triangulation angle are removed "
               "(deg)");
  manager->Add("Normalization.extent", &o.normalization.extent,
               "extent of the central part of the normalised scene");
  AddFoldResolutionOptions(manager, &o.fold);
}

std::vector<ImagePairGeometry> FilterPairsByRotation(
    const std::vector<ImagePairGeometry>& pairs,
    const std::map<image_t, Eigen::Matrix3d>& rotations,
    double max_rotation_error_deg) {
  std::vector<ImagePairGeometry> kept;
  for (const ImagePairGeometry& pair : pairs) {
    const auto r1 = rotations.find(pair.image_id1);
    const auto r2 = rotations.find(pair.image_id2);
    if (r1 == rotations.end() || r2 == rotations.end()) continue;
    // R_ij = R_j R_i^T.
    const Eigen::Matrix3d averaged = r2->second * r1->second.transpose();
    if (AngularDistanceDeg(pair.R, averaged) <= max_rotation_error_deg) {
      kept.push_back(pair);
    }
  }
  return kept;
}

std::vector<std::vector<image_t>> PairComponents(
    const std::vector<ImagePairGeometry>& pairs) {
  std::map<image_t, image_t> parent;
  std::function<image_t(image_t)> find = [&](image_t x) {
    while (parent.at(x) != x) {
      parent[x] = parent.at(parent.at(x));
      x = parent.at(x);
    }
    return x;
  };
  for (const ImagePairGeometry& pair : pairs) {
    parent.emplace(pair.image_id1, pair.image_id1);
    parent.emplace(pair.image_id2, pair.image_id2);
  }
  for (const ImagePairGeometry& pair : pairs) {
    const image_t a = find(pair.image_id1);
    const image_t b = find(pair.image_id2);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::map<image_t, std::vector<image_t>> by_root;
  for (const auto& [image_id, unused] : parent) {
    by_root[find(image_id)].push_back(image_id);
  }
  std::vector<std::vector<image_t>> components;
  for (auto& [root, images] : by_root) components.push_back(std::move(images));
  // Stable: equal sizes keep the order of their smallest image id.
  std::stable_sort(components.begin(), components.end(),
                   [](const auto& a, const auto& b) {
                     return a.size() > b.size();
                   });
  return components;
}

}  // namespace colmap_irav4
