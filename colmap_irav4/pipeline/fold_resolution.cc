#include "colmap_irav4/pipeline/fold_resolution.h"

#include <algorithm>
#include <map>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

struct Attempt {
  bool ok = false;
  MappedModel model;
  FoldReport fold;
  std::string failure;
};

void RecordFold(const FoldReport& fold, const std::string& outcome,
                ComponentReport* report, double seconds) {
  report->fold_score = fold.fold_score;
  report->folded = fold.folded;
  report->fold_predicted_pairs = fold.num_predicted_pairs;
  report->fold_missing_pairs = fold.num_missing_pairs;
  report->fold_outcome = outcome;
  StageReport stage{"fold check"};
  stage.seconds = seconds;
  stage.figures = {
      {"fold score", fold.fold_score},
      {"predicted pairs", static_cast<double>(fold.num_predicted_pairs)},
      {"missing pairs", static_cast<double>(fold.num_missing_pairs)},
      {"contradicted strong pairs",
       static_cast<double>(fold.num_strong_inconsistent_pairs)},
      {"contradictory tracks",
       static_cast<double>(fold.num_contradictory_tracks)},
      {"suspect pairs", static_cast<double>(fold.suspect_pairs.size())}};
  report->stages.push_back(stage);
}

std::vector<ImagePairGeometry> PairsWithin(
    const std::vector<ImagePairGeometry>& pairs, const std::set<image_t>& images) {
  std::vector<ImagePairGeometry> kept;
  for (const ImagePairGeometry& pair : pairs) {
    if (images.count(pair.image_id1) && images.count(pair.image_id2)) {
      kept.push_back(pair);
    }
  }
  return kept;
}

// Whether the model's rotations contradict the pair's measured rotation
// (false when an image is not in the model).
bool ContradictedByModel(const ImagePairGeometry& pair,
                         const Reconstruction& reconstruction,
                         double max_rotation_error_deg) {
  const auto image1 = reconstruction.images.find(pair.image_id1);
  const auto image2 = reconstruction.images.find(pair.image_id2);
  if (image1 == reconstruction.images.end() ||
      image2 == reconstruction.images.end()) {
    return false;
  }
  const Eigen::Matrix3d R1 =
      image1->second.cam_from_world.rotation.toRotationMatrix();
  const Eigen::Matrix3d R2 =
      image2->second.cam_from_world.rotation.toRotationMatrix();
  return AngularDistanceDeg(pair.R, R2 * R1.transpose()) >
         max_rotation_error_deg;
}

}  // namespace


void AddFoldResolutionOptions(OptionManager* manager,
                              FoldResolutionOptions* options) {
  FoldResolutionOptions& o = *options;
  FoldDetectionOptions& d = o.detection;
  manager->Add("Fold.detect", &o.detect,
               "test every model for a fold (symmetric scenes)");
  manager->Add("Fold.resolve", &o.resolve,
               "resolve a detected fold: remove the suspect pairs and map "
               "again, else split the model at the weakest cut");
  manager->Add("Fold.max_iterations", &o.max_iterations,
               "rounds of removing suspect pairs before a split");
  manager->Add("Fold.max_fold_score", &d.max_fold_score,
               "models with a larger fraction of predicted overlapping pairs "
               "without matches are folded");
  manager->Add("Fold.min_missing_pairs", &d.min_missing_pairs,
               "... and at least this many such pairs");
  manager->Add("Fold.max_view_angle_deg", &d.max_view_angle_deg,
               "two cameras are expected to match a point only from rays "
               "closer than this (deg)");
  manager->Add("Fold.min_overlap_fraction", &d.min_overlap_fraction,
               "a pair is predicted to overlap when each image expects this "
               "fraction of the other's points");
}

FoldEvidence BuildFoldEvidence(const DatabaseContents& database,
                               const std::vector<ImagePairGeometry>& pairs,
                               const std::set<image_t>& images) {
  FoldEvidence evidence;
  std::map<image_pair_t, PairEvidence> by_id;
  auto entry = [&](image_t a, image_t b) -> PairEvidence& {
    PairEvidence& pair = by_id[ImagePairToPairId(a, b)];
    if (pair.image_id1 == kInvalidImageId) {
      pair.image_id1 = std::min(a, b);
      pair.image_id2 = std::max(a, b);
    }
    return pair;
  };
  for (const auto& [pair_id, num_matches] : database.num_matches) {
    const auto [a, b] = PairIdToImagePair(pair_id);
    if (!images.count(a) || !images.count(b)) continue;
    entry(a, b).num_matches = num_matches;
  }
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    if (!images.count(geometry.image_id1) || !images.count(geometry.image_id2)) {
      continue;
    }
    PairEvidence& pair = entry(geometry.image_id1, geometry.image_id2);
    // Failed verifications are stored with no inliers (config UNDEFINED).
    pair.num_inliers =
        geometry.config == TwoViewGeometry::UNDEFINED
            ? 0
            : static_cast<int>(geometry.inlier_matches.size());
  }
  for (const ImagePairGeometry& geometry : pairs) {
    if (!images.count(geometry.image_id1) || !images.count(geometry.image_id2)) {
      continue;
    }
    PairEvidence& pair = entry(geometry.image_id1, geometry.image_id2);
    pair.has_rotation = true;
    // Oriented image_id1 -> image_id2 of the evidence (smaller id first).
    pair.R = geometry.image_id1 == pair.image_id1 ? geometry.R
                                                  : Eigen::Matrix3d(geometry.R.transpose());
    pair.num_inliers = std::max(pair.num_inliers, geometry.num_inliers);
  }
  for (auto& [pair_id, pair] : by_id) evidence.pairs.push_back(pair);
  // COLMAP's matchers record every pair they try, failures included (a
  // matches row with 0 rows, a two_view_geometries row of config UNDEFINED),
  // so an absent pair was not tried. A database that records no failure at
  // all (raw matches deleted, or written by a tool that keeps only the
  // matched pairs) cannot say: exhaustive matching is assumed.
  bool records_failures = false;
  for (const auto& [pair_id, num_matches] : database.num_matches) {
    if (num_matches == 0) records_failures = true;
  }
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    if (geometry.config == TwoViewGeometry::UNDEFINED ||
        geometry.inlier_matches.empty()) {
      records_failures = true;
    }
  }
  evidence.absent_pairs_were_tried = !records_failures;
  return evidence;
}

std::vector<MappedModel> MapComponentWithFoldCheck(
    const FoldResolutionOptions& options, int min_model_size,
    const FoldEvidence& evidence, const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
    const MapComponentFunction& map_component, std::vector<std::string>* notes,
    std::string* failure) {
  auto run = [&](const std::vector<image_t>& run_images,
                 const std::vector<ImagePairGeometry>& run_pairs,
                 const std::string& run_prefix) {
    Attempt attempt;
    attempt.ok = map_component(run_images, run_pairs, run_prefix,
                               &attempt.model.reconstruction,
                               &attempt.model.report, &attempt.failure);
    if (attempt.ok && options.detect) {
      Timer timer;
      attempt.fold = DetectFold(options.detection,
                                attempt.model.reconstruction, evidence);
      const double seconds = timer.ElapsedSeconds();
      RecordFold(attempt.fold, attempt.fold.folded ? "folded" : "clean",
                 &attempt.model.report, seconds);
      LOG(INFO) << run_prefix << "fold check: " << std::fixed
                << attempt.fold.Describe() << " (" << seconds << " s)";
    }
    return attempt;
  };

  Attempt first = run(images, pairs, prefix);
  if (!first.ok) {
    *failure = first.failure;
    return {};
  }
  if (!options.detect || !first.fold.folded) {
    return {std::move(first.model)};
  }
  LOG(WARNING) << prefix << "the model of " << images.size()
               << " images looks FOLDED (symmetric scene: some cameras may "
                  "sit at their mirrored twin's place): "
               << first.fold.Describe();
  if (!options.resolve) {
    notes->push_back(prefix + "model looks folded (fold score " +
                     std::to_string(first.fold.fold_score) +
                     "); not resolved (--Fold.resolve 0)");
    first.model.report.fold_outcome = "folded (not resolved)";
    return {std::move(first.model)};
  }

  // 1. Re-orientation across the weakest cut. The images on one side of it
  // sit at their twins' place: across the cut, the pairs the folded model
  // agrees with are those that folded it, and those it contradicts are the
  // true ones. Keep only the latter across the cut and map again.
  {
    const auto [side1, side2] = FoldCut(
        options.detection, first.model.reconstruction, evidence, first.fold);
    if (!side2.empty()) {
      const std::set<image_t> in_side1(side1.begin(), side1.end());
      const std::set<image_t> in_side2(side2.begin(), side2.end());
      std::vector<ImagePairGeometry> reoriented;
      for (const ImagePairGeometry& pair : pairs) {
        const bool cross =
            (in_side1.count(pair.image_id1) && in_side2.count(pair.image_id2)) ||
            (in_side2.count(pair.image_id1) && in_side1.count(pair.image_id2));
        if (!cross || ContradictedByModel(pair, first.model.reconstruction,
                                          options.detection
                                              .max_rotation_error_deg)) {
          reoriented.push_back(pair);
        }
      }
      const size_t num_dropped = pairs.size() - reoriented.size();
      LOG(INFO) << prefix << "fold resolution: cut into " << side1.size()
                << " and " << side2.size() << " images; " << num_dropped
                << " pairs across it agree with the fold and are removed, "
                   "mapping again";
      const std::vector<std::vector<image_t>> components =
          PairComponents(reoriented);
      if (num_dropped > 0 && !components.empty() &&
          static_cast<int>(components[0].size()) >= min_model_size) {
        Attempt attempt = run(
            components[0],
            PairsWithin(reoriented, std::set<image_t>(components[0].begin(),
                                                      components[0].end())),
            prefix);
        if (attempt.ok && !attempt.fold.folded &&
            attempt.model.reconstruction.images.size() * 4 >=
                first.model.reconstruction.images.size() * 3) {
          attempt.model.report.fold_outcome =
              "resolved (" + std::to_string(num_dropped) +
              " pairs across the fold removed)";
          LOG(INFO) << prefix << "fold resolved: " << attempt.fold.Describe();
          notes->push_back(prefix + "fold resolved by removing " +
                           std::to_string(num_dropped) +
                           " pairs that agree with it across its cut");
          return {std::move(attempt.model)};
        }
        if (attempt.ok) {
          LOG(INFO) << prefix << "re-oriented model not accepted: "
                    << attempt.fold.Describe();
        }
      }
    }
  }

  // 2. Remove the suspect pairs and map again.
  std::vector<ImagePairGeometry> current = pairs;
  Attempt best = std::move(first);
  size_t num_removed = 0;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    const std::set<std::pair<image_t, image_t>> suspects(
        best.fold.suspect_pairs.begin(), best.fold.suspect_pairs.end());
    const size_t before = current.size();
    current.erase(
        std::remove_if(current.begin(), current.end(),
                       [&](const ImagePairGeometry& pair) {
                         return suspects.count(
                             {std::min(pair.image_id1, pair.image_id2),
                              std::max(pair.image_id1, pair.image_id2)});
                       }),
        current.end());
    if (current.size() == before) break;
    num_removed += before - current.size();
    LOG(INFO) << prefix << "fold resolution " << iteration + 1 << ": "
              << before - current.size()
              << " suspect pairs removed, mapping again";
    const std::vector<std::vector<image_t>> components = PairComponents(current);
    if (components.empty() ||
        static_cast<int>(components[0].size()) < min_model_size) {
      break;
    }
    Attempt attempt = run(components[0], PairsWithin(current, std::set<image_t>(
                                             components[0].begin(),
                                             components[0].end())),
                          prefix);
    if (!attempt.ok) break;
    // Only a better-supported model replaces the previous one.
    const bool better =
        attempt.fold.fold_score < best.fold.fold_score &&
        attempt.model.reconstruction.images.size() * 4 >=
            best.model.reconstruction.images.size() * 3;
    if (!better) break;
    best = std::move(attempt);
    if (!best.fold.folded) {
      best.model.report.fold_outcome =
          "resolved (" + std::to_string(num_removed) + " pairs removed)";
      LOG(INFO) << prefix << "fold resolved by removing " << num_removed
                << " pairs: " << best.fold.Describe();
      notes->push_back(prefix + "fold resolved by removing " +
                       std::to_string(num_removed) + " suspect pairs");
      return {std::move(best.model)};
    }
  }

  // 3. Split at the weakest cut.
  const auto [side1, side2] =
      FoldCut(options.detection, best.model.reconstruction, evidence, best.fold);
  if (!side2.empty()) {
    LOG(WARNING) << prefix << "fold not resolved: splitting into "
                 << side1.size() << " and " << side2.size() << " images";
    std::vector<MappedModel> models;
    for (const std::vector<image_t>* side : {&side1, &side2}) {
      const std::set<image_t> side_images(side->begin(), side->end());
      const std::vector<ImagePairGeometry> side_pairs =
          PairsWithin(current, side_images);
      for (const std::vector<image_t>& component : PairComponents(side_pairs)) {
        if (static_cast<int>(component.size()) < min_model_size) break;
        Attempt attempt = run(
            component,
            PairsWithin(side_pairs,
                        std::set<image_t>(component.begin(), component.end())),
            prefix + "[split] ");
        if (!attempt.ok) continue;
        attempt.model.report.fold_outcome =
            std::string("split") + (attempt.fold.folded ? " (still folded)" : "");
        models.push_back(std::move(attempt.model));
      }
    }
    if (!models.empty()) {
      notes->push_back(prefix + "folded model split into " +
                       std::to_string(models.size()) + " models");
      return models;
    }
  }
  LOG(WARNING) << prefix
               << "fold not resolved and no cut found: the model is written "
                  "but is likely FOLDED: "
               << best.fold.Describe();
  notes->push_back(prefix + "model likely folded (fold score " +
                   std::to_string(best.fold.fold_score) + "), not resolved");
  best.model.report.fold_outcome = "folded (unresolved)";
  return {std::move(best.model)};
}

}  // namespace colmap_irav4
