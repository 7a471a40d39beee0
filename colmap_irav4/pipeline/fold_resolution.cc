#include "colmap_irav4/pipeline/fold_resolution.h"

#include <algorithm>
#include <map>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

struct Attempt {
  bool ok = false;
  bool refined = false;
  FoldCheckedModel model;
  std::string failure;
};

// Adds the fold check's figures to its stage.
void AddFoldFigures(const FoldReport& fold, StageTimer* stage) {
  stage->Add("fold score", fold.fold_score);
  stage->Add("predicted pairs", static_cast<double>(fold.num_predicted_pairs));
  stage->Add("missing pairs", static_cast<double>(fold.num_missing_pairs));
  stage->Add("contradicted strong pairs",
             static_cast<double>(fold.num_strong_inconsistent_pairs));
  stage->Add("contradictory tracks",
             static_cast<double>(fold.num_contradictory_tracks));
  stage->Add("suspect pairs", static_cast<double>(fold.suspect_pairs.size()));
  stage->Add("weak pairs", static_cast<double>(fold.num_weak_pairs));
  stage->Add("weak pairs across their cut",
             static_cast<double>(fold.num_weak_cut_pairs));
}

std::vector<ImagePairGeometry> PairsWithin(
    const std::vector<ImagePairGeometry>& pairs,
    const std::set<image_t>& images) {
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
    if (!images.count(geometry.image_id1) ||
        !images.count(geometry.image_id2)) {
      continue;
    }
    PairEvidence& pair = entry(geometry.image_id1, geometry.image_id2);
    pair.verified = true;
    // Failed verifications are stored with no inliers (config UNDEFINED).
    pair.num_inliers = geometry.config == TwoViewGeometry::UNDEFINED
                           ? 0
                           : static_cast<int>(geometry.inlier_matches.size());
  }
  for (const ImagePairGeometry& geometry : pairs) {
    if (!images.count(geometry.image_id1) ||
        !images.count(geometry.image_id2)) {
      continue;
    }
    PairEvidence& pair = entry(geometry.image_id1, geometry.image_id2);
    pair.verified = true;
    pair.has_rotation = true;
    // Oriented image_id1 -> image_id2 of the evidence (smaller id first).
    pair.R = geometry.image_id1 == pair.image_id1
                 ? geometry.R
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

ComponentStages GlobalMapperStages(const GlobalMapperOptions& options,
                                   const DatabaseContents& database,
                                   const std::map<camera_t, Camera>& cameras) {
  ComponentStages stages;
  stages.position = [&options, &database, &cameras](
                        const std::vector<image_t>& images,
                        const std::vector<ImagePairGeometry>& pairs,
                        const std::string& prefix, std::string* failure) {
    auto mapper = std::make_unique<GlobalMapper>(options, database, cameras,
                                                 images, pairs, prefix);
    if (mapper->RotationAveraging() && mapper->RotationFilter() &&
        mapper->BuildTracks() && mapper->Positioning()) {
      return mapper;
    }
    *failure = mapper->failure();
    return std::unique_ptr<GlobalMapper>();
  };
  stages.refine = [](GlobalMapper* mapper, std::string* failure) {
    if (mapper->IterativeBundleAdjustment() && mapper->Finalize()) return true;
    *failure = mapper->failure();
    return false;
  };
  return stages;
}

std::vector<FoldCheckedModel> MapComponentWithFoldCheck(
    const FoldResolutionOptions& options, int min_model_size,
    const FoldEvidence& evidence, const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
    const ComponentStages& stages, std::vector<std::string>* notes,
    std::string* failure) {
  auto check = [&](Attempt* attempt, const std::string& when,
                   const std::string& check_prefix) {
    StageTimer stage("fold check (" + when + ")");
    // After positioning the model holds only the tracks selected for it:
    // the predicted overlap is scaled to all the tracks, which the verified
    // inliers count (DetectFold's `tracks`).
    const GlobalMapper& mapper = *attempt->model.mapper;
    attempt->model.fold =
        DetectFold(options.detection, mapper.reconstruction(), evidence,
                   attempt->refined ? nullptr : &mapper.tracks());
    attempt->model.checked = true;
    AddFoldFigures(attempt->model.fold, &stage);
    stage.Finish(check_prefix, &attempt->model.stages);
    attempt->model.outcome = attempt->model.fold.folded ? "folded" : "clean";
    LOG(INFO) << check_prefix << "fold check (" << when
              << "): " << attempt->model.fold.Describe();
  };
  auto refine = [&](Attempt* attempt, const std::string& run_prefix) {
    if (attempt->refined) return attempt->ok;
    attempt->refined = true;
    attempt->ok = stages.refine(attempt->model.mapper.get(), &attempt->failure);
    if (attempt->ok && options.detect)
      check(attempt, "after refinement", run_prefix);
    return attempt->ok;
  };
  // Positions, checks; refines (and checks again) unless folded and to be
  // resolved (refining a folded model is wasted time).
  auto run = [&](const std::vector<image_t>& run_images,
                 const std::vector<ImagePairGeometry>& run_pairs,
                 const std::string& run_prefix) {
    Attempt attempt;
    attempt.model.mapper =
        stages.position(run_images, run_pairs, run_prefix, &attempt.failure);
    attempt.ok = attempt.model.mapper != nullptr;
    if (!attempt.ok) return attempt;
    if (options.detect) {
      check(&attempt, "after positioning", run_prefix);
      if (attempt.model.fold.folded && options.resolve) return attempt;
    }
    refine(&attempt, run_prefix);
    return attempt;
  };
  auto finish = [&](Attempt* attempt, const std::string& outcome,
                    std::vector<FoldCheckedModel>* models) {
    if (!refine(attempt, prefix)) return false;
    if (!outcome.empty()) attempt->model.outcome = outcome;
    models->push_back(std::move(attempt->model));
    return true;
  };
  // A model written as folded stays flagged even if the check after
  // refinement no longer sees the fold.
  auto finish_folded = [&](Attempt* attempt, const std::string& outcome,
                           std::vector<FoldCheckedModel>* models) {
    if (!finish(attempt, outcome, models)) return false;
    models->back().fold.folded = true;
    return true;
  };

  std::vector<FoldCheckedModel> models;
  Attempt first = run(images, pairs, prefix);
  if (!first.ok) {
    *failure = first.failure;
    return {};
  }
  if (!options.detect || !first.model.fold.folded || !options.resolve) {
    if (!first.model.fold.folded) {
      finish(&first, "", &models);
    } else {
      LOG(WARNING) << prefix << "the model of " << images.size()
                   << " images looks FOLDED (symmetric scene: some cameras "
                      "may sit at their mirrored twin's place): "
                   << first.model.fold.Describe();
      notes->push_back(prefix + "model looks folded (fold score " +
                       std::to_string(first.model.fold.fold_score) +
                       "); not resolved (--Fold.resolve 0)");
      finish_folded(&first, "folded (not resolved)", &models);
    }
    if (models.empty()) *failure = first.failure;
    return models;
  }
  LOG(WARNING) << prefix << "the model of " << images.size()
               << " images looks FOLDED (symmetric scene: some cameras may "
                  "sit at their mirrored twin's place), resolving: "
               << first.model.fold.Describe();

  // 1. Re-orientation across the weakest cut. The images on one side of it
  // sit at their twins' place: across the cut, the pairs the folded model
  // agrees with are those that folded it, and those it contradicts are the
  // true ones. Keep only the latter across the cut and map again. A cut
  // placed from a model folded in several places re-orients only part of
  // it: while the re-oriented model is better supported (lower fold score,
  // no fewer images), cut it again (up to 1 + max_iterations rounds).
  const size_t num_first_images =
      first.model.mapper->reconstruction().images.size();
  // A resolution may lose a few images, not a quarter of the first model's.
  auto keeps_most = [&](size_t num_images) {
    return num_images * 4 >= num_first_images * 3;
  };
  // A re-mapped model that is taken: not folded after positioning nor after
  // refinement, and keeping most images.
  auto accepted = [&](Attempt* attempt) {
    return !attempt->model.fold.folded && refine(attempt, prefix) &&
           !attempt->model.fold.folded &&
           keeps_most(attempt->model.mapper->reconstruction().images.size());
  };
  std::vector<ImagePairGeometry> current = pairs;
  Attempt best = std::move(first);
  size_t num_removed = 0;
  for (int round = 0; round <= options.max_iterations; ++round) {
    const Reconstruction& model = best.model.mapper->reconstruction();
    const auto [side1, side2] =
        FoldCut(options.detection, model, evidence, best.model.fold);
    if (side2.empty()) break;
    const std::set<image_t> in_side1(side1.begin(), side1.end());
    const std::set<image_t> in_side2(side2.begin(), side2.end());
    std::vector<ImagePairGeometry> reoriented;
    for (const ImagePairGeometry& pair : current) {
      const bool cross =
          (in_side1.count(pair.image_id1) && in_side2.count(pair.image_id2)) ||
          (in_side2.count(pair.image_id1) && in_side1.count(pair.image_id2));
      if (!cross ||
          ContradictedByModel(pair, model,
                              options.detection.max_rotation_error_deg)) {
        reoriented.push_back(pair);
      }
    }
    const size_t num_dropped = current.size() - reoriented.size();
    LOG(INFO) << prefix << "fold resolution (cut " << round + 1
              << "): cut into " << side1.size() << " and " << side2.size()
              << " images; " << num_dropped
              << " pairs across it agree with the fold and are removed, "
                 "mapping again";
    const std::vector<std::vector<image_t>> components =
        PairComponents(reoriented);
    if (num_dropped == 0 || components.empty() ||
        static_cast<int>(components[0].size()) < min_model_size) {
      break;
    }
    const std::set<image_t> component(components[0].begin(),
                                      components[0].end());
    std::vector<ImagePairGeometry> component_pairs =
        PairsWithin(reoriented, component);
    Attempt attempt = run(components[0], component_pairs, prefix);
    if (!attempt.ok) break;
    if (accepted(&attempt)) {
      num_removed += num_dropped;
      // Cameras turned alone among cameras the right way round are no cut;
      // re-orient them once (their pairs the model agrees with removed),
      // else write the model flagged folded.
      const std::vector<image_t> alone_images =
          attempt.model.fold.weak_alone_images;
      if (!alone_images.empty()) {
        const Reconstruction& resolved = attempt.model.mapper->reconstruction();
        const std::set<image_t> alone(alone_images.begin(), alone_images.end());
        std::vector<ImagePairGeometry> kept;
        for (const ImagePairGeometry& pair : component_pairs) {
          if ((!alone.count(pair.image_id1) && !alone.count(pair.image_id2)) ||
              ContradictedByModel(pair, resolved,
                                  options.detection.max_rotation_error_deg)) {
            kept.push_back(pair);
          }
        }
        const size_t num_alone_dropped = component_pairs.size() - kept.size();
        LOG(INFO) << prefix << alone.size()
                  << " images may be turned alone: " << num_alone_dropped
                  << " pairs at them agree with the model and are removed, "
                     "mapping again";
        const std::vector<std::vector<image_t>> kept_components =
            PairComponents(kept);
        bool reoriented_alone = false;
        if (num_alone_dropped > 0 && !kept_components.empty() &&
            keeps_most(kept_components[0].size())) {
          Attempt again = run(
              kept_components[0],
              PairsWithin(kept, std::set<image_t>(kept_components[0].begin(),
                                                  kept_components[0].end())),
              prefix);
          if (again.ok && accepted(&again) &&
              again.model.fold.weak_alone_images.empty()) {
            attempt = std::move(again);
            num_removed += num_alone_dropped;
            reoriented_alone = true;
          }
        }
        if (!reoriented_alone) {
          LOG(WARNING) << prefix << "fold resolved but " << alone.size()
                       << " images may still be turned alone: the model is "
                          "written flagged FOLDED: "
                       << attempt.model.fold.Describe();
          notes->push_back(prefix + std::to_string(alone.size()) +
                           " images may be turned alone after the fold "
                           "resolution");
          finish_folded(&attempt,
                        "folded (" + std::to_string(alone.size()) +
                            " images may be turned alone)",
                        &models);
          return models;
        }
      }
      LOG(INFO) << prefix << "fold resolved: " << attempt.model.fold.Describe();
      notes->push_back(prefix + "fold resolved by removing " +
                       std::to_string(num_removed) +
                       " pairs that agree with it across " +
                       std::to_string(round + 1) + " cut(s)");
      finish(&attempt,
             "resolved (" + std::to_string(num_removed) +
                 " pairs across the fold removed)",
             &models);
      return models;
    }
    LOG(INFO) << prefix << "re-oriented model not accepted: "
              << attempt.model.fold.Describe();
    if (!(attempt.model.fold.fold_score < best.model.fold.fold_score) ||
        attempt.model.mapper->reconstruction().images.size() * 4 <
            best.model.mapper->reconstruction().images.size() * 3) {
      break;
    }
    best = std::move(attempt);
    current = std::move(component_pairs);
    num_removed += num_dropped;
  }

  // 2. Remove the suspect pairs and map again.
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    const std::set<std::pair<image_t, image_t>> suspects(
        best.model.fold.suspect_pairs.begin(),
        best.model.fold.suspect_pairs.end());
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
    const std::vector<std::vector<image_t>> components =
        PairComponents(current);
    if (components.empty() ||
        static_cast<int>(components[0].size()) < min_model_size) {
      break;
    }
    Attempt attempt =
        run(components[0],
            PairsWithin(current, std::set<image_t>(components[0].begin(),
                                                   components[0].end())),
            prefix);
    if (!attempt.ok) break;
    // Only a better-supported model replaces the previous one.
    const bool better =
        attempt.model.fold.fold_score < best.model.fold.fold_score &&
        attempt.model.mapper->reconstruction().images.size() * 4 >=
            best.model.mapper->reconstruction().images.size() * 3;
    if (!better) break;
    best = std::move(attempt);
    if (!best.model.fold.folded && refine(&best, prefix) &&
        !best.model.fold.folded) {
      LOG(INFO) << prefix << "fold resolved by removing " << num_removed
                << " pairs: " << best.model.fold.Describe();
      notes->push_back(prefix + "fold resolved by removing " +
                       std::to_string(num_removed) + " suspect pairs");
      finish(&best,
             "resolved (" + std::to_string(num_removed) + " pairs removed)",
             &models);
      return models;
    }
  }

  // 3. Split at the weakest cut: separate models rather than a folded one.
  const auto [side1, side2] =
      FoldCut(options.detection, best.model.mapper->reconstruction(), evidence,
              best.model.fold);
  if (!side2.empty()) {
    LOG(WARNING) << prefix << "fold not resolved: splitting into "
                 << side1.size() << " and " << side2.size() << " images";
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
        if (!attempt.ok || !refine(&attempt, prefix + "[split] ")) continue;
        if (attempt.model.fold.folded) {
          LOG(WARNING) << prefix << "[split] part of " << component.size()
                       << " images still looks folded: "
                       << attempt.model.fold.Describe();
        }
        finish(&attempt,
               std::string("split") +
                   (attempt.model.fold.folded ? " (still folded)" : ""),
               &models);
      }
    }
    if (!models.empty()) {
      notes->push_back(prefix + "folded model split into " +
                       std::to_string(models.size()) + " models");
      return models;
    }
  }
  // Flagged after positioning from weak pairs alone and nothing removed: that
  // check sees only the tracks selected for positioning; the check after
  // refinement (every track, adjusted) decides.
  if (num_removed == 0 && !best.model.fold.missing_fold &&
      refine(&best, prefix) && !best.model.fold.folded) {
    LOG(INFO) << prefix
              << "no fold after refinement (the check after positioning "
                 "flagged weak pairs alone): "
              << best.model.fold.Describe();
    notes->push_back(prefix +
                     "weak pairs flagged after positioning, clean after "
                     "refinement");
    finish(&best, "clean after refinement", &models);
    return models;
  }
  LOG(WARNING) << prefix
               << "fold not resolved and no cut found: the model is written "
                  "but is likely FOLDED: "
               << best.model.fold.Describe();
  notes->push_back(prefix + "model likely folded (fold score " +
                   std::to_string(best.model.fold.fold_score) +
                   "), not resolved");
  if (!finish_folded(&best, "folded (unresolved)", &models)) {
    *failure = best.failure;
  }
  return models;
}

}  // namespace colmap_irav4
