#pragma once

// The global mapper of one connected component (COLMAP's sfm/global_mapper).
// Solve() runs the stages in their order (the one place it is written):
//   rotation averaging -> rotation-consistency filter
//   -> tracks from the inlier matches -> global positioning -> fold check
//   -> bundle adjustment rounds with filtering, retriangulation, the
//      two-view check and (optional, off by default) point merging after
//      the first -> final filtering and normalisation -> fold check.
// One public method per stage, callable (and testable) one by one; every
// stage's algorithm lives in its own folder, this class holds the state
// between them. Resolving a fold is the component mapper's
// (pipeline/component_mapper.h); reading the database, building the view
// graph, looping over its components, colouring and writing the models is
// the pipeline's (pipeline/global_pipeline.h).

#include <functional>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/part_merge.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/positioning/track_selection.h"
#include "colmap_irav4/positioning/translation_averaging.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/refinement/model_rigidity.h"
#include "colmap_irav4/refinement/point_merging.h"
#include "colmap_irav4/refinement/pose_constraint.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/refinement/two_view_check.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/run_summary.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"

namespace colmap_irav4 {

// The rotation-consistency filter between rotation averaging and tracks.
struct RotationFilterOptions {
  // Pairs whose relative rotation disagrees with the averaged rotations
  // (angle of R_ij^T R_j R_i^T) by more than this are dropped (deg).
  double max_rotation_error_deg = 5.0;
  void Check() const;  // throws InputError naming the option
};

// How the camera centres (and points) are found after rotation averaging.
enum class PositioningMethod { kGlobalPositioning, kTranslationAveraging };
template <>
const EnumNames<PositioningMethod>& NamesOf<PositioningMethod>();

struct GlobalMapperOptions {
  // Components of the view graph with fewer images give no model
  // (COLMAP's min_model_size; 3 is the least a global model needs).
  int min_model_size = 3;
  // Rotation averaging method: irav4 (the default once registered), ira,
  // l1_irls, spanning_tree (see RotationAveragerMethods()).
  std::string rotation_method;
  // global_positioning or translation_averaging.
  PositioningMethod positioning_method = PositioningMethod::kGlobalPositioning;
  // Ceres / worker threads of every stage; -1: all cores.
  int num_threads = -1;
  // Seed of every stage's random choices (random initialisation of global
  // positioning or translation averaging, RANSAC triangulation, IRAv4's
  // random_cds reference): the same seed gives the same model (with the same
  // number of threads).
  int seed = 0;
  // Progress bars on the iterative stages (positioning, bundle adjustment):
  // 1 on, 0 off, -1 on a terminal or for long work (>= 100 images).
  int progress = -1;
  // Rounds of (bundle adjustment, filtering) before retriangulation; each
  // bundle adjustment itself filters by reprojection error between its solves.
  int num_ba_iterations = 2;
  // The tracks global positioning solves for (--Mapper.positioning_*); the
  // rest are triangulated after the first bundle adjustment. Fewer
  // unknowns, same poses, much faster (measurements: docs/BENCHMARKS.md).
  PositioningTrackSelectionOptions positioning_tracks;
  // Memory bound: at most this many tracks (points) enter the model, those
  // positioning uses first, then the longest; a warning says how many were
  // dropped (0: no cap).
  int max_num_tracks = 0;
  // Weakly tied parts left out of the adjustments (0: off). Before each
  // bundle adjustment (and the two-view check's), the model's rigidity with
  // ties of this many shared points (refinement/model_rigidity.h; before the
  // first adjustment counted over every track, the model then holding
  // positioning's only): images in no rigid part of min_model_size images
  // or more leave the model (the rigidity split would not write them), and
  // each point keeps only the observations of its part with the most, so
  // that the parts are adjusted apart (each its own gauge) instead of one
  // crawling about the few points that tie it to the rest.
  int weak_part_min_shared_points = 0;
  // Before each bundle adjustment too (0: off): images in fewer than this
  // many triangles of the component's pairs as given, before the rotation
  // filter (two of its partners paired with each other), among the model's
  // images leave the model, repeated until every image has them: no cycle
  // of relative poses checks such an image's place (an image joined only by
  // a random pair or two is one).
  int weak_image_min_pair_triangles = 0;

  // Skip flags of the optional stages. The view graph, rotation averaging,
  // tracks and positioning cannot be skipped: nothing downstream exists
  // without them.
  bool skip_rotation_filter = false;
  bool skip_bundle_adjustment = false;
  bool skip_retriangulation = false;
  bool skip_filtering = false;
  bool skip_normalization = false;
  bool skip_colors = false;
  // Point colours come from the images decoded at 1/downscale of their size
  // (1, 2, 4 or 8): JPEG decoding at half size is several times faster and a
  // point's colour is a mean over its track anyway.
  int color_image_downscale = 2;
  // Cameras with invalid intrinsics (non-positive or non-finite focal,
  // implausible distortion) are an error; with this flag they start from a
  // default focal and are refined (see DatabaseReadOptions).
  bool reset_invalid_cameras = false;
  // A second pass: the relative poses derived again with the cameras (focal,
  // principal point, distortion) the first mapping's bundle adjustment
  // refined, held as priors; the images no model registered keep the
  // database's (or self-calibrated) cameras. Rotation averaging, the
  // rotation filter and the whole mapping run again on that view graph; the
  // second pass's models are written.
  bool recalibrated_second_pass = false;

  // Pose priors (GPS, gravity; io/pose_priors.h): from pose_prior_path when
  // given (`IMAGE_NAME X Y Z [GX GY GZ]` lines, X Y Z latitude, longitude,
  // altitude with pose_prior_wgs84), else from the database. Used when
  // use_pose_priors and present: each model with enough position priors is
  // placed in their frame by global positioning, bundle adjustment keeps
  // them as robust terms, and it is written in that frame (no
  // normalisation).
  bool use_pose_priors = true;
  std::string pose_prior_path;
  bool pose_prior_wgs84 = false;
  PosePriorOptions pose_priors;
  ViewGraphBuilderOptions view_graph;
  RotationAveragerOptions rotation_averaging;
  RotationFilterOptions rotation_filter;
  TrackBuilderOptions tracks;
  GlobalPositionerOptions global_positioning;
  TranslationAveragingOptions translation_averaging;
  TriangulationOptions triangulation;
  TwoViewCheckOptions two_view_check;
  PointMergingOptions point_merging;
  BundleAdjustmentOptions bundle_adjustment;
  FilterOptions filtering;
  NormalizationOptions normalization;
  // Per-image pose constraint of every model (summary.json, warnings).
  PoseConstraintOptions pose_constraint;
  // Fold check of every model and its resolution (symmetric scenes).
  FoldResolutionOptions fold;
  // A model split into rigid parts: the parts joined again through the
  // pairs across them their 3D points confirm (pipeline/part_merge.h).
  PartMergeOptions part_merge;

  GlobalMapperOptions();
  // Throws InputError naming the offending option by the flag it is
  // registered under (AddGlobalMapperOptions), for every stage's struct.
  void Check() const;

  // A copy whose stage options carry the mapper-wide settings, every stage's
  // copy of them (num_threads: view graph, rotation averaging, Ceres solves,
  // colours; seed: rotation averaging, positioning, triangulation; progress
  // bars and progress lines; min_num_matches: the fold check's;
  // skip_retriangulation: positioning uses every track), for a run on
  // `num_images` images (progress -1: on from 100 images or on a terminal).
  // The pipeline applies it once per run; GlobalMapper takes its result.
  GlobalMapperOptions ForStages(size_t num_images) const;
};

// The rotation method used when none is given: irav4 when registered in the
// factory, else the best available baseline.
std::string DefaultRotationMethod();

// Maps one connected component of the view graph. Stages run in the order of
// Solve(); each returns false (with failure() saying why) when no model of
// min_model_size images can result, and appends its figures to stages().
// The stages that make the model are virtual: the test seam of the fold
// resolution (a stand-in maps by copying a given model).
class GlobalMapper {
 public:
  // `options`: with the mapper-wide settings applied (ForStages).
  // `database` (keypoints, inlier matches, image names) and `cameras` (the
  // view graph's, possibly self-calibrated) must outlive the mapper. `images`
  // and `pairs`: the component. `log_prefix` starts every log line (e.g.
  // "[component 1] "). `evidence`: the database's evidence about the
  // component's pairs for the fold checks (null: no fold check; must outlive
  // the mapper).
  GlobalMapper(const GlobalMapperOptions& options,
               const DatabaseContents& database,
               const std::map<camera_t, Camera>& cameras,
               std::vector<image_t> images,
               std::vector<ImagePairGeometry> pairs,
               std::string log_prefix = "",
               const FoldEvidence* evidence = nullptr);
  GlobalMapper(const GlobalMapper&) = default;
  virtual ~GlobalMapper() = default;

  // The stages in order (see the top of this file); false when a stage gave
  // up. With `stop_if_folded`, returns true after the fold check after
  // positioning when that check finds a fold (refining a folded model is
  // wasted time); a later Solve() continues with the refinement. Once
  // refined (or failed), Solve() returns the same answer without work.
  bool Solve(bool stop_if_folded = false);
  // Whether Solve() has run the refinement.
  bool refined() const { return state_ == State::kRefined; }

  // Absolute rotations of the component's images (those the method
  // estimated) -> rotations(). Called before Solve() (to look at the
  // rotations first), Solve() goes on from them.
  virtual bool RotationAveraging();
  // Drops the pairs disagreeing with the rotations (all pairs kept with
  // skip_rotation_filter), then keeps the largest connected part.
  virtual bool RotationFilter();
  // The model's images (rotations, keypoints) and the tracks of the inlier
  // matches of the kept pairs; with global positioning, the tracks it uses
  // become the model's points.
  virtual bool BuildTracks();
  // Camera centres (and points): global positioning, or translation
  // averaging followed by triangulation of every track.
  virtual bool Positioning();
  // num_ba_iterations rounds of bundle adjustment followed by filtering;
  // retriangulation after the first (or alone when there is none).
  virtual bool IterativeBundleAdjustment();
  // Triangulates every track from the current poses (completes the points of
  // tracks positioning did not use).
  bool Retriangulation();
  // After retriangulation: the two-view points checked against poses
  // adjusted without them (refinement/two_view_check.h).
  bool TwoViewCheck();
  // After the two-view check, with point_merging.enabled: points of
  // different tracks that are one 3D point merged
  // (refinement/point_merging.h).
  bool PointMerging();
  // Final filtering, cameras no image uses removed, normalisation.
  virtual bool Finalize();
  // The fold check (refinement/fold_detection.h) of the model as it is;
  // `when`: "after positioning" or "after refinement". Nothing without
  // evidence or with fold.detect off. Returns whether it found a fold.
  bool CheckFold(const std::string& when);
  // Whether the model is one rigid piece (refinement/model_rigidity.h).
  ModelRigidity CheckRigidity();
  // With weak_part_min_shared_points or weak_image_min_pair_triangles: the
  // weak parts and images left out of the adjustment that follows (`when`
  // names it in the stage).
  void LeaveOutWeakParts(const std::string& when);
  // Keeps only `images` (those of the model among them), their observations
  // and the points still seen twice: a model that is not one rigid piece is
  // written as its parts.
  void RestrictToImages(const std::set<image_t>& images);
  // Point colours from the images under image_path (empty: grey). Returns
  // the number of images that could not be read.
  int ColorPoints(const std::string& image_path);
  // Releases the keypoints of the model's images (each image's points2D;
  // the model's observations stay in its points' tracks): a mapper held
  // while its component is mapped again (the fold resolution's best model
  // so far) keeps its poses, points, tracks and fold report, and the
  // keypoints, which the database holds, are not held twice (377 MiB at
  // 5,000 photo images). Only images whose keypoints are the database's and
  // whose links to points are their tracks' are released. Solve(),
  // CheckFold(), CheckRigidity(), RestrictToImages() and ColorPoints()
  // resume first; the poses and points may be read while suspended, the
  // keypoints not.
  void SuspendKeypoints();
  // Reads the released keypoints back and links them to their points.
  void ResumeKeypoints();
  bool keypoints_suspended() const { return !suspended_images_.empty(); }

  const GlobalMapperOptions& options() const { return options_; }
  const std::vector<image_t>& images() const { return images_; }
  // Pairs of the component as given (before the rotation filter).
  size_t num_component_pairs() const { return num_component_pairs_; }
  // The component's pairs; after RotationFilter() the kept ones.
  const std::vector<ImagePairGeometry>& pairs() const { return pairs_; }
  const std::map<image_t, Eigen::Matrix3d>& rotations() const {
    return rotations_;
  }
  const std::vector<Track>& tracks() const { return tracks_; }
  Reconstruction& reconstruction() { return reconstruction_; }
  const Reconstruction& reconstruction() const { return reconstruction_; }
  const std::vector<StageReport>& stages() const { return stages_; }
  const std::string& failure() const { return failure_; }
  // Whether the model was placed in the pose priors' frame (metric).
  bool in_prior_frame() const { return in_prior_frame_; }
  // The images whose position / gravity prior the last bundle adjustment
  // left out (beyond PosePriorOptions::gate_std: GatePosePriors), by name.
  const std::vector<std::string>& rejected_position_priors() const {
    return rejected_position_priors_;
  }
  const std::vector<std::string>& rejected_gravity_priors() const {
    return rejected_gravity_priors_;
  }
  // The last fold check's report; fold_checked() false: none ran.
  const FoldReport& fold() const { return fold_; }
  bool fold_checked() const { return fold_checked_; }
  void set_log_prefix(const std::string& prefix) { log_prefix_ = prefix; }

 protected:
  // Runs one bundle adjustment of the refinement: `adjust` runs it on the
  // model and returns false when Ceres found no usable solution; `stage`:
  // the stage's name ("bundle adjustment 2", "two-view check"). The test
  // seam of a failed adjustment (a stand-in reports a failure).
  virtual bool RunAdjustment(const std::string& stage,
                             const std::function<bool()>& adjust);

 private:
  // The one place a failed bundle adjustment is handled. Once an earlier
  // adjustment succeeded, a failed one must not lose that model: the model
  // goes back to what it was before `adjust` ran (a warning, the figure
  // "warning: bundle adjustment failed, model kept as before it" of
  // `stage`) and `*kept` is set; the refinement goes on. Before that (the
  // model is only positioned), the failure is the component's: false with
  // `failure` as the reason.
  bool AdjustOrKeepModel(StageTimer* stage, const std::string& failure,
                         const std::function<bool()>& adjust, bool* kept);
  bool Fail(const std::string& reason);
  // Fails when the model has no 3D point left (`when`: after which step):
  // bundle adjustment has nothing to adjust and a model of poses alone is no
  // reconstruction. Names a pure rotation (panorama) when the pairs say so.
  bool FailIfNoPoints(const std::string& when);
  // Adds the model's registered images, points and reprojection errors to
  // the stage's figures.
  void AddModelFigures(StageTimer* stage);
  // Keeps the priors a bundle adjustment left out (by name), adds their
  // counts to its stage and logs them.
  void RecordRejectedPriors(const BundleAdjustmentSummary& summary,
                            StageTimer* stage);
  // Logs the images a filtering removed from the model (a warning).
  void WarnFilteredImages(const FilterSummary& summary) const;
  // The images of the model (or, before positioning, with a rotation).
  std::set<image_t> CurrentImages() const;
  // At verbosity 1: the images of `before` no longer in the model after
  // `stage` (which stage loses which image).
  void LogImagesLeft(const std::string& stage,
                     const std::set<image_t>& before) const;

  enum class State { kNew, kPositioned, kRefined, kFailed };

  const GlobalMapperOptions options_;  // with the mapper-wide settings applied
  const DatabaseContents& database_;
  const std::map<camera_t, Camera>& cameras_;
  const std::vector<image_t> images_;
  const size_t num_component_pairs_;
  std::string log_prefix_;

  std::vector<ImagePairGeometry> pairs_;
  // With weak_image_min_pair_triangles: the pairs as given (before the
  // rotation filter), whose triangles it counts.
  std::vector<std::pair<image_t, image_t>> given_pairs_;
  std::map<image_t, Eigen::Matrix3d> rotations_;
  std::vector<Track> tracks_;
  Reconstruction reconstruction_;
  // The observations of positioning's points left out of its problem by
  // --Mapper.positioning_max_observations_per_image, added back after it.
  std::vector<std::pair<point3D_t, TrackElement>> positioning_dropped_;
  // SchurDensity of the positioning tracks before that cap (-1: not capped).
  double positioning_schur_density_ = -1;
  bool retriangulated_ = false;
  // Whether a bundle adjustment of the model succeeded (the model to fall
  // back on when a later one fails).
  bool adjusted_ = false;
  bool in_prior_frame_ = false;
  std::vector<std::string> rejected_position_priors_;
  std::vector<std::string> rejected_gravity_priors_;
  // The last bundle adjustment's noise by keypoint scale
  // (BundleAdjustmentSummary::keypoint_noise): the filters and the
  // retriangulation scale their thresholds by it; empty before or without.
  KeypointScaleNoise keypoint_noise_;
  std::vector<StageReport> stages_;
  std::string failure_;
  const FoldEvidence* evidence_;
  // The images whose keypoints SuspendKeypoints() released.
  std::set<image_t> suspended_images_;
  FoldReport fold_;
  bool fold_checked_ = false;
  // Whether GlobalMapper::RotationAveraging() gave rotations_ (Solve() then
  // does not average again).
  bool rotations_averaged_ = false;
  State state_ = State::kNew;
};

// Drops pairs whose rotation disagrees with the averaged rotations by more
// than max_rotation_error_deg (rotations: cam_from_world by image id; pairs
// with an image without rotation are dropped too). Returns the kept pairs.
std::vector<ImagePairGeometry> FilterPairsByRotation(
    const std::vector<ImagePairGeometry>& pairs,
    const std::map<image_t, Eigen::Matrix3d>& rotations,
    double max_rotation_error_deg);

}  // namespace colmap_irav4
