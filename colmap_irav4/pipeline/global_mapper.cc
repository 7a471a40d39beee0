#include "colmap_irav4/pipeline/global_mapper.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iomanip>
#include <numeric>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

#include <glog/logging.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/positioning/translation_averaging.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

std::string FormatFigure(double value) {
  std::ostringstream stream;
  if (value == std::floor(value) && std::abs(value) < 1e15) {
    stream << static_cast<long long>(value);
  } else {
    stream << std::fixed << std::setprecision(3) << value;
  }
  return stream.str();
}

// Logs the stage's line: "[component] name: 1.23 s, pairs 55, ...".
void LogStage(const std::string& prefix, const StageReport& stage) {
  // Process CPU time so far: wall time alone misleads on a loaded machine.
  static double last_cpu = 0;
  const double cpu = static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
  std::ostringstream line;
  line << prefix << stage.name << ": " << std::fixed << std::setprecision(2)
       << stage.seconds << " s (cpu " << cpu - last_cpu << " s)";
  last_cpu = cpu;
  for (const auto& [name, value] : stage.figures) {
    line << ", " << name << " " << FormatFigure(value);
  }
  LOG(INFO) << line.str();
}

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string JsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  std::ostringstream stream;
  stream << std::setprecision(10) << value;
  return stream.str();
}

void AppendStagesJson(const std::vector<StageReport>& stages,
                      const std::string& indent, std::ostringstream* out) {
  *out << "[";
  for (size_t i = 0; i < stages.size(); ++i) {
    const StageReport& stage = stages[i];
    *out << (i ? "," : "") << "\n" << indent << "  {\"name\": "
         << JsonString(stage.name)
         << ", \"seconds\": " << JsonNumber(stage.seconds);
    for (const auto& [name, value] : stage.figures) {
      *out << ", " << JsonString(name) << ": " << JsonNumber(value);
    }
    *out << "}";
  }
  *out << (stages.empty() ? "" : "\n" + indent) << "]";
}

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

void AddModelFigures(Reconstruction* reconstruction, StageReport* stage) {
  const double error = UpdateReprojectionErrors(reconstruction);
  stage->figures.push_back(
      {"registered images", static_cast<double>(reconstruction->images.size())});
  stage->figures.push_back(
      {"points", static_cast<double>(reconstruction->points3D.size())});
  stage->figures.push_back({"mean reprojection error px", error});
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

// Maps one component (its images and pairs). Returns false with the reason
// in *failure when no model of min_model_size images results.
bool MapComponent(const GlobalMapperOptions& options,
                  const DatabaseContents& database,
                  const std::map<camera_t, Camera>& cameras,
                  const std::map<image_pair_t, size_t>& geometry_index,
                  const std::vector<image_t>& component_images,
                  const std::vector<ImagePairGeometry>& component_pairs,
                  const std::string& prefix, Reconstruction* reconstruction,
                  ComponentReport* report, std::string* failure) {
  report->num_images_in_graph = static_cast<int>(component_images.size());
  report->num_pairs_in_graph = static_cast<int>(component_pairs.size());

  // Rotation averaging.
  Timer timer;
  StageReport stage{"rotation averaging (" + options.rotation_method + ")"};
  RotationGraph graph;
  std::map<image_t, int> vertex;
  for (const image_t image_id : component_images) {
    vertex[image_id] = graph.AddVertex(database.images.at(image_id).name);
  }
  for (const ImagePairGeometry& pair : component_pairs) {
    graph.AddEdge(vertex.at(pair.image_id1), vertex.at(pair.image_id2), pair.R,
                  pair.num_inliers);
  }
  const std::unique_ptr<RotationAverager> averager = CreateRotationAverager(
      options.rotation_method, options.rotation_averaging);
  const RotationAveragingResult result = averager->Estimate(graph);
  std::map<image_t, Eigen::Matrix3d> rotations;
  for (const image_t image_id : component_images) {
    const int v = vertex.at(image_id);
    if (result.estimated[v]) rotations[image_id] = result.rotations[v];
  }
  stage.seconds = timer.ElapsedSeconds();
  stage.figures = {{"images", static_cast<double>(graph.NumVertices())},
                   {"pairs", static_cast<double>(graph.NumEdges())},
                   {"rotations", static_cast<double>(rotations.size())}};
  LogStage(prefix, stage);
  report->stages.push_back(stage);

  // Rotation-consistency filter; the largest remaining component is kept.
  std::vector<ImagePairGeometry> pairs;
  timer.Restart();
  stage = StageReport{"rotation filter"};
  if (options.skip_rotation_filter) {
    pairs = FilterPairsByRotation(component_pairs, rotations, 180.0);
  } else {
    pairs = FilterPairsByRotation(component_pairs, rotations,
                                  options.rotation_filter.max_rotation_error_deg);
  }
  const std::vector<std::vector<image_t>> components = PairComponents(pairs);
  std::set<image_t> kept_images;
  if (!components.empty()) {
    kept_images.insert(components[0].begin(), components[0].end());
  }
  const size_t num_consistent = pairs.size();
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                             [&](const ImagePairGeometry& pair) {
                               return !kept_images.count(pair.image_id1);
                             }),
              pairs.end());
  for (auto it = rotations.begin(); it != rotations.end();) {
    it = kept_images.count(it->first) ? std::next(it) : rotations.erase(it);
  }
  stage.seconds = timer.ElapsedSeconds();
  stage.figures = {
      {"pairs kept", static_cast<double>(pairs.size())},
      {"pairs dropped (rotation)",
       static_cast<double>(component_pairs.size() - num_consistent)},
      {"images", static_cast<double>(kept_images.size())}};
  if (options.skip_rotation_filter) stage.name += " (skipped)";
  LogStage(prefix, stage);
  report->stages.push_back(stage);
  if (static_cast<int>(rotations.size()) < options.min_model_size) {
    *failure = "only " + std::to_string(rotations.size()) +
               " images with consistent rotations";
    return false;
  }

  // A pure rotation (panorama): every pair has a zero translation, the
  // cameras share one centre and no point can be triangulated.
  if (std::all_of(pairs.begin(), pairs.end(), [](const ImagePairGeometry& p) {
        return !(p.t.squaredNorm() > 0);
      })) {
    *failure = "pure rotation (panorama): all " + std::to_string(pairs.size()) +
               " pairs have no translation, the cameras share one centre and "
               "no 3D point can be triangulated";
    return false;
  }

  // Tracks from the inlier matches of the kept pairs.
  timer.Restart();
  stage = StageReport{"tracks"};
  *reconstruction = MakeReconstruction(database, cameras, rotations);
  std::vector<ImagePairMatches> matches;
  matches.reserve(pairs.size());
  for (const ImagePairGeometry& pair : pairs) {
    const TwoViewGeometry& geometry = database.two_view_geometries.at(
        geometry_index.at(ImagePairToPairId(pair.image_id1, pair.image_id2)));
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
  const std::vector<Track> tracks = BuildTracks(
      options.tracks, matches, reconstruction->images, &track_stats);
  const bool global_positioning =
      options.positioning_method == "global_positioning";
  // Global positioning needs only enough tracks to tie every camera down;
  // the others are triangulated from the refined poses afterwards.
  const std::vector<Track> positioning_tracks =
      global_positioning && !options.skip_retriangulation
          ? SelectTracksForPositioning(
                tracks, options.positioning_tracks_per_image)
          : tracks;
  if (global_positioning) {
    AddTracksToReconstruction(positioning_tracks, reconstruction);
  }
  stage.seconds = timer.ElapsedSeconds();
  stage.figures = {
      {"tracks", static_cast<double>(track_stats.num_tracks)},
      {"tracks for positioning",
       static_cast<double>(global_positioning ? positioning_tracks.size() : 0)},
      {"dropped inconsistent", static_cast<double>(track_stats.num_inconsistent)},
      {"dropped short", static_cast<double>(track_stats.num_too_short)},
      {"dropped long", static_cast<double>(track_stats.num_too_long)}};
  LogStage(prefix, stage);
  report->stages.push_back(stage);

  // Positioning of camera centres (and points).
  timer.Restart();
  stage = StageReport{options.positioning_method};
  if (global_positioning) {
    GlobalPositionerSummary positioner_summary;
    if (!RunGlobalPositioning(options.global_positioning, reconstruction,
                              &positioner_summary)) {
      *failure = "global positioning failed";
      return false;
    }
    stage.figures = {
        {"iterations", static_cast<double>(positioner_summary.num_iterations)},
        {"observations filtered",
         static_cast<double>(positioner_summary.num_observations_filtered)}};
  } else {
    TranslationAveragingSummary averaging_summary;
    if (!RunTranslationAveraging(options.translation_averaging, pairs,
                                 reconstruction, &averaging_summary)) {
      *failure = "translation averaging failed";
      return false;
    }
    const TriangulationSummary triangulation =
        TriangulateTracks(options.triangulation, tracks, reconstruction);
    stage.figures = {
        {"iterations", static_cast<double>(averaging_summary.num_iterations)},
        {"outlier pairs", static_cast<double>(averaging_summary.num_outlier_pairs)},
        {"points triangulated",
         static_cast<double>(triangulation.num_points_added)}};
  }
  stage.seconds = timer.ElapsedSeconds();
  AddModelFigures(reconstruction, &stage);
  LogStage(prefix, stage);
  report->stages.push_back(stage);

  // Bundle adjustment rounds, each followed by filtering; retriangulation of
  // every track after the first (then the poses are good enough).
  BundleAdjustmentOptions ba_options = options.bundle_adjustment;
  ba_options.refine_focal_length = options.ba_refine_focal_length;
  ba_options.refine_principal_point = options.ba_refine_principal_point;
  ba_options.refine_extra_params = options.ba_refine_extra_params;
  const int num_ba = options.skip_bundle_adjustment ? 0 : options.num_ba_iterations;
  bool retriangulated = options.skip_retriangulation;
  for (int iteration = 0; iteration < std::max(num_ba, 1); ++iteration) {
    if (iteration < num_ba) {
      timer.Restart();
      stage = StageReport{"bundle adjustment " + std::to_string(iteration + 1)};
      BundleAdjustmentSummary ba_summary;
      // After retriangulation the model is nearly clean: the last bundle
      // adjustment is one solve (a second one for the few observations its
      // filter removes changes nothing); the filtering below follows it.
      BundleAdjustmentOptions round_options = ba_options;
      if (retriangulated && iteration + 1 == num_ba) round_options.num_rounds = 1;
      if (!RunBundleAdjustment(round_options, reconstruction, &ba_summary)) {
        *failure = "bundle adjustment failed";
        return false;
      }
      const FilterSummary filter_summary =
          RunFiltering(options.filtering, reconstruction);
      stage.seconds = timer.ElapsedSeconds();
      stage.figures = {
          {"iterations", static_cast<double>(ba_summary.num_iterations)},
          {"observations filtered",
           static_cast<double>(ba_summary.num_observations_filtered +
                               filter_summary.num_observations_filtered)},
          {"points filtered (angle)",
           static_cast<double>(filter_summary.num_points_filtered)}};
      AddModelFigures(reconstruction, &stage);
      LogStage(prefix, stage);
      report->stages.push_back(stage);
    }
    if (!retriangulated) {
      timer.Restart();
      stage = StageReport{"retriangulation"};
      const TriangulationSummary triangulation =
          TriangulateTracks(options.triangulation, tracks, reconstruction);
      retriangulated = true;
      stage.seconds = timer.ElapsedSeconds();
      stage.figures = {
          {"tracks tried", static_cast<double>(triangulation.num_tracks_tried)},
          {"points added", static_cast<double>(triangulation.num_points_added)},
          {"observations added",
           static_cast<double>(triangulation.num_observations_added)}};
      AddModelFigures(reconstruction, &stage);
      LogStage(prefix, stage);
      report->stages.push_back(stage);
    }
  }

  if (!options.skip_filtering) {
    timer.Restart();
    stage = StageReport{"final filtering"};
    const FilterSummary filter_summary =
        RunFiltering(options.filtering, reconstruction);
    stage.seconds = timer.ElapsedSeconds();
    stage.figures = {
        {"observations filtered",
         static_cast<double>(filter_summary.num_observations_filtered)},
        {"points filtered (angle)",
         static_cast<double>(filter_summary.num_points_filtered)},
        {"images filtered",
         static_cast<double>(filter_summary.num_images_filtered)}};
    AddModelFigures(reconstruction, &stage);
    LogStage(prefix, stage);
    report->stages.push_back(stage);
  }
  RemoveUnusedCameras(reconstruction);
  if (static_cast<int>(reconstruction->images.size()) < options.min_model_size) {
    *failure = "only " + std::to_string(reconstruction->images.size()) +
               " images left after refinement";
    return false;
  }

  if (!options.skip_normalization) {
    timer.Restart();
    stage = StageReport{"normalisation"};
    NormalizeReconstruction(options.normalization, reconstruction);
    stage.seconds = timer.ElapsedSeconds();
    LogStage(prefix, stage);
    report->stages.push_back(stage);
  }
  return true;
}

}  // namespace

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
  manager->Add("BundleAdjustment.print_progress", &ba.print_progress,
               "print Ceres' iterations");

  manager->Add("Filter.max_reproj_error", &o.filtering.max_reproj_error,
               "observations over this reprojection error are removed (px)");
  manager->Add("Filter.min_tri_angle", &o.filtering.min_tri_angle,
               "points with a smaller largest triangulation angle are removed "
               "(deg)");
  manager->Add("Normalization.extent", &o.normalization.extent,
               "extent of the central part of the normalised scene");
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

int ColorPointsFromImages(const std::string& image_path,
                          Reconstruction* reconstruction, int downscale) {
  CHECK(downscale == 1 || downscale == 2 || downscale == 4 || downscale == 8)
      << downscale;
  // JPEG decoders scale by 2, 4 or 8 inside the DCT: much faster, and the
  // colour of a point (a mean over its track) barely changes.
  const int flags = downscale == 1   ? cv::IMREAD_COLOR
                    : downscale == 2 ? cv::IMREAD_REDUCED_COLOR_2
                    : downscale == 4 ? cv::IMREAD_REDUCED_COLOR_4
                                     : cv::IMREAD_REDUCED_COLOR_8;
  // Per image, the colour at each observation (read in parallel, summed
  // serially so that the result does not depend on the thread count).
  std::vector<const Image*> images;
  for (const auto& [image_id, image] : reconstruction->images) {
    images.push_back(&image);
  }
  std::vector<std::vector<std::pair<point3D_t, Eigen::Vector3d>>> colors(
      images.size());
  std::vector<char> missing(images.size(), 0);
  std::atomic<size_t> next(0);
  auto worker = [&]() {
    for (size_t i = next++; i < images.size(); i = next++) {
      const Image& image = *images[i];
      const cv::Mat bgr =
          cv::imread((fs::path(image_path) / image.name).string(), flags);
      if (bgr.empty()) {
        missing[i] = 1;
        continue;
      }
      for (const Point2D& point2D : image.points2D) {
        if (point2D.point3D_id == kInvalidPoint3DId) continue;
        // Keypoints put the centre of the top-left pixel at (0.5, 0.5):
        // bilinear interpolation between the four nearest pixel centres.
        const double x = point2D.xy.x() / downscale - 0.5;
        const double y = point2D.xy.y() / downscale - 0.5;
        const int x0 = static_cast<int>(std::floor(x));
        const int y0 = static_cast<int>(std::floor(y));
        if (x0 < 0 || y0 < 0 || x0 + 1 >= bgr.cols || y0 + 1 >= bgr.rows) {
          continue;
        }
        const double dx = x - x0;
        const double dy = y - y0;
        Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
        const double w[4] = {(1 - dx) * (1 - dy), dx * (1 - dy),
                             (1 - dx) * dy, dx * dy};
        const cv::Vec3b* pixels[4] = {&bgr.at<cv::Vec3b>(y0, x0),
                                      &bgr.at<cv::Vec3b>(y0, x0 + 1),
                                      &bgr.at<cv::Vec3b>(y0 + 1, x0),
                                      &bgr.at<cv::Vec3b>(y0 + 1, x0 + 1)};
        for (int k = 0; k < 4; ++k) {
          rgb += w[k] * Eigen::Vector3d((*pixels[k])[2], (*pixels[k])[1],
                                        (*pixels[k])[0]);
        }
        colors[i].emplace_back(point2D.point3D_id, rgb);
      }
    }
  };
  const int num_threads = std::max(
      1, std::min<int>(EffectiveNumThreads(-1), static_cast<int>(images.size())));
  std::vector<std::thread> threads;
  for (int t = 1; t < num_threads; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& thread : threads) thread.join();

  std::map<point3D_t, std::pair<Eigen::Vector3d, int>> sums;
  int num_missing = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    if (missing[i]) {
      ++num_missing;
      LOG(WARNING) << (fs::path(image_path) / images[i]->name).string()
                   << ": cannot read the image; its points stay grey";
    }
    for (const auto& [point3D_id, rgb] : colors[i]) {
      auto& sum = sums[point3D_id];
      if (sum.second == 0) sum.first.setZero();
      sum.first += rgb;
      ++sum.second;
    }
  }
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    const auto it = sums.find(point3D_id);
    if (it == sums.end()) {
      point.color.setConstant(128);
      continue;
    }
    const Eigen::Vector3d mean = it->second.first / it->second.second;
    for (int c = 0; c < 3; ++c) {
      point.color[c] = static_cast<uint8_t>(
          std::clamp(std::round(mean[c]), 0.0, 255.0));
    }
  }
  return num_missing;
}

std::string GlobalMapperSummary::ToJson() const {
  std::ostringstream out;
  out << "{\n  \"database_path\": " << JsonString(database_path)
      << ",\n  \"rotation_method\": " << JsonString(rotation_method)
      << ",\n  \"positioning_method\": " << JsonString(positioning_method)
      << ",\n  \"num_database_images\": " << num_database_images
      << ",\n  \"num_database_pairs\": " << num_database_pairs
      << ",\n  \"total_seconds\": " << JsonNumber(total_seconds)
      << ",\n  \"stages\": ";
  AppendStagesJson(stages, "  ", &out);
  out << ",\n  \"models\": [";
  for (size_t i = 0; i < components.size(); ++i) {
    const ComponentReport& c = components[i];
    out << (i ? "," : "") << "\n    {\"index\": " << c.index
        << ", \"path\": " << JsonString(std::to_string(c.index))
        << ", \"num_images_in_graph\": " << c.num_images_in_graph
        << ", \"num_pairs_in_graph\": " << c.num_pairs_in_graph
        << ", \"num_registered_images\": " << c.num_registered_images
        << ", \"num_points\": " << c.num_points
        << ", \"num_observations\": " << c.num_observations
        << ", \"mean_track_length\": " << JsonNumber(c.mean_track_length)
        << ", \"mean_reprojection_error\": "
        << JsonNumber(c.mean_reprojection_error) << ",\n     \"stages\": ";
    AppendStagesJson(c.stages, "     ", &out);
    out << "}";
  }
  out << (components.empty() ? "" : "\n  ") << "],\n  \"notes\": [";
  for (size_t i = 0; i < notes.size(); ++i) {
    out << (i ? ", " : "") << JsonString(notes[i]);
  }
  out << "]\n}\n";
  return out.str();
}

std::vector<Reconstruction> RunGlobalMapper(const GlobalMapperOptions& options,
                                            const DatabaseContents& database,
                                            const std::string& image_path,
                                            GlobalMapperSummary* summary) {
  options.Check();
  Timer total_timer;
  GlobalMapperOptions effective = options;
  effective.global_positioning.num_threads = options.num_threads;
  effective.bundle_adjustment.num_threads = options.num_threads;
  effective.translation_averaging.num_threads = options.num_threads;
  const bool show_progress =
      options.progress == 1 ||
      (options.progress == -1 &&
       (isatty(fileno(stderr)) || database.images.size() >= 100));
  effective.global_positioning.show_progress_bar = show_progress;
  effective.bundle_adjustment.show_progress_bar = show_progress;
  effective.translation_averaging.show_progress_bar = show_progress;
  summary->rotation_method = options.rotation_method;
  summary->positioning_method = options.positioning_method;
  summary->num_database_images = static_cast<int>(database.images.size());
  summary->num_database_pairs =
      static_cast<int>(database.two_view_geometries.size());
  if (options.skip_retriangulation) {
    summary->notes.push_back("retriangulation skipped");
  }

  Timer timer;
  ViewGraphSummary view_graph_summary;
  const ViewGraph view_graph =
      BuildViewGraph(database, effective.view_graph, &view_graph_summary);
  const std::vector<std::vector<image_t>> components =
      PairComponents(view_graph.pairs);
  StageReport stage{"view graph"};
  stage.seconds = timer.ElapsedSeconds();
  int num_dropped = 0;
  for (const auto& [reason, count] : view_graph_summary.num_dropped) {
    num_dropped += count;
  }
  stage.figures = {
      {"pairs read", static_cast<double>(view_graph_summary.num_pairs_read)},
      {"pairs kept", static_cast<double>(view_graph.pairs.size())},
      {"pairs dropped", static_cast<double>(num_dropped)},
      {"connected images", static_cast<double>(view_graph.image_names.size())},
      {"components", static_cast<double>(components.size())},
      {"largest component",
       components.empty() ? 0.0 : static_cast<double>(components[0].size())}};
  LogStage("", stage);
  summary->stages.push_back(stage);

  if (components.empty() ||
      static_cast<int>(components[0].size()) < options.min_model_size) {
    // Say what was dropped and why: "run a matcher" is wrong advice when the
    // pairs are there but a filter or the configuration removed them.
    std::string dropped;
    for (const auto& [reason, count] : view_graph_summary.num_dropped) {
      dropped += (dropped.empty() ? "" : ", ") + std::to_string(count) + " " +
                 reason;
    }
    throw InputError(
        database.path,
        "no model: the largest connected group of images has " +
            std::to_string(components.empty() ? 0 : components[0].size()) +
            " image(s), at least " + std::to_string(options.min_model_size) +
            " are needed (" + std::to_string(view_graph.pairs.size()) +
            " usable verified pairs of " +
            std::to_string(view_graph_summary.num_pairs_read) +
            (dropped.empty() ? "" : "; dropped: " + dropped) +
            (view_graph_summary.num_pairs_read == 0
                 ? "; run a matcher"
                 : "; see --ViewGraph.drop_configs, --Mapper.min_num_matches") +
            ")");
  }

  std::map<image_pair_t, size_t> geometry_index;
  for (size_t i = 0; i < database.two_view_geometries.size(); ++i) {
    const TwoViewGeometry& g = database.two_view_geometries[i];
    geometry_index[ImagePairToPairId(g.image_id1, g.image_id2)] = i;
  }

  std::vector<std::pair<Reconstruction, ComponentReport>> models;
  for (size_t c = 0; c < components.size(); ++c) {
    if (static_cast<int>(components[c].size()) < options.min_model_size) break;
    const std::set<image_t> images(components[c].begin(), components[c].end());
    std::vector<ImagePairGeometry> pairs;
    for (const ImagePairGeometry& pair : view_graph.pairs) {
      if (images.count(pair.image_id1)) pairs.push_back(pair);
    }
    const std::string prefix =
        components.size() > 1 ? "[component " + std::to_string(c) + "] " : "";
    Reconstruction reconstruction;
    ComponentReport report;
    std::string failure;
    if (!MapComponent(effective, database, view_graph.cameras, geometry_index,
                      components[c], pairs, prefix, &reconstruction, &report, &failure)) {
      LOG(WARNING) << prefix << "no model for the component of "
                   << components[c].size() << " images: " << failure;
      summary->notes.push_back("component of " +
                               std::to_string(components[c].size()) +
                               " images gave no model: " + failure);
      continue;
    }
    models.emplace_back(std::move(reconstruction), std::move(report));
  }
  if (models.empty()) {
    throw InputError(database.path,
                     "no model: no component could be reconstructed (see the "
                     "warnings above)");
  }
  // Largest first, by registered images (stable: graph order on ties).
  std::stable_sort(models.begin(), models.end(),
                   [](const auto& a, const auto& b) {
                     return a.first.images.size() > b.first.images.size();
                   });

  std::vector<Reconstruction> reconstructions;
  for (size_t k = 0; k < models.size(); ++k) {
    Reconstruction& reconstruction = models[k].first;
    ComponentReport& report = models[k].second;
    report.index = static_cast<int>(k);
    timer.Restart();
    StageReport colors{"colours"};
    if (!image_path.empty() && !options.skip_colors) {
      const int num_missing = ColorPointsFromImages(
          image_path, &reconstruction, options.color_image_downscale);
      colors.figures = {{"images read", static_cast<double>(
                                            reconstruction.images.size() -
                                            num_missing)},
                        {"images missing", static_cast<double>(num_missing)}};
      if (num_missing > 0) {
        summary->notes.push_back(std::to_string(num_missing) +
                                 " image(s) missing under " + image_path +
                                 ": their points are grey");
      }
    } else {
      for (auto& [point3D_id, point] : reconstruction.points3D) {
        point.color.setConstant(128);
      }
      colors.name += " (grey: no --image_path)";
    }
    colors.seconds = timer.ElapsedSeconds();
    LogStage(models.size() > 1 ? "[model " + std::to_string(k) + "] " : "",
             colors);
    report.stages.push_back(colors);

    report.mean_reprojection_error = UpdateReprojectionErrors(&reconstruction);
    report.num_registered_images = static_cast<int>(reconstruction.images.size());
    report.num_points = static_cast<int>(reconstruction.points3D.size());
    report.num_observations = static_cast<int>(NumObservations(reconstruction));
    report.mean_track_length = MeanTrackLength(reconstruction);
    LOG(INFO) << "Model " << k << ": " << report.num_registered_images
              << " registered images (of " << report.num_images_in_graph
              << " in the component), " << report.num_points << " points, "
              << report.num_observations << " observations, mean track length "
              << std::fixed << std::setprecision(2) << report.mean_track_length
              << ", mean reprojection error " << std::setprecision(3)
              << report.mean_reprojection_error << " px";
    summary->components.push_back(report);
    reconstructions.push_back(std::move(reconstruction));
  }
  summary->total_seconds += total_timer.ElapsedSeconds();
  return reconstructions;
}

GlobalMapperSummary RunGlobalMapperOnDatabase(
    const GlobalMapperOptions& options, const std::string& database_path,
    const std::string& image_path, const std::string& output_path,
    const std::string& output_type) {
  options.Check();
  if (output_type != "BIN" && output_type != "TXT" && output_type != "bin" &&
      output_type != "txt") {
    throw InputError("--output_type", "must be BIN or TXT");
  }
  if (!image_path.empty() && !fs::is_directory(image_path)) {
    throw InputError(image_path, "image directory does not exist");
  }
  // Output writable, OUT/0 replaceable, summary.json not a directory: checked
  // before any work; models are staged in a temporary directory and
  // installed atomically (util/atomic_output.h).
  OutputTransaction output(output_path);

  Timer total_timer;
  GlobalMapperSummary summary;
  summary.database_path = database_path;
  Timer timer;
  DatabaseReadOptions read_options;
  read_options.reset_invalid_cameras = options.reset_invalid_cameras;
  const DatabaseContents database = ReadDatabase(database_path, read_options);
  for (const std::string& warning : database.warnings) {
    summary.notes.push_back(database_path + ": " + warning);
  }
  // Names images.txt cannot hold fail now, not after the reconstruction.
  if (output_type == "TXT" || output_type == "txt") {
    for (const auto& [image_id, image] : database.images) {
      const std::string problem = TextImageNameProblem(image.name);
      if (!problem.empty()) {
        throw InputError(database_path, "image " + std::to_string(image_id) +
                                            ": " + problem +
                                            "; use --output_type BIN");
      }
    }
  }
  StageReport stage{"database"};
  stage.seconds = timer.ElapsedSeconds();
  size_t num_keypoints = 0;
  for (const auto& [image_id, keypoints] : database.keypoints) {
    num_keypoints += keypoints.size();
  }
  stage.figures = {{"cameras", static_cast<double>(database.cameras.size())},
                   {"images", static_cast<double>(database.images.size())},
                   {"keypoints", static_cast<double>(num_keypoints)},
                   {"verified pairs",
                    static_cast<double>(database.two_view_geometries.size())}};
  // Observations that never reach positioning or bundle adjustment.
  for (const auto& [reason, count] : database.num_keypoints_invalid) {
    stage.figures.push_back({reason + "s dropped", static_cast<double>(count)});
  }
  if (database.num_matches_dropped_invalid_keypoint > 0) {
    stage.figures.push_back(
        {"inlier matches dropped (invalid keypoint)",
         static_cast<double>(database.num_matches_dropped_invalid_keypoint)});
  }
  LogStage("", stage);
  summary.stages.push_back(stage);

  std::vector<Reconstruction> models =
      RunGlobalMapper(options, database, image_path, &summary);

  timer.Restart();
  for (size_t k = 0; k < models.size(); ++k) {
    WriteReconstruction(models[k], output.StagingModelPath(static_cast<int>(k)),
                        output_type);
  }
  for (const std::string& stale :
       output.StaleModelDirectories(static_cast<int>(models.size()))) {
    summary.notes.push_back(stale + " is left over from an earlier run");
  }
  stage = StageReport{"writing"};
  stage.seconds = timer.ElapsedSeconds();
  stage.figures = {{"models", static_cast<double>(models.size())}};
  LogStage("", stage);
  summary.stages.push_back(stage);
  summary.total_seconds = total_timer.ElapsedSeconds();
  WriteFileAtomically(output.StagingFilePath("summary.json"), summary.ToJson());
  output.Commit(static_cast<int>(models.size()), {"summary.json"});
  LOG(INFO) << "Wrote " << models.size() << " model(s) and summary.json to "
            << output_path << " in " << std::fixed << std::setprecision(2)
            << summary.total_seconds << " s total";
  return summary;
}

}  // namespace colmap_irav4
