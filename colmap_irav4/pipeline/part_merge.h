#pragma once

// The rigid parts of a split model joined again (docs/notes/
// 2026-12-04-merge-split-parts.md). A model the rigidity check splits
// (refinement/model_rigidity.h) is often right part by part but turned
// between parts: random false pairs at the weak joins outvoted the few true
// ones in rotation averaging. The parts' own 3D points tell the pairs across
// a join apart: for a pair (a, b), a in part A and b in part B, b's rotation
// in A's frame follows from the pair's relative rotation and a's rotation;
// with it fixed, b's bearing rays to the points of A that a's matched
// keypoints observe must meet them from one centre. A true pair's rays do
// (up to noise); a false pair's random matches do not. A false pair whose
// matches fit a ghost pose (a random pair the generator or a repeated
// structure makes consistent with some other relative pose) is confirmed
// too, but gives its own rotation and position between the parts: two parts
// are joined only by several confirmed pairs that one similarity between
// the parts explains. Pairs across the parts
// so joined whose rotation contradicts the join are removed, and the
// component is mapped again (pipeline/component_mapper.h).

#include <map>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/refinement/model_rigidity.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

struct PartMergeOptions {
  // Join the rigid parts of a split model through the pairs across them
  // that the parts' 3D points confirm, and map the component again.
  bool merge = true;
  // A point is met when b's ray reaches it within this angle (deg).
  double max_ray_error_deg = 0.1;
  // A pair is confirmed when at least this many of its points are met...
  int min_met_points = 5;
  // ... making at least this fraction of its points.
  double min_met_fraction = 0.5;
  // Two parts are joined only by at least this many confirmed pairs
  // (distinct image pairs) that one similarity between the parts explains:
  // a ghost-pose false pair is confirmed alone (at 10,000 photo images, 312
  // random pairs were), but two agree only by chance.
  int min_join_pairs = 2;
  // Confirmed pairs agree when one similarity between the parts explains
  // them: the rotations between the parts they give within this angle
  // (deg)...
  double max_join_spread_deg = 3.0;
  // ... and each placed image's centre within this fraction of its
  // distance to its met points (at 10,000 photo images two of three joins
  // had two random pairs agreeing on the rotation alone).
  double max_join_center_error = 0.03;
  // Pairs across joined parts whose relative rotation contradicts the join
  // by more than this are removed before mapping again (deg).
  double max_rotation_error_deg = 10.0;
  // Before mapping again, the model's rigidity check is run with the tracks
  // of the pairs across its parts added (JoinedRigidity; the pairs the
  // re-mapping's rotation filter keeps under the probe's rotations): when
  // they tie no rigid parts together (e.g. every pair at one image on one
  // side: an articulation join, whose relative scale no re-mapping fixes),
  // the re-mapped model would not be less split and the mapping is skipped.
  bool check_rigid_joins = true;
  // Before mapping again, the remaining pairs' rotation averaging (cheap)
  // is compared with the join: a joined part it turns by more than this
  // (deg) will split off again (false pairs elsewhere still mislead it).
  // The mapping is done only when the joins it keeps leave fewer large
  // groups than the model has rigid parts.
  double max_join_turn_deg = 10.0;
  // Also remove the pairs across parts that the parts' points refute
  // (PartMergePlan::refuted), joined parts or not: false pairs across parts
  // not joined still mislead the re-mapping's rotation averaging.
  bool remove_refuted = true;
  // Rounds of (join, map again) while the model stays split.
  int max_rounds = 3;
  // The re-mapped model is kept only when it writes at least this fraction
  // of the images the split model writes (and is less split, not folded).
  double min_image_fraction = 0.99;
  // RANSAC samples of 2 points for b's centre where there are more
  // 2-point sets than this (else every set is tried); also the pairs of
  // confirmed checks that hypothesise a join's similarity.
  int max_ransac_samples = 500;

  // Throws InputError naming the option (--PartMerge.*).
  void Check() const;
};

// One direction of a pair across parts: image b placed from the points of
// image a's part.
struct CrossPairCheck {
  image_t image_id_a = kInvalidImageId;
  image_t image_id_b = kInvalidImageId;
  int part_a = -1;
  int part_b = -1;
  // Matches whose keypoint in a observes a point of part A.
  int num_points = 0;
  // Those whose point b's ray reaches from b's fitted centre.
  int num_met = 0;
  bool confirmed = false;
  // The points of part A met (ids in the model).
  std::vector<point3D_t> met_point_ids;
  // b's rotation (cam_from_world) in the frame of the model's part A.
  Eigen::Matrix3d R_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d center_b = Eigen::Vector3d::Zero();
};

// The confirmed pairs between two parts (a join).
struct PartJoin {
  int part1 = -1;  // the smaller part index
  int part2 = -1;
  int num_pairs = 0;  // confirmed pairs (either direction)
  // Of those, the most that one similarity between the parts explains
  // (max_join_spread_deg, max_join_center_error).
  int num_agreeing = 0;
  // Whether num_agreeing reaches min_join_pairs: the parts may be joined.
  bool agreed = false;
  // Distinct points met by the agreeing pairs' checks, in the direction
  // that meets more (points of one part only: the same scene point seen
  // from both sides counts once).
  int num_points = 0;
  // Index into PartMergePlan::checks of the agreeing check with most met
  // points (the join's rotation).
  int best_check = -1;
};

struct PartMergePlan {
  // Every checked direction of every pair across parts.
  std::vector<CrossPairCheck> checks;
  int num_pairs_across = 0;  // view-graph pairs across parts
  int num_confirmed = 0;     // of those, confirmed in either direction
  // Per pair of parts with a confirmed pair, agreed joins first, then most
  // met points (ties: the order of the parts).
  std::vector<PartJoin> joins;
  // Per part (index into the parts given): its group after the join (the
  // smallest part index of the group), and the rotation that turns its
  // images into the group's frame: R_i -> R_i * correction.
  std::vector<int> group;
  std::vector<Eigen::Matrix3d> correction;
  int num_parts = 0;
  std::vector<size_t> part_sizes;  // images of each part in the model
  int num_groups = 0;  // parts joined into groups (parts alone count too)
  // Pairs across parts of one group whose relative rotation contradicts
  // the join (image ids, smaller first): to be removed.
  std::set<std::pair<image_t, image_t>> contradicted;
  // Pairs across parts (of any groups) that the parts' points refute: in
  // some direction at least min_met_points points to test, and in no
  // direction confirmed nor min_met_fraction of them met (a random pair's
  // matches; image ids, smaller first). Removed too with remove_refuted.
  std::set<std::pair<image_t, image_t>> refuted;
};

// Checks one direction of a pair: b's rotation is pair rotation x a's; its
// centre is fitted (RANSAC over 2-point sets, refit on the inliers) to b's
// rays to the points of `part_a` (images) that a's matched keypoints
// observe (points seen by at least two images of part_a). `matches`:
// keypoint in a -> keypoint in b. `R_ab`: cam_b_from_cam_a.
CrossPairCheck CheckCrossPair(
    const PartMergeOptions& options, const Reconstruction& reconstruction,
    const std::set<image_t>& part_a, image_t image_id_a, image_t image_id_b,
    const Eigen::Matrix3d& R_ab,
    const std::vector<std::pair<point2D_t, point2D_t>>& matches);

// Checks every pair of `pairs` across two of `parts` (image sets of the
// model, disjoint) in both directions (inlier matches from `geometries`,
// the database's), joins the parts through the agreed joins (a spanning
// tree of the parts, the join with most met points first, each through its
// best agreeing check) and lists the pairs across parts of one group that
// the join contradicts.
PartMergePlan PlanPartMerge(const PartMergeOptions& options,
                            const Reconstruction& reconstruction,
                            const std::vector<std::vector<image_t>>& parts,
                            const std::vector<ImagePairGeometry>& pairs,
                            const std::vector<TwoViewGeometry>& geometries);

// How far `rotations` (cam_from_world of the model's images, e.g. a new
// rotation averaging's) turn each joined part against its group's first
// part, after the plan's corrections (deg, per part; 0 for a group's first
// part and for parts alone). A part's frame change is the chordal mean over
// its images of (model rotation x correction)^T x new rotation; a part with
// no image in `rotations` is reported as 180 deg turned (the join is lost).
std::vector<double> JoinTurnsDeg(
    const PartMergePlan& plan, const Reconstruction& reconstruction,
    const std::vector<std::vector<image_t>>& parts,
    const std::map<image_t, Eigen::Matrix3d>& rotations);

// The rigidity (refinement/model_rigidity.h) of `reconstruction` with the
// tracks a re-mapping would build across its parts: the inlier matches
// (from `geometries`) of every pair of `pairs` (those the re-mapping keeps,
// after its rotation filter) between two of `parts` join the keypoints'
// points into one, as track building does (a keypoint without a point
// joins the other's; two without make a new point). The parts themselves
// stay as rigid as they are. When its num_large_blocks is not below the
// model's, the pairs across share too few points to tie any parts rigidly
// (e.g. all at one image of a part: an articulation join, whose relative
// scale no re-mapping fixes).
ModelRigidity JoinedRigidity(const Reconstruction& reconstruction,
                             const std::vector<std::vector<image_t>>& parts,
                             const std::vector<ImagePairGeometry>& pairs,
                             const std::vector<TwoViewGeometry>& geometries,
                             int min_model_size);

// The number of groups of at least `min_size` images (plan.part_sizes)
// when each part joins its group only if `turns` (JoinTurnsDeg) keeps it
// within `max_turn_deg`; a part turned further counts alone.
int NumLargeGroupsKept(const PartMergePlan& plan,
                       const std::vector<double>& turns, double max_turn_deg,
                       int min_size);

}  // namespace colmap_irav4
