#pragma once

// Large synthetic scenes with exact ground truth, for benchmarks and for the
// symmetric-scene protocol: walls of points (a courtyard seen from inside, a
// street between two facades, a tower seen from all sides, landmarks of a
// photo collection), cameras walking along them, noisy keypoints, and the
// verified pairs a matcher would store: true pairs, random false pairs and
// mirror-twin false pairs.
//
// The structure is symmetric under M = 180 deg about the vertical (world Y)
// axis through the origin, (x, y, z) -> (-x, y, -z): points come in twins X,
// M X (up to a fraction of unique points). A mirror-twin false pair (i, j)
// matches i's keypoints of M X with j's keypoints of X, i.e. it is a true pair
// of twin(i) = camera i moved by M (cam_from_world P_i M) and j; such pairs
// agree with each other around cycles, as on 1DSfM's Gendarmenmarkt.
//
// Cost: O(observations * track length) (pairs are found from the tracks,
// never by testing all image pairs); visibility uses a grid over the ground
// plane, so each camera only tests the points near it.

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "colmap_irav4/geometry/gps.h"
#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/io/pose_priors.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

enum class SceneLayout {
  kCourtyard,  // rectangle of walls, cameras inside looking at them
  kStreet,     // two long facades of repeated modules, cameras in between
  kTower,      // rectangular tower, cameras around it looking at it
  // A photo collection: num_parts landmarks (towers) too far apart to share
  // a point, so no true pair joins two parts; around each a dense core of
  // cameras 5-25 m from its walls and a sparse periphery 25-70 m out, each
  // image aimed at a random spot of its landmark; one camera per image
  // (COLMAP's single_camera 0) of several image sizes, focal lengths drawn
  // from [min_focal_ratio, max_focal_ratio] x width (long ones: zoomed-in
  // shots of a detail, which resolve points farther away), SIMPLE_RADIAL-like
  // distortion up to max_radial_distortion; the database stores the focal
  // prior a user's EXIF gives (prior_focal_fraction of the cameras) or
  // COLMAP's guess 1.2 x max(width, height) and no distortion.
  kPhoto,
};
// "courtyard", "street", "tower", "photo"; throws InputError for another name.
SceneLayout SceneLayoutFromName(const std::string& name);
std::string SceneLayoutName(SceneLayout layout);

struct SceneGeneratorOptions {
  SceneLayout layout = SceneLayout::kCourtyard;
  int num_images = 100;
  // Camera path length per image (m): the scene grows with the number of
  // images, so that the pairs per image stay bounded.
  double image_spacing = 0.5;
  // Points per square metre of wall (before the detection probability).
  double point_density = 40.0;
  // Fraction of points without a mirror twin (breaks the symmetry a little,
  // as real buildings do).
  double unique_point_fraction = 0.0;
  // Depth relief of the walls (m): points lie up to this far behind the wall
  // plane, so that no pair is planar.
  double wall_relief = 0.6;
  // Uneven density in [0, 1): this fraction of the cameras crowd around a few
  // hot spots, and the point density varies along the walls by this factor.
  double density_skew = 0.0;
  int num_hotspots = 3;
  // Courtyard: cameras turn gradually at the corners of their loop: within
  // this arc length (m) either side of a corner their viewing direction
  // turns from one wall to the next (capped at 0.4 of the shorter side). 0:
  // an abrupt 90 deg turn, which leaves a large courtyard's sides tied by
  // only a few pairs. (The tower, seen whole from afar, needs no turn.)
  double corner_turn_length = 10.0;
  // Cameras: COLMAP model names, one per camera in turn; images are assigned
  // to num_cameras cameras at random (1: one shared camera).
  std::vector<std::string> camera_models = {"SIMPLE_RADIAL"};
  int num_cameras = 1;
  int width = 1600;
  int height = 1200;
  double focal_length = 1200.0;  // px; cameras after the first vary +-15%
  // Detection: probability that a projecting point yields a keypoint, the
  // farthest distance at which it does, keypoint noise (px, per coordinate).
  double detection_probability = 0.8;
  double max_view_distance = 40.0;
  // (A noisy keypoint that would leave the image is drawn again: a detector
  // reports positions inside [0, width] x [0, height] only.)
  double noise_px = 1.0;
  // Keypoint scales: with keypoint_scales each keypoint gets one, drawn
  // log-uniform in [1.5, 12] px (SIFT's range in COLMAP's Strecha databases),
  // and the database stores 4 floats per keypoint (x, y, scale,
  // orientation 0). A keypoint's noise is then noise_px * (scale /
  // sqrt(1.5 * 12))^noise_scale_exponent: 0 the same for all, 1 proportional
  // to the scale (a detector localises coarse keypoints less precisely).
  bool keypoint_scales = false;
  double noise_scale_exponent = 0.0;
  // Detector repeatability: each image keeps a random subset of at most this
  // many of the keypoints of the points it sees (before clutter), so that
  // images seeing many points keep a smaller share of them and a pair's
  // inliers are a varying fraction of its co-visible points. 0: all.
  int max_keypoints_per_image = 0;
  // Keypoints of nothing (clutter), as a fraction of each image's keypoints.
  double clutter_fraction = 0.1;
  // A pair is written when it has at least this many inliers.
  int min_num_inliers = 15;
  // Keep only each image's best pairs (most shared points): the pair is kept
  // if it is among the best of either image. 0: all pairs.
  int max_pairs_per_image = 0;
  // Raw (unverified) matches: inliers plus this fraction of wrong ones.
  double raw_outlier_ratio = 0.25;
  // Fraction of the true and mirror pairs that are mirror-twin false pairs
  // (a mirror pair replaces the true pair of the same images, if any), then
  // fraction of all pairs that are random false pairs (random matches
  // consistent with a random relative pose).
  double mirror_pair_rate = 0.0;
  double random_pair_rate = 0.0;
  // A false pair matches only this fraction of the correspondences its
  // (false) geometry would allow.
  double false_pair_inlier_fraction = 0.4;
  // Viewpoint-dependent match rates (PairMatchRate): a true or mirror pair
  // keeps only a fraction of the correspondences its geometry allows, as
  // descriptors match less across a viewpoint change, a scale change and at
  // a distance. Fraction exp(-(a / match_angle_falloff_deg)^2) for the angle
  // a (deg) between the two cameras' rays to the pair's shared points (0:
  // no falloff), times (near / far distance to them) / (1 + mean distance /
  // match_distance_falloff) (m; 0: no falloff), times a per-pair log-normal
  // factor of this sigma (texture, lighting; capped at 1 overall). A pair
  // left with fewer than min_num_inliers is not written.
  double match_angle_falloff_deg = 0.0;
  double match_distance_falloff = 0.0;
  double match_rate_sigma = 0.0;
  // Photo layout (kPhoto): landmarks, focal range (x image width), share of
  // the cameras with a prior focal (EXIF) and its relative error (uniform in
  // +-prior_focal_error), largest |k| of the first radial coefficient.
  int num_parts = 3;
  double min_focal_ratio = 0.7;
  double max_focal_ratio = 2.5;
  double prior_focal_fraction = 0.7;
  double prior_focal_error = 0.05;
  double max_radial_distortion = 0.1;
  // Store cam2_from_cam1 in two_view_geometries.qvec/tvec (COLMAP 3.8 leaves
  // them zero unless asked).
  bool store_relative_pose = false;
  // Two-view geometry (E, F, the stored pose) of the true relative pose;
  // false: of the pose re-estimated on the pair's noisy inliers
  // (EstimateRelativePose, refined), as a matcher's would be. Exact E leaks
  // the truth to a mapper that decomposes it without refining (COLMAP 4's
  // global_mapper; docs/notes/2026-12-03-colmap4-at-1000-images.md).
  bool exact_two_view_geometry = true;
  // Store what a matcher's two-view geometry estimation would (COLMAP's
  // rule, MatcherTwoViewGeometry): inliers within 4 px of a pinhole F fitted
  // by RANSAC to the pair's matches (or of E fitted with the database's
  // cameras, CALIBRATED, where both have a prior focal and E has > 0.95 of
  // F's inliers; PLANAR_OR_PANORAMIC where a fitted H has > 0.8 of them),
  // pairs left under min_num_inliers not written; overrides
  // exact_two_view_geometry. false: the matches of the true (or false) pose
  // all stored, E/F of the true cameras.
  bool matcher_geometry = false;
  uint64_t seed = 1;

  void Check() const;  // throws InputError naming the option
};

enum class PairKind { kTrue, kMirror, kRandom };
std::string PairKindName(PairKind kind);

struct GeneratedPair {
  image_t image_id1 = kInvalidImageId;  // image_id1 < image_id2
  image_t image_id2 = kInvalidImageId;
  PairKind kind = PairKind::kTrue;
  // Correspondences the pair's geometry allows (shared points of a true pair,
  // twin-shared points of a mirror pair), before thinning.
  int num_candidates = 0;
  // Fraction of them the pair keeps (viewpoint-dependent match rate; mirror
  // pairs then keep false_pair_inlier_fraction of that).
  double match_rate = 1.0;
  // Random pairs only: their inliers (generated with the scene, since they
  // add clutter keypoints to image_id2).
  FeatureMatches random_inliers;
  Rigid3d random_cam2_from_cam1;
};

struct GeneratedScene {
  SceneGeneratorOptions options;
  // Exact ground truth: cameras, poses, keypoints (noisy; clutter keypoints
  // have no point), points with their full tracks.
  Reconstruction truth;
  // The cameras as the database stores them (photo layout: focal priors or
  // COLMAP's guess, no distortion; empty: the true cameras). A pair is
  // CALIBRATED if both its cameras have a prior focal, else UNCALIBRATED, as
  // COLMAP's two-view geometry estimation labels it.
  std::map<camera_t, Camera> database_cameras;
  // Photo layout: the part (landmark) of each image, indexed by image_id - 1
  // (empty for the other layouts).
  std::vector<int> image_parts;
  // Twin of each point (kInvalidPoint3DId if unique or not in the model).
  std::vector<point3D_t> twin_of_point;  // indexed by point3D_id
  std::vector<GeneratedPair> pairs;      // ordered by (image_id1, image_id2)
  int num_true_pairs = 0;
  int num_mirror_pairs = 0;
  int num_random_pairs = 0;
  int num_mirror_candidates = 0;  // pairs that could have been mirror pairs
  // The camera path: length (m), each image's arc-length position on it
  // (indexed by image_id - 1) and the arc lengths of its corners (courtyard,
  // tower: a closed loop with 4 corners; street: none).
  double path_length = 0;
  std::vector<double> image_path_positions;
  std::vector<double> path_corners;
};

GeneratedScene GenerateScene(const SceneGeneratorOptions& options);

// For each corner of the camera path (scene.path_corners), the number of
// true pairs whose images lie on either side of it (the shorter way round
// the loop passes it): the pairs that tie the path's sides together.
std::vector<int> PairsAcrossCorners(const GeneratedScene& scene);

// The stored geometry of a pair (database orientation image_id1 <
// image_id2): inlier matches, CALIBRATED config, E and F of its (possibly
// false) relative pose, the pose itself if store_relative_pose; with
// matcher_geometry what a matcher fits to the pair's matches (config
// DEGENERATE, no inliers, where fewer than min_num_inliers are left).
// Deterministic (seeded by the scene's seed and the pair), independent of
// call order. raw_matches (may be null): the pair's matches (the inliers
// without matcher_geometry) plus wrong matches.
TwoViewGeometry PairGeometry(const GeneratedScene& scene,
                             const GeneratedPair& pair,
                             FeatureMatches* raw_matches);

// cam2_from_cam1 that a pair's matches are consistent with: the true relative
// pose, the twin's (P_2 M P_1^-1) or the random one.
Rigid3d PairRelativePose(const GeneratedScene& scene,
                         const GeneratedPair& pair);

// M applied to a cam_from_world pose: the pose of the camera's mirror twin.
Rigid3d MirrorTwinPose(const Rigid3d& cam_from_world);

// Writes `scene` as a new COLMAP 3.8 database (cameras, images, keypoints,
// matches, two_view_geometries), to a temporary name renamed when complete.
// Throws InputError if `path` exists. num_inliers (may be null): the stored
// inliers of each of scene.pairs, 0 where the pair was not written
// (matcher_geometry).
void WriteSceneDatabase(const GeneratedScene& scene, const std::string& path,
                        std::vector<int>* num_inliers = nullptr);

// GPS-like pose priors of a generated scene: each camera centre in a local
// east-north-up frame at `origin` (the scene's world mapped so that its
// vertical Y is up: (x, y, z) -> (x, -z, y)), with Gaussian noise, a few
// outliers far off, and gravity (down in the camera frame) with angular
// noise. Drawn from their own random stream: the scene is the same with or
// without them.
struct PosePriorGeneratorOptions {
  double horizontal_std = 3.0;  // m, east and north each
  double vertical_std = 5.0;    // m
  // Fraction of the priors displaced by a random direction times a distance
  // uniform in [outlier_min_distance, outlier_max_distance] (m).
  double outlier_fraction = 0.05;
  double outlier_min_distance = 30.0;
  double outlier_max_distance = 100.0;
  // Standard deviation (deg) of each of the two tilt components of gravity.
  double gravity_std_deg = 1.0;
  Wgs84 origin = {47.3769, 8.5417, 408.0};
  uint64_t seed = 1;
  void Check() const;  // throws InputError naming the option
};

struct GeneratedPosePriors {
  PosePriorGeneratorOptions options;
  // The priors' frame: east-north-up at the origin the mapper picks from
  // them (the median latitude, longitude and altitude; ConvertPosePriors),
  // so that a model placed by them compares with the truth without any
  // alignment.
  Wgs84 enu_origin;
  // As a COLMAP database stores them: WGS84 position, covariance
  // diag(h^2, h^2, v^2) (m^2), gravity.
  std::map<image_t, StoredPosePrior> wgs84;
  // The same positions in that east-north-up frame (m).
  std::map<image_t, Eigen::Vector3d> enu;
  std::set<image_t> outliers;
};

GeneratedPosePriors GeneratePosePriors(
    const GeneratedScene& scene, const PosePriorGeneratorOptions& options);

// The true model in the priors' east-north-up frame (metric, z up).
Reconstruction TruthInPriorFrame(const GeneratedScene& scene,
                                 const GeneratedPosePriors& priors);

// `IMAGE_NAME X Y Z` lines (COLMAP model_aligner's --ref_images_path):
// east, north, up (m), or with `wgs84` latitude, longitude, altitude.
void WritePosePriorText(const GeneratedScene& scene,
                        const GeneratedPosePriors& priors, bool wgs84,
                        const std::string& path);

}  // namespace colmap_irav4
