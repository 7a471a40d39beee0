#pragma once

// Fold detection for symmetric and repetitive scenes.
//
// A folded model places some cameras at the position of their mirrored twin
// (e.g. a courtyard whose opposite walls look alike): false image pairs whose
// matches agree with the twin become consistent, and the model is complete
// and self-consistent, with exit 0. What the model cannot hide is what the
// database knows and the model contradicts:
//   - missing correspondences: image pairs the model says look at the same
//     points from nearly the same direction, but the database holds no
//     verified matches for them (the images were matched and did not match);
//   - inconsistent strong pairs: verified pairs with many inliers whose
//     relative rotation the model contradicts;
//   - tracks seen from contradictory sides of their point.
//   - weak pairs across a cut: a false (mirror) pair that the folded model
//     explains matches only part of what a true pair with the same predicted
//     overlap matches (only the repeated part of the facade matches), so its
//     verified inliers per co-visible model point predicted for it fall far
//     below the typical ratio; in a folded model these weak pairs are the
//     ones that cross the fold, and nearly every consistent pair across it
//     is weak (where the symmetry is strong the folded model leaves few
//     pairs missing, and this is the remaining evidence).
// The fold score is the fraction of the predicted-overlapping (tried) pairs
// without matches, or, where the weak pairs form a cut, the fraction of the
// consistent predicted pairs that are weak and cross it (whichever is
// larger): near 0 for a correct model from exhaustive matching, high where
// cameras were folded onto their twins' side.

#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/track.h"
#include "colmap_irav4/scene/types.h"
#include "colmap_irav4/util/enum_names.h"

namespace colmap_irav4 {

// The parts a fold cut divides (FoldDetectionOptions::cut_parts).
enum class FoldCutParts { kModel, kRigidParts, kAgreeingParts };
template <>
const EnumNames<FoldCutParts>& NamesOf<FoldCutParts>();

struct FoldDetectionOptions {
  // Rays of two cameras to a point more than this apart (deg): the cameras
  // are not expected to match the point (descriptors fail at wide angles).
  double max_view_angle_deg = 30.0;
  // Distance ratio of two cameras to a point above which they are not
  // expected to match it (scale change).
  double max_scale_ratio = 2.0;
  // A camera is expected to match only points no farther from it than
  // (nearly all) the model points it observes: what an image detects ends at
  // some depth (resolution, blur, the reach of its detector), and its own
  // points say where; beyond it the geometry alone over-predicts the overlap
  // (the far walls of a courtyard).
  bool within_observed_depth = true;
  // Predict overlap only between images of one rigid part of the model
  // (refinement/model_rigidity.h): parts joined through a single image have
  // a free scale about it, and the model places their cameras relative to
  // each other arbitrarily (a correct sparse model's pairs across such a
  // joint looked missing although their images were tens of metres apart).
  bool within_rigid_parts = true;
  // A pair is predicted to overlap when each image expects at least this
  // fraction of the other's model points.
  double min_overlap_fraction = 0.3;
  // ... and at least this many of them.
  int min_overlap_points = 20;
  // Model points sampled per image (evenly over its observations): bounds the
  // cost at images^2 * this projections.
  int max_points_per_image = 300;
  // A pair with fewer verified inliers counts as not matched (the mapper
  // sets it to its --Mapper.min_num_matches).
  int min_num_matches = 15;
  // Models with a higher fold score are reported folded...
  double max_fold_score = 0.1;
  // ... when at least this many predicted pairs are missing.
  int min_missing_pairs = 5;
  // A verified pair disagreeing with the model's rotations by more than this
  // (deg) is inconsistent with the model.
  double max_rotation_error_deg = 5.0;
  // Two rays of one track more than this apart (deg): the point is seen from
  // contradictory sides.
  double contradictory_ray_angle_deg = 120.0;
  // A used pair is suspected (explains the fold) when at least this many
  // images predicted to overlap both match exactly one of them, and more of
  // them do than match both.
  int min_suspect_conflicts = 2;
  // A consistent predicted pair is weak when its verified inliers per
  // co-visible model point predicted for it fall below this fraction of the
  // typical ratio (upper quartiles: false pairs may be the majority where
  // the symmetry is strong). 0: weak pairs are not used. A false pair that
  // keeps more than about this fraction of what a true pair matches cannot
  // be told from a true one.
  double weak_pair_ratio = 0.75;
  // The typical ratio of a pair from a fit to the images' own match rates,
  // the pair's view angle and its change of scale (log ratio = a_i + a_j +
  // b(angle) + c(scale), upper quartiles; the shared effects b and c
  // counting the predicted pairs that failed the verification too), not one
  // figure for the whole model. A detector keeps fewer of the points an
  // image sees where it sees many, and descriptors match less across wider
  // angles and scales: with one figure, the images that match less (a
  // stretch of a long wall, the corners) form a cut of weak pairs in a
  // correct model.
  bool weak_pair_rate_model = true;
  // With the rate model, a predicted pair without matches counts as missing
  // only where the model expects at least this many times min_num_matches
  // inliers for it: a true pair between images that keep few of their
  // points, or across a wide angle, may fail the verification.
  double missing_pair_inlier_factor = 2.0;
  // A model is folded when a cut separates at least this many weak pairs...
  int min_weak_cut_pairs = 10;
  // ... that make at least this fraction of the consistent predicted pairs
  // across it (a fold leaves only false pairs consistent across it; the
  // wide-baseline pairs of a correct sequence are weak too, but a cut through
  // it also crosses its strong near pairs).
  double min_weak_cut_fraction = 0.9;
  // An image is "weak alone" when at least this many consistent predicted
  // pairs are at it, all weak, and at least this many verified pairs at it
  // contradict the model: what a camera turned alone among cameras the
  // right way round shows (its true pairs contradicted, its false ones
  // weak), which no cut separates (a cut needs strong pairs on both sides).
  // Reported only; the resolution re-orients such images of a model it
  // would accept.
  int min_weak_alone_pairs = 2;
  // Which parts of a folded model its cut divides, each on its own (pairs
  // between parts are left out; a part whose cut does not explain its
  // missing and weak pairs stays whole). kModel: one cut through the whole
  // model; at 10,000 photo images it also crossed the landmarks that cannot
  // fold, and the resolution removed their true pairs across it.
  // kRigidParts: the rigid parts (within_rigid_parts' parts); there one
  // landmark was tied rigidly to the folded one by its false pairs' points.
  // kAgreeingParts: the components of the pairs the model agrees with (its
  // rotations within max_rotation_error_deg, trusted, suspect or weak: a
  // fold's halves stay together by the false pairs that folded them), each
  // pair counted only in at least cut_min_pair_triangles triangles of such
  // pairs (the odd false pair the model agrees with by chance joins two
  // landmarks, but not in triangles).
  // docs/notes/2026-12-06-fold-cut-at-10000.md
  FoldCutParts cut_parts = FoldCutParts::kModel;
  // kModel: the agreeing parts (as kAgreeingParts') whose own cut finds no
  // fold stay whole, on the side of the model's cut holding most of their
  // images, when another part's cut finds one. At 10,000 photo images the
  // model's cut still split landmarks 1 and 2 after the fold cut of
  // landmark 0 was converged; the true pairs removed across it left them
  // 10x less accurate (docs/notes/2026-12-08-unfolded-parts-stay-whole.md).
  bool cut_keep_unfolded_parts = true;
  // kAgreeingParts and cut_keep_unfolded_parts: the triangles a pair needs
  // to join its images' part.
  int cut_min_pair_triangles = 2;
  // The cut's eigenvector: power iterations until it converges, at most
  // this many (SignedGraphCut). 300 (kSignedCutFixedIterations): exactly
  // 300, the cut of before, which on a 5,454-image symmetric landmark was
  // not converged and mixed the fold's halves.
  int cut_max_power_iterations = 20000;
  // The cut also pushes apart the images of the verified pairs the model
  // contradicts by the fold's own rotation: a true pair across a fold
  // measures what the truth has where the model holds one image at its
  // mirror twin's place, so its discrepancy in the model's frame
  // (R_j^T R_ij R_i, model rotations R) is the symmetry's rotation, the
  // same for every such pair, while the odd false pair's is anything. The
  // most common discrepancy of the contradicted pairs is taken as the
  // fold's rotation when at least cut_min_fold_rotation_pairs pairs share
  // it (within max_rotation_error_deg; see below); each of them weighs as a
  // trusted pair of its inliers. False: missing and weak pairs only.
  bool cut_fold_rotation_pairs = false;
  int cut_min_fold_rotation_pairs = 10;
  // ... among the pairs contradicted by at least this (deg): the symmetries
  // that fold a model turn it by a large angle (180 deg for opposite
  // facades, 90 for a square courtyard), while the contradicted pairs of a
  // 5,454-image photo landmark shared a 7.7 deg discrepancy (focal errors)
  // that is no fold.
  double cut_min_fold_rotation_deg = 30;
  // ... and shared by at least this fraction of them (a fold's: over 90% on
  // the tower and varying-match courtyards; that landmark's most common
  // discrepancy over 30 deg: 5%).
  double cut_min_fold_rotation_share = 0.25;
  // Skip the camera pairs too far apart to share a point under the view
  // angle and scale ratio before projecting any point (exact: the report is
  // the same; false only to measure what it saves).
  bool skip_distant_pairs = true;

  // Throws InputError naming the option (--Fold.*).
  void Check() const;
};

// The fold check and its resolution around the mapping of a component
// (pipeline/fold_resolution.h).
struct FoldResolutionOptions {
  // Test every model for a fold (fold score in summary.json, a warning).
  bool detect = true;
  // Resolve detected folds (remove suspect pairs and re-map, else split).
  bool resolve = true;
  // Rounds of (remove suspect pairs, re-map) before a split is tried.
  int max_iterations = 2;
  // A model in the pose priors' frame that the check finds clean is mapped
  // again across candidate fold cuts (pipeline/prior_fold.h), and a
  // re-mapped model that the priors agree with clearly better replaces it.
  bool settle_with_priors = true;
  FoldDetectionOptions detection;

  // Throws InputError naming the option (--Fold.*).
  void Check() const;
};

// What the database says about one image pair (any orientation).
struct PairEvidence {
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  // Verified inlier matches (0: the verification failed or found none).
  int num_inliers = 0;
  // Raw (unverified) matches; -1 where the database does not say.
  int num_matches = -1;
  // Whether the database holds its verification (a two_view_geometries row,
  // or a measured rotation). A pair with raw matches but no verification
  // (rows deleted, verification not run) was not tried as far as the fold
  // check can tell: it is not a missing pair.
  bool verified = false;
  // Measured relative rotation cam2_from_cam1 (the view graph's), if any.
  bool has_rotation = false;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
};

struct FoldEvidence {
  std::vector<PairEvidence> pairs;
  // Whether a pair absent from `pairs` was matched and found nothing (true
  // when the database keeps no record of the pairs it tried, e.g. its raw
  // matches were deleted: exhaustive matching is then assumed).
  bool absent_pairs_were_tried = false;
};

// A verified pair the model agrees with, and how much of what the model
// predicts the two images share its matches cover.
struct PairSupport {
  image_t image_id1 = kInvalidImageId;  // smaller id
  image_t image_id2 = kInvalidImageId;
  int num_inliers = 0;
  // Model points of image 1 that image 2 is expected to see, and vice versa
  // (scaled from the sample to all of the image's points, or to its
  // observations in all the tracks: DetectFold's `tracks`).
  double num_predicted12 = 0;
  double num_predicted21 = 0;
  // Whether the pair is one of the predicted overlapping pairs.
  bool predicted = false;
  // Mean angle (deg) between the two cameras' rays to the predicted
  // co-visible points.
  double view_angle_deg = 0;
  // Mean |log| of the ratio of the two cameras' distances to those points
  // (a change of scale).
  double log_scale = 0;
  // Inliers per predicted co-visible point (geometric mean of both
  // directions), the typical ratio for this pair (weak_pair_rate_model), and
  // whether the ratio is below weak_pair_ratio of that.
  double ratio = 0;
  double expected_ratio = 0;
  bool weak = false;
};

struct FoldReport {
  // Fraction of the predicted-overlapping tried pairs without matches.
  double fold_score = 0;
  bool folded = false;
  // Whether the missing pairs alone make it folded (max_fold_score,
  // min_missing_pairs); folded is this or weak_fold.
  bool missing_fold = false;
  int num_images = 0;
  int num_predicted_pairs = 0;
  int num_missing_pairs = 0;
  // Predicted pairs without matches that the rate model expected too few
  // inliers of (missing_pair_inlier_factor): counted neither predicted nor
  // missing.
  int num_unexpected_pairs = 0;
  // Verified pairs (with a rotation) the model contradicts, and those of them
  // with at least the median inlier count of the pairs the model agrees with.
  int num_inconsistent_pairs = 0;
  int num_strong_inconsistent_pairs = 0;
  int num_tracks = 0;
  int num_contradictory_tracks = 0;
  // Images in order; predicted and missing pairs per image.
  std::map<image_t, int> image_predicted_pairs;
  std::map<image_t, int> image_missing_pairs;
  // (smaller id, larger id).
  std::vector<std::pair<image_t, image_t>> missing_pairs;
  // Pairs the model agrees with that explain the conflict (their matches
  // tie together images whose other predicted neighbours disagree).
  std::vector<std::pair<image_t, image_t>> suspect_pairs;
  // The consistent pairs with a predicted overlap in both directions.
  std::vector<PairSupport> pair_support;
  // Typical inliers per predicted co-visible point of the consistent
  // predicted pairs (0 if none), how many of those pairs are weak, and the
  // cut that best separates the weak pairs from the strong ones: weak and
  // strong consistent predicted pairs across it. weak_fold: the cut is a
  // fold (min_weak_cut_pairs, min_weak_cut_fraction, and the smaller side
  // holds a strong pair, so that one poorly matched image is not a fold).
  double typical_ratio = 0;
  int num_support_pairs = 0;
  int num_weak_pairs = 0;
  int num_weak_cut_pairs = 0;
  int num_strong_cut_pairs = 0;
  bool weak_fold = false;
  // Images weak alone (min_weak_alone_pairs).
  std::vector<image_t> weak_alone_images;

  // One line for the log: "fold score 0.42 (31 of 74 predicted pairs
  // missing), ...".
  std::string Describe() const;
};

// Tests the model against the evidence. Only registered images and the
// model's points are used; cameras must have valid parameters.
// `tracks`: where the model holds only some of the tracks of its images
// (after global positioning: those selected for it, a few hundred per image
// whatever the image holds), all of them. A pair's verified inliers count
// all the points it shares, so the points predicted for it are then scaled
// to the image's observations in all the tracks, not to its model points:
// else the inliers per predicted point measure the share of an image's
// tracks that positioning kept (high in the dense parts of a scene, about 1
// in sparse ones), not the pair, and a correct model's weak pairs separate
// its dense part from its sparse one. Null: the model's points.
FoldReport DetectFold(const FoldDetectionOptions& options,
                      const Reconstruction& reconstruction,
                      const FoldEvidence& evidence,
                      const std::vector<Track>* tracks = nullptr);

// A 2-partition of the n nodes of a signed graph (edges (a, b, weight):
// positive pull together, negative push apart) that maximises the agreement
// sum w_ab x_a x_b: the leading eigenvector of the signed adjacency, then
// single flips while they help. Deterministic. Sides are +1 / -1.
// `max_power_iterations`: kSignedCutFixedIterations runs exactly that many
// (the weak-pair cut of the fold check, tuned with them); more: until the
// eigenvector changes by less than kSignedCutTolerance, at most that many.
constexpr int kSignedCutFixedIterations = 300;
constexpr double kSignedCutTolerance = 1e-9;
std::vector<int> SignedGraphCut(
    int n, const std::vector<std::tuple<int, int, double>>& edges,
    int max_power_iterations = kSignedCutFixedIterations);

// The weakest cut of a folded model: a 2-partition of the images that keeps
// together the images matched by trusted pairs (the model agrees with them,
// not suspected, not weak; weight: their verified inliers, normalised to a
// mean of one) and separates the images of
// missing pairs and of weak predicted pairs (each -1, scaled so that the
// negative and the positive edges weigh the same in total). Returns the two
// sides (each sorted; the larger first); one side is empty when the cut does
// not explain the fold (fewer than 80% of the missing and weak pairs cross
// it, and fewer than the trusted pairs it cuts).
std::pair<std::vector<image_t>, std::vector<image_t>> FoldCut(
    const FoldDetectionOptions& options, const Reconstruction& reconstruction,
    const FoldEvidence& evidence, const FoldReport& report);

}  // namespace colmap_irav4
