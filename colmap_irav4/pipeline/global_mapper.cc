#include "colmap_irav4/pipeline/global_mapper.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/point_colors.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/threading.h"

namespace colmap_irav4 {
namespace {

// An image's keypoints as the database holds them (point3D ids unset).
std::vector<Point2D> DatabasePoints2D(const DatabaseContents& database,
                                      image_t image_id) {
  std::vector<Point2D> points2D;
  const auto keypoints = database.keypoints.find(image_id);
  if (keypoints == database.keypoints.end()) return points2D;
  points2D.resize(keypoints->second.size());
  for (size_t k = 0; k < keypoints->second.size(); ++k) {
    points2D[k].xy = keypoints->second[k].cast<double>();
  }
  const auto scales = database.keypoint_scales.find(image_id);
  if (scales != database.keypoint_scales.end()) {
    for (size_t k = 0; k < scales->second.size(); ++k) {
      points2D[k].scale = scales->second[k];
    }
  }
  return points2D;
}

// Whether `points2D` are the database's keypoints of `image_id` (those
// DatabasePoints2D reads, whatever their point3D ids).
bool AreDatabasePoints2D(const DatabaseContents& database, image_t image_id,
                         const std::vector<Point2D>& points2D) {
  const auto keypoints = database.keypoints.find(image_id);
  if (keypoints == database.keypoints.end() ||
      keypoints->second.size() != points2D.size()) {
    return false;
  }
  const auto scales = database.keypoint_scales.find(image_id);
  const std::vector<float>* scale =
      scales == database.keypoint_scales.end() ? nullptr : &scales->second;
  if (scale != nullptr && scale->size() != points2D.size()) return false;
  for (size_t k = 0; k < points2D.size(); ++k) {
    if (points2D[k].xy != keypoints->second[k].cast<double>() ||
        points2D[k].scale != (scale == nullptr ? 0.0f : (*scale)[k])) {
      return false;
    }
  }
  return true;
}

// The images of the model with their rotations and all their keypoints.
Reconstruction MakeReconstruction(
    const DatabaseContents& database, const std::map<camera_t, Camera>& cameras,
    const std::map<image_t, Eigen::Matrix3d>& rotations) {
  Reconstruction reconstruction;
  for (const auto& [image_id, R] : rotations) {
    const DatabaseImage& database_image = database.images.at(image_id);
    Image& image = reconstruction.images[image_id];
    image.image_id = image_id;
    image.name = database_image.name;
    image.camera_id = database_image.camera_id;
    image.cam_from_world.rotation = Eigen::Quaterniond(R).normalized();
    image.points2D = DatabasePoints2D(database, image_id);
    reconstruction.cameras[image.camera_id] = cameras.at(image.camera_id);
  }
  return reconstruction;
}

// The stall rule of the mapper's last adjustment: its own
// (last_stall_num_iterations, off by default), not the one of the
// adjustments before it.
void UseLastStallRule(BundleAdjustmentOptions* options) {
  options->stall_num_iterations = options->last_stall_num_iterations;
  options->stall_relative_decrease = options->last_stall_relative_decrease;
  if (options->last_gauge_min_shared_points > 0) {
    options->gauge_min_shared_points = options->last_gauge_min_shared_points;
  }
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

// The figures of a filtering (`num_observations_filtered_before`: by the
// bundle adjustment before it, counted with it).
void AddFilterFigures(int num_observations_filtered_before,
                      const FilterSummary& summary, StageTimer* stage) {
  stage->Add("observations filtered",
             static_cast<double>(num_observations_filtered_before +
                                 summary.num_observations_filtered));
  stage->Add("points filtered (angle)",
             static_cast<double>(summary.num_points_filtered));
  stage->Add("images filtered",
             static_cast<double>(summary.num_images_filtered));
  stage->Add("images filtered (bogus camera)",
             static_cast<double>(summary.bogus_camera_images.size()));
}

// How an adjustment's solves went: their iterations, and the counts that
// are not zero of conjugate gradients, images left out, solves stopped on
// the stall rule and solves started again damped.
void AddSolveFigures(const BundleAdjustmentSummary& summary,
                     StageTimer* stage) {
  stage->Add("iterations", static_cast<double>(summary.num_iterations));
  stage->Add("solves", static_cast<double>(summary.num_solves));
  if (summary.num_linear_iterations > 0) {
    stage->Add("conjugate gradient iterations",
               static_cast<double>(summary.num_linear_iterations));
  }
  if (summary.num_images_left_out > 0) {
    stage->Add("images left out (few observations)",
               static_cast<double>(summary.num_images_left_out));
  }
  if (summary.num_stalled_solves > 0) {
    stage->Add("solves stopped as the cost stalled",
               static_cast<double>(summary.num_stalled_solves));
  }
  if (summary.num_damped_restarts > 0) {
    stage->Add("solves started again damped",
               static_cast<double>(summary.num_damped_restarts));
  }
}

}  // namespace

GlobalMapper::GlobalMapper(const GlobalMapperOptions& options,
                           const DatabaseContents& database,
                           const std::map<camera_t, Camera>& cameras,
                           std::vector<image_t> images,
                           std::vector<ImagePairGeometry> pairs,
                           std::string log_prefix, const FoldEvidence* evidence)
    : options_(options),
      database_(database),
      cameras_(cameras),
      images_(std::move(images)),
      num_component_pairs_(pairs.size()),
      log_prefix_(std::move(log_prefix)),
      pairs_(std::move(pairs)),
      retriangulated_(options.skip_retriangulation),
      evidence_(evidence) {
  if (options_.weak_image_min_pair_triangles > 0) {
    given_pairs_.reserve(pairs_.size());
    for (const ImagePairGeometry& pair : pairs_) {
      given_pairs_.emplace_back(pair.image_id1, pair.image_id2);
    }
  }
}

bool GlobalMapper::Fail(const std::string& reason) {
  failure_ = reason;
  return false;
}

bool GlobalMapper::FailIfNoPoints(const std::string& when) {
  if (!reconstruction_.points3D.empty()) return true;
  const size_t num_without_translation = static_cast<size_t>(std::count_if(
      pairs_.begin(), pairs_.end(), [](const ImagePairGeometry& pair) {
        return !(pair.t.squaredNorm() > 0);
      }));
  std::ostringstream angle;
  angle << options_.filtering.min_tri_angle;
  // A panorama whose few noisy pairs got a spurious translation reaches this
  // point instead of the check in RotationFilter: positioning then places
  // every camera near one centre and the filter removes every point for its
  // triangulation angle. Most pairs without translation name the cause.
  if (2 * num_without_translation >= pairs_.size()) {
    return Fail(
        "pure rotation (panorama): " + std::to_string(num_without_translation) +
        " of " + std::to_string(pairs_.size()) +
        " pairs have no measurable translation and no 3D point has a "
        "triangulation angle of " +
        angle.str() + " deg " + when +
        ": the cameras share one centre and no 3D point can be "
        "triangulated");
  }
  return Fail("no 3D point left " + when + " (none has a triangulation angle " +
              "of " + angle.str() + " deg with a reprojection error " +
              "within the filter's limits)");
}

void GlobalMapper::AddModelFigures(StageTimer* stage) {
  const double error = UpdateReprojectionErrors(&reconstruction_);
  stage->Add("registered images",
             static_cast<double>(reconstruction_.images.size()));
  stage->Add("points", static_cast<double>(reconstruction_.points3D.size()));
  stage->Add("mean reprojection error per observation px", error);
  stage->Add("mean reprojection error per point px",
             MeanPointReprojectionError(reconstruction_));
}

void GlobalMapper::WarnFilteredImages(const FilterSummary& summary) const {
  if (!summary.bogus_camera_images.empty()) {
    // The deleted images' cameras stay in the model until Finalize: their
    // parameters say what went wrong.
    std::ostringstream names;
    for (image_t image_id : summary.bogus_camera_images) {
      const DatabaseImage& image = database_.images.at(image_id);
      const Camera& camera = reconstruction_.cameras.at(image.camera_id);
      names << " " << image.name << " (focal length "
            << CameraMeanFocalLength(camera) << " px, " << camera.width << " x "
            << camera.height << ")";
    }
    LOG(WARNING) << log_prefix_ << summary.bogus_camera_images.size()
                 << " image(s) removed from the model with their "
                 << summary.num_bogus_camera_observations
                 << " observation(s): their camera has bogus parameters "
                    "(focal length outside ["
                 << options_.filtering.min_focal_length_ratio << ", "
                 << options_.filtering.max_focal_length_ratio
                 << "] x the larger image side, principal point outside the "
                    "image or a distortion parameter over "
                 << options_.filtering.max_extra_param << "):" << names.str();
  }
  if (summary.filtered_images.empty()) return;
  // Not a failure, but the model is smaller than the component: say which
  // images left it and why (their poses had no point to rest on).
  std::ostringstream names;
  for (image_t image_id : summary.filtered_images) {
    names << " " << database_.images.at(image_id).name;
  }
  LOG(WARNING) << log_prefix_ << summary.filtered_images.size()
               << " image(s) removed from the model: fewer than "
               << options_.filtering.min_num_observations_per_image
               << " observation(s) left after the filters, so no point "
                  "supports the pose rotation averaging and positioning gave "
                  "them:"
               << names.str();
}

std::set<image_t> GlobalMapper::CurrentImages() const {
  std::set<image_t> images;
  if (state_ == State::kNew && reconstruction_.images.empty()) {
    for (const auto& [image_id, rotation] : rotations_) images.insert(image_id);
  } else {
    for (const auto& [image_id, image] : reconstruction_.images) {
      images.insert(image_id);
    }
  }
  return images;
}

void GlobalMapper::LogImagesLeft(const std::string& stage,
                                 const std::set<image_t>& before) const {
  if (!VLOG_IS_ON(1)) return;
  const std::set<image_t> after = CurrentImages();
  std::ostringstream names;
  int num_left = 0;
  for (const image_t image_id : before) {
    if (after.count(image_id)) continue;
    ++num_left;
    const auto it = database_.images.find(image_id);
    names << " "
          << (it != database_.images.end() ? it->second.name
                                           : std::to_string(image_id));
  }
  if (num_left > 0) {
    VLOG(1) << log_prefix_ << stage << ": " << num_left
            << " image(s) left the model:" << names.str();
  }
}

bool GlobalMapper::Solve(bool stop_if_folded) {
  ResumeKeypoints();
  if (state_ == State::kNew) {
    // Rotations a caller averaged already (RotationAveraging() before
    // Solve(): the part merge's probe) are not averaged again.
    if (!(rotations_averaged_ || RotationAveraging())) {
      state_ = State::kFailed;
      return false;
    }
    const std::set<image_t> averaged = CurrentImages();
    if (!RotationFilter()) {
      state_ = State::kFailed;
      return false;
    }
    LogImagesLeft("rotation filter", averaged);
    const std::set<image_t> filtered = CurrentImages();
    if (!(BuildTracks() && Positioning())) {
      state_ = State::kFailed;
      return false;
    }
    LogImagesLeft("tracks and positioning", filtered);
    state_ = State::kPositioned;
    if (CheckFold("after positioning") && stop_if_folded) return true;
  }
  if (state_ == State::kPositioned) {
    const std::set<image_t> positioned = CurrentImages();
    if (!(IterativeBundleAdjustment() && Finalize())) {
      state_ = State::kFailed;
      return false;
    }
    LogImagesLeft("refinement (bundle adjustment, filtering)", positioned);
    state_ = State::kRefined;
    // Retriangulation made the points of every track it could: the tracks
    // are not read again (a model kept for writing holds no copy of them).
    tracks_ = std::vector<Track>();
    CheckFold("after refinement");
  }
  return state_ == State::kRefined;
}

bool GlobalMapper::CheckFold(const std::string& when) {
  if (evidence_ == nullptr || !options_.fold.detect) return false;
  ResumeKeypoints();
  StageTimer stage("fold check (" + when + ")");
  // After positioning the model holds only the tracks selected for it: the
  // predicted overlap is scaled to all the tracks, which the verified
  // inliers count (DetectFold's `tracks`).
  fold_ = DetectFold(options_.fold.detection, reconstruction_, *evidence_,
                     state_ == State::kRefined ? nullptr : &tracks_);
  fold_checked_ = true;
  stage.Add("fold score", fold_.fold_score);
  stage.Add("predicted pairs", static_cast<double>(fold_.num_predicted_pairs));
  stage.Add("missing pairs", static_cast<double>(fold_.num_missing_pairs));
  stage.Add("contradicted strong pairs",
            static_cast<double>(fold_.num_strong_inconsistent_pairs));
  stage.Add("contradictory tracks",
            static_cast<double>(fold_.num_contradictory_tracks));
  stage.Add("suspect pairs", static_cast<double>(fold_.suspect_pairs.size()));
  stage.Add("weak pairs", static_cast<double>(fold_.num_weak_pairs));
  stage.Add("weak pairs across their cut",
            static_cast<double>(fold_.num_weak_cut_pairs));
  stage.Finish(log_prefix_, &stages_);
  LOG(INFO) << log_prefix_ << "fold check (" << when
            << "): " << fold_.Describe();
  return fold_.folded;
}

ModelRigidity GlobalMapper::CheckRigidity() {
  ResumeKeypoints();
  StageTimer stage("rigidity check");
  const ModelRigidity rigidity = AnalyzeModelRigidity(
      ModelRigidityOptions(), reconstruction_, options_.min_model_size);
  stage.Add("blocks", static_cast<double>(rigidity.blocks.size()));
  stage.Add("large blocks", static_cast<double>(rigidity.num_large_blocks));
  stage.Finish(log_prefix_, &stages_);
  return rigidity;
}

void GlobalMapper::LeaveOutWeakParts(const std::string& when) {
  const int min_triangles = options_.weak_image_min_pair_triangles;
  if (options_.weak_part_min_shared_points <= 0 && min_triangles <= 0) {
    return;
  }
  ResumeKeypoints();
  StageTimer stage("weak parts (" + when + ")");
  int num_unchecked_left_out = 0;
  if (min_triangles > 0) {
    const std::set<image_t> before = CurrentImages();
    std::set<image_t> kept = before;
    while (true) {
      std::map<image_t, std::set<image_t>> partners;
      for (const auto& [image_id1, image_id2] : given_pairs_) {
        if (kept.count(image_id1) && kept.count(image_id2)) {
          partners[image_id1].insert(image_id2);
          partners[image_id2].insert(image_id1);
        }
      }
      std::vector<image_t> unchecked;
      for (const image_t image_id : kept) {
        int num_triangles = 0;
        const std::set<image_t>& mine = partners[image_id];
        for (auto a = mine.begin(); a != mine.end(); ++a) {
          const std::set<image_t>& theirs = partners[*a];
          for (auto b = std::next(a);
               b != mine.end() && num_triangles < min_triangles; ++b) {
            num_triangles += theirs.count(*b) > 0 ? 1 : 0;
          }
          if (num_triangles >= min_triangles) break;
        }
        if (num_triangles < min_triangles) unchecked.push_back(image_id);
      }
      if (unchecked.empty()) break;
      for (const image_t image_id : unchecked) kept.erase(image_id);
    }
    if (kept.size() < before.size() &&
        static_cast<int>(kept.size()) >= options_.min_model_size) {
      num_unchecked_left_out = static_cast<int>(before.size() - kept.size());
      RestrictToImages(kept);
      LogImagesLeft(stage.report().name + " (in no pair triangle)", before);
    }
  }
  if (options_.weak_part_min_shared_points <= 0) {
    stage.Add("images left out (few pair triangles)", num_unchecked_left_out);
    AddModelFigures(&stage);
    stage.Finish(log_prefix_, &stages_);
    return;
  }
  ModelRigidityOptions rigidity_options;
  rigidity_options.min_shared_points = options_.weak_part_min_shared_points;
  ModelRigidity rigidity;
  if (retriangulated_) {
    rigidity = AnalyzeModelRigidity(rigidity_options, reconstruction_,
                                    options_.min_model_size);
  } else {
    // Before retriangulation the model holds positioning's tracks only: the
    // ties are those every track will give.
    std::vector<image_t> images;
    for (const auto& [image_id, image] : reconstruction_.images) {
      images.push_back(image_id);
    }
    std::vector<std::vector<image_t>> point_images;
    point_images.reserve(tracks_.size());
    for (const Track& track : tracks_) {
      std::vector<image_t>& ids = point_images.emplace_back();
      for (const TrackElement& element : track) ids.push_back(element.image_id);
    }
    rigidity = AnalyzeTieRigidity(rigidity_options, images, point_images,
                                  options_.min_model_size);
  }
  std::map<image_t, int> part_of;
  int num_parts = 0;
  for (const std::vector<image_t>& block : rigidity.blocks) {
    if (static_cast<int>(block.size()) < options_.min_model_size) continue;
    for (const image_t image_id : block) part_of[image_id] = num_parts;
    ++num_parts;
  }
  int num_images_left_out = 0;
  int num_observations_cut = 0;
  // Without a part large enough the model stays as it is (its own
  // failure, if any, is the later stages' to report).
  if (num_parts > 0) {
    std::set<image_t> kept;
    for (const auto& [image_id, part] : part_of) kept.insert(image_id);
    const std::set<image_t> before = CurrentImages();
    num_images_left_out = static_cast<int>(before.size() - kept.size());
    if (num_images_left_out > 0) {
      RestrictToImages(kept);
      LogImagesLeft(stage.report().name, before);
    }
    if (num_parts > 1) {
      std::vector<TrackElement> cut;
      std::vector<int> count(num_parts, 0);
      for (const auto& [point3D_id, point3D] : reconstruction_.points3D) {
        std::fill(count.begin(), count.end(), 0);
        for (const TrackElement& element : point3D.track) {
          ++count[part_of.at(element.image_id)];
        }
        const int home = static_cast<int>(
            std::max_element(count.begin(), count.end()) - count.begin());
        for (const TrackElement& element : point3D.track) {
          if (part_of.at(element.image_id) != home) cut.push_back(element);
        }
      }
      for (const TrackElement& element : cut) {
        DeleteObservation(element.image_id, element.point2D_idx,
                          &reconstruction_);
      }
      num_observations_cut = static_cast<int>(cut.size());
    }
  }
  stage.Add("images left out (few pair triangles)", num_unchecked_left_out);
  stage.Add("parts", num_parts);
  stage.Add("images left out", num_images_left_out);
  stage.Add("observations cut between parts", num_observations_cut);
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
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
  rotations_averaged_ = true;
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
  pairs_ = PairsWithin(pairs_, kept_images);
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
  TrackBuilder track_builder(options_.tracks, reconstruction_.images);
  for (const ImagePairGeometry& pair : pairs_) {
    const TwoViewGeometry& geometry =
        *geometries.at(ImagePairToPairId(pair.image_id1, pair.image_id2));
    track_builder.AddMatches(geometry.image_id1, geometry.image_id2,
                             geometry.inlier_matches);
  }
  TrackBuilderStats track_stats;
  tracks_ = track_builder.Build(&track_stats);
  const bool global_positioning =
      options_.positioning_method == PositioningMethod::kGlobalPositioning;
  // Global positioning needs only enough tracks to tie every camera down;
  // the others are triangulated from the refined poses afterwards.
  std::vector<size_t> selected;
  // Parallel to `selected`: the observations each gives positioning.
  std::vector<Track> selected_observations;
  positioning_dropped_.clear();
  if (global_positioning) {
    const PositioningTrackSelectionOptions& selection =
        options_.positioning_tracks;
    std::vector<std::pair<image_t, image_t>> pair_ids;
    std::vector<double> pair_inliers;  // the pair quota's pairs' strengths
    pair_ids.reserve(pairs_.size());
    pair_inliers.reserve(pairs_.size());
    for (const ImagePairGeometry& pair : pairs_) {
      pair_ids.emplace_back(pair.image_id1, pair.image_id2);
      pair_inliers.push_back(pair.num_inliers);
    }
    const ObservationCellFn cell = [&](const TrackElement& element) {
      const Image& image = reconstruction_.images.at(element.image_id);
      const Camera& camera = reconstruction_.cameras.at(image.camera_id);
      const Eigen::Vector2d& xy = image.points2D[element.point2D_idx].xy;
      return GridCell(xy.x(), xy.y(), static_cast<double>(camera.width),
                      static_cast<double>(camera.height), selection.grid_size);
    };
    selected = SelectTracksForPositioning(selection, tracks_, pair_ids, cell,
                                          pair_inliers, &selected_observations);
  }
  // The cap: positioning's tracks first (they keep every pair tied), then
  // the longest; the others are dropped.
  size_t num_capped = 0;
  const size_t cap = static_cast<size_t>(options_.max_num_tracks);
  if (options_.max_num_tracks > 0 && tracks_.size() > cap) {
    const size_t num_positioning_selected = selected.size();
    std::vector<char> priority(tracks_.size(), 0);
    for (const size_t k : selected) priority[k] = 1;
    std::vector<size_t> order(tracks_.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return priority[a] != priority[b] ? priority[a] > priority[b]
                                        : tracks_[a].size() > tracks_[b].size();
    });
    std::vector<char> keep(tracks_.size(), 0);
    for (size_t k = 0; k < cap; ++k) keep[order[k]] = 1;
    std::vector<Track> kept;
    std::vector<size_t> kept_selected;
    std::vector<Track> kept_observations;
    kept.reserve(cap);
    size_t next_selected = 0;  // `selected` is increasing
    for (size_t k = 0; k < tracks_.size(); ++k) {
      const bool is_selected =
          next_selected < selected.size() && selected[next_selected] == k;
      if (is_selected) ++next_selected;
      if (!keep[k]) continue;
      if (is_selected) {
        kept_selected.push_back(kept.size());
        kept_observations.push_back(
            std::move(selected_observations[next_selected - 1]));
      }
      kept.push_back(std::move(tracks_[k]));
    }
    num_capped = tracks_.size() - kept.size();
    LOG(WARNING) << log_prefix_ << tracks_.size()
                 << " tracks exceed --Mapper.max_num_tracks " << cap << ": the "
                 << num_capped
                 << " shortest are dropped (fewer points, less memory; raise "
                    "the cap or set it to 0 for all)";
    tracks_ = std::move(kept);
    selected = std::move(kept_selected);
    selected_observations = std::move(kept_observations);
    // A cap that leaves a camera with too few of positioning's observations
    // cannot place it: the model would be wrong (cameras hundreds of metres
    // off), not smaller. 5: a camera centre's 3 unknowns with some margin.
    if (global_positioning) {
      constexpr int kMinObservations = 5;
      std::map<image_t, int> observations;
      for (const Track& track : selected_observations) {
        for (const TrackElement& element : track) {
          ++observations[element.image_id];
        }
      }
      for (const image_t image_id : images_) {
        if (observations[image_id] >= kMinObservations) continue;
        throw InputError(
            "--Mapper.max_num_tracks",
            std::to_string(cap) + " leaves image " + std::to_string(image_id) +
                " with " + std::to_string(observations[image_id]) +
                " observation(s) for positioning, at least " +
                std::to_string(kMinObservations) +
                " are needed to place a camera; raise it (positioning "
                "selects " +
                std::to_string(num_positioning_selected) +
                " tracks; 0: no cap)");
      }
    }
  }
  size_t num_positioning_tracks = 0;
  if (global_positioning) {
    const std::vector<point3D_t> point3D_ids =
        AddTracksToReconstruction(selected_observations, &reconstruction_);
    num_positioning_tracks = selected.size();
    // The observations the cap left out, to be added back after positioning.
    size_t num_observations = 0;
    for (size_t i = 0; i < selected.size(); ++i) {
      const Track& track = tracks_[selected[i]];
      const Track& kept = selected_observations[i];
      num_observations += track.size();
      if (kept.size() == track.size()) continue;
      // `kept` is a subsequence of `track`.
      size_t j = 0;
      for (const TrackElement& element : track) {
        if (j < kept.size() && kept[j].image_id == element.image_id &&
            kept[j].point2D_idx == element.point2D_idx) {
          ++j;
        } else {
          positioning_dropped_.emplace_back(point3D_ids[i], element);
        }
      }
    }
    positioning_schur_density_ = -1;
    if (!positioning_dropped_.empty()) {
      // The linear solver is chosen by the density of the tracks as
      // selected: the cap thins the problem, not the graph's coupling
      // (5,000 photo images: 5.2% -> 4.9% counted after it, under the 5%
      // of --GlobalPositioning.iterative_schur_min_density, and a sparse
      // factor that fills in to nearly dense).
      std::vector<const Track*> uncapped;
      uncapped.reserve(selected.size());
      for (const size_t k : selected) uncapped.push_back(&tracks_[k]);
      positioning_schur_density_ = SchurDensity(uncapped);
      LOG(INFO) << log_prefix_ << "positioning: " << positioning_dropped_.size()
                << " of " << num_observations << " observations of its "
                << selected.size()
                << " tracks left out by "
                   "--Mapper.positioning_max_observations_per_image "
                << options_.positioning_tracks.max_observations_per_image
                << " (added back after it)";
      stage.Add("positioning observations left out (per-image cap)",
                static_cast<double>(positioning_dropped_.size()));
    }
  }
  selected_observations.clear();
  selected_observations.shrink_to_fit();
  stage.Add("tracks", static_cast<double>(track_stats.num_tracks));
  stage.Add("tracks for positioning",
            static_cast<double>(num_positioning_tracks));
  stage.Add("dropped inconsistent",
            static_cast<double>(track_stats.num_inconsistent));
  stage.Add("dropped short", static_cast<double>(track_stats.num_too_short));
  stage.Add("dropped long", static_cast<double>(track_stats.num_too_long));
  stage.Add("dropped (max_num_tracks)", static_cast<double>(num_capped));
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::Positioning() {
  StageTimer stage(EnumName(options_.positioning_method));
  if (options_.positioning_method == PositioningMethod::kGlobalPositioning) {
    GlobalPositionerSummary positioner_summary;
    if (!RunGlobalPositioning(
            options_.global_positioning, &reconstruction_, &positioner_summary,
            options_.use_pose_priors ? &database_.pose_priors : nullptr,
            positioning_schur_density_)) {
      return Fail("global positioning failed");
    }
    if (!positioning_dropped_.empty()) {
      const size_t num_restored = RestorePositioningObservations(
          positioning_dropped_,
          options_.global_positioning.max_angular_error_deg, &reconstruction_);
      stage.Add("observations added back (per-image cap)",
                static_cast<double>(num_restored));
      LOG(INFO) << log_prefix_ << "positioning: " << num_restored << " of "
                << positioning_dropped_.size()
                << " observations left out of it added back (within "
                << options_.global_positioning.max_angular_error_deg << " deg)";
      positioning_dropped_.clear();
      positioning_dropped_.shrink_to_fit();
    }
    // Pose priors: the model is in their frame from here on.
    in_prior_frame_ = positioner_summary.in_prior_frame;
    if (in_prior_frame_) {
      stage.Add("position priors",
                static_cast<double>(positioner_summary.num_position_priors));
      stage.Add(
          "position prior inliers",
          static_cast<double>(positioner_summary.num_position_prior_inliers));
      stage.Add("gravity priors",
                static_cast<double>(positioner_summary.num_gravity_priors));
      // Logged as a warning by positioning: a fold or poor priors.
      if (positioner_summary.priors_disagree) {
        stage.Add(
            "warning: position priors off the model",
            static_cast<double>(positioner_summary.num_position_priors -
                                positioner_summary.num_position_prior_inliers));
      }
    }
    stage.Add("iterations",
              static_cast<double>(positioner_summary.num_iterations));
    stage.Add("observations",
              static_cast<double>(positioner_summary.num_observations));
    stage.Add(
        "observations filtered",
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

bool GlobalMapper::RunAdjustment(const std::string& /*stage*/,
                                 const std::function<bool()>& adjust) {
  return adjust();
}

bool GlobalMapper::AdjustOrKeepModel(StageTimer* stage,
                                     const std::string& failure,
                                     const std::function<bool()>& adjust,
                                     bool* kept) {
  *kept = false;
  const std::string& name = stage->report().name;
  if (!adjusted_) {
    if (!RunAdjustment(name, adjust)) return Fail(failure);
    adjusted_ = true;
    return true;
  }
  // A failed solve may leave the model part-way (poses moved, observations
  // filtered between rounds, the two-view check's points set aside): the
  // copy is what is kept. It costs one model's memory next to the problem's.
  Reconstruction before = reconstruction_;
  if (RunAdjustment(name, adjust)) return true;
  reconstruction_ = std::move(before);
  *kept = true;
  LOG(WARNING) << log_prefix_ << name
               << ": bundle adjustment failed (Ceres found no usable "
                  "solution); the model is kept as it was before it (after "
                  "the last bundle adjustment that succeeded)";
  stage->Add("warning: bundle adjustment failed, model kept as before it", 1);
  return true;
}

bool GlobalMapper::IterativeBundleAdjustment() {
  const int num_ba =
      options_.skip_bundle_adjustment ? 0 : options_.num_ba_iterations;
  for (int iteration = 0; iteration < std::max(num_ba, 1); ++iteration) {
    if (iteration < num_ba) {
      LeaveOutWeakParts("before bundle adjustment " +
                        std::to_string(iteration + 1));
      StageTimer stage("bundle adjustment " + std::to_string(iteration + 1));
      // After retriangulation the model is nearly clean: the last bundle
      // adjustment is one solve (a second one for the few observations its
      // filter removes changes nothing); the filtering below follows it.
      BundleAdjustmentOptions round_options = options_.bundle_adjustment;
      if (retriangulated_ && iteration + 1 == num_ba) {
        round_options.num_rounds = 1;
      }
      // Only the last adjustment must reach its tolerances: the ones before
      // it hand their poses to retriangulation and the next adjustment
      // (its own stall rule, last_stall_num_iterations, off by default).
      if (iteration + 1 == num_ba) UseLastStallRule(&round_options);
      if (!FailIfNoPoints(iteration == 0 ? "after positioning"
                                         : "after retriangulation")) {
        return false;
      }
      BundleAdjustmentSummary ba_summary;
      bool kept = false;
      if (!AdjustOrKeepModel(
              &stage, "bundle adjustment failed",
              [&] {
                return RunBundleAdjustment(
                    round_options, &reconstruction_, &ba_summary,
                    in_prior_frame_ ? &database_.pose_priors : nullptr);
              },
              &kept)) {
        return false;
      }
      if (!kept) {
        keypoint_noise_ = ba_summary.keypoint_noise;
        const FilterSummary filter_summary = RunFiltering(
            options_.filtering, &reconstruction_, &keypoint_noise_);
        AddSolveFigures(ba_summary, &stage);
        if (!ba_summary.scale_bin_noise_px.empty()) {
          // The noise that weighed the observations: finest and coarsest of
          // the keypoint scale bins.
          stage.Add("keypoint noise px (finest scales)",
                    ba_summary.scale_bin_noise_px.front());
          stage.Add("keypoint noise px (coarsest scales)",
                    ba_summary.scale_bin_noise_px.back());
        }
        if (in_prior_frame_) RecordRejectedPriors(ba_summary, &stage);
        stage.AddText("solver backend", ba_summary.backend_reason);
        stage.AddText("linear solver", ba_summary.linear_solver_reason);
        if (ba_summary.schur_density >= 0) {
          stage.Add("pairs sharing a point (fraction)",
                    ba_summary.schur_density);
        }
        // Where its time goes (wall seconds; not figures: they vary by run).
        LOG(INFO) << log_prefix_ << "bundle adjustment "
                  << std::to_string(iteration + 1) << ": "
                  << ba_summary.backend_reason << "; "
                  << (ba_summary.linear_solver_reason.empty()
                          ? ba_summary.linear_solver
                          : ba_summary.linear_solver_reason)
                  << ", building the problems " << ba_summary.problem_seconds
                  << " s, Ceres' preprocessing "
                  << ba_summary.preprocessor_seconds << " s, linear solves "
                  << ba_summary.linear_solver_seconds << " s of "
                  << ba_summary.seconds << " s";
        AddFilterFigures(ba_summary.num_observations_filtered, filter_summary,
                         &stage);
        WarnFilteredImages(filter_summary);
      }
      AddModelFigures(&stage);
      stage.Finish(log_prefix_, &stages_);
    }
    // Every track is triangulated once, after the first round: then the
    // poses are good enough.
    if (!retriangulated_ &&
        !(Retriangulation() && TwoViewCheck() && PointMerging())) {
      return false;
    }
  }
  return true;
}

void GlobalMapper::RecordRejectedPriors(const BundleAdjustmentSummary& summary,
                                        StageTimer* stage) {
  const auto names = [&](const std::vector<image_t>& image_ids) {
    std::vector<std::string> result;
    for (const image_t image_id : image_ids) {
      result.push_back(reconstruction_.images.at(image_id).name);
    }
    return result;
  };
  rejected_position_priors_ = names(summary.rejected_position_priors);
  rejected_gravity_priors_ = names(summary.rejected_gravity_priors);
  stage->Add("position priors left out (beyond the gate)",
             static_cast<double>(rejected_position_priors_.size()));
  stage->Add("gravity priors left out (beyond the gate)",
             static_cast<double>(rejected_gravity_priors_.size()));
  const auto log = [&](const std::vector<std::string>& rejected,
                       const std::string& kind) {
    if (rejected.empty()) return;
    std::ostringstream list;
    for (size_t k = 0; k < rejected.size(); ++k) {
      list << (k ? ", " : "") << rejected[k];
    }
    LOG(INFO) << log_prefix_ << stage->report().name << ": " << rejected.size()
              << " " << kind << " prior(s) more than "
              << options_.bundle_adjustment.pose_priors.gate_std
              << " standard deviations off the model left out: " << list.str();
  };
  log(rejected_position_priors_, "position");
  log(rejected_gravity_priors_, "gravity");
}

bool GlobalMapper::Retriangulation() {
  StageTimer stage("retriangulation");
  const TriangulationSummary triangulation = TriangulateTracks(
      options_.triangulation, tracks_, &reconstruction_, &keypoint_noise_);
  retriangulated_ = true;
  stage.Add("tracks tried",
            static_cast<double>(triangulation.num_tracks_tried));
  stage.Add("points added",
            static_cast<double>(triangulation.num_points_added));
  stage.Add("observations added",
            static_cast<double>(triangulation.num_observations_added));
  stage.Add("observations added to their track's point",
            static_cast<double>(triangulation.num_observations_completed));
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::TwoViewCheck() {
  if (!options_.two_view_check.enabled || options_.skip_bundle_adjustment) {
    return true;
  }
  LeaveOutWeakParts("before the two-view check");
  StageTimer stage("two-view check");
  TwoViewCheckSummary summary;
  bool kept = false;
  // Its adjustment is the last one when no bundle adjustment follows.
  BundleAdjustmentOptions check_options = options_.bundle_adjustment;
  if (options_.num_ba_iterations <= 1) UseLastStallRule(&check_options);
  if (!AdjustOrKeepModel(
          &stage, "bundle adjustment of the two-view check failed",
          [&] {
            return CheckTwoViewPoints(
                options_.two_view_check, check_options, options_.triangulation,
                options_.pose_constraint, &reconstruction_, &keypoint_noise_,
                &summary);
          },
          &kept)) {
    return false;
  }
  if (kept) {
    AddModelFigures(&stage);
    stage.Finish(log_prefix_, &stages_);
    return true;
  }
  stage.Add("two-view points checked",
            static_cast<double>(summary.num_points_checked));
  stage.Add("two-view points restored",
            static_cast<double>(summary.num_points_restored));
  stage.Add("images poorly constrained",
            static_cast<double>(summary.num_images_poorly_constrained));
  stage.Add("two-view points withheld",
            static_cast<double>(summary.num_points_withheld));
  AddSolveFigures(summary.bundle_adjustment, &stage);
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::PointMerging() {
  if (!options_.point_merging.enabled) return true;
  StageTimer stage("point merging");
  const PointMergingSummary summary =
      MergePoints(options_.point_merging, &reconstruction_, &keypoint_noise_);
  stage.Add("candidates tested", static_cast<double>(summary.num_candidates));
  stage.Add("points merged", static_cast<double>(summary.num_merges));
  stage.Add("observations moved",
            static_cast<double>(summary.num_observations_moved));
  stage.Add("noise variance px^2", summary.noise_variance);
  AddModelFigures(&stage);
  stage.Finish(log_prefix_, &stages_);
  return true;
}

bool GlobalMapper::Finalize() {
  if (!options_.skip_filtering) {
    StageTimer stage("final filtering");
    const FilterSummary filter_summary =
        RunFiltering(options_.filtering, &reconstruction_, &keypoint_noise_);
    AddFilterFigures(0, filter_summary, &stage);
    WarnFilteredImages(filter_summary);
    AddModelFigures(&stage);
    stage.Finish(log_prefix_, &stages_);
  }
  if (!FailIfNoPoints("after refinement")) return false;
  RemoveUnusedCameras(&reconstruction_);
  if (static_cast<int>(reconstruction_.images.size()) <
      options_.min_model_size) {
    return Fail("only " + std::to_string(reconstruction_.images.size()) +
                " images left after refinement");
  }
  // A model in the pose priors' frame stays there (metric).
  if (!options_.skip_normalization && !in_prior_frame_) {
    StageTimer stage("normalisation");
    NormalizeReconstruction(options_.normalization, &reconstruction_);
    stage.Finish(log_prefix_, &stages_);
  }
  return true;
}

void GlobalMapper::RestrictToImages(const std::set<image_t>& images) {
  ResumeKeypoints();
  std::vector<image_t> dropped;
  for (const auto& [image_id, image] : reconstruction_.images) {
    if (!images.count(image_id)) dropped.push_back(image_id);
  }
  for (const image_t image_id : dropped) {
    DeleteImage(image_id, &reconstruction_);
  }
  RemoveUnusedCameras(&reconstruction_);
  pairs_ = PairsWithin(pairs_, images);
}

int GlobalMapper::ColorPoints(const std::string& image_path) {
  ResumeKeypoints();
  StageTimer stage("colours");
  int num_missing = 0;
  if (!image_path.empty() && !options_.skip_colors) {
    num_missing = ColorPointsFromImages(image_path, &reconstruction_,
                                        options_.color_image_downscale,
                                        options_.num_threads);
    stage.Add("images read",
              static_cast<double>(reconstruction_.images.size() - num_missing));
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

void GlobalMapper::SuspendKeypoints() {
  // Only where ResumeKeypoints gives back exactly what is released: the
  // database's keypoints, linked to the points whose tracks name them and
  // to no other.
  std::map<image_t, size_t> num_linked;
  std::set<image_t> kept;
  for (const auto& [point3D_id, point] : reconstruction_.points3D) {
    for (const TrackElement& element : point.track) {
      const auto image = reconstruction_.images.find(element.image_id);
      if (image == reconstruction_.images.end()) continue;
      const std::vector<Point2D>& points2D = image->second.points2D;
      if (element.point2D_idx >= points2D.size() ||
          points2D[element.point2D_idx].point3D_id != point3D_id) {
        kept.insert(element.image_id);
      }
      ++num_linked[element.image_id];
    }
  }
  for (auto& [image_id, image] : reconstruction_.images) {
    if (image.points2D.empty() || kept.count(image_id) ||
        suspended_images_.count(image_id) ||
        !AreDatabasePoints2D(database_, image_id, image.points2D)) {
      continue;
    }
    const size_t num_points2D_linked = static_cast<size_t>(
        std::count_if(image.points2D.begin(), image.points2D.end(),
                      [](const Point2D& point2D) {
                        return point2D.point3D_id != kInvalidPoint3DId;
                      }));
    if (num_points2D_linked != num_linked[image_id]) continue;
    image.points2D = {};
    suspended_images_.insert(image_id);
  }
}

void GlobalMapper::ResumeKeypoints() {
  if (suspended_images_.empty()) return;
  for (const image_t image_id : suspended_images_) {
    reconstruction_.images.at(image_id).points2D =
        DatabasePoints2D(database_, image_id);
  }
  for (const auto& [point3D_id, point] : reconstruction_.points3D) {
    for (const TrackElement& element : point.track) {
      if (suspended_images_.count(element.image_id)) {
        reconstruction_.images.at(element.image_id)
            .points2D[element.point2D_idx]
            .point3D_id = point3D_id;
      }
    }
  }
  suspended_images_.clear();
}

void RotationFilterOptions::Check() const {
  if (!(max_rotation_error_deg > 0 && max_rotation_error_deg <= 180)) {
    throw OptionError(&max_rotation_error_deg,
                      "RotationFilter.max_rotation_error_deg",
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
  bundle_adjustment.loss_function = BundleAdjustmentLoss::kTrivial;
  // Track completion off in the mapper: on Strecha it gives back
  // observations the first bundle adjustment's filter removed (castle-P19:
  // 2,508; rotation median 0.0411 -> 0.0478 deg, fountain-P11 0.0426 ->
  // 0.0454) and the photo scenes gain nothing from it (photo_300_s1: 5
  // observations); docs/notes/2026-12-05-track-completion.md.
  triangulation.complete_tracks = false;
}

template <>
const EnumNames<PositioningMethod>& NamesOf<PositioningMethod>() {
  static const EnumNames<PositioningMethod> names = {
      {PositioningMethod::kGlobalPositioning, "global_positioning"},
      {PositioningMethod::kTranslationAveraging, "translation_averaging"}};
  return names;
}

namespace {

// Every setting's check; the errors name the flags as written here, which
// GlobalMapperOptions::Check() replaces by the registered ones.
void CheckEverySetting(const GlobalMapperOptions& options) {
  const GlobalMapperOptions& o = options;
  if (o.min_model_size < 3) {
    throw OptionError(&o.min_model_size, "Mapper.min_model_size",
                      "must be >= 3");
  }
  const std::vector<std::string> methods = RotationAveragerMethods();
  if (std::find(methods.begin(), methods.end(), o.rotation_method) ==
      methods.end()) {
    throw OptionError(&o.rotation_method, "Mapper.rotation_method",
                      "unknown method '" + o.rotation_method + "' (one of " +
                          RotationAveragerMethodList() + ")");
  }
  if (o.num_threads == 0 || o.num_threads < -1) {
    throw OptionError(&o.num_threads, "Mapper.num_threads",
                      "must be -1 (all cores) or > 0");
  }
  if (o.seed < 0) {
    throw OptionError(&o.seed, "Mapper.seed", "must be >= 0");
  }
  if (o.progress < -1 || o.progress > 1) {
    throw OptionError(&o.progress, "Mapper.progress",
                      "must be -1 (auto), 0 or 1");
  }
  if (o.color_image_downscale != 1 && o.color_image_downscale != 2 &&
      o.color_image_downscale != 4 && o.color_image_downscale != 8) {
    throw OptionError(&o.color_image_downscale, "Mapper.color_image_downscale",
                      "must be 1, 2, 4 or 8");
  }
  if (o.weak_part_min_shared_points < 0) {
    throw OptionError(&o.weak_part_min_shared_points,
                      "Mapper.weak_part_min_shared_points", "must be >= 0");
  }
  if (o.weak_image_min_pair_triangles < 0) {
    throw OptionError(&o.weak_image_min_pair_triangles,
                      "Mapper.weak_image_min_pair_triangles", "must be >= 0");
  }
  if (o.num_ba_iterations < 0) {
    throw OptionError(&o.num_ba_iterations, "Mapper.num_ba_iterations",
                      "must be >= 0");
  }
  o.view_graph.Check();
  o.rotation_averaging.Check();
  o.rotation_filter.Check();
  o.tracks.Check();
  o.global_positioning.Check();
  o.translation_averaging.Check();
  o.triangulation.Check();
  o.two_view_check.Check();
  o.point_merging.Check();
  o.positioning_tracks.Check();
  if (o.max_num_tracks < 0) {
    throw OptionError(&o.max_num_tracks, "Mapper.max_num_tracks",
                      "must be >= 0");
  }
  o.bundle_adjustment.Check();
  o.filtering.Check();
  o.normalization.Check();
  o.pose_constraint.Check();
  o.fold.Check();
  o.part_merge.Check();
  o.pose_priors.Check();
  if (!o.pose_prior_path.empty() &&
      !std::filesystem::is_regular_file(o.pose_prior_path)) {
    throw OptionError(&o.pose_prior_path, "Mapper.pose_prior_path",
                      "no such file: '" + o.pose_prior_path + "'");
  }
}

}  // namespace

void GlobalMapperOptions::Check() const {
  // Checked on a registered copy: an error about a registered member names
  // its flag as registered (OptionManager::Check), never a hand-written one.
  GlobalMapperOptions registered = *this;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &registered);
  manager.Check([&registered] { CheckEverySetting(registered); });
}

GlobalMapperOptions GlobalMapperOptions::ForStages(size_t num_images) const {
  GlobalMapperOptions stages = *this;
  const bool show_progress =
      progress == 1 ||
      (progress == -1 && (isatty(fileno(stderr)) || num_images >= 100));
  stages.view_graph.num_threads = num_threads;
  stages.rotation_averaging.irav4.engine.num_threads =
      ResolveNumThreads(num_threads);
  stages.rotation_averaging.log_progress = show_progress;
  stages.rotation_averaging.irav4.seed = seed;
  stages.global_positioning.random_seed = seed;
  stages.translation_averaging.random_seed = seed;
  stages.triangulation.random_seed = seed;
  stages.global_positioning.pose_priors = pose_priors;
  stages.bundle_adjustment.pose_priors = pose_priors;
  // A pair with fewer inliers than the view graph keeps counts as not
  // matched for the fold check too.
  stages.fold.detection.min_num_matches = view_graph.min_num_inliers;
  // Without retriangulation the tracks positioning leaves out would have no
  // points: positioning takes them all.
  if (skip_retriangulation) stages.positioning_tracks.tracks_per_image = 0;
  for (SolverOptions* solver :
       {&stages.global_positioning.solver, &stages.translation_averaging.solver,
        &stages.bundle_adjustment.solver}) {
    solver->ceres.num_threads = num_threads;
    solver->show_progress_bar = show_progress;
  }
  return stages;
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
    if (RelativeRotationErrorDeg(pair, r1->second, r2->second) <=
        max_rotation_error_deg) {
      kept.push_back(pair);
    }
  }
  return kept;
}

}  // namespace colmap_irav4
