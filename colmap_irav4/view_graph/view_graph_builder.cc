#include "colmap_irav4/view_graph/view_graph_builder.h"

#include <algorithm>
#include <numeric>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/threading.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {
namespace {

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    const size_t begin = item.find_first_not_of(" \t");
    const size_t end = item.find_last_not_of(" \t");
    if (begin == std::string::npos) continue;
    items.push_back(item.substr(begin, end - begin + 1));
  }
  return items;
}

// The database's pairs that pass the cheap filters (configuration, inlier
// count and ratio), in database order; the others counted in `summary`.
std::vector<const TwoViewGeometry*> FilterPairs(
    const DatabaseContents& database, const ViewGraphBuilderOptions& options,
    ViewGraphSummary* summary) {
  const std::vector<int> drop_configs = options.DropConfigs();
  std::vector<const TwoViewGeometry*> candidates;
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    if (std::find(drop_configs.begin(), drop_configs.end(), geometry.config) !=
        drop_configs.end()) {
      ++summary->num_dropped["config " + TwoViewConfigName(geometry.config)];
      continue;
    }
    if (geometry.config < 0 || geometry.config > TwoViewGeometry::MULTIPLE) {
      ++summary->num_dropped["unknown config"];
      continue;
    }
    const int num_inliers = static_cast<int>(geometry.inlier_matches.size());
    if (num_inliers < options.min_num_inliers) {
      ++summary->num_dropped["fewer than min_num_inliers inliers"];
      continue;
    }
    if (options.min_inlier_ratio > 0) {
      const auto it = database.num_matches.find(
          ImagePairToPairId(geometry.image_id1, geometry.image_id2));
      if (it != database.num_matches.end() && it->second > 0 &&
          num_inliers < options.min_inlier_ratio * it->second) {
        ++summary->num_dropped["inlier ratio below min_inlier_ratio"];
        continue;
      }
    }
    candidates.push_back(&geometry);
  }
  return candidates;
}

// Focal self-calibration from the fundamental matrices of the `candidates`
// (F is in pixels: it does not depend on the focal guess).
void CalibrateFocals(const DatabaseContents& database,
                     const std::vector<const TwoViewGeometry*>& candidates,
                     const FocalCalibrationOptions& options,
                     ViewGraphSummary* summary,
                     std::map<camera_t, Camera>* cameras) {
  std::vector<FocalCalibrationPair> calibration_pairs;
  for (const TwoViewGeometry* geometry : candidates) {
    if (geometry->config != TwoViewGeometry::UNCALIBRATED &&
        geometry->config != TwoViewGeometry::CALIBRATED) {
      continue;  // planar / panoramic: F is ill-defined
    }
    FocalCalibrationPair pair;
    pair.camera_id1 = database.images.at(geometry->image_id1).camera_id;
    pair.camera_id2 = database.images.at(geometry->image_id2).camera_id;
    pair.F = geometry->F;
    pair.weight = static_cast<double>(geometry->inlier_matches.size());
    calibration_pairs.push_back(pair);
  }
  summary->focal_calibration =
      CalibrateFocalLengths(calibration_pairs, options, cameras);
}

// Moves the candidates outside the largest connected component of the
// candidate pairs (images by index) to `deferred`; the number and the
// largest size of the other components of two images or more.
void DeferOutsideLargestComponent(
    const std::map<image_t, int>& index, size_t num_images,
    std::vector<const TwoViewGeometry*>* candidates,
    std::vector<const TwoViewGeometry*>* deferred, int* num_deferred_components,
    int* largest_deferred_component) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(candidates->size());
  for (const TwoViewGeometry* geometry : *candidates) {
    edges.emplace_back(index.at(geometry->image_id1),
                       index.at(geometry->image_id2));
  }
  const std::vector<std::vector<int>> candidate_components =
      ConnectedComponents(static_cast<int>(num_images), edges);
  std::vector<char> in_largest(num_images, 0);
  if (!candidate_components.empty()) {
    for (const int i : candidate_components[0]) in_largest[i] = 1;
  }
  for (size_t c = 1; c < candidate_components.size(); ++c) {
    if (candidate_components[c].size() < 2) break;  // sorted: singletons
    ++*num_deferred_components;
    *largest_deferred_component =
        std::max(*largest_deferred_component,
                 static_cast<int>(candidate_components[c].size()));
  }
  std::vector<const TwoViewGeometry*> in_component;
  for (const TwoViewGeometry* geometry : *candidates) {
    (in_largest[index.at(geometry->image_id1)] ? in_component : *deferred)
        .push_back(geometry);
  }
  candidates->swap(in_component);
}

// Derives the relative poses of `geometries` (each image's keypoints
// undistorted once, then the pairs; both in parallel) and appends the
// successful ones to `pairs` and `poses`, in order.
void DeriveRelativePoses(const DatabaseContents& database,
                         const ViewGraphBuilderOptions& options,
                         const std::map<camera_t, Camera>& cameras,
                         const std::vector<const TwoViewGeometry*>& geometries,
                         ViewGraphSummary* summary,
                         std::vector<ImagePairGeometry>* pairs,
                         std::vector<RelativePose>* poses) {
  std::map<image_t, std::vector<Eigen::Vector2d>> normalized;
  for (const TwoViewGeometry* geometry : geometries) {
    normalized[geometry->image_id1];
    normalized[geometry->image_id2];
  }
  std::vector<std::pair<const image_t, std::vector<Eigen::Vector2d>>*> slots;
  for (auto& slot : normalized) slots.push_back(&slot);
  ParallelFor(options.num_threads, slots.size(), [&](size_t i) {
    const image_t image_id = slots[i]->first;
    const Camera& camera = cameras.at(database.images.at(image_id).camera_id);
    const FeatureKeypoints& keypoints = database.keypoints.at(image_id);
    std::vector<Eigen::Vector2d>& points = slots[i]->second;
    points.reserve(keypoints.size());
    for (const auto& keypoint : keypoints) {
      points.push_back(CameraImageToCamera(camera, keypoint.cast<double>()));
    }
  });
  std::vector<RelativePose> derived(geometries.size());
  ParallelFor(options.num_threads, geometries.size(), [&](size_t i) {
    const TwoViewGeometry& geometry = *geometries[i];
    const DatabaseImage& image1 = database.images.at(geometry.image_id1);
    const DatabaseImage& image2 = database.images.at(geometry.image_id2);
    derived[i] = EstimateRelativePoseNormalized(
        geometry, cameras.at(image1.camera_id), cameras.at(image2.camera_id),
        normalized.at(geometry.image_id1), normalized.at(geometry.image_id2),
        options.relative_pose);
  });
  for (size_t i = 0; i < geometries.size(); ++i) {
    const TwoViewGeometry& geometry = *geometries[i];
    const RelativePose& pose = derived[i];
    if (!pose.success) {
      VLOG(1) << "pair (" << geometry.image_id1 << ", " << geometry.image_id2
              << "): " << pose.failure;
      ++summary->num_dropped["relative pose failed"];
      continue;
    }
    ImagePairGeometry pair;
    pair.image_id1 = geometry.image_id1;
    pair.image_id2 = geometry.image_id2;
    pair.R = pose.R;
    pair.t = pose.t;
    pair.num_inliers = static_cast<int>(geometry.inlier_matches.size());
    pair.config = geometry.config;
    pairs->push_back(pair);
    poses->push_back(pose);
  }
}

}  // namespace

void ViewGraphBuilderOptions::Check() const {
  if (min_num_inliers < 0) {
    throw OptionError(&min_num_inliers, "ViewGraph.min_num_inliers",
                      "must be >= 0");
  }
  if (num_threads == 0 || num_threads < -1) {
    throw OptionError(&num_threads, "ViewGraph.num_threads",
                      "must be -1 (all cores) or >= 1");
  }
  if (!(min_inlier_ratio >= 0 && min_inlier_ratio <= 1)) {
    throw OptionError(&min_inlier_ratio, "ViewGraph.min_inlier_ratio",
                      "must be in [0, 1]");
  }
  for (const std::string& name : SplitComma(drop_configs)) {
    if (TwoViewConfigFromName(name) < 0) {
      throw OptionError(&drop_configs, "ViewGraph.drop_configs",
                        "unknown configuration '" + name +
                            "' (UNDEFINED, DEGENERATE, CALIBRATED, "
                            "UNCALIBRATED, PLANAR, PANORAMIC, "
                            "PLANAR_OR_PANORAMIC, WATERMARK, MULTIPLE)");
    }
  }
  focal_calibration.Check();
  relative_pose.Check();
}

std::vector<int> ViewGraphBuilderOptions::DropConfigs() const {
  std::vector<int> configs;
  for (const std::string& name : SplitComma(drop_configs)) {
    const int config = TwoViewConfigFromName(name);
    CHECK_GE(config, 0) << name;
    configs.push_back(config);
  }
  return configs;
}

void ViewGraphSummary::Print(std::ostream& stream) const {
  stream << "View graph summary\n"
         << "  cameras:              " << num_cameras << "\n"
         << "  images:               " << num_images << "\n"
         << "  verified pairs read:  " << num_pairs_read << "\n"
         << "  pairs kept:           " << num_pairs_kept << "\n";
  for (const auto& [source, count] : num_kept_by_source) {
    stream << "    pose from " << source << ": " << count << "\n";
  }
  stream << "    without translation (pure rotation): "
         << num_kept_without_translation << "\n";
  int total_dropped = 0;
  for (const auto& [reason, count] : num_dropped) total_dropped += count;
  stream << "  pairs dropped:        " << total_dropped << "\n";
  for (const auto& [reason, count] : num_dropped) {
    stream << "    " << reason << ": " << count << "\n";
  }
  for (const FocalCalibrationResult& result : focal_calibration) {
    stream << "  camera " << result.camera_id << " focal " << result.guess_focal
           << " -> " << result.focal << " px (" << result.num_pairs << " pairs"
           << (result.calibrated ? "" : ", kept: " + result.reason) << ")\n";
  }
  stream << "  connected components: " << num_components << "\n"
         << "  images in the largest component: " << num_images_in_component
         << "\n";
}

ViewGraph BuildViewGraph(const DatabaseContents& database,
                         const ViewGraphBuilderOptions& options,
                         ViewGraphSummary* summary,
                         const std::map<camera_t, Camera>* given_cameras) {
  options.Check();
  *summary = ViewGraphSummary();
  summary->num_cameras = static_cast<int>(database.cameras.size());
  summary->num_images = static_cast<int>(database.images.size());
  summary->num_pairs_read =
      static_cast<int>(database.two_view_geometries.size());
  // Pairs the database reader already skipped (self-pairs, duplicates).
  for (const auto& [reason, count] : database.num_pairs_dropped) {
    summary->num_dropped[reason] += count;
    summary->num_pairs_read += count;
  }
  // Filters first (cheap, sequential), then the relative poses of the
  // survivors in parallel (independent per pair).
  std::vector<const TwoViewGeometry*> candidates =
      FilterPairs(database, options, summary);
  std::map<camera_t, Camera> cameras =
      given_cameras != nullptr ? *given_cameras : database.cameras;
  CHECK_EQ(cameras.size(), database.cameras.size());
  if (options.focal_calibration.calibrate_focal) {
    CalibrateFocals(database, candidates, options.focal_calibration, summary,
                    &cameras);
  }

  // Cheap rejection before any pose is derived: a pair outside the largest
  // connected component of the candidate pairs cannot end in the largest
  // component of the kept ones, unless failed poses split that component
  // below the size of another; the other components are then derived too
  // (below), so the result is the same as deriving every pair.
  std::map<image_t, int> index;
  std::vector<image_t> ids;
  for (const auto& [image_id, image] : database.images) {
    index[image_id] = static_cast<int>(ids.size());
    ids.push_back(image_id);
  }
  std::vector<const TwoViewGeometry*> deferred;
  int largest_deferred_component = 0;
  int num_deferred_components = 0;
  if (options.keep_largest_component) {
    DeferOutsideLargestComponent(index, ids.size(), &candidates, &deferred,
                                 &num_deferred_components,
                                 &largest_deferred_component);
  }

  std::vector<ImagePairGeometry> pairs;
  std::vector<RelativePose> poses;
  // Connected components over the kept pairs, on image indices in image id
  // order. An image without a pair is a singleton component and is not
  // counted. Largest by images first; ties go to the component of the
  // smallest image id, for determinism.
  std::vector<std::vector<int>> components;
  std::vector<std::pair<int, int>> edges;
  auto find_components = [&]() {
    edges.clear();
    for (const ImagePairGeometry& pair : pairs) {
      edges.emplace_back(index.at(pair.image_id1), index.at(pair.image_id2));
    }
    components = ConnectedComponents(static_cast<int>(ids.size()), edges);
  };
  DeriveRelativePoses(database, options, cameras, candidates, summary, &pairs,
                      &poses);
  find_components();
  if (!deferred.empty() &&
      (components.empty() ||
       static_cast<int>(components[0].size()) <= largest_deferred_component)) {
    // Failed poses split the largest candidate component: derive the rest.
    DeriveRelativePoses(database, options, cameras, deferred, summary, &pairs,
                        &poses);
    deferred.clear();
    num_deferred_components = 0;
    find_components();
  }
  if (!deferred.empty()) {
    summary->num_dropped["outside the largest component"] +=
        static_cast<int>(deferred.size());
  }
  std::vector<char> has_pair(ids.size(), 0);
  for (const auto& [a, b] : edges) has_pair[a] = has_pair[b] = 1;
  // The components not derived count as read (each is at least one).
  summary->num_components =
      num_deferred_components +
      static_cast<int>(std::count_if(
          components.begin(), components.end(),
          [](const std::vector<int>& c) { return c.size() > 1; }));
  std::vector<char> in_best(ids.size(), 0);
  const bool has_best = !components.empty() && components[0].size() > 1;
  if (has_best) {
    for (const int i : components[0]) in_best[i] = 1;
  }

  ViewGraph view_graph;
  view_graph.cameras = cameras;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const ImagePairGeometry& pair = pairs[i];
    const bool in_component = in_best[index.at(pair.image_id1)];
    if (options.keep_largest_component && !in_component) {
      ++summary->num_dropped["outside the largest component"];
      continue;
    }
    view_graph.pairs.push_back(pair);
    ++summary->num_kept_by_source[RelativePoseSourceName(poses[i].source)];
    if (!poses[i].has_translation) ++summary->num_kept_without_translation;
  }
  for (size_t i = 0; i < ids.size(); ++i) {
    if (!has_pair[i]) continue;
    if (options.keep_largest_component && !in_best[i]) continue;
    view_graph.image_names[ids[i]] = database.images.at(ids[i]).name;
  }
  summary->num_pairs_kept = static_cast<int>(view_graph.pairs.size());
  summary->num_images_in_component =
      has_best ? static_cast<int>(components[0].size()) : 0;
  return view_graph;
}

}  // namespace colmap_irav4
