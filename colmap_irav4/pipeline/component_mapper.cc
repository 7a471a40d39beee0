#include "colmap_irav4/pipeline/component_mapper.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/prior_fold.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"

namespace colmap_irav4 {
namespace {

// `pairs` less those at images with a single pair among `component_pairs`.
// In a component found folded such an image cannot be checked: no second
// pair closes a loop with its pair and the fold check predicts no overlap
// of note for it, while in a symmetric scene its one pair may be a mirror
// pair (the cut then leaves it with the image it pairs, turned).
std::vector<ImagePairGeometry> PairsWithoutSinglePairImages(
    const std::vector<ImagePairGeometry>& pairs,
    const std::vector<ImagePairGeometry>& component_pairs) {
  std::map<image_t, int> num_pairs;
  for (const ImagePairGeometry& pair : component_pairs) {
    ++num_pairs[pair.image_id1];
    ++num_pairs[pair.image_id2];
  }
  std::vector<ImagePairGeometry> kept;
  for (const ImagePairGeometry& pair : pairs) {
    if (num_pairs[pair.image_id1] > 1 && num_pairs[pair.image_id2] > 1) {
      kept.push_back(pair);
    }
  }
  return kept;
}

}  // namespace

std::vector<ImagePairGeometry> PairsReorientedAcrossCut(
    const std::vector<ImagePairGeometry>& pairs,
    const Reconstruction& reconstruction, const std::vector<image_t>& side,
    double max_rotation_error_deg, bool drop_contradicted_within) {
  const std::set<image_t> in_side(side.begin(), side.end());
  std::vector<ImagePairGeometry> reoriented;
  for (const ImagePairGeometry& pair : pairs) {
    const bool in_model = reconstruction.images.count(pair.image_id1) &&
                          reconstruction.images.count(pair.image_id2);
    const bool cross = in_model && in_side.count(pair.image_id1) !=
                                       in_side.count(pair.image_id2);
    const bool contradicted =
        ContradictedByModel(pair, reconstruction, max_rotation_error_deg);
    if (cross ? contradicted
              : !(in_model && drop_contradicted_within && contradicted)) {
      reoriented.push_back(pair);
    }
  }
  return reoriented;
}

FoldEvidence BuildModelFoldEvidence(const DatabaseContents& database,
                                    const Reconstruction& model) {
  std::set<image_t> images;
  for (const auto& [image_id, image] : model.images) images.insert(image_id);
  ViewGraphSummary summary;
  const ViewGraph graph =
      BuildViewGraph(database, ViewGraphBuilderOptions(), &summary);
  std::vector<ImagePairGeometry> pairs;
  for (const ImagePairGeometry& pair : graph.pairs) {
    if (images.count(pair.image_id1) && images.count(pair.image_id2)) {
      pairs.push_back(pair);
    }
  }
  return BuildFoldEvidence(database, pairs, images);
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

ComponentMapper::ComponentMapper(const GlobalMapperOptions& options,
                                 const DatabaseContents& database,
                                 const std::map<camera_t, Camera>& cameras,
                                 std::string log_prefix)
    : options_(options),
      database_(database),
      cameras_(cameras),
      prefix_(std::move(log_prefix)) {}

std::unique_ptr<GlobalMapper> ComponentMapper::NewMapper(
    const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
    const FoldEvidence* evidence) const {
  return std::make_unique<GlobalMapper>(options_, database_, cameras_, images,
                                        pairs, prefix, evidence);
}

std::unique_ptr<GlobalMapper> ComponentMapper::Attempt(
    const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix) {
  return Attempt(NewMapper(images, pairs, prefix, evidence_));
}

std::unique_ptr<GlobalMapper> ComponentMapper::Attempt(
    std::unique_ptr<GlobalMapper> mapper) {
  // The model held meanwhile keeps no copy of the database's keypoints.
  if (best_ != nullptr) best_->SuspendKeypoints();
  if (!mapper->Solve(/*stop_if_folded=*/options_.fold.resolve)) {
    failure_ = mapper->failure();
    return nullptr;
  }
  return mapper;
}

bool ComponentMapper::Finish(std::unique_ptr<GlobalMapper> mapper,
                             const std::string& outcome, bool folded) {
  if (!mapper->Solve()) {
    failure_ = mapper->failure();
    return false;
  }
  ComponentModel model;
  model.folded = folded || mapper->fold().folded;
  if (!outcome.empty()) {
    model.fold_outcome = outcome;
  } else if (mapper->fold_checked()) {
    model.fold_outcome = mapper->fold().folded ? "folded" : "clean";
  }
  model.mapper = std::move(mapper);
  models_.push_back(std::move(model));
  return true;
}

bool ComponentMapper::KeepsMost(size_t num_images,
                                size_t num_reference_images) {
  return num_images * 4 >= num_reference_images * 3;
}

bool ComponentMapper::Accepted(GlobalMapper* mapper) {
  return !mapper->fold().folded && mapper->Solve() && !mapper->fold().folded &&
         KeepsMost(mapper->reconstruction().images.size(), num_first_images_);
}

std::vector<ComponentModel> ComponentMapper::Map(
    const FoldEvidence& evidence, const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs) {
  evidence_ = &evidence;
  component_pairs_ = &pairs;
  models_.clear();
  notes_.clear();
  failure_.clear();
  num_removed_ = 0;
  std::unique_ptr<GlobalMapper> first = Attempt(images, pairs, prefix_);
  if (first == nullptr) return {};
  // Whether models_ holds the model of the component's pairs as given, which
  // the fold check did not flag after positioning: the one whose rigid
  // parts may be joined again (a model from a fold resolution was mapped
  // from pairs chosen against a fold; left as it is).
  bool mapped_from_pairs = false;
  if (!first->fold().folded) {
    if (!SettleFoldWithPriors(&first, pairs)) {
      mapped_from_pairs = Finish(std::move(first), "");
    }
  } else if (!options_.fold.resolve) {
    LOG(WARNING) << prefix_ << "the model of " << images.size()
                 << " images looks FOLDED (symmetric scene: some cameras "
                    "may sit at their mirrored twin's place): "
                 << first->fold().Describe();
    notes_.push_back(prefix_ + "model looks folded (fold score " +
                     std::to_string(first->fold().fold_score) +
                     "); not resolved (--Fold.resolve 0)");
    Finish(std::move(first), "folded (not resolved)", /*folded=*/true);
  } else {
    LOG(WARNING) << prefix_ << "the model of " << images.size()
                 << " images looks FOLDED (symmetric scene: some cameras may "
                    "sit at their mirrored twin's place), resolving: "
                 << first->fold().Describe();
    num_first_images_ = first->reconstruction().images.size();
    current_pairs_ = pairs;
    best_ = std::move(first);
    if (!ReorientAcrossCut() && !RemoveSuspectPairs() && !SplitAtCut()) {
      WriteFolded();
    }
    best_.reset();
  }
  ModelRigidity rigidity;
  const bool rigidity_checked = mapped_from_pairs && models_.size() == 1 &&
                                MergeRigidParts(&models_[0], pairs, &rigidity);
  std::vector<ComponentModel> models;
  for (ComponentModel& model : models_) {
    model.mapper->ResumeKeypoints();
    for (ComponentModel& part : SplitIntoRigidParts(
             std::move(model), rigidity_checked ? &rigidity : nullptr)) {
      models.push_back(std::move(part));
    }
  }
  models_.clear();
  return models;
}

bool ComponentMapper::SettleFoldWithPriors(
    std::unique_ptr<GlobalMapper>* model,
    const std::vector<ImagePairGeometry>& pairs) {
  GlobalMapper& first = **model;
  if (!options_.fold.settle_with_priors || !first.in_prior_frame() ||
      !first.Solve() || first.fold().folded) {
    return false;
  }
  const PriorAgreement before = MeasurePriorAgreement(
      first.reconstruction(), database_.pose_priors, options_.pose_priors);
  // The candidate sides to turn back, in order: the priors' outlier groups,
  // then the fold check's weakest cut (which it could not call a fold).
  std::vector<std::pair<std::string, std::vector<image_t>>> candidates;
  const std::vector<image_t> off =
      PriorOutlierGroups(before, first.pairs(), options_.min_model_size);
  if (!off.empty()) candidates.emplace_back("priors off the model", off);
  if (first.fold_checked()) {
    const auto [side1, side2] =
        FoldCut(options_.fold.detection, first.reconstruction(), *evidence_,
                first.fold());
    if (!side2.empty() && side1 != off && side2 != off) {
      candidates.emplace_back("the fold check's weakest cut", side2);
    }
  }
  if (candidates.empty()) return false;
  LOG(INFO) << prefix_ << "pose priors: " << before.Describe() << "; "
            << candidates.size()
            << " candidate fold cut(s) to map again across";
  num_first_images_ = first.reconstruction().images.size();
  const std::string failure = failure_;
  for (const auto& [name, side] : candidates) {
    // Only the pairs the model with `side` turned agrees with.
    const std::vector<ImagePairGeometry> reoriented =
        PairsReorientedAcrossCut(pairs, first.reconstruction(), side,
                                 options_.fold.detection.max_rotation_error_deg,
                                 /*drop_contradicted_within=*/true);
    const size_t num_removed = pairs.size() - reoriented.size();
    const std::vector<std::vector<image_t>> components =
        PairComponents(reoriented);
    if (num_removed == 0 || components.empty() ||
        static_cast<int>(components[0].size()) < options_.min_model_size) {
      continue;
    }
    // Mapping again costs a whole mapping: only across a cut whose pairs
    // the priors already contradict (a correct model's weakest cut is no
    // fold).
    const double contrast =
        PriorPairContrast(first.reconstruction(), database_.pose_priors,
                          options_.pose_priors, first.pairs(), side);
    LOG(INFO) << prefix_ << "pose priors: the pairs across the cut of "
              << side.size() << " images (" << name << ") are " << contrast
              << " times as far off the priors as those within";
    if (contrast < kMinPriorPairContrast) continue;
    LOG(INFO) << prefix_ << "pose priors: " << side.size() << " images ("
              << name << ") turned back: " << num_removed
              << " pairs the model so turned contradicts are removed, "
                 "mapping again";
    const std::vector<ImagePairGeometry> component_pairs = PairsWithin(
        reoriented,
        std::set<image_t>(components[0].begin(), components[0].end()));
    first.SuspendKeypoints();
    std::unique_ptr<GlobalMapper> attempt =
        Attempt(components[0], component_pairs, prefix_);
    failure_ = failure;
    // The images must not object: no fold found, no image lost.
    if (attempt == nullptr || !Accepted(attempt.get()) ||
        !attempt->in_prior_frame() ||
        attempt->reconstruction().images.size() < num_first_images_) {
      LOG(INFO) << prefix_ << "pose priors: the re-mapped model is not taken"
                << (attempt == nullptr
                        ? std::string(" (no model)")
                        : " (" +
                              std::to_string(
                                  attempt->reconstruction().images.size()) +
                              " images; " + attempt->fold().Describe() + ")");
      continue;
    }
    const PriorAgreement after = MeasurePriorAgreement(
        attempt->reconstruction(), database_.pose_priors, options_.pose_priors);
    if (!PriorsAgreeBetter(before, after)) {
      LOG(INFO) << prefix_ << "pose priors: re-mapped " << after.Describe()
                << ": not clearly better, not taken";
      continue;
    }
    const std::string outcome = PriorSettledOutcome(side.size(), num_removed);
    LOG(WARNING) << prefix_
                 << "the model was FOLDED (the images alone did not show "
                    "it): the pose priors agree far better with it re-mapped ("
                 << before.Describe() << " -> " << after.Describe() << "); "
                 << outcome;
    notes_.push_back(prefix_ + "fold " + outcome);
    // As after a re-orientation across the fold check's cut: cameras still
    // turned alone are re-oriented once, else the model is written flagged.
    size_t num_alone_removed = 0;
    size_t num_alone_restored = 0;
    std::vector<ImagePairGeometry> mapped_pairs = component_pairs;
    if (!attempt->fold().weak_alone_images.empty() &&
        !ReorientImagesTurnedAlone(&attempt, component_pairs,
                                   &num_alone_removed, &num_alone_restored,
                                   &mapped_pairs)) {
      return true;
    }
    // Cameras turned alone the fold check did not see: their priors say so.
    size_t num_lone_turned = 0;
    if (!TurnBackLoneCameras(&attempt, mapped_pairs, &num_lone_turned)) {
      return true;
    }
    Finish(std::move(attempt),
           PriorSettledOutcome(side.size(), num_removed, num_alone_removed,
                               num_alone_restored, num_lone_turned));
    return true;
  }
  return false;
}

bool ComponentMapper::ReorientAcrossCut() {
  // The images on one side of the weakest cut sit at their twins' place:
  // across the cut, the pairs the folded model agrees with are those that
  // folded it, and those it contradicts are the true ones. Keep only the
  // latter across the cut and map again. A cut placed from a model folded
  // in several places re-orients only part of it: while the re-oriented
  // model is better supported (lower fold score, no fewer images), cut it
  // again (up to 1 + max_iterations rounds).
  const FoldResolutionOptions& options = options_.fold;
  for (int round = 0; round <= options.max_iterations; ++round) {
    const Reconstruction& model = best_->reconstruction();
    const auto [side1, side2] =
        FoldCut(options.detection, model, *evidence_, best_->fold());
    if (side2.empty()) break;
    const std::vector<ImagePairGeometry> across = PairsReorientedAcrossCut(
        current_pairs_, model, side2, options.detection.max_rotation_error_deg);
    const std::vector<ImagePairGeometry> reoriented =
        PairsWithoutSinglePairImages(across, *component_pairs_);
    const size_t num_dropped = current_pairs_.size() - reoriented.size();
    LOG(INFO) << prefix_ << "fold resolution (cut " << round + 1
              << "): cut into " << side1.size() << " and " << side2.size()
              << " images; " << current_pairs_.size() - across.size()
              << " pairs across it agree with the fold and are removed ("
              << across.size() - reoriented.size()
              << " more of images with a single pair), mapping again";
    const std::vector<std::vector<image_t>> components =
        PairComponents(reoriented);
    if (num_dropped == 0 || components.empty() ||
        static_cast<int>(components[0].size()) < options_.min_model_size) {
      break;
    }
    std::vector<ImagePairGeometry> component_pairs = PairsWithin(
        reoriented,
        std::set<image_t>(components[0].begin(), components[0].end()));
    std::unique_ptr<GlobalMapper> attempt =
        Attempt(components[0], component_pairs, prefix_);
    if (attempt == nullptr) break;
    if (Accepted(attempt.get())) {
      size_t num_alone_removed = 0;
      size_t num_alone_restored = 0;
      if (!attempt->fold().weak_alone_images.empty() &&
          !ReorientImagesTurnedAlone(&attempt, component_pairs,
                                     &num_alone_removed, &num_alone_restored)) {
        return true;
      }
      // Net: each restored pair is at a camera of this model, so a cut (this
      // or an earlier one) removed it and it is counted in num_removed_ +
      // num_dropped: the difference is not negative.
      const size_t num_removed =
          num_removed_ + num_dropped + num_alone_removed - num_alone_restored;
      LOG(INFO) << prefix_ << "fold resolved: " << attempt->fold().Describe();
      notes_.push_back(prefix_ + "fold resolved by removing " +
                       std::to_string(num_removed) +
                       " pairs that agree with it across " +
                       std::to_string(round + 1) + " cut(s)");
      Finish(std::move(attempt), "resolved (" + std::to_string(num_removed) +
                                     " pairs across the fold removed)");
      return true;
    }
    LOG(INFO) << prefix_ << "re-oriented model not accepted: "
              << attempt->fold().Describe();
    if (!(attempt->fold().fold_score < best_->fold().fold_score) ||
        !KeepsMost(attempt->reconstruction().images.size(),
                   best_->reconstruction().images.size())) {
      break;
    }
    best_ = std::move(attempt);
    current_pairs_ = std::move(component_pairs);
    num_removed_ += num_dropped;
  }
  return false;
}

bool ComponentMapper::ReorientImagesTurnedAlone(
    std::unique_ptr<GlobalMapper>* attempt,
    const std::vector<ImagePairGeometry>& pairs, size_t* num_pairs_removed,
    size_t* num_pairs_restored, std::vector<ImagePairGeometry>* mapped_pairs) {
  // Cameras turned alone among cameras the right way round are no cut;
  // re-orient them once (their pairs the model agrees with removed), else
  // write the model flagged folded.
  const std::vector<image_t>& weak_alone = (*attempt)->fold().weak_alone_images;
  const Reconstruction& resolved = (*attempt)->reconstruction();
  const double max_error = options_.fold.detection.max_rotation_error_deg;
  // Only those whose own pairs say so (all of the component's: a cut may
  // have removed a turned camera's true pairs). Each costs its pairs; a
  // false candidate costs a whole mapping: the 1,000-image photo scene's 46
  // were all the right way round
  // (docs/notes/2026-12-04-turned-alone-by-own-pairs.md).
  std::set<image_t> alone;
  for (const image_t image_id : weak_alone) {
    if (TurnedAloneByItsPairs(resolved, *component_pairs_, image_id,
                              max_error)) {
      alone.insert(image_id);
    }
  }
  if (alone.empty()) {
    LOG(INFO) << prefix_ << weak_alone.size()
              << " images weak alone, none turned by its own pairs (those "
                 "the model contradicts agree on no other pose, or carry "
                 "less than half the inliers of those it agrees with)";
    *num_pairs_removed = 0;
    *num_pairs_restored = 0;
    if (mapped_pairs != nullptr) *mapped_pairs = pairs;
    return true;
  }
  std::vector<ImagePairGeometry> kept;
  std::set<std::pair<image_t, image_t>> present;
  for (const ImagePairGeometry& pair : pairs) {
    present.insert(std::minmax(pair.image_id1, pair.image_id2));
    if ((!alone.count(pair.image_id1) && !alone.count(pair.image_id2)) ||
        ContradictedByModel(pair, resolved, max_error)) {
      kept.push_back(pair);
    }
  }
  const size_t num_alone_dropped = pairs.size() - kept.size();
  // A camera turned alone with no pair left was left on the wrong side of
  // a cut: the cut removed its true pairs across it (they agreed with the
  // folded model) and kept the false ones. Those of its pairs removed
  // earlier that the model now contradicts are given back (else the camera
  // is dropped, and with it the joint its pairs made). A camera that keeps
  // pairs the model contradicts is re-oriented by those alone.
  std::set<image_t> bare = alone;
  for (const ImagePairGeometry& pair : kept) {
    bare.erase(pair.image_id1);
    bare.erase(pair.image_id2);
  }
  size_t num_restored = 0;
  for (const ImagePairGeometry& pair : *component_pairs_) {
    if ((bare.count(pair.image_id1) || bare.count(pair.image_id2)) &&
        !present.count(std::minmax(pair.image_id1, pair.image_id2)) &&
        ContradictedByModel(pair, resolved, max_error)) {
      kept.push_back(pair);
      ++num_restored;
    }
  }
  LOG(INFO) << prefix_ << alone.size() << " of " << weak_alone.size()
            << " images weak alone may be turned alone: " << num_alone_dropped
            << " pairs at them agree with the model and are removed, "
            << num_restored
            << " removed before that the model contradicts are restored, "
               "mapping again";
  const std::vector<std::vector<image_t>> kept_components =
      PairComponents(kept);
  if (num_alone_dropped > 0 && !kept_components.empty() &&
      KeepsMost(kept_components[0].size(), num_first_images_)) {
    std::vector<ImagePairGeometry> again_pairs =
        PairsWithin(kept, std::set<image_t>(kept_components[0].begin(),
                                            kept_components[0].end()));
    (*attempt)->SuspendKeypoints();
    std::unique_ptr<GlobalMapper> again =
        Attempt(kept_components[0], again_pairs, prefix_);
    if (again != nullptr && Accepted(again.get()) &&
        again->fold().weak_alone_images.empty()) {
      *attempt = std::move(again);
      if (mapped_pairs != nullptr) *mapped_pairs = std::move(again_pairs);
      *num_pairs_removed = num_alone_dropped;
      *num_pairs_restored = num_restored;
      return true;
    }
  }
  LOG(WARNING) << prefix_ << "fold resolved but " << alone.size()
               << " images may still be turned alone: the model is "
                  "written flagged FOLDED: "
               << (*attempt)->fold().Describe();
  WriteTurnedAlone(std::move(*attempt), alone.size(),
                   " after the fold resolution", "");
  return false;
}

void ComponentMapper::WriteTurnedAlone(std::unique_ptr<GlobalMapper> mapper,
                                       size_t num_images,
                                       const std::string& note_reason,
                                       const std::string& outcome_reason) {
  const std::string alone =
      std::to_string(num_images) + " images may be turned alone";
  notes_.push_back(prefix_ + alone + note_reason);
  Finish(std::move(mapper), "folded (" + alone + outcome_reason + ")",
         /*folded=*/true);
}

bool ComponentMapper::TurnBackLoneCameras(
    std::unique_ptr<GlobalMapper>* attempt,
    const std::vector<ImagePairGeometry>& pairs, size_t* num_turned) {
  const Reconstruction& model = (*attempt)->reconstruction();
  const PriorAgreement before =
      MeasurePriorAgreement(model, database_.pose_priors, options_.pose_priors);
  const double max_error = options_.fold.detection.max_rotation_error_deg;
  // The cameras whose prior the bundle adjustment leaves out (beyond the
  // gate; 3 std without one): a camera turned alone sits at its mirrored
  // twin's place, tens of std from its fix, while a camera whose fix is
  // merely noisy is within the gate (its prior holds it). Turned back
  // across the pairs at it that the model contradicts (from all of the
  // component's pairs: a cut may have removed its true ones), such a camera
  // comes within the gate, and to at most half its distance from its fix:
  // tower 60 seed 2's image35 goes from 25.9 std to 3.4 (3.25 after the
  // mapping; docs/notes/2026-12-04-lone-turned-camera.md). A GPS outlier's
  // camera turned goes to its twin's place, not to its fix (27-33 std
  // there), and a right camera's noisy fix stays as far off (courtyard 100
  // seed 3: 4.9 -> 5.4 std, 3.3 -> 4.8).
  const double gate_std =
      options_.pose_priors.gate_std > 0 ? options_.pose_priors.gate_std : 3.0;
  std::vector<image_t> turned;
  std::vector<ImagePairGeometry> turned_pairs;
  int num_off = 0;
  for (const auto& [image_id, r] : before.residuals) {
    if (r < gate_std) continue;
    ++num_off;
    const TurnedBackPose pose =
        TurnBackAlone(model, *component_pairs_, image_id, max_error);
    if (!pose.found) continue;
    const PosePrior& prior = database_.pose_priors.at(image_id);
    const double r_turned =
        (PositionPriorSqrtInformation(prior, options_.pose_priors) *
         (pose.cam_from_world.Inverse().translation - prior.position))
            .norm();
    LOG(INFO) << prefix_ << "pose priors: image " << image_id << " is " << r
              << " std off its prior; turned back across " << pose.pairs.size()
              << " of its pairs it would be " << r_turned << " std off";
    if (r_turned >= std::min(gate_std, 0.5 * r)) continue;
    turned.push_back(image_id);
    turned_pairs.insert(turned_pairs.end(), pose.pairs.begin(),
                        pose.pairs.end());
  }
  if (turned.empty()) {
    if (num_off > 0) {
      LOG(INFO) << prefix_ << "pose priors: " << num_off
                << " images off their priors, none turned alone (GPS "
                   "outliers)";
    }
    return true;
  }
  // The pairs at the turned cameras: those of their turned-back poses.
  const std::set<image_t> moved(turned.begin(), turned.end());
  std::vector<ImagePairGeometry> again_pairs;
  for (const ImagePairGeometry& pair : pairs) {
    if (!moved.count(pair.image_id1) && !moved.count(pair.image_id2)) {
      again_pairs.push_back(pair);
    }
  }
  std::set<std::pair<image_t, image_t>> present;
  for (const ImagePairGeometry& pair : turned_pairs) {
    if (present.insert(std::minmax(pair.image_id1, pair.image_id2)).second) {
      again_pairs.push_back(pair);
    }
  }
  LOG(WARNING) << prefix_ << turned.size()
               << " images may be turned alone (their priors are off the "
                  "model and meet them turned back): mapping again with "
                  "their pairs that agree turned back";
  const std::vector<std::vector<image_t>> components =
      PairComponents(again_pairs);
  std::unique_ptr<GlobalMapper> again;
  if (!components.empty() &&
      KeepsMost(components[0].size(), num_first_images_)) {
    (*attempt)->SuspendKeypoints();
    again = Attempt(
        components[0],
        PairsWithin(again_pairs, std::set<image_t>(components[0].begin(),
                                                   components[0].end())),
        prefix_);
  }
  if (again != nullptr && Accepted(again.get()) && again->in_prior_frame() &&
      again->reconstruction().images.size() >= model.images.size()) {
    const PriorAgreement after = MeasurePriorAgreement(
        again->reconstruction(), database_.pose_priors, options_.pose_priors);
    if (LoneTurnSettled(before, after, turned, gate_std)) {
      LOG(WARNING) << prefix_ << turned.size()
                   << " images turned alone turned back by their priors ("
                   << before.Describe() << " -> " << after.Describe() << ")";
      *attempt = std::move(again);
      *num_turned = turned.size();
      return true;
    }
    LOG(INFO) << prefix_ << "pose priors: re-mapped " << after.Describe()
              << ": does not settle them";
  }
  LOG(WARNING) << prefix_ << turned.size()
               << " images may be turned alone (their priors say so) and "
                  "mapping again does not settle them: the model is written "
                  "flagged FOLDED";
  WriteTurnedAlone(std::move(*attempt), turned.size(), " (their priors say so)",
                   ": their priors say so");
  return false;
}

bool ComponentMapper::RemoveSuspectPairs() {
  for (int iteration = 0; iteration < options_.fold.max_iterations;
       ++iteration) {
    const std::set<std::pair<image_t, image_t>> suspects(
        best_->fold().suspect_pairs.begin(), best_->fold().suspect_pairs.end());
    const size_t before = current_pairs_.size();
    current_pairs_.erase(
        std::remove_if(current_pairs_.begin(), current_pairs_.end(),
                       [&](const ImagePairGeometry& pair) {
                         return suspects.count(
                             {std::min(pair.image_id1, pair.image_id2),
                              std::max(pair.image_id1, pair.image_id2)});
                       }),
        current_pairs_.end());
    if (current_pairs_.size() == before) break;
    num_removed_ += before - current_pairs_.size();
    LOG(INFO) << prefix_ << "fold resolution " << iteration + 1 << ": "
              << before - current_pairs_.size()
              << " suspect pairs removed, mapping again";
    const std::vector<std::vector<image_t>> components =
        PairComponents(current_pairs_);
    if (components.empty() ||
        static_cast<int>(components[0].size()) < options_.min_model_size) {
      break;
    }
    std::unique_ptr<GlobalMapper> attempt = Attempt(
        components[0],
        PairsWithin(current_pairs_, std::set<image_t>(components[0].begin(),
                                                      components[0].end())),
        prefix_);
    if (attempt == nullptr) break;
    // Only a better-supported model replaces the previous one.
    const bool better = attempt->fold().fold_score < best_->fold().fold_score &&
                        KeepsMost(attempt->reconstruction().images.size(),
                                  best_->reconstruction().images.size());
    if (!better) break;
    best_ = std::move(attempt);
    if (!best_->fold().folded && best_->Solve() && !best_->fold().folded) {
      LOG(INFO) << prefix_ << "fold resolved by removing " << num_removed_
                << " pairs: " << best_->fold().Describe();
      notes_.push_back(prefix_ + "fold resolved by removing " +
                       std::to_string(num_removed_) + " suspect pairs");
      Finish(std::move(best_),
             "resolved (" + std::to_string(num_removed_) + " pairs removed)");
      return true;
    }
  }
  return false;
}

bool ComponentMapper::SplitAtCut() {
  const auto [side1, side2] =
      FoldCut(options_.fold.detection, best_->reconstruction(), *evidence_,
              best_->fold());
  if (side2.empty()) return false;
  LOG(WARNING) << prefix_ << "fold not resolved: splitting into "
               << side1.size() << " and " << side2.size() << " images";
  const std::string split_prefix = prefix_ + "[split] ";
  for (const std::vector<image_t>* side : {&side1, &side2}) {
    const std::vector<ImagePairGeometry> side_pairs = PairsWithin(
        current_pairs_, std::set<image_t>(side->begin(), side->end()));
    for (const std::vector<image_t>& component : PairComponents(side_pairs)) {
      if (static_cast<int>(component.size()) < options_.min_model_size) break;
      std::unique_ptr<GlobalMapper> attempt = Attempt(
          component,
          PairsWithin(side_pairs,
                      std::set<image_t>(component.begin(), component.end())),
          split_prefix);
      if (attempt == nullptr || !attempt->Solve()) continue;
      const bool folded = attempt->fold().folded;
      if (folded) {
        LOG(WARNING) << split_prefix << "part of " << component.size()
                     << " images still looks folded: "
                     << attempt->fold().Describe();
      }
      Finish(std::move(attempt),
             std::string("split") + (folded ? " (still folded)" : ""));
    }
  }
  if (models_.empty()) return false;
  notes_.push_back(prefix_ + "folded model split into " +
                   std::to_string(models_.size()) + " models");
  return true;
}

void ComponentMapper::WriteFolded() {
  // Flagged after positioning from weak pairs alone and nothing removed: that
  // check sees only the tracks selected for positioning; the check after
  // refinement (every track, adjusted) decides.
  if (num_removed_ == 0 && !best_->fold().missing_fold && best_->Solve() &&
      !best_->fold().folded) {
    LOG(INFO) << prefix_
              << "no fold after refinement (the check after positioning "
                 "flagged weak pairs alone): "
              << best_->fold().Describe();
    notes_.push_back(prefix_ +
                     "weak pairs flagged after positioning, clean after "
                     "refinement");
    Finish(std::move(best_), "clean after refinement");
    return;
  }
  LOG(WARNING) << prefix_
               << "fold not resolved and no cut found: the model is written "
                  "but is likely FOLDED: "
               << best_->fold().Describe();
  notes_.push_back(prefix_ + "model likely folded (fold score " +
                   std::to_string(best_->fold().fold_score) +
                   "), not resolved");
  Finish(std::move(best_), "folded (unresolved)", /*folded=*/true);
}

bool ComponentMapper::MergeRigidParts(
    ComponentModel* model, const std::vector<ImagePairGeometry>& pairs,
    ModelRigidity* checked_rigidity) {
  const PartMergeOptions& options = options_.part_merge;
  if (!options.merge || model->folded) return false;
  ModelRigidity& rigidity = *checked_rigidity;
  rigidity = model->mapper->CheckRigidity();
  if (rigidity.num_large_blocks <= 1) return true;
  const int num_parts_first = rigidity.num_large_blocks;
  // The images the split model writes (its parts of min_model_size images
  // or more): the re-mapped model must write as many (within the option).
  const size_t num_written_first =
      NumWrittenImages(model->mapper->reconstruction(), rigidity);
  std::vector<ImagePairGeometry> current_pairs = pairs;
  size_t num_removed = 0;
  int num_rounds_kept = 0;
  std::string stop;  // why the last round stopped, if it did
  for (int round = 0;
       round < options.max_rounds && rigidity.num_large_blocks > 1; ++round) {
    const std::string round_name =
        "part merge (round " + std::to_string(round + 1) + ")";
    const PartMergePlan plan =
        PlanPartMerge(options, model->mapper->reconstruction(), rigidity.blocks,
                      current_pairs, database_.two_view_geometries);
    LOG(INFO) << prefix_ << round_name << ": " << rigidity.num_large_blocks
              << " rigid parts (" << plan.num_parts << " with the small ones); "
              << plan.num_confirmed << " of " << plan.num_pairs_across
              << " pairs across them confirmed by the parts' points, "
                 "joining them into "
              << plan.num_groups << " groups; " << plan.contradicted.size()
              << " pairs across joined parts contradict the join by more "
                 "than "
              << options.max_rotation_error_deg << " deg";
    for (const PartJoin& join : plan.joins) {
      std::ostringstream best;
      if (join.best_check >= 0) {
        const CrossPairCheck& check = plan.checks[join.best_check];
        best << " (best " << check.image_id_a << " -> " << check.image_id_b
             << ", " << check.num_met << " of " << check.num_points << ")";
      }
      LOG(INFO) << prefix_ << round_name << ": parts " << join.part1 << " ("
                << plan.part_sizes[join.part1] << " images) and " << join.part2
                << " (" << plan.part_sizes[join.part2]
                << "): " << join.num_pairs << " confirmed pairs, "
                << join.num_agreeing
                << " of them explained by one similarity between the parts "
                   "(rotation within "
                << options.max_join_spread_deg << " deg, centres within "
                << options.max_join_center_error << " of their depth) meeting "
                << join.num_points << " points" << best.str()
                << (join.agreed ? ": joined"
                                : ": not joined (fewer than " +
                                      std::to_string(options.min_join_pairs) +
                                      " agreeing pairs)");
    }
    if (plan.num_confirmed == 0) {
      stop = "no pair across the parts confirmed";
      break;
    }
    if (plan.num_groups == plan.num_parts) {
      stop = "no two parts joined by " +
             std::to_string(options.min_join_pairs) +
             " confirmed pairs one similarity explains";
      break;
    }
    std::set<std::pair<image_t, image_t>> removed = plan.contradicted;
    if (options.remove_refuted) {
      removed.insert(plan.refuted.begin(), plan.refuted.end());
    }
    LOG(INFO) << prefix_ << round_name << ": " << plan.refuted.size()
              << " pairs across parts refuted by the parts' points"
              << (options.remove_refuted ? "" : " (kept)");
    if (removed.empty()) {
      stop =
          "no pair contradicts the join nor is refuted (mapping again "
          "would not change the model)";
      break;
    }
    std::vector<ImagePairGeometry> kept;
    for (const ImagePairGeometry& pair : current_pairs) {
      if (!removed.count(std::minmax(pair.image_id1, pair.image_id2))) {
        kept.push_back(pair);
      }
    }
    const std::vector<std::vector<image_t>> components = PairComponents(kept);
    if (components.empty() ||
        static_cast<int>(components[0].size()) < options_.min_model_size) {
      stop = "no component left after removing the pairs";
      break;
    }
    kept = PairsWithin(
        kept, std::set<image_t>(components[0].begin(), components[0].end()));
    LOG(INFO) << prefix_ << round_name << ": " << removed.size()
              << " pairs removed, mapping the component again ("
              << components[0].size() << " images)";
    // The remaining pairs' rotation averaging first (a small part of a
    // mapping's cost): a joined part it turns apart again (false pairs
    // elsewhere still mislead it) splits off again in the re-mapped model.
    // Mapping again only pays where the joins it keeps leave fewer large
    // groups than the model has rigid parts.
    // The probe is the attempt's own mapper: Solve() then goes on from its
    // rotations (the same ones it would average again).
    std::unique_ptr<GlobalMapper> probe =
        NewMapper(components[0], kept, prefix_ + "[parts joined] ", evidence_);
    {
      if (probe->RotationAveraging()) {
        const std::vector<double> turns =
            JoinTurnsDeg(plan, model->mapper->reconstruction(), rigidity.blocks,
                         probe->rotations());
        int worst = 0;
        int num_turned = 0;
        for (int p = 0; p < static_cast<int>(turns.size()); ++p) {
          if (turns[p] > turns[worst]) worst = p;
          num_turned += turns[p] > options.max_join_turn_deg ? 1 : 0;
        }
        const int num_large_kept = NumLargeGroupsKept(
            plan, turns, options.max_join_turn_deg, options_.min_model_size);
        LOG(INFO) << prefix_ << round_name
                  << ": rotation averaging of the remaining pairs turns "
                  << num_turned << " joined parts by more than "
                  << options.max_join_turn_deg << " deg (most: part " << worst
                  << ", " << turns[worst] << " deg); the joins it keeps leave "
                  << num_large_kept << " large groups";
        if (num_large_kept >= rigidity.num_large_blocks) {
          stop = "rotation averaging of the remaining pairs turns " +
                 std::to_string(num_turned) +
                 " joined parts apart again (most " +
                 std::to_string(static_cast<int>(std::lround(turns[worst]))) +
                 " deg) and keeps no join of large parts";
          break;
        }
        // Whether the pairs across the parts can make the model rigid at
        // all: its rigidity check with the tracks of the pairs the
        // re-mapping keeps (those its rotation filter keeps under these
        // rotations) added across the parts (a fraction of a second).
        // Joins whose pairs all hold one image of a part (articulation
        // joins) or share too few points tie nothing the check counts; no
        // re-mapping makes them rigid.
        if (options.check_rigid_joins) {
          const ModelRigidity joined = JoinedRigidity(
              model->mapper->reconstruction(), rigidity.blocks,
              FilterPairsByRotation(
                  kept, probe->rotations(),
                  probe->options().skip_rotation_filter
                      ? 180.0
                      : probe->options()
                            .rotation_filter.max_rotation_error_deg),
              database_.two_view_geometries, options_.min_model_size);
          LOG(INFO) << prefix_ << round_name
                    << ": with the tracks of the pairs across the parts "
                       "added the model would be "
                    << joined.num_large_blocks << " rigid part(s)";
          if (joined.num_large_blocks >= rigidity.num_large_blocks) {
            stop = "the pairs across the parts tie none of them rigidly (" +
                   std::to_string(joined.num_large_blocks) +
                   " rigid parts with their tracks added)";
            break;
          }
        }
      }
    }
    const std::string failure = failure_;
    model->mapper->SuspendKeypoints();
    std::unique_ptr<GlobalMapper> attempt = Attempt(std::move(probe));
    failure_ = failure;
    ModelRigidity merged;
    if (attempt == nullptr || !attempt->Solve()) {
      stop = "the re-mapped component gave no model";
    } else if (attempt->fold().folded) {
      stop = "the re-mapped model looks folded (" + attempt->fold().Describe() +
             ")";
    } else {
      merged = attempt->CheckRigidity();
      const size_t num_written =
          NumWrittenImages(attempt->reconstruction(), merged);
      if (merged.num_large_blocks >= rigidity.num_large_blocks) {
        stop = "the re-mapped model is not less split (" +
               std::to_string(merged.num_large_blocks) + " rigid parts)";
      } else if (static_cast<double>(num_written) <
                 options.min_image_fraction * num_written_first) {
        stop = "the re-mapped model writes " + std::to_string(num_written) +
               " images, the split one " + std::to_string(num_written_first);
      }
    }
    if (!stop.empty()) break;
    LOG(INFO) << prefix_ << round_name
              << ": re-mapped model kept: " << merged.num_large_blocks
              << " rigid part(s), " << attempt->reconstruction().images.size()
              << " images";
    model->mapper = std::move(attempt);
    model->fold_outcome = model->mapper->fold_checked() ? "clean" : "";
    current_pairs = std::move(kept);
    rigidity = std::move(merged);
    num_removed += removed.size();
    ++num_rounds_kept;
  }
  const std::string result =
      std::to_string(num_parts_first) + " rigid parts -> " +
      std::to_string(std::max(rigidity.num_large_blocks, 1)) + " (" +
      std::to_string(num_rounds_kept) + " round(s) kept, " +
      std::to_string(num_removed) + " pairs removed" +
      (stop.empty() ? "" : "; stopped: " + stop) + ")";
  if (num_rounds_kept > 0) {
    LOG(INFO) << prefix_ << "part merge: " << result;
  } else {
    LOG(INFO) << prefix_ << "part merge: the split model is kept: " << result;
  }
  model->part_merge = result;
  notes_.push_back(prefix_ + "part merge: " + result);
  return true;
}

std::vector<const std::vector<image_t>*> ComponentMapper::WrittenParts(
    const ModelRigidity& rigidity) const {
  std::vector<const std::vector<image_t>*> parts;
  if (rigidity.num_large_blocks <= 1) return parts;
  for (const std::vector<image_t>& block : rigidity.blocks) {
    if (static_cast<int>(block.size()) >= options_.min_model_size) {
      parts.push_back(&block);
    }
  }
  return parts;
}

size_t ComponentMapper::NumWrittenImages(const Reconstruction& reconstruction,
                                         const ModelRigidity& rigidity) const {
  const std::vector<const std::vector<image_t>*> parts = WrittenParts(rigidity);
  if (parts.empty()) return reconstruction.images.size();
  size_t num_images = 0;
  for (const std::vector<image_t>* part : parts) num_images += part->size();
  return num_images;
}

std::vector<ComponentModel> ComponentMapper::SplitIntoRigidParts(
    ComponentModel model, const ModelRigidity* checked_rigidity) {
  // The model as it is when it is one rigid piece, else its rigid parts of
  // min_model_size images or more, each as a model of its own, with a
  // warning: never one model whose parts sit at an arbitrary relative offset
  // or scale.
  const ModelRigidity rigidity = checked_rigidity != nullptr
                                     ? *checked_rigidity
                                     : model.mapper->CheckRigidity();
  std::vector<ComponentModel> parts;
  const std::vector<const std::vector<image_t>*> blocks =
      WrittenParts(rigidity);
  if (blocks.empty()) {
    parts.push_back(std::move(model));
    return parts;
  }
  std::string sizes;
  for (const std::vector<image_t>* block : blocks) {
    sizes += (sizes.empty() ? "" : ", ") + std::to_string(block->size());
  }
  const std::string message =
      "the model of " +
      std::to_string(model.mapper->reconstruction().images.size()) +
      " images is not one rigid piece: its parts of " + sizes +
      " images are joined through single images only (fewer than " +
      std::to_string(ModelRigidityOptions().min_shared_points) +
      " points seen from both parts otherwise), so their relative position "
      "and scale are not determined; writing the parts as separate models";
  LOG(WARNING) << prefix_ << message;
  notes_.push_back(prefix_ + message);
  if (VLOG_IS_ON(1)) {
    // Images of blocks under min_model_size images, and images in no block.
    std::set<image_t> written;
    for (const std::vector<image_t>* block : blocks) {
      written.insert(block->begin(), block->end());
    }
    std::ostringstream left;
    for (const auto& [image_id, image] :
         model.mapper->reconstruction().images) {
      if (!written.count(image_id)) {
        left << " " << database_.images.at(image_id).name;
      }
    }
    VLOG(1) << prefix_
            << "rigidity split: images in no written part:" << left.str();
  }
  for (const std::vector<image_t>* block : blocks) {
    ComponentModel part;
    part.mapper = std::make_unique<GlobalMapper>(*model.mapper);
    part.mapper->RestrictToImages(
        std::set<image_t>(block->begin(), block->end()));
    part.folded = model.folded;
    part.part_merge = model.part_merge;
    part.fold_outcome =
        model.fold_outcome.empty() || model.fold_outcome == "clean"
            ? "split (not rigid)"
            : model.fold_outcome + ", split (not rigid)";
    parts.push_back(std::move(part));
  }
  return parts;
}

}  // namespace colmap_irav4
