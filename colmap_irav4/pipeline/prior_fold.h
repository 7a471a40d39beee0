#pragma once

// Folds that the images alone cannot settle, settled by the pose priors.
//
// A silent fold (refinement/fold_detection.h: the fold check found nothing
// conclusive) turns part of the cameras 180 deg onto their mirrored twins'
// side. Rotation averaging decides it and the priors cannot enter there: a
// position prior does not constrain a rotation, and gravity cannot see a
// turn about the vertical. What the priors can do is judge a turned group
// once it is named: the model mapped again with that group turned back
// fits the priors far better (every turned camera sat at its twin's place)
// where the fold was real, and no better where it was not. The component
// mapper (pipeline/component_mapper.h) therefore names candidate groups,
// maps again across each (the pairs across it that the model agrees with
// removed, as the fold resolution does), and keeps a re-mapped model only
// when the priors agree with it clearly better and the images do not object
// (no fold found, no image lost). Candidates:
//   - the images whose priors are off the model by more than 3 standard
//     deviations, where they form connected groups too large for GPS
//     outliers (a turned half of a tower sits tens of metres off);
//   - the fold check's own weakest cut, which it found but could not call a
//     fold (the images alone do not decide; the priors do).

#include <map>
#include <string>
#include <vector>

#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/scene/pose_prior.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// How well a model's camera centres agree with their position priors, in
// the priors' frame (whitened residuals: standard deviations).
struct PriorAgreement {
  // Registered images with a position prior, and those within 3 standard
  // deviations of it.
  int num_priors = 0;
  int num_within = 0;
  // Sum over the priors of min(r^2, 9): the priors' negative log-likelihood
  // (up to a constant) with everything beyond 3 std counted as an outlier,
  // so that a GPS outlier 50 m off weighs what one 3 std off does and the
  // many cameras a fold puts 1-3 std off are all counted.
  double capped_cost = 0;
  // Whitened residual norm by image.
  std::map<image_t, double> residuals;

  // Counts one image's whitened residual norm `r` in every figure above.
  void Add(image_t image_id, double r);
  // "97 of 100 priors within 3 std, capped cost 312.4".
  std::string Describe() const;
};

PriorAgreement MeasurePriorAgreement(const Reconstruction& reconstruction,
                                     const PosePriors& priors,
                                     const PosePriorOptions& options);

// Whether a re-mapped model agrees with the priors clearly better than the
// model it would replace (margins: see the definition).
bool PriorsAgreeBetter(const PriorAgreement& before,
                       const PriorAgreement& after);

// The images whose priors are off the model by more than 3 standard
// deviations, in the connected groups (joined by `pairs`, the pairs the
// model agrees with) of at least max(min_group_size, 10% of the priors)
// images: too many together for independent GPS outliers (5% of consumer
// fixes, scattered). Sorted; empty when there is none.
std::vector<image_t> PriorOutlierGroups(
    const PriorAgreement& agreement,
    const std::vector<ImagePairGeometry>& pairs, int min_group_size);

// How much worse the priors agree with the relative positions of the pairs
// across a cut (one image in `side`) than with those of the pairs on either
// side: the median whitened residual of (c_j - c_i) - (p_j - p_i) over the
// pairs across, divided by that over the pairs within (`pairs`: those the
// model agrees with; covariance: the two priors' summed). The offset and
// most of a poor similarity to the priors cancel in a difference. Across a
// fold the pairs the model agrees with are false: each puts a camera at its
// twin's place, metres from where its fix says; in a correct model the
// pairs across any cut are as true as those within (about 1). 0 when
// fewer than 5 pairs across or within have priors.
// The least contrast of a cut worth mapping again across: measured 1.7-3.8
// across the folds of the symmetric suite (tower 60, courtyard 100, seeds
// 1-3), 0.97-1.12 across the weakest cut of correct courtyards of 100
// images (docs/notes/2026-12-03-priors-components-and-folds.md).
constexpr double kMinPriorPairContrast = 1.4;

double PriorPairContrast(const Reconstruction& reconstruction,
                         const PosePriors& priors,
                         const PosePriorOptions& options,
                         const std::vector<ImagePairGeometry>& pairs,
                         const std::vector<image_t>& side);

// A camera turned alone that the fold check does not see (after a settling
// by the priors, its prior off the model like a GPS outlier's), turned back
// across its own pairs: those the model contradicts that agree on one
// rotation (a camera turned alone: its true pairs), with the centre where
// the directions to its neighbours they measure meet. The cost is that of
// its pairs, no mapping. `found` false: fewer than kMinTurnBackPairs pairs
// agree, or their directions do not fix a centre.
struct TurnedBackPose {
  bool found = false;
  Rigid3d cam_from_world;
  // The pairs at the camera that agree with the turned-back pose.
  std::vector<ImagePairGeometry> pairs;
  // The inliers of the pairs at the camera that the model agrees with
  // (summed whether or not a pose is found).
  int64_t num_agreeing_inliers = 0;
};

// Three pairs: two directions fix a centre, the third checks it (and one
// mirror pair alone cannot turn a camera).
constexpr int kMinTurnBackPairs = 3;

// Whether the model's rotations contradict the pair's measured rotation by
// more than max_rotation_error_deg (false when an image is not in the model).
bool ContradictedByModel(const ImagePairGeometry& pair,
                         const Reconstruction& reconstruction,
                         double max_rotation_error_deg);

TurnedBackPose TurnBackAlone(const Reconstruction& reconstruction,
                             const std::vector<ImagePairGeometry>& pairs,
                             image_t image_id, double max_rotation_error_deg);

// Whether camera `image_id`'s own pairs say it is turned alone: the pairs
// at it that the model contradicts agree on another pose (TurnBackAlone
// finds one) and carry at least half as many inliers as the pairs at it
// that the model agrees with. A camera turned alone among cameras the right
// way round has its true pairs against the model and only its false ones
// (mirror-twin) for it; a camera the right way round that the fold check
// finds weak alone only because a few false pairs contradict it (random
// ones agree on no pose; its mirror-twin ones are few next to its true
// ones) has not.
bool TurnedAloneByItsPairs(const Reconstruction& reconstruction,
                           const std::vector<ImagePairGeometry>& pairs,
                           image_t image_id, double max_rotation_error_deg);

// Whether a model with the cameras `turned` turned back settles them: each
// within `max_std` of its own prior (the mapper: the prior gate, the priors
// its bundle adjustment keeps) and at most half as far off it as in
// `before`, and the other priors agree no worse (no fewer within 3 std; a
// capped cost at most 10% higher, a re-mapping's noise). A GPS outlier's
// camera does not pass: turned, it moves to its mirrored twin's place, not
// to its fix.
bool LoneTurnSettled(const PriorAgreement& before, const PriorAgreement& after,
                     const std::vector<image_t>& turned, double max_std);

// The fold outcome of a model the priors settled: "resolved by pose priors
// (N images turned back, M pairs removed)", and when cameras it left turned
// alone were re-oriented after that, the pairs at them removed and those
// removed earlier that were given back, each counted on its own (a camera
// the cut left with no pair gets more back than it loses: a difference
// would be negative).
// `num_lone_turned`: cameras turned alone that TurnBackAlone turned back
// after that.
std::string PriorSettledOutcome(size_t num_turned_back, size_t num_removed,
                                size_t num_alone_removed = 0,
                                size_t num_alone_restored = 0,
                                size_t num_lone_turned = 0);

}  // namespace colmap_irav4
