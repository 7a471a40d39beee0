#include "colmap_irav4/eval/scene_generator.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <numeric>
#include <random>
#include <unordered_map>
#include <unordered_set>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/io/database_writer.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {
namespace {

// A vertical wall: segment a-b in the ground plane (x, z), heights [y0, y1],
// `normal` (x, z) pointing to the side the cameras see it from.
struct Wall {
  Eigen::Vector2d a;
  Eigen::Vector2d b;
  double y0 = 0;
  double y1 = 0;
  Eigen::Vector2d normal;
  double Length() const { return (b - a).norm(); }
};

// A closed rectangular loop (half sizes hx, hz, centred on the origin)
// parameterised by arc length, for camera paths.
struct RectLoop {
  double hx = 1;
  double hz = 1;
  double Perimeter() const { return 4 * (hx + hz); }
  // Arc lengths of the corners: the start of each side.
  std::vector<double> Corners() const {
    return {0, 2 * hx, 2 * hx + 2 * hz, 4 * hx + 2 * hz};
  }
  // The outward direction at arc length s, turned gradually at the corners:
  // within `turn` of a corner it rotates from one side's normal to the
  // next's (the diagonal at the corner itself), so that neighbouring cameras
  // around a corner keep looking at overlapping walls.
  Eigen::Vector2d TurningOutward(double s, double turn) const {
    Eigen::Vector2d point, outward;
    At(s, &point, &outward);
    turn = std::min(turn, 0.4 * 2 * std::min(hx, hz));
    if (turn <= 0) return outward;
    const double p = Perimeter();
    double along = std::fmod(s, p);
    if (along < 0) along += p;
    // Signed distance to the nearest corner (negative: before it).
    double best = p;
    for (const double corner : Corners()) {
      for (const double c : {corner, corner + p, corner - p}) {
        if (std::abs(along - c) < std::abs(best)) {
          best = along - c;
        }
      }
    }
    if (std::abs(best) >= turn) return outward;
    // Before a corner the path turns left next (counter-clockwise loop seen
    // from above in x, z: outward rotates by +90 deg from one side to the
    // next); weight of the other side's normal: 0.5 at the corner, 0 at
    // `turn`.
    const double other_weight = 0.5 * (1 - std::abs(best) / turn);
    const double angle = (best < 0 ? 1 : -1) * other_weight * 0.5 * kPi;
    const double c = std::cos(angle), sn = std::sin(angle);
    return {c * outward.x() - sn * outward.y(),
            sn * outward.x() + c * outward.y()};
  }
  // Point at arc length s and the outward normal of its side.
  void At(double s, Eigen::Vector2d* point, Eigen::Vector2d* outward) const {
    s = std::fmod(s, Perimeter());
    if (s < 0) s += Perimeter();
    const double sides[4] = {2 * hx, 2 * hz, 2 * hx, 2 * hz};
    int side = 0;
    while (side < 3 && s > sides[side]) s -= sides[side++];
    switch (side) {
      case 0:  // south, z = -hz, x increasing
        *point = {-hx + s, -hz};
        *outward = {0, -1};
        break;
      case 1:  // east, x = hx
        *point = {hx, -hz + s};
        *outward = {1, 0};
        break;
      case 2:  // north, z = hz, x decreasing
        *point = {hx - s, hz};
        *outward = {0, 1};
        break;
      default:  // west, x = -hx
        *point = {-hx, hz - s};
        *outward = {-1, 0};
        break;
    }
  }
};

// Walls of a rectangle with half sizes hx, hz; normals inward or outward.
std::vector<Wall> RectWalls(double hx, double hz, double height, bool inward) {
  const Eigen::Vector2d corners[4] = {
      {-hx, -hz}, {hx, -hz}, {hx, hz}, {-hx, hz}};
  const Eigen::Vector2d outward[4] = {{0, -1}, {1, 0}, {0, 1}, {-1, 0}};
  std::vector<Wall> walls;
  for (int k = 0; k < 4; ++k) {
    Wall wall;
    wall.a = corners[k];
    wall.b = corners[(k + 1) % 4];
    wall.y0 = 0;
    wall.y1 = height;
    wall.normal = inward ? -outward[k] : outward[k];
    walls.push_back(wall);
  }
  return walls;
}

// cam_from_world rotation of a camera looking along `forward` (world), image
// y pointing down (world Y is up), rolled by `roll` radians.
Eigen::Matrix3d LookAlong(const Eigen::Vector3d& forward, double roll) {
  const Eigen::Vector3d z = forward.normalized();
  Eigen::Vector3d x = (-Eigen::Vector3d::UnitY()).cross(z).normalized();
  Eigen::Vector3d y = z.cross(x);
  const double c = std::cos(roll), s = std::sin(roll);
  const Eigen::Vector3d xr = c * x + s * y;
  const Eigen::Vector3d yr = -s * x + c * y;
  Eigen::Matrix3d R;
  R.row(0) = xr.transpose();
  R.row(1) = yr.transpose();
  R.row(2) = z.transpose();
  return R;
}

const Eigen::Quaterniond& MirrorRotation() {
  // 180 deg about world Y: (x, y, z) -> (-x, y, -z).
  static const Eigen::Quaterniond q(0, 0, 1, 0);
  return q;
}

Eigen::Vector3d Mirror(const Eigen::Vector3d& x) {
  return {-x.x(), x.y(), -x.z()};
}

uint64_t Mix(uint64_t x) {  // splitmix64
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

Camera MakeCamera(const SceneGeneratorOptions& options, camera_t camera_id,
                  std::mt19937_64* rng) {
  const std::string& model_name =
      options.camera_models[(camera_id - 1) % options.camera_models.size()];
  Camera camera;
  camera.camera_id = camera_id;
  camera.model_id = CameraModelNameToId(model_name);
  camera.width = options.width;
  camera.height = options.height;
  camera.has_prior_focal_length = true;
  camera.params.assign(CameraModelNumParams(camera.model_id), 0.0);
  std::uniform_real_distribution<double> vary(0.85, 1.15);
  const double focal =
      options.focal_length * (camera_id == 1 ? 1.0 : vary(*rng));
  const std::vector<int> focal_idxs =
      CameraModelFocalLengthIdxs(camera.model_id);
  for (size_t k = 0; k < focal_idxs.size(); ++k) {
    // Slightly different fx and fy where the model has both.
    camera.params[focal_idxs[k]] = focal * (k == 0 ? 1.0 : 1.002);
  }
  const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
  camera.params[pp[0]] = 0.5 * options.width + (camera_id == 1 ? 0.0 : 3.0);
  camera.params[pp[1]] = 0.5 * options.height - (camera_id == 1 ? 0.0 : 2.0);
  // Mild distortion: first coefficient -0.02, then smaller ones.
  const std::vector<int> extra = CameraModelExtraParamsIdxs(camera.model_id);
  for (size_t k = 0; k < extra.size(); ++k) {
    camera.params[extra[k]] = k == 0 ? -0.02 : 0.002 / (1.0 + k);
  }
  if (model_name == "FOV") camera.params[extra[0]] = 0.05;  // omega > 0
  return camera;
}

// Photo layout: image sizes of users' cameras (landscape and portrait).
constexpr int kPhotoImageSizes[][2] = {{1600, 1200}, {1200, 1600},
                                       {2048, 1536}, {1024, 768},
                                       {1920, 1080}, {1080, 1920}};

// A camera of the photo layout (SceneLayout::kPhoto) and, in `stored`, what
// the database holds for it: the EXIF focal (within prior_focal_error) for
// prior_focal_fraction of the cameras, else COLMAP's guess 1.2 x
// max(width, height) without the prior flag; no distortion (COLMAP's
// initial value).
Camera MakePhotoCamera(const SceneGeneratorOptions& options, camera_t camera_id,
                       std::mt19937_64* rng, Camera* stored) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int(&size)[2] = kPhotoImageSizes[static_cast<size_t>(
      unit(*rng) * std::size(kPhotoImageSizes))];
  Camera camera;
  camera.camera_id = camera_id;
  camera.model_id = CameraModelNameToId(
      options.camera_models[(camera_id - 1) % options.camera_models.size()]);
  camera.width = size[0];
  camera.height = size[1];
  camera.params.assign(CameraModelNumParams(camera.model_id), 0.0);
  const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
  camera.params[pp[0]] = 0.5 * camera.width;
  camera.params[pp[1]] = 0.5 * camera.height;
  *stored = camera;
  const double focal =
      camera.width *
      (options.min_focal_ratio +
       unit(*rng) * (options.max_focal_ratio - options.min_focal_ratio));
  const bool has_prior = unit(*rng) < options.prior_focal_fraction;
  const double prior_focal =
      has_prior ? focal * (1 + options.prior_focal_error * (2 * unit(*rng) - 1))
                : 1.2 * std::max(camera.width, camera.height);
  for (const int idx : CameraModelFocalLengthIdxs(camera.model_id)) {
    camera.params[idx] = focal;
    stored->params[idx] = prior_focal;
  }
  camera.has_prior_focal_length = true;
  stored->has_prior_focal_length = has_prior;
  const std::vector<int> extra = CameraModelExtraParamsIdxs(camera.model_id);
  const double k = options.max_radial_distortion * (2 * unit(*rng) - 1);
  if (!extra.empty()) camera.params[extra[0]] = k;
  return camera;
}

// `xy` (inside the image) plus Gaussian noise of noise_px per coordinate,
// drawn again while the result is outside [0, width] x [0, height]: a
// detector reports keypoints inside the image only. Resampling (a Gaussian
// truncated to the image) rather than clamping: clamping would put a share of
// the border keypoints exactly on the border line. The truncation biases a
// keypoint within ~noise_px of the border inwards by a fraction of a pixel,
// as a detector's own border handling does.
Eigen::Vector2d NoisyKeypoint(const Eigen::Vector2d& xy, double noise_px,
                              const Camera& camera, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const double w = camera.width, h = camera.height;
  for (int attempt = 0; attempt < 100; ++attempt) {
    const double nx = normal(*rng), ny = normal(*rng);
    const Eigen::Vector2d noisy = xy + noise_px * Eigen::Vector2d(nx, ny);
    if (noisy.x() >= 0 && noisy.y() >= 0 && noisy.x() <= w && noisy.y() <= h) {
      return noisy;
    }
  }
  // Unreachable in practice (each attempt succeeds with probability >= 1/4):
  // the noiseless position, which is inside.
  return xy;
}

// The range of keypoint scales with keypoint_scales (px).
constexpr double kMinKeypointScale = 1.5, kMaxKeypointScale = 12.0;

// The keypoint of a projection at `xy`: with keypoint_scales a scale, and
// noise that follows it (SceneGeneratorOptions); without, noise_px's noise
// (and the same random draws as before scales existed).
Point2D NoisyPoint2D(const Eigen::Vector2d& xy,
                     const SceneGeneratorOptions& options, const Camera& camera,
                     std::mt19937_64* rng) {
  Point2D point2D;
  double noise_px = options.noise_px;
  if (options.keypoint_scales) {
    std::uniform_real_distribution<double> log_scale(
        std::log(kMinKeypointScale), std::log(kMaxKeypointScale));
    point2D.scale = static_cast<float>(std::exp(log_scale(*rng)));
    noise_px *= std::pow(
        point2D.scale / std::sqrt(kMinKeypointScale * kMaxKeypointScale),
        options.noise_scale_exponent);
  }
  point2D.xy = NoisyKeypoint(xy, noise_px, camera, rng);
  return point2D;
}

// Detector repeatability (max_keypoints_per_image): keeps a random subset of
// at most that many of `image`'s keypoints, which are all of points (no
// clutter yet) and the last observations of their points in `observations`
// (indexed by point3D_id - 1; the image was the last to add to them).
// Seeded by the scene's seed and the image: the main stream of random draws
// is the same with and without it.
void SubsampleKeypoints(const SceneGeneratorOptions& options, Image* image,
                        std::vector<std::vector<TrackElement>>* observations) {
  const size_t max_keypoints =
      static_cast<size_t>(options.max_keypoints_per_image);
  if (max_keypoints == 0 || image->points2D.size() <= max_keypoints) return;
  std::mt19937_64 rng(Mix(options.seed ^ Mix(0x5eedull + image->image_id)));
  std::vector<char> keep(image->points2D.size(), 0);
  std::fill(keep.begin(), keep.begin() + max_keypoints, 1);
  std::shuffle(keep.begin(), keep.end(), rng);
  std::vector<Point2D> kept;
  kept.reserve(max_keypoints);
  for (size_t idx = 0; idx < image->points2D.size(); ++idx) {
    const Point2D& point2D = image->points2D[idx];
    std::vector<TrackElement>& track = (*observations)[point2D.point3D_id - 1];
    CHECK(!track.empty() && track.back().image_id == image->image_id);
    if (keep[idx]) {
      track.back().point2D_idx = static_cast<point2D_t>(kept.size());
      kept.push_back(point2D);
    } else {
      track.pop_back();
    }
  }
  image->points2D = std::move(kept);
}

// Whether a pair's match rate depends on its viewpoints (PairMatchRate).
bool ViewpointMatchRates(const SceneGeneratorOptions& options) {
  return options.match_angle_falloff_deg > 0 ||
         options.match_distance_falloff > 0 || options.match_rate_sigma > 0;
}

// The fraction of its candidate correspondences a pair keeps
// (SceneGeneratorOptions::match_angle_falloff_deg ...): cameras at `center1`
// and `center2` looking at shared points around `point`. Seeded by the
// scene's seed and the pair (independent of the order of the calls).
double PairMatchRate(const SceneGeneratorOptions& options,
                     const Eigen::Vector3d& center1,
                     const Eigen::Vector3d& center2,
                     const Eigen::Vector3d& point, image_pair_t pair_id) {
  const Eigen::Vector3d ray1 = center1 - point;
  const Eigen::Vector3d ray2 = center2 - point;
  const double d1 = ray1.norm(), d2 = ray2.norm();
  double rate = 1.0;
  if (options.match_angle_falloff_deg > 0 && d1 > 0 && d2 > 0) {
    const double angle_deg =
        RadToDeg(std::acos(std::clamp(ray1.dot(ray2) / (d1 * d2), -1.0, 1.0)));
    rate *= std::exp(-std::pow(angle_deg / options.match_angle_falloff_deg, 2));
  }
  if (options.match_distance_falloff > 0 && d1 > 0 && d2 > 0) {
    rate *= std::min(d1, d2) / std::max(d1, d2) /
            (1 + 0.5 * (d1 + d2) / options.match_distance_falloff);
  }
  if (options.match_rate_sigma > 0) {
    std::mt19937_64 rng(Mix(options.seed ^ Mix(0x7a7eull ^ Mix(pair_id))));
    std::normal_distribution<double> normal(0.0, options.match_rate_sigma);
    rate *= std::exp(normal(rng));
  }
  return std::min(1.0, rate);
}

struct Layout {
  std::vector<Wall> walls;
  // Camera path: arc-length parameter in [0, path_length); position and
  // viewing direction for a parameter are drawn by PlaceCamera.
  double path_length = 0;
};

struct PointCloud {
  std::vector<Eigen::Vector3d> xyz;
  std::vector<int> wall;  // index into Layout::walls
  std::vector<int> twin;  // index of the twin point, -1 if none
};

}  // namespace

SceneLayout SceneLayoutFromName(const std::string& name) {
  if (name == "courtyard") return SceneLayout::kCourtyard;
  if (name == "street") return SceneLayout::kStreet;
  if (name == "tower") return SceneLayout::kTower;
  if (name == "photo") return SceneLayout::kPhoto;
  throw InputError("--layout", "unknown layout '" + name +
                                   "' (courtyard, street, tower or photo)");
}

std::string SceneLayoutName(SceneLayout layout) {
  switch (layout) {
    case SceneLayout::kCourtyard:
      return "courtyard";
    case SceneLayout::kStreet:
      return "street";
    case SceneLayout::kTower:
      return "tower";
    case SceneLayout::kPhoto:
      return "photo";
  }
  return "";
}

std::string PairKindName(PairKind kind) {
  switch (kind) {
    case PairKind::kTrue:
      return "true";
    case PairKind::kMirror:
      return "mirror";
    case PairKind::kRandom:
      return "random";
  }
  return "";
}

void SceneGeneratorOptions::Check() const {
  auto require = [](bool ok, const std::string& name, const std::string& what) {
    if (!ok) throw InputError("--" + name, what);
  };
  require(num_images >= 2 && num_images < 2000000, "num_images",
          "must be >= 2");
  require(image_spacing > 0, "image_spacing", "must be > 0");
  require(point_density > 0, "point_density", "must be > 0");
  require(unique_point_fraction >= 0 && unique_point_fraction <= 1,
          "unique_point_fraction", "must be in [0, 1]");
  require(wall_relief >= 0, "wall_relief", "must be >= 0");
  require(density_skew >= 0 && density_skew < 1, "density_skew",
          "must be in [0, 1)");
  require(num_hotspots >= 1, "num_hotspots", "must be >= 1");
  require(corner_turn_length >= 0, "corner_turn_length", "must be >= 0");
  require(!camera_models.empty(), "camera_models", "must name a model");
  for (const std::string& name : camera_models) {
    require(CameraModelNameToId(name) >= 0, "camera_models",
            "unknown camera model '" + name + "'");
  }
  require(num_cameras >= 1 && num_cameras <= num_images, "num_cameras",
          "must be in [1, num_images]");
  require(width >= 16 && height >= 16, "width/height", "must be >= 16 px");
  require(focal_length > 0, "focal_length", "must be > 0");
  require(detection_probability > 0 && detection_probability <= 1,
          "detection_probability", "must be in (0, 1]");
  require(max_view_distance > 0, "max_view_distance", "must be > 0");
  require(noise_px >= 0, "noise_px", "must be >= 0");
  require(std::isfinite(noise_scale_exponent) &&
              (keypoint_scales || noise_scale_exponent == 0),
          "noise_scale_exponent", "needs keypoint_scales 1");
  require(max_keypoints_per_image >= 0, "max_keypoints_per_image",
          "must be >= 0");
  require(match_angle_falloff_deg >= 0, "match_angle_falloff_deg",
          "must be >= 0");
  require(match_distance_falloff >= 0, "match_distance_falloff",
          "must be >= 0");
  require(match_rate_sigma >= 0 && match_rate_sigma <= 3, "match_rate_sigma",
          "must be in [0, 3]");
  require(clutter_fraction >= 0 && clutter_fraction < 10, "clutter_fraction",
          "must be in [0, 10)");
  require(min_num_inliers >= 8, "min_num_inliers", "must be >= 8");
  require(max_pairs_per_image >= 0, "max_pairs_per_image", "must be >= 0");
  require(raw_outlier_ratio >= 0 && raw_outlier_ratio <= 10,
          "raw_outlier_ratio", "must be in [0, 10]");
  require(mirror_pair_rate >= 0 && mirror_pair_rate < 1, "mirror_pair_rate",
          "must be in [0, 1)");
  require(random_pair_rate >= 0 && random_pair_rate < 1, "random_pair_rate",
          "must be in [0, 1)");
  require(mirror_pair_rate + random_pair_rate < 1, "mirror_pair_rate",
          "mirror_pair_rate + random_pair_rate must be < 1");
  require(false_pair_inlier_fraction > 0 && false_pair_inlier_fraction <= 1,
          "false_pair_inlier_fraction", "must be in (0, 1]");
  require(num_parts >= 1 && num_parts <= 10, "num_parts", "must be in [1, 10]");
  require(min_focal_ratio > 0.1 && max_focal_ratio >= min_focal_ratio &&
              max_focal_ratio <= 20,
          "min_focal_ratio", "need 0.1 < min <= max_focal_ratio <= 20");
  require(prior_focal_fraction >= 0 && prior_focal_fraction <= 1,
          "prior_focal_fraction", "must be in [0, 1]");
  require(prior_focal_error >= 0 && prior_focal_error < 0.5,
          "prior_focal_error", "must be in [0, 0.5)");
  require(max_radial_distortion >= 0 && max_radial_distortion <= 0.5,
          "max_radial_distortion", "must be in [0, 0.5]");
  require(layout != SceneLayout::kPhoto ||
              std::find(camera_models.begin(), camera_models.end(), "FOV") ==
                  camera_models.end(),
          "camera_models",
          "the photo layout draws a radial coefficient (FOV has none)");
}

Rigid3d MirrorTwinPose(const Rigid3d& cam_from_world) {
  // (P M)(X) = R M X + t: M is linear, so only the rotation changes.
  Rigid3d twin = cam_from_world;
  twin.rotation = (cam_from_world.rotation * MirrorRotation()).normalized();
  return twin;
}

std::vector<int> PairsAcrossCorners(const GeneratedScene& scene) {
  std::vector<int> counts(scene.path_corners.size(), 0);
  const double p = scene.path_length;
  if (p <= 0) return counts;
  auto wrap = [p](double x) {
    x = std::fmod(x, p);
    return x < 0 ? x + p : x;
  };
  for (const GeneratedPair& pair : scene.pairs) {
    if (pair.kind != PairKind::kTrue) continue;
    const double s1 = scene.image_path_positions.at(pair.image_id1 - 1);
    const double s2 = scene.image_path_positions.at(pair.image_id2 - 1);
    // The shorter arc between the two images: [start, start + length].
    double start = s1;
    double length = wrap(s2 - s1);
    if (length > 0.5 * p) {
      start = s2;
      length = p - length;
    }
    for (size_t c = 0; c < scene.path_corners.size(); ++c) {
      const double offset = wrap(scene.path_corners[c] - start);
      if (offset > 0 && offset <= length) ++counts[c];
    }
  }
  return counts;
}

namespace {

// Street layout: half the street's width and the length of a facade module (m).
constexpr double kStreetHalfWidth = 6;
constexpr double kModuleLength = 6;

// The one random stream of a scene. The steps draw from it in a fixed order
// (a seed's scene depends on it), all through one normal distribution: the
// standard library's may keep a second value for its next call.
struct SceneRandom {
  explicit SceneRandom(uint64_t seed) : rng(seed) {}
  double Unit() { return unit(rng); }
  double Normal() { return normal(rng); }
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> unit{0.0, 1.0};
  std::normal_distribution<double> normal{0.0, 1.0};
};

// Photo layout: cameras' distances from the landmark's walls (m), core and
// periphery, the periphery's share of the images, the camera loop's distance
// from the walls (m; the distances are offsets from it).
constexpr double kPhotoCore[2] = {5, 25};
constexpr double kPhotoPeriphery[2] = {25, 70};
constexpr double kPhotoPeripheryFraction = 0.25;
constexpr double kPhotoLoopOffset = 16;
constexpr double kPhotoLandmarkHeight = 30;

// The walls and the camera path of a layout.
struct SceneGeometry {
  Layout layout;
  RectLoop loop;                  // the camera loop (courtyard, tower, photo)
  double street_half_length = 0;  // street: half the camera path
  // Photo: each part's landmark centre (x, z) and the end of its share of
  // the camera path (arc length; the parts share it in order).
  std::vector<Eigen::Vector2d> part_centres;
  std::vector<double> part_ends;
  double landmark_hx = 0, landmark_hz = 0;
};

// Photo layout: how far a camera detects points (m). A point's image shrinks
// as focal / distance, so a longer lens resolves it farther away: the widest
// lens (min_focal_ratio x width) detects up to max_view_distance.
double PhotoDetectionRange(const SceneGeneratorOptions& options,
                           const Camera& camera) {
  return options.max_view_distance * CameraMeanFocalLength(camera) /
         (options.min_focal_ratio * camera.width);
}

// Photo layout: landmarks at x = p * spacing, far enough apart that no camera
// of one sees a point of another; part p gets a share of the images
// proportional to 1 / (p + 1) (a popular landmark and less popular ones).
// The first, at the origin, is symmetric under M (its mirror-twin pairs are
// among its own images); the others have no twins (SamplePointCloud).
void BuildPhotoGeometry(const SceneGeneratorOptions& options,
                        SceneGeometry* geometry) {
  const int num_parts = options.num_parts;
  std::vector<double> weights;
  double total = 0;
  for (int p = 0; p < num_parts; ++p) {
    weights.push_back(1.0 / (p + 1));
    total += weights.back();
  }
  // The landmark grows with its images (pairs per image grow as sqrt(n)).
  const double hx =
      std::max(8.0, 1.2 * std::sqrt(options.num_images * weights[0] / total));
  const double hz = 0.8 * hx;
  geometry->landmark_hx = hx;
  geometry->landmark_hz = hz;
  geometry->loop.hx = hx + kPhotoLoopOffset;
  geometry->loop.hz = hz + kPhotoLoopOffset;
  const double max_range = options.max_view_distance * options.max_focal_ratio /
                           options.min_focal_ratio;
  const double spacing = 2 * (hx + kPhotoPeriphery[1] + max_range) + 10;
  const double path_length = geometry->layout.path_length;
  double end = 0;
  for (int p = 0; p < num_parts; ++p) {
    const Eigen::Vector2d centre(p * spacing, 0);
    geometry->part_centres.push_back(centre);
    end += weights[p] / total * path_length;
    geometry->part_ends.push_back(end);
    for (Wall wall : RectWalls(hx, hz, kPhotoLandmarkHeight, false)) {
      wall.a += centre;
      wall.b += centre;
      geometry->layout.walls.push_back(wall);
    }
  }
  geometry->part_ends.back() = path_length;
}

SceneGeometry BuildGeometry(const SceneGeneratorOptions& options) {
  const double path_length = options.num_images * options.image_spacing;
  SceneGeometry geometry;
  Layout& layout = geometry.layout;
  RectLoop& loop = geometry.loop;
  layout.path_length = path_length;
  switch (options.layout) {
    case SceneLayout::kCourtyard: {
      // Cameras walk a loop ~5 m inside the walls.
      loop.hx = std::max(1.0, 0.6 * path_length / 4);
      loop.hz = std::max(1.0, 0.4 * path_length / 4);
      const double inset = 5.0;
      layout.walls = RectWalls(loop.hx + inset, loop.hz + inset, 10.0, true);
      layout.path_length = loop.Perimeter();
      break;
    }
    case SceneLayout::kTower: {
      // A tall tower; cameras on a loop around it, 8-30 m from its walls.
      const double hx = std::max(6.0, 0.55 * 0.5 * path_length / 4);
      const double hz = 0.8 * hx;
      layout.walls = RectWalls(hx, hz, 30.0, false);
      loop.hx = hx + 16;
      loop.hz = hz + 16;
      layout.path_length = loop.Perimeter();
      break;
    }
    case SceneLayout::kStreet: {
      geometry.street_half_length = std::max(15.0, 0.5 * path_length);
      for (int side : {-1, 1}) {
        Wall wall;
        wall.a = {-geometry.street_half_length - 10, side * kStreetHalfWidth};
        wall.b = {geometry.street_half_length + 10, side * kStreetHalfWidth};
        wall.y0 = 0;
        wall.y1 = 12.0;
        wall.normal = {0, -side};
        layout.walls.push_back(wall);
      }
      layout.path_length = 2 * geometry.street_half_length;
      break;
    }
    case SceneLayout::kPhoto:
      BuildPhotoGeometry(options, &geometry);
      break;
  }
  return geometry;
}

// Density along the walls (uneven with density_skew): a slow wave.
double DensityFactor(const SceneGeneratorOptions& options, double arc) {
  return (1 - options.density_skew) +
         options.density_skew * 0.5 * (1 + std::sin(2 * kPi * arc / 23.0));
}

Eigen::Vector3d SampleWallPoint(const SceneGeneratorOptions& options,
                                const Wall& wall, double along,
                                SceneRandom* random) {
  const Eigen::Vector2d dir = (wall.b - wall.a).normalized();
  const Eigen::Vector2d ground = wall.a + along * dir;
  const double y = wall.y0 + random->Unit() * (wall.y1 - wall.y0);
  // Relief behind the wall plane (away from the viewers).
  const double depth = options.wall_relief * random->Unit();
  const Eigen::Vector2d p = ground - depth * wall.normal;
  return Eigen::Vector3d(p.x(), y, p.y());
}

// Index of the wall M maps `wall` onto.
int MirrorWall(const Layout& layout, int wall) {
  const Eigen::Vector2d mid =
      0.5 * (layout.walls[wall].a + layout.walls[wall].b);
  for (size_t k = 0; k < layout.walls.size(); ++k) {
    const Eigen::Vector2d other = 0.5 * (layout.walls[k].a + layout.walls[k].b);
    if ((other + mid).norm() < 1e-6) return static_cast<int>(k);
  }
  LOG(FATAL) << "walls not symmetric";
  return -1;
}

// Walls drawn in proportion to their area.
class WallPicker {
 public:
  explicit WallPicker(const Layout& layout) {
    for (const Wall& wall : layout.walls) {
      total_area_ += wall.Length() * (wall.y1 - wall.y0);
      cumulative_area_.push_back(total_area_);
    }
  }
  double TotalArea() const { return total_area_; }
  int Pick(SceneRandom* random) const {
    return static_cast<int>(std::lower_bound(cumulative_area_.begin(),
                                             cumulative_area_.end(),
                                             random->Unit() * total_area_) -
                            cumulative_area_.begin());
  }

 private:
  std::vector<double> cumulative_area_;
  double total_area_ = 0;
};

void AddPoint(const Eigen::Vector3d& xyz, int wall, int twin,
              PointCloud* cloud) {
  cloud->xyz.push_back(xyz);
  cloud->wall.push_back(wall);
  cloud->twin.push_back(twin);
}

// Street: repeated facade modules on the south wall, their twins on the north.
void AddStreetTwins(const SceneGeneratorOptions& options, const Layout& layout,
                    int64_t num_twin_pairs, SceneRandom* random,
                    PointCloud* cloud) {
  const Wall& south = layout.walls[0];
  const double length = south.Length();
  const int num_modules = static_cast<int>(std::ceil(length / kModuleLength));
  const int per_module = static_cast<int>(
      std::round(static_cast<double>(num_twin_pairs) / num_modules));
  std::vector<Eigen::Vector3d> module_points;
  for (int k = 0; k < per_module; ++k) {
    module_points.push_back(SampleWallPoint(
        options, south, random->Unit() * kModuleLength, random));
  }
  for (int m = 0; m < num_modules; ++m) {
    for (const Eigen::Vector3d& base : module_points) {
      const Eigen::Vector3d xyz =
          base + Eigen::Vector3d(m * kModuleLength, 0, 0);
      if (xyz.x() > south.b.x()) continue;
      if (random->Unit() > DensityFactor(options, xyz.x() - south.a.x())) {
        continue;
      }
      const int index = static_cast<int>(cloud->xyz.size());
      AddPoint(xyz, 0, index + 1, cloud);
      AddPoint(Mirror(xyz), 1, index, cloud);
    }
  }
}

void AddWallTwins(const SceneGeneratorOptions& options, const Layout& layout,
                  const WallPicker& walls, int64_t num_twin_pairs,
                  SceneRandom* random, PointCloud* cloud) {
  for (int64_t k = 0; k < num_twin_pairs; ++k) {
    const int wall = walls.Pick(random);
    const double along = random->Unit() * layout.walls[wall].Length();
    const Eigen::Vector3d xyz =
        SampleWallPoint(options, layout.walls[wall], along, random);
    if (random->Unit() > DensityFactor(options, along + 7.0 * wall)) continue;
    const int index = static_cast<int>(cloud->xyz.size());
    AddPoint(xyz, wall, index + 1, cloud);
    AddPoint(Mirror(xyz), MirrorWall(layout, wall), index, cloud);
  }
}

// `count` points without twins on `layout`'s walls (cloud wall index: the
// layout's plus wall_offset).
void AddUniquePoints(const SceneGeneratorOptions& options, const Layout& layout,
                     const WallPicker& walls, int64_t count, int wall_offset,
                     SceneRandom* random, PointCloud* cloud) {
  for (int64_t k = 0; k < count; ++k) {
    const int wall = walls.Pick(random);
    const Eigen::Vector3d xyz =
        SampleWallPoint(options, layout.walls[wall],
                        random->Unit() * layout.walls[wall].Length(), random);
    AddPoint(xyz, wall + wall_offset, -1, cloud);
  }
}

// The walls seen whole from afar (tower, photo landmarks) get a third of the
// density: their images' keypoints stay comparable with the other layouts'.
constexpr double kDistantWallDensity = 0.3;

// Points: twins X, M X (the wall set is symmetric under M), then the unique
// fraction without twins.
PointCloud SamplePointCloud(const SceneGeneratorOptions& options,
                            const Layout& layout, SceneRandom* random) {
  const WallPicker walls(layout);
  const double expected_points = options.point_density * walls.TotalArea() *
                                 (options.layout == SceneLayout::kTower ||
                                          options.layout == SceneLayout::kPhoto
                                      ? kDistantWallDensity
                                      : 1.0);
  const int64_t num_twin_pairs = static_cast<int64_t>(
      std::round(0.5 * expected_points * (1 - options.unique_point_fraction)));
  const int64_t num_unique = static_cast<int64_t>(
      std::round(expected_points * options.unique_point_fraction));
  PointCloud cloud;
  if (options.layout == SceneLayout::kStreet) {
    AddStreetTwins(options, layout, num_twin_pairs, random, &cloud);
  } else {
    AddWallTwins(options, layout, walls, num_twin_pairs, random, &cloud);
  }
  AddUniquePoints(options, layout, walls, num_unique, 0, random, &cloud);
  return cloud;
}

// Photo layout: the first landmark's walls (the first 4, symmetric under M)
// as a tower's, the other landmarks' points without twins.
PointCloud SamplePhotoPointCloud(const SceneGeneratorOptions& options,
                                 const Layout& layout, SceneRandom* random) {
  constexpr int kWallsPerLandmark = 4;
  Layout first, others;
  first.walls.assign(layout.walls.begin(),
                     layout.walls.begin() + kWallsPerLandmark);
  others.walls.assign(layout.walls.begin() + kWallsPerLandmark,
                      layout.walls.end());
  PointCloud cloud = SamplePointCloud(options, first, random);
  if (others.walls.empty()) return cloud;
  const WallPicker walls(others);
  AddUniquePoints(
      options, others, walls,
      static_cast<int64_t>(std::round(
          kDistantWallDensity * options.point_density * walls.TotalArea())),
      kWallsPerLandmark, random, &cloud);
  return cloud;
}

// The cloud's points by cell of a grid over the ground plane, for
// visibility queries.
class VisibilityGrid {
 public:
  static constexpr double kCell = 4.0;

  explicit VisibilityGrid(const PointCloud& cloud) {
    for (size_t k = 0; k < cloud.xyz.size(); ++k) {
      cells_[Key(CellIndex(cloud.xyz[k].x()), CellIndex(cloud.xyz[k].z()))]
          .push_back(static_cast<int>(k));
    }
  }
  static int64_t CellIndex(double coordinate) {
    return static_cast<int64_t>(std::floor(coordinate / kCell));
  }
  // The points of cell (ix, iz); null if none.
  const std::vector<int>* Find(int64_t ix, int64_t iz) const {
    const auto it = cells_.find(Key(ix, iz));
    return it == cells_.end() ? nullptr : &it->second;
  }

 private:
  // In unsigned arithmetic: a left shift of a negative cell index is
  // undefined behaviour (same bits as before where it was defined).
  static int64_t Key(int64_t ix, int64_t iz) {
    return static_cast<int64_t>((static_cast<uint64_t>(ix) << 32) ^
                                (static_cast<uint64_t>(iz) & 0xffffffffu));
  }
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

// Camera path parameters of the images, sorted: uniform, plus hot spots with
// density_skew.
std::vector<double> SamplePathParameters(const SceneGeneratorOptions& options,
                                         double path_length,
                                         SceneRandom* random) {
  const int n = options.num_images;
  std::vector<double> hotspots;
  for (int h = 0; h < options.num_hotspots; ++h) {
    hotspots.push_back(random->Unit() * path_length);
  }
  std::vector<double> params(n);
  for (int i = 0; i < n; ++i) {
    if (random->Unit() < options.density_skew) {
      const double centre = hotspots[i % hotspots.size()];
      params[i] = centre + random->Normal() * std::max(2.0, path_length / 60);
    } else {
      params[i] = (i + random->Unit()) / n * path_length;
    }
  }
  std::sort(params.begin(), params.end());
  return params;
}

void RecordImagePathPositions(const SceneGeneratorOptions& options,
                              const SceneGeometry& geometry,
                              const std::vector<double>& params,
                              GeneratedScene* scene) {
  const double path_length = geometry.layout.path_length;
  scene->path_length = path_length;
  scene->image_path_positions.resize(params.size());
  for (size_t i = 0; i < params.size(); ++i) {
    double along = std::fmod(params[i], path_length);
    if (along < 0) along += path_length;
    scene->image_path_positions[i] = along;
  }
  if (options.layout != SceneLayout::kStreet &&
      options.layout != SceneLayout::kPhoto) {
    scene->path_corners = geometry.loop.Corners();
  }
}

// Image `image_id` of camera `camera_id` at `center` looking along
// `forward`, rolled by a few degrees.
Image LookingImage(image_t image_id, camera_t camera_id,
                   const Eigen::Vector3d& center,
                   const Eigen::Vector3d& forward, SceneRandom* random) {
  Image image;
  image.image_id = image_id;
  image.name = "image" + std::to_string(image_id) + ".jpg";
  image.camera_id = camera_id;
  image.cam_from_world.rotation =
      Eigen::Quaterniond(LookAlong(forward, DegToRad(3.0) * random->Normal()));
  image.cam_from_world.translation = -(image.cam_from_world.rotation * center);
  return image;
}

// Image `image_id` at path parameter s: its camera, its pose, its part
// (photo layout; 0 otherwise), and (out) its centre and viewing direction.
Image PlacePhotoImage(const SceneGeometry& geometry, image_t image_id, double s,
                      SceneRandom* random, Eigen::Vector3d* center,
                      Eigen::Vector3d* forward, int* part);

Image PlaceImage(const SceneGeneratorOptions& options,
                 const SceneGeometry& geometry, image_t image_id, double s,
                 SceneRandom* random, Eigen::Vector3d* center,
                 Eigen::Vector3d* forward, int* part) {
  *part = 0;
  if (options.layout == SceneLayout::kPhoto) {
    return PlacePhotoImage(geometry, image_id, s, random, center, forward,
                           part);
  }
  const double yaw =
      DegToRad(options.layout == SceneLayout::kTower ? 25.0 : 40.0) *
      (2 * random->Unit() - 1);
  double pitch = DegToRad(5 + 15 * random->Unit());
  Eigen::Vector2d ground = Eigen::Vector2d::Zero();
  Eigen::Vector2d facing = Eigen::Vector2d::UnitX();
  switch (options.layout) {
    case SceneLayout::kCourtyard: {
      Eigen::Vector2d outward;
      geometry.loop.At(s, &ground, &outward);
      ground += 1.0 * (2 * random->Unit() - 1) * outward;
      // Look at the nearest wall, turning gradually at the corners.
      facing = geometry.loop.TurningOutward(s, options.corner_turn_length);
      break;
    }
    case SceneLayout::kTower: {
      Eigen::Vector2d outward;
      geometry.loop.At(s, &ground, &outward);
      // 8-30 m from the walls (the loop is 16 m out).
      ground += (-8 + 22 * random->Unit()) * outward;
      // (Seen whole from afar, the tower ties its loop's sides together
      // at an abrupt turn too: no gradual turn needed.)
      facing = -outward;
      pitch = DegToRad(10 + 20 * random->Unit());
      break;
    }
    case SceneLayout::kPhoto:  // PlacePhotoImage
      break;
    case SceneLayout::kStreet: {
      const double side = random->Unit() < 0.5 ? -1 : 1;
      ground = {std::fmod(s, geometry.layout.path_length) -
                    geometry.street_half_length,
                (2 * random->Unit() - 1) * 0.4 * kStreetHalfWidth};
      facing = {0, side};
      break;
    }
  }
  const Eigen::Vector2d dir(
      std::cos(yaw) * facing.x() - std::sin(yaw) * facing.y(),
      std::sin(yaw) * facing.x() + std::cos(yaw) * facing.y());
  *center =
      Eigen::Vector3d(ground.x(), 1.6 + 0.3 * random->Normal(), ground.y());
  *forward = Eigen::Vector3d(std::cos(pitch) * dir.x(), std::sin(pitch),
                             std::cos(pitch) * dir.y());
  std::uniform_int_distribution<int> camera_pick(1, options.num_cameras);
  const camera_t camera_id =
      options.num_cameras == 1 ? 1 : camera_pick(random->rng);
  return LookingImage(image_id, camera_id, *center, *forward, random);
}

// Photo layout: image `image_id` (its own camera) at path parameter s: the
// part whose share of the path holds s, a position on that part's camera
// loop moved into the core or the periphery, aimed at a random spot of the
// landmark.
Image PlacePhotoImage(const SceneGeometry& geometry, image_t image_id, double s,
                      SceneRandom* random, Eigen::Vector3d* center,
                      Eigen::Vector3d* forward, int* part) {
  const double path_length = geometry.layout.path_length;
  double along = std::fmod(s, path_length);
  if (along < 0) along += path_length;
  *part = static_cast<int>(
      std::min<size_t>(std::upper_bound(geometry.part_ends.begin(),
                                        geometry.part_ends.end(), along) -
                           geometry.part_ends.begin(),
                       geometry.part_ends.size() - 1));
  const double start = *part == 0 ? 0.0 : geometry.part_ends[*part - 1];
  const double fraction =
      (along - start) / std::max(1e-9, geometry.part_ends[*part] - start);
  Eigen::Vector2d ground, outward;
  geometry.loop.At(fraction * geometry.loop.Perimeter(), &ground, &outward);
  const double* range =
      random->Unit() < kPhotoPeripheryFraction ? kPhotoPeriphery : kPhotoCore;
  const double distance = range[0] + (range[1] - range[0]) * random->Unit();
  const Eigen::Vector2d& centre = geometry.part_centres[*part];
  ground += centre + (distance - kPhotoLoopOffset) * outward;
  *center =
      Eigen::Vector3d(ground.x(), 1.6 + 0.3 * random->Normal(), ground.y());
  const Eigen::Vector3d aim(
      centre.x() + geometry.landmark_hx * (2 * random->Unit() - 1),
      2 + (kPhotoLandmarkHeight - 4) * random->Unit(),
      centre.y() + geometry.landmark_hz * (2 * random->Unit() - 1));
  *forward = (aim - *center).normalized();
  return LookingImage(image_id, image_id, *center, *forward, random);
}

// Keypoints of the cloud points `image` detects (within range, in front,
// seen from the walls' front side); observations[k] gets (image, keypoint)
// for cloud point k.
void DetectPoints(const SceneGeneratorOptions& options, const Layout& layout,
                  const PointCloud& cloud, const VisibilityGrid& grid,
                  const Camera& camera, const Eigen::Vector3d& center,
                  const Eigen::Vector3d& forward, SceneRandom* random,
                  Image* image,
                  std::vector<std::vector<TrackElement>>* observations) {
  constexpr double cell = VisibilityGrid::kCell;
  const Eigen::Matrix3d R = image->cam_from_world.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = image->cam_from_world.translation;
  const double focal = CameraMeanFocalLength(camera);
  const double max_u = 0.5 * camera.width / focal * 1.2;
  const double max_v = 0.5 * camera.height / focal * 1.2;
  const double range = options.layout == SceneLayout::kPhoto
                           ? PhotoDetectionRange(options, camera)
                           : options.max_view_distance;
  const int64_t ix0 = VisibilityGrid::CellIndex(center.x() - range);
  const int64_t ix1 = VisibilityGrid::CellIndex(center.x() + range);
  const int64_t iz0 = VisibilityGrid::CellIndex(center.z() - range);
  const int64_t iz1 = VisibilityGrid::CellIndex(center.z() + range);
  const Eigen::Vector2d forward_ground(forward.x(), forward.z());
  // Half the horizontal field of view plus 25 deg (roll, pitch, cell size).
  const double min_cos =
      std::cos(std::min(DegToRad(89.0), std::atan(max_u) + DegToRad(25.0)));
  for (int64_t ix = ix0; ix <= ix1; ++ix) {
    for (int64_t iz = iz0; iz <= iz1; ++iz) {
      // Skip cells wholly behind the camera.
      const Eigen::Vector2d cell_centre((ix + 0.5) * cell - center.x(),
                                        (iz + 0.5) * cell - center.z());
      if (cell_centre.dot(forward_ground.normalized()) < -cell) continue;
      // ... and cells far outside the horizontal field of view.
      if (cell_centre.norm() > 2 * cell &&
          cell_centre.normalized().dot(forward_ground.normalized()) < min_cos) {
        continue;
      }
      const std::vector<int>* points = grid.Find(ix, iz);
      if (points == nullptr) continue;
      for (const int k : *points) {
        const Eigen::Vector3d& X = cloud.xyz[k];
        const Eigen::Vector3d in_cam = R * X + t;
        if (in_cam.z() < 0.5 || in_cam.norm() > range) continue;
        const Wall& wall = layout.walls[cloud.wall[k]];
        if ((center.x() - X.x()) * wall.normal.x() +
                (center.z() - X.z()) * wall.normal.y() <=
            0) {
          continue;  // seen from behind the wall
        }
        const Eigen::Vector2d uv = in_cam.hnormalized();
        if (std::abs(uv.x()) > max_u || std::abs(uv.y()) > max_v) continue;
        const Eigen::Vector2d xy = CameraCameraToImage(camera, uv);
        if (xy.x() < 0 || xy.y() < 0 || xy.x() > camera.width ||
            xy.y() > camera.height) {
          continue;
        }
        if (random->Unit() >= options.detection_probability) continue;
        Point2D point2D = NoisyPoint2D(xy, options, camera, &random->rng);
        point2D.point3D_id = static_cast<point3D_t>(k) + 1;
        (*observations)[k].push_back(
            {image->image_id, static_cast<point2D_t>(image->points2D.size())});
        image->points2D.push_back(point2D);
      }
    }
  }
}

// Clutter keypoints: features of nothing.
void AddClutterKeypoints(const SceneGeneratorOptions& options,
                         const Camera& camera, SceneRandom* random,
                         Image* image) {
  const int num_clutter = static_cast<int>(
      std::round(options.clutter_fraction * image->points2D.size()));
  for (int k = 0; k < num_clutter; ++k) {
    Point2D point2D;
    point2D.xy =
        RandomVector<2>(random->unit, random->rng)
            .cwiseProduct(Eigen::Vector2d(camera.width, camera.height));
    if (options.keypoint_scales) {
      point2D.scale = static_cast<float>(
          kMinKeypointScale +
          (kMaxKeypointScale - kMinKeypointScale) * random->Unit());
    }
    image->points2D.push_back(point2D);
  }
}

// The images of `truth` (its cameras set), one per path parameter, and their
// parts (if image_parts is not null); returns the observations of each cloud
// point: (image, keypoint index).
std::vector<std::vector<TrackElement>> ObserveImages(
    const SceneGeneratorOptions& options, const SceneGeometry& geometry,
    const PointCloud& cloud, const std::vector<double>& params,
    SceneRandom* random, Reconstruction* truth, std::vector<int>* image_parts) {
  const VisibilityGrid grid(cloud);
  std::vector<std::vector<TrackElement>> observations(cloud.xyz.size());
  for (int i = 0; i < options.num_images; ++i) {
    Eigen::Vector3d center, forward;
    int part = 0;
    Image image = PlaceImage(options, geometry, i + 1, params[i], random,
                             &center, &forward, &part);
    if (image_parts != nullptr) image_parts->push_back(part);
    const Camera& camera = truth->cameras.at(image.camera_id);
    DetectPoints(options, geometry.layout, cloud, grid, camera, center, forward,
                 random, &image, &observations);
    SubsampleKeypoints(options, &image, &observations);
    AddClutterKeypoints(options, camera, random, &image);
    truth->images[image.image_id] = std::move(image);
  }
  return observations;
}

// Points seen at least twice enter the model (id = cloud index + 1), with
// their twins in scene->twin_of_point; the keypoints of the others become
// clutter.
void KeepTrackedPoints(const PointCloud& cloud,
                       std::vector<std::vector<TrackElement>>* observations,
                       GeneratedScene* scene) {
  Reconstruction& truth = scene->truth;
  const int64_t num_cloud_points = static_cast<int64_t>(cloud.xyz.size());
  scene->twin_of_point.assign(num_cloud_points + 1, kInvalidPoint3DId);
  for (int64_t k = 0; k < num_cloud_points; ++k) {
    std::vector<TrackElement>& track = (*observations)[k];
    if (track.size() < 2) {
      for (const TrackElement& element : track) {
        truth.images.at(element.image_id)
            .points2D[element.point2D_idx]
            .point3D_id = kInvalidPoint3DId;
      }
      track.clear();
      track.shrink_to_fit();
      continue;
    }
    Point3D point;
    point.xyz = cloud.xyz[k];
    point.color = Eigen::Matrix<uint8_t, 3, 1>(128, 128, 128);
    point.track = std::move(track);
    truth.points3D.emplace_hint(truth.points3D.end(), k + 1, std::move(point));
  }
  for (const auto& [point3D_id, point] : truth.points3D) {
    const int twin = cloud.twin[point3D_id - 1];
    if (twin >= 0 && truth.points3D.count(twin + 1)) {
      scene->twin_of_point[point3D_id] = twin + 1;
    }
  }
}

struct Candidate {
  image_t image_id1, image_id2;
  int count;
  double match_rate = 1.0;
};

struct PairCandidates {
  std::vector<Candidate> true_pairs;
  std::vector<Candidate> mirror;
};

// Dense counters of the points one first image shares with each later image,
// reset after each first image; with viewpoint-dependent match rates also
// their sums (PairMatchRate).
struct SharedPointCounts {
  SharedPointCounts(int num_images, bool with_sums) : count(num_images + 1, 0) {
    if (with_sums) sum.assign(num_images + 1, Eigen::Vector3d::Zero());
  }
  void Add(image_t other, const Eigen::Vector3d& xyz) {
    if (count[other]++ == 0) touched.push_back(other);
    if (!sum.empty()) sum[other] += xyz;
  }
  void Clear() {
    for (const image_t other : touched) {
      count[other] = 0;
      if (!sum.empty()) sum[other].setZero();
    }
    touched.clear();
  }
  std::vector<int> count;
  std::vector<Eigen::Vector3d> sum;
  std::vector<image_t> touched;
};

// Pairs from the tracks: shared points (true) and twin-shared points
// (mirror: image i sees M X where image j sees X), counted per first image.
PairCandidates FindCandidatePairs(const SceneGeneratorOptions& options,
                                  const PointCloud& cloud,
                                  const GeneratedScene& scene) {
  const int n = options.num_images;
  const Reconstruction& truth = scene.truth;
  std::vector<const std::vector<TrackElement>*> track_of(cloud.xyz.size() + 1,
                                                         nullptr);
  for (const auto& [point3D_id, point] : truth.points3D)
    track_of[point3D_id] = &point.track;
  // With viewpoint-dependent match rates: the sums of the shared (true) and
  // twin-shared (mirror: the points the second image sees) points, and the
  // camera centres (PairMatchRate).
  const bool viewpoint_rates = ViewpointMatchRates(options);
  std::vector<Eigen::Vector3d> centers(n + 1);
  if (viewpoint_rates) {
    for (const auto& [image_id, image] : truth.images) {
      centers[image_id] = image.cam_from_world.Inverse().translation;
    }
  }
  SharedPointCounts shared(n, viewpoint_rates), mirrored(n, viewpoint_rates);
  PairCandidates candidates;
  for (const auto& [image_id, image] : truth.images) {
    for (const Point2D& point2D : image.points2D) {
      if (point2D.point3D_id == kInvalidPoint3DId) continue;
      for (const TrackElement& element : *track_of[point2D.point3D_id]) {
        if (element.image_id <= image_id) continue;
        shared.Add(element.image_id, cloud.xyz[point2D.point3D_id - 1]);
      }
      const point3D_t twin = scene.twin_of_point[point2D.point3D_id];
      if (twin == kInvalidPoint3DId) continue;
      for (const TrackElement& element : *track_of[twin]) {
        if (element.image_id <= image_id) continue;
        mirrored.Add(element.image_id, cloud.xyz[twin - 1]);
      }
    }
    std::sort(shared.touched.begin(), shared.touched.end());
    std::sort(mirrored.touched.begin(), mirrored.touched.end());
    for (const image_t other : shared.touched) {
      const double rate =
          viewpoint_rates
              ? PairMatchRate(options, centers[image_id], centers[other],
                              shared.sum[other] / shared.count[other],
                              ImagePairToPairId(image_id, other))
              : 1.0;
      if (shared.count[other] * rate >= options.min_num_inliers) {
        candidates.true_pairs.push_back(
            {image_id, other, shared.count[other], rate});
      }
    }
    for (const image_t other : mirrored.touched) {
      // A mirror pair is the true pair of image_id's twin (centre M c) and
      // other, on the points other sees.
      const double rate =
          viewpoint_rates
              ? PairMatchRate(options, Mirror(centers[image_id]),
                              centers[other],
                              mirrored.sum[other] / mirrored.count[other],
                              ImagePairToPairId(image_id, other))
              : 1.0;
      if (mirrored.count[other] * options.false_pair_inlier_fraction * rate >=
              options.min_num_inliers &&
          mirrored.count[other] > shared.count[other]) {
        candidates.mirror.push_back(
            {image_id, other, mirrored.count[other], rate});
      }
    }
    shared.Clear();
    mirrored.Clear();
  }
  return candidates;
}

// Each image's best max_pairs_per_image pairs only (by count, then order).
void KeepBestPairsPerImage(int num_images, int max_pairs_per_image,
                           std::vector<Candidate>* pairs) {
  std::vector<std::vector<std::pair<int, size_t>>> by_image(num_images + 1);
  for (size_t k = 0; k < pairs->size(); ++k) {
    by_image[(*pairs)[k].image_id1].push_back({(*pairs)[k].count, k});
    by_image[(*pairs)[k].image_id2].push_back({(*pairs)[k].count, k});
  }
  std::vector<char> keep(pairs->size(), 0);
  for (auto& list : by_image) {
    std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    for (size_t k = 0;
         k < list.size() && k < static_cast<size_t>(max_pairs_per_image); ++k) {
      keep[list[k].second] = 1;
    }
  }
  std::vector<Candidate> kept;
  for (size_t k = 0; k < pairs->size(); ++k) {
    if (keep[k]) kept.push_back((*pairs)[k]);
  }
  pairs->swap(kept);
}

// The written pairs so far and where each is in `pairs`.
struct PairList {
  std::vector<GeneratedPair> pairs;
  std::unordered_map<image_pair_t, size_t> index;
};

GeneratedPair PairFromCandidate(const Candidate& candidate, PairKind kind) {
  GeneratedPair pair;
  pair.image_id1 = candidate.image_id1;
  pair.image_id2 = candidate.image_id2;
  pair.kind = kind;
  pair.num_candidates = candidate.count;
  pair.match_rate = candidate.match_rate;
  return pair;
}

PairList TruePairs(const std::vector<Candidate>& true_pairs) {
  PairList list;
  for (const Candidate& candidate : true_pairs) {
    const GeneratedPair pair = PairFromCandidate(candidate, PairKind::kTrue);
    list.index[ImagePairToPairId(pair.image_id1, pair.image_id2)] =
        list.pairs.size();
    list.pairs.push_back(pair);
  }
  return list;
}

// Mirror pairs: random candidates until they make mirror_pair_rate of all
// pairs; one replaces the true pair of the same images if there is one.
void AddMirrorPairs(const SceneGeneratorOptions& options,
                    std::vector<Candidate> mirror_candidates,
                    SceneRandom* random, PairList* list) {
  std::shuffle(mirror_candidates.begin(), mirror_candidates.end(), random->rng);
  int num_mirror = 0;
  int64_t num_pairs = static_cast<int64_t>(list->pairs.size());
  for (const Candidate& candidate : mirror_candidates) {
    if (num_pairs == 0 ||
        num_mirror >= options.mirror_pair_rate * num_pairs - 1e-9) {
      break;
    }
    const GeneratedPair pair = PairFromCandidate(candidate, PairKind::kMirror);
    const image_pair_t pair_id =
        ImagePairToPairId(pair.image_id1, pair.image_id2);
    const auto it = list->index.find(pair_id);
    if (it != list->index.end()) {
      list->pairs[it->second] = pair;
    } else {
      list->index[pair_id] = list->pairs.size();
      list->pairs.push_back(pair);
      ++num_pairs;
    }
    ++num_mirror;
  }
  if (num_mirror < options.mirror_pair_rate * num_pairs - 1e-9) {
    LOG(WARNING) << "only " << num_mirror << " mirror-twin pairs possible ("
                 << mirror_candidates.size() << " candidates), fewer than "
                 << options.mirror_pair_rate * 100 << "% of " << num_pairs;
  }
}

// Up to `target` inliers of a random false pair consistent with its relative
// pose: keypoints of image1 and, for each, a new clutter keypoint of image2.
void AddRandomPairInliers(const SceneGeneratorOptions& options,
                          const Image& image1, const Camera& camera1,
                          const Camera& camera2, int target,
                          SceneRandom* random, Image* image2,
                          GeneratedPair* pair) {
  const Rigid3d& pose = pair->random_cam2_from_cam1;
  std::uniform_int_distribution<point2D_t> keypoint_pick(
      0, image1.points2D.size() - 1);
  std::unordered_set<point2D_t> used;
  for (int tries = 0; tries < 20 * target &&
                      static_cast<int>(pair->random_inliers.size()) < target;
       ++tries) {
    const point2D_t idx1 = keypoint_pick(random->rng);
    if (!used.insert(idx1).second) continue;
    const Eigen::Vector2d x1 =
        CameraImageToCamera(camera1, image1.points2D[idx1].xy);
    // A clutter keypoint beyond the radius where the distortion folds over
    // (wide portrait cameras with k < 0) is on no ray: NaN, which every
    // range check below would let through.
    if (!x1.allFinite()) continue;
    const Eigen::Vector3d X1 = (3 + 27 * random->Unit()) * x1.homogeneous();
    const Eigen::Vector3d X2 = pose * X1;
    if (X2.z() < 0.5) continue;
    const Eigen::Vector2d uv = X2.hnormalized();
    if (std::abs(uv.x()) > 1.5 || std::abs(uv.y()) > 1.5) continue;
    Eigen::Vector2d xy = CameraCameraToImage(camera2, uv);
    if (xy.x() < 0 || xy.y() < 0 || xy.x() > camera2.width ||
        xy.y() > camera2.height) {
      continue;
    }
    const Point2D point2D = NoisyPoint2D(xy, options, camera2, &random->rng);
    pair->random_inliers.push_back(
        {idx1, static_cast<point2D_t>(image2->points2D.size())});
    image2->points2D.push_back(point2D);
  }
}

// Random false pairs (random_pair_rate of all pairs): inliers consistent with
// a random relative pose, whose second keypoints are new clutter keypoints of
// image_id2.
void AddRandomPairs(const SceneGeneratorOptions& options, SceneRandom* random,
                    Reconstruction* truth, PairList* list) {
  const int64_t num_pairs = static_cast<int64_t>(list->pairs.size());
  const int64_t num_random = static_cast<int64_t>(std::round(
      options.random_pair_rate * num_pairs / (1 - options.random_pair_rate)));
  std::uniform_int_distribution<image_t> image_pick(1, options.num_images);
  for (int64_t r = 0, attempts = 0;
       r < num_random && attempts < 100 * num_random + 100; ++attempts) {
    image_t id1 = image_pick(random->rng), id2 = image_pick(random->rng);
    if (id1 == id2) continue;
    if (id1 > id2) std::swap(id1, id2);
    const image_pair_t pair_id = ImagePairToPairId(id1, id2);
    if (list->index.count(pair_id)) continue;
    Image& image1 = truth->images.at(id1);
    Image& image2 = truth->images.at(id2);
    if (image1.points2D.empty()) continue;
    // Random rotation up to 30 deg, random unit translation.
    const Eigen::Vector3d axis = RandomVector<3>(random->normal, random->rng);
    GeneratedPair pair;
    pair.image_id1 = id1;
    pair.image_id2 = id2;
    pair.kind = PairKind::kRandom;
    pair.random_cam2_from_cam1.rotation = Eigen::Quaterniond(
        Eigen::AngleAxisd(DegToRad(30.0) * random->Unit(), axis.normalized()));
    pair.random_cam2_from_cam1.translation =
        RandomVector<3>(random->normal, random->rng).normalized();
    const int target =
        options.min_num_inliers +
        static_cast<int>(random->Unit() * 2 * options.min_num_inliers);
    AddRandomPairInliers(options, image1, truth->cameras.at(image1.camera_id),
                         truth->cameras.at(image2.camera_id), target, random,
                         &image2, &pair);
    if (static_cast<int>(pair.random_inliers.size()) <
        options.min_num_inliers) {
      continue;  // its clutter keypoints stay: harmless
    }
    pair.num_candidates = static_cast<int>(pair.random_inliers.size());
    list->index[pair_id] = list->pairs.size();
    list->pairs.push_back(std::move(pair));
    ++r;
  }
}

// The true cameras and, for the photo layout (one camera per image), the
// database's (MakePhotoCamera).
void MakeCameras(const SceneGeneratorOptions& options, SceneRandom* random,
                 GeneratedScene* scene) {
  if (options.layout != SceneLayout::kPhoto) {
    for (int c = 1; c <= options.num_cameras; ++c) {
      scene->truth.cameras[c] = MakeCamera(options, c, &random->rng);
    }
    return;
  }
  for (int c = 1; c <= options.num_images; ++c) {
    scene->truth.cameras[c] =
        MakePhotoCamera(options, c, &random->rng, &scene->database_cameras[c]);
  }
}

// The pairs in (image_id1, image_id2) order, counted by kind.
void SetScenePairs(std::vector<GeneratedPair> pairs, GeneratedScene* scene) {
  std::sort(pairs.begin(), pairs.end(),
            [](const GeneratedPair& a, const GeneratedPair& b) {
              return a.image_id1 != b.image_id1 ? a.image_id1 < b.image_id1
                                                : a.image_id2 < b.image_id2;
            });
  for (const GeneratedPair& pair : pairs) {
    switch (pair.kind) {
      case PairKind::kTrue:
        ++scene->num_true_pairs;
        break;
      case PairKind::kMirror:
        ++scene->num_mirror_pairs;
        break;
      case PairKind::kRandom:
        ++scene->num_random_pairs;
        break;
    }
  }
  scene->pairs = std::move(pairs);
}

}  // namespace

GeneratedScene GenerateScene(const SceneGeneratorOptions& options) {
  options.Check();
  SceneRandom random(options.seed);
  const SceneGeometry geometry = BuildGeometry(options);
  const PointCloud cloud =
      options.layout == SceneLayout::kPhoto
          ? SamplePhotoPointCloud(options, geometry.layout, &random)
          : SamplePointCloud(options, geometry.layout, &random);

  GeneratedScene scene;
  scene.options = options;
  MakeCameras(options, &random, &scene);
  const std::vector<double> params =
      SamplePathParameters(options, geometry.layout.path_length, &random);
  RecordImagePathPositions(options, geometry, params, &scene);
  const bool photo = options.layout == SceneLayout::kPhoto;
  std::vector<std::vector<TrackElement>> observations =
      ObserveImages(options, geometry, cloud, params, &random, &scene.truth,
                    photo ? &scene.image_parts : nullptr);
  KeepTrackedPoints(cloud, &observations, &scene);
  observations.clear();

  PairCandidates candidates = FindCandidatePairs(options, cloud, scene);
  if (options.max_pairs_per_image > 0) {
    KeepBestPairsPerImage(options.num_images, options.max_pairs_per_image,
                          &candidates.true_pairs);
  }
  PairList pairs = TruePairs(candidates.true_pairs);
  scene.num_mirror_candidates = static_cast<int>(candidates.mirror.size());
  AddMirrorPairs(options, std::move(candidates.mirror), &random, &pairs);
  AddRandomPairs(options, &random, &scene.truth, &pairs);
  SetScenePairs(std::move(pairs.pairs), &scene);
  return scene;
}

Rigid3d PairRelativePose(const GeneratedScene& scene,
                         const GeneratedPair& pair) {
  if (pair.kind == PairKind::kRandom) return pair.random_cam2_from_cam1;
  Rigid3d pose1 = scene.truth.images.at(pair.image_id1).cam_from_world;
  const Rigid3d& pose2 = scene.truth.images.at(pair.image_id2).cam_from_world;
  if (pair.kind == PairKind::kMirror) pose1 = MirrorTwinPose(pose1);
  const Rigid3d world_from_cam1 = pose1.Inverse();
  Rigid3d relative;
  relative.rotation = (pose2.rotation * world_from_cam1.rotation).normalized();
  relative.translation =
      pose2.rotation * world_from_cam1.translation + pose2.translation;
  return relative;
}

namespace {

// The camera as the database stores it (GeneratedScene::database_cameras).
const Camera& DatabaseCamera(const GeneratedScene& scene, camera_t camera_id) {
  return scene.database_cameras.empty() ? scene.truth.cameras.at(camera_id)
                                        : scene.database_cameras.at(camera_id);
}

// Track of a point, through a lookup the caller chooses (the model's map for
// one pair, a flat table when writing every pair).
using TrackLookup = std::function<const std::vector<TrackElement>&(point3D_t)>;

// image1's keypoint of X (true pair) or of M X (mirror pair) with image2's
// keypoint of X, in image1's keypoint order.
FeatureMatches CandidateMatches(const GeneratedScene& scene,
                                const GeneratedPair& pair,
                                const TrackLookup& track_of) {
  FeatureMatches matches;
  const Image& image1 = scene.truth.images.at(pair.image_id1);
  for (point2D_t idx1 = 0; idx1 < image1.points2D.size(); ++idx1) {
    point3D_t point3D_id = image1.points2D[idx1].point3D_id;
    if (point3D_id == kInvalidPoint3DId) continue;
    if (pair.kind == PairKind::kMirror) {
      point3D_id = scene.twin_of_point[point3D_id];
      if (point3D_id == kInvalidPoint3DId) continue;
    }
    for (const TrackElement& element : track_of(point3D_id)) {
      if (element.image_id == pair.image_id2) {
        matches.push_back({idx1, element.point2D_idx});
        break;
      }
    }
  }
  return matches;
}

// An image's keypoints as the database stores them.
FeatureKeypoints Keypoints(const Image& image) {
  FeatureKeypoints keypoints;
  keypoints.reserve(image.points2D.size());
  for (const Point2D& point2D : image.points2D) {
    keypoints.push_back(point2D.xy.cast<float>());
  }
  return keypoints;
}

// Appends raw_outlier_ratio x its size wrong (random) matches to `matches`.
void AddWrongMatches(const SceneGeneratorOptions& options, const Image& image1,
                     const Image& image2, std::mt19937_64* rng,
                     FeatureMatches* matches) {
  const int num_wrong =
      static_cast<int>(std::round(options.raw_outlier_ratio * matches->size()));
  if (image1.points2D.empty() || image2.points2D.empty()) return;
  std::uniform_int_distribution<point2D_t> pick1(0, image1.points2D.size() - 1);
  std::uniform_int_distribution<point2D_t> pick2(0, image2.points2D.size() - 1);
  for (int k = 0; k < num_wrong; ++k)
    matches->push_back({pick1(*rng), pick2(*rng)});
}

// COLMAP's two-view geometry estimation: max_error (px) of F's, E's and H's
// inliers, the share of F's inliers E must have for a calibrated pair, and
// the share of E's (or F's) above which H's make the pair planar or
// panoramic.
constexpr double kMatcherMaxErrorPx = 4.0;
constexpr double kMatcherMinEFInlierRatio = 0.95;
constexpr double kMatcherMaxHInlierRatio = 0.8;

// A two-view matrix (F, E: x2^T M x1 = 0; H: x2 ~ M x1) fitted as a
// matcher's RANSAC would, and its inliers (error within max_error).
struct TwoViewFit {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  std::vector<char> is_inlier;
  int num_inliers = 0;
};

using LinearSolver = bool (*)(const std::vector<Eigen::Vector2d>&,
                              const std::vector<Eigen::Vector2d>&,
                              Eigen::Matrix3d*);
using SquaredError = double (*)(const Eigen::Matrix3d&, const Eigen::Vector2d&,
                                const Eigen::Vector2d&);

// Hypotheses: `seeds`, the least-squares fit to all correspondences and fits
// to random minimal samples of sample_size (until 99.9% confidence of an
// all-inlier sample at the best inlier ratio, 20 to 500 samples); the one
// with most inliers is then refitted to its inliers while their number grows
// (local optimisation).
TwoViewFit FitTwoViewMatrix(const std::vector<Eigen::Vector2d>& points1,
                            const std::vector<Eigen::Vector2d>& points2,
                            double max_error, LinearSolver solver,
                            SquaredError squared_error, int sample_size,
                            const std::vector<Eigen::Matrix3d>& seeds,
                            std::mt19937_64* rng) {
  const int num = static_cast<int>(points1.size());
  const double max_error_sq = max_error * max_error;
  TwoViewFit best;
  best.is_inlier.assign(num, 0);
  std::vector<char> is_inlier(num);
  auto consider = [&](const Eigen::Matrix3d& M) {
    if (!M.allFinite() || !(M.norm() > 0)) return false;
    int count = 0;
    for (int i = 0; i < num; ++i) {
      // NaN (a point on no ray) is no inlier.
      is_inlier[i] = squared_error(M, points1[i], points2[i]) <= max_error_sq;
      count += is_inlier[i];
    }
    if (count <= best.num_inliers) return false;
    best.M = M / M.norm();
    best.is_inlier = is_inlier;
    best.num_inliers = count;
    return true;
  };
  for (const Eigen::Matrix3d& seed : seeds) consider(seed);
  if (num < sample_size) return best;
  Eigen::Matrix3d M;
  if (solver(points1, points2, &M)) consider(M);
  std::vector<int> order(num);
  std::iota(order.begin(), order.end(), 0);
  std::vector<Eigen::Vector2d> sample1(sample_size), sample2(sample_size);
  constexpr int kMinTrials = 20;
  constexpr int kMaxTrials = 500;
  for (int trial = 0; trial < kMaxTrials; ++trial) {
    for (int k = 0; k < sample_size; ++k) {
      std::uniform_int_distribution<int> pick(k, num - 1);
      std::swap(order[k], order[pick(*rng)]);
      sample1[k] = points1[order[k]];
      sample2[k] = points2[order[k]];
    }
    if (solver(sample1, sample2, &M)) consider(M);
    const double all_inlier_sample =
        std::pow(static_cast<double>(best.num_inliers) / num, sample_size);
    if (trial + 1 >= kMinTrials &&
        (all_inlier_sample >= 1 ||
         trial + 1 >= std::log(1e-3) / std::log1p(-all_inlier_sample))) {
      break;
    }
  }
  for (int pass = 0; pass < 10 && best.num_inliers >= sample_size; ++pass) {
    std::vector<Eigen::Vector2d> inliers1, inliers2;
    for (int i = 0; i < num; ++i) {
      if (!best.is_inlier[i]) continue;
      inliers1.push_back(points1[i]);
      inliers2.push_back(points2[i]);
    }
    if (!solver(inliers1, inliers2, &M) || !consider(M)) break;
  }
  return best;
}

FeatureMatches SelectMatches(const FeatureMatches& matches,
                             const std::vector<char>& keep) {
  FeatureMatches selected;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (keep[i]) selected.push_back(matches[i]);
  }
  return selected;
}

// What a matcher's two-view geometry estimation stores for `matches` (the
// rule of COLMAP's, not its code). F is fitted in pixels (pinhole, no
// distortion), H in pixels (transfer error); where both database cameras
// have a prior focal, E too, on the keypoints normalised by the database's
// cameras (threshold 4 px over their focal lengths). Then: E's inliers more
// than 0.95 of F's (and >= min_num_inliers): calibrated, the larger of E's
// and F's inliers; else F's >= min_num_inliers: uncalibrated, F's; either
// way PLANAR_OR_PANORAMIC (with H's inliers if more) where H's exceed 0.8 of
// E's (calibrated) or F's (uncalibrated), else CALIBRATED / UNCALIBRATED;
// else H's >= min_num_inliers: PLANAR_OR_PANORAMIC; else DEGENERATE, no
// inliers. E, F and H are stored as fitted. The true geometry (its F with
// the true cameras' K, its E) seeds the F and E fits, as the best of a
// matcher's many samples would be near it.
void MatcherTwoViewGeometry(const GeneratedScene& scene, const Image& image1,
                            const Image& image2, const Rigid3d& relative,
                            const FeatureMatches& matches, std::mt19937_64* rng,
                            TwoViewGeometry* geometry) {
  const int min_num_inliers = scene.options.min_num_inliers;
  std::vector<Eigen::Vector2d> pixels1, pixels2;
  pixels1.reserve(matches.size());
  pixels2.reserve(matches.size());
  for (const FeatureMatch& match : matches) {
    pixels1.push_back(image1.points2D[match.point2D_idx1].xy);
    pixels2.push_back(image2.points2D[match.point2D_idx2].xy);
  }
  const Eigen::Matrix3d true_E = EssentialFromPose(
      relative.rotation.toRotationMatrix(), relative.translation.normalized());
  const Eigen::Matrix3d true_K1 =
      CameraCalibrationMatrix(scene.truth.cameras.at(image1.camera_id));
  const Eigen::Matrix3d true_K2 =
      CameraCalibrationMatrix(scene.truth.cameras.at(image2.camera_id));
  const TwoViewFit fundamental = FitTwoViewMatrix(
      pixels1, pixels2, kMatcherMaxErrorPx, &EstimateFundamentalEightPoint,
      &SampsonErrorSquared, 8,
      {true_K2.inverse().transpose() * true_E * true_K1.inverse()}, rng);
  const TwoViewFit homography = FitTwoViewMatrix(
      pixels1, pixels2, kMatcherMaxErrorPx, &EstimateHomographyDLT,
      &HomographyTransferErrorSquared, 4, {}, rng);
  geometry->F = fundamental.M;
  geometry->H = homography.M;
  geometry->E.setZero();

  TwoViewFit essential;
  const Camera& camera1 = DatabaseCamera(scene, image1.camera_id);
  const Camera& camera2 = DatabaseCamera(scene, image2.camera_id);
  if (camera1.has_prior_focal_length && camera2.has_prior_focal_length) {
    std::vector<Eigen::Vector2d> normalized1, normalized2;
    normalized1.reserve(matches.size());
    normalized2.reserve(matches.size());
    for (size_t i = 0; i < matches.size(); ++i) {
      normalized1.push_back(CameraImageToCamera(camera1, pixels1[i]));
      normalized2.push_back(CameraImageToCamera(camera2, pixels2[i]));
    }
    const Eigen::Matrix3d K1 = CameraCalibrationMatrix(camera1);
    const Eigen::Matrix3d K2 = CameraCalibrationMatrix(camera2);
    const double max_error =
        0.5 * (kMatcherMaxErrorPx / (0.5 * (K1(0, 0) + K1(1, 1))) +
               kMatcherMaxErrorPx / (0.5 * (K2(0, 0) + K2(1, 1))));
    // E from the fitted F with the database's K, projected onto the
    // essential matrices.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(
        K2.transpose() * fundamental.M * K1,
        Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d E_of_F = svd.matrixU() *
                                   Eigen::Vector3d(1, 1, 0).asDiagonal() *
                                   svd.matrixV().transpose();
    essential = FitTwoViewMatrix(
        normalized1, normalized2, max_error, &EstimateEssentialEightPoint,
        &SampsonErrorSquared, 8, {true_E, E_of_F}, rng);
    geometry->E = essential.M;
  }

  const TwoViewFit* best = nullptr;
  int planar_reference = 0;  // H's inliers are compared with these
  if (essential.num_inliers >= min_num_inliers &&
      essential.num_inliers >
          kMatcherMinEFInlierRatio * fundamental.num_inliers) {
    geometry->config = TwoViewGeometry::CALIBRATED;
    best = essential.num_inliers >= fundamental.num_inliers ? &essential
                                                            : &fundamental;
    planar_reference = essential.num_inliers;
  } else if (fundamental.num_inliers >= min_num_inliers) {
    geometry->config = TwoViewGeometry::UNCALIBRATED;
    best = &fundamental;
    planar_reference = fundamental.num_inliers;
  } else if (homography.num_inliers >= min_num_inliers) {
    geometry->config = TwoViewGeometry::PLANAR_OR_PANORAMIC;
    best = &homography;
  } else {
    geometry->config = TwoViewGeometry::DEGENERATE;
    geometry->inlier_matches.clear();
    return;
  }
  if (planar_reference > 0 &&
      homography.num_inliers > kMatcherMaxHInlierRatio * planar_reference) {
    geometry->config = TwoViewGeometry::PLANAR_OR_PANORAMIC;
    if (homography.num_inliers > best->num_inliers) best = &homography;
  }
  geometry->inlier_matches = SelectMatches(matches, best->is_inlier);
}

// The stored geometry from the pair's candidate matches (ignored for random
// pairs, whose inliers are fixed).
TwoViewGeometry FinishPairGeometry(const GeneratedScene& scene,
                                   const GeneratedPair& pair,
                                   FeatureMatches candidates,
                                   FeatureMatches* raw_matches) {
  const SceneGeneratorOptions& options = scene.options;
  std::mt19937_64 rng(Mix(
      options.seed ^ Mix(ImagePairToPairId(pair.image_id1, pair.image_id2))));
  const Image& image1 = scene.truth.images.at(pair.image_id1);
  const Image& image2 = scene.truth.images.at(pair.image_id2);
  TwoViewGeometry geometry;
  geometry.image_id1 = pair.image_id1;
  geometry.image_id2 = pair.image_id2;
  geometry.config =
      DatabaseCamera(scene, image1.camera_id).has_prior_focal_length &&
              DatabaseCamera(scene, image2.camera_id).has_prior_focal_length
          ? TwoViewGeometry::CALIBRATED
          : TwoViewGeometry::UNCALIBRATED;
  if (pair.kind == PairKind::kRandom) {
    geometry.inlier_matches = pair.random_inliers;
  } else {
    geometry.inlier_matches = std::move(candidates);
    // A false pair matches only part of what its geometry allows; a pair
    // with a viewpoint-dependent match rate only that part.
    const double fraction =
        (pair.kind == PairKind::kMirror ? options.false_pair_inlier_fraction
                                        : 1.0) *
        pair.match_rate;
    if (pair.kind == PairKind::kMirror || fraction < 1) {
      std::shuffle(geometry.inlier_matches.begin(),
                   geometry.inlier_matches.end(), rng);
      const size_t keep = std::max<size_t>(
          options.min_num_inliers,
          static_cast<size_t>(
              std::round(fraction * geometry.inlier_matches.size())));
      if (geometry.inlier_matches.size() > keep)
        geometry.inlier_matches.resize(keep);
      std::sort(geometry.inlier_matches.begin(), geometry.inlier_matches.end(),
                [](const FeatureMatch& a, const FeatureMatch& b) {
                  return a.point2D_idx1 < b.point2D_idx1;
                });
    }
  }

  const Rigid3d relative = PairRelativePose(scene, pair);
  if (options.matcher_geometry) {
    // Its own stream, so that the wrong raw matches are those drawn without.
    std::mt19937_64 fit_rng(
        Mix(options.seed ^ 0x6d61746368ULL ^
            Mix(ImagePairToPairId(pair.image_id1, pair.image_id2))));
    FeatureMatches matches = std::move(geometry.inlier_matches);
    MatcherTwoViewGeometry(scene, image1, image2, relative, matches, &fit_rng,
                           &geometry);
    if (options.store_relative_pose && !geometry.inlier_matches.empty()) {
      RelativePoseOptions fit;
      fit.refine = false;
      const RelativePose estimate = EstimateRelativePose(
          geometry, DatabaseCamera(scene, image1.camera_id),
          DatabaseCamera(scene, image2.camera_id), Keypoints(image1),
          Keypoints(image2), fit);
      if (estimate.success && estimate.has_translation) {
        geometry.has_pose = true;
        const Eigen::Quaterniond rotation(estimate.R);
        geometry.qvec = Eigen::Vector4d(rotation.w(), rotation.x(),
                                        rotation.y(), rotation.z());
        geometry.tvec = estimate.t;
      }
    }
    if (raw_matches) {
      *raw_matches = std::move(matches);
      AddWrongMatches(options, image1, image2, &rng, raw_matches);
    }
    return geometry;
  }
  Eigen::Matrix3d R = relative.rotation.toRotationMatrix();
  Eigen::Vector3d t = relative.translation.normalized();
  geometry.E = EssentialFromPose(R, t);
  const Camera& camera1 = scene.truth.cameras.at(image1.camera_id);
  const Camera& camera2 = scene.truth.cameras.at(image2.camera_id);
  if (!options.exact_two_view_geometry) {
    // What a matcher stores: the pose fitted to the noisy inliers, started
    // from the true one (its RANSAC's hypothesis) and refined, however
    // weakly the inliers determine it.
    RelativePoseOptions fit;
    fit.refine_max_rotation_std_deg = 180;
    const RelativePose estimate = EstimateRelativePose(
        geometry, camera1, camera2, Keypoints(image1), Keypoints(image2), fit);
    if (estimate.success && estimate.has_translation && estimate.refined) {
      R = estimate.R;
      t = estimate.t;
      geometry.E = EssentialFromPose(R, t);
    }
  }
  const Eigen::Matrix3d K1 = CameraCalibrationMatrix(camera1);
  const Eigen::Matrix3d K2 = CameraCalibrationMatrix(camera2);
  geometry.F = K2.inverse().transpose() * geometry.E * K1.inverse();
  geometry.F /= geometry.F.norm();
  if (options.store_relative_pose) {
    geometry.has_pose = true;
    const Eigen::Quaterniond rotation(R);
    geometry.qvec =
        Eigen::Vector4d(rotation.w(), rotation.x(), rotation.y(), rotation.z());
    geometry.tvec = t;
  }

  if (raw_matches) {
    *raw_matches = geometry.inlier_matches;
    AddWrongMatches(options, image1, image2, &rng, raw_matches);
  }
  return geometry;
}

}  // namespace

TwoViewGeometry PairGeometry(const GeneratedScene& scene,
                             const GeneratedPair& pair,
                             FeatureMatches* raw_matches) {
  FeatureMatches candidates;
  if (pair.kind != PairKind::kRandom) {
    candidates = CandidateMatches(
        scene, pair, [&](point3D_t id) -> const std::vector<TrackElement>& {
          return scene.truth.points3D.at(id).track;
        });
  }
  return FinishPairGeometry(scene, pair, std::move(candidates), raw_matches);
}

void WriteSceneDatabase(const GeneratedScene& scene, const std::string& path,
                        std::vector<int>* num_inliers) {
  if (num_inliers) num_inliers->assign(scene.pairs.size(), 0);
  DatabaseWriter writer(path);
  for (const auto& [camera_id, camera] : scene.truth.cameras)
    writer.WriteCamera(DatabaseCamera(scene, camera_id));
  for (const auto& [image_id, image] : scene.truth.images) {
    writer.WriteImage(image_id, image.name, image.camera_id);
    FeatureKeypoints keypoints;
    std::vector<float> scales;
    keypoints.reserve(image.points2D.size());
    for (const Point2D& point2D : image.points2D) {
      keypoints.push_back(point2D.xy.cast<float>());
      if (scene.options.keypoint_scales) scales.push_back(point2D.scale);
    }
    writer.WriteKeypoints(image_id, keypoints, scales);
  }
  // Flat track table (the model's map costs a cache miss per level), and the
  // candidates of all pairs of one first image in one pass over its
  // keypoints: O(observations * track length) in all.
  point3D_t max_id = 0;
  for (const auto& [point3D_id, point] : scene.truth.points3D)
    max_id = point3D_id;
  std::vector<const std::vector<TrackElement>*> tracks(max_id + 1, nullptr);
  for (const auto& [point3D_id, point] : scene.truth.points3D)
    tracks[point3D_id] = &point.track;
  FeatureMatches raw_matches;
  std::unordered_map<image_t, FeatureMatches> true_candidates,
      mirror_candidates;
  for (size_t begin = 0; begin < scene.pairs.size();) {
    const image_t image_id1 = scene.pairs[begin].image_id1;
    size_t end = begin;
    true_candidates.clear();
    mirror_candidates.clear();
    for (; end < scene.pairs.size() && scene.pairs[end].image_id1 == image_id1;
         ++end) {
      const GeneratedPair& pair = scene.pairs[end];
      if (pair.kind == PairKind::kTrue) true_candidates[pair.image_id2];
      if (pair.kind == PairKind::kMirror) mirror_candidates[pair.image_id2];
    }
    const Image& image1 = scene.truth.images.at(image_id1);
    for (point2D_t idx1 = 0; idx1 < image1.points2D.size(); ++idx1) {
      const point3D_t point3D_id = image1.points2D[idx1].point3D_id;
      if (point3D_id == kInvalidPoint3DId) continue;
      for (const TrackElement& element : *tracks[point3D_id]) {
        const auto it = true_candidates.find(element.image_id);
        if (it != true_candidates.end())
          it->second.push_back({idx1, element.point2D_idx});
      }
      const point3D_t twin = scene.twin_of_point[point3D_id];
      if (twin == kInvalidPoint3DId || mirror_candidates.empty()) continue;
      for (const TrackElement& element : *tracks[twin]) {
        const auto it = mirror_candidates.find(element.image_id);
        if (it != mirror_candidates.end())
          it->second.push_back({idx1, element.point2D_idx});
      }
    }
    for (size_t k = begin; k < end; ++k) {
      const GeneratedPair& pair = scene.pairs[k];
      FeatureMatches candidates;
      if (pair.kind == PairKind::kTrue)
        candidates = std::move(true_candidates[pair.image_id2]);
      if (pair.kind == PairKind::kMirror) {
        candidates = std::move(mirror_candidates[pair.image_id2]);
      }
      const TwoViewGeometry geometry =
          FinishPairGeometry(scene, pair, std::move(candidates), &raw_matches);
      // A matcher writes no pair it could not verify.
      if (geometry.config == TwoViewGeometry::DEGENERATE) continue;
      if (num_inliers)
        (*num_inliers)[k] = static_cast<int>(geometry.inlier_matches.size());
      writer.WriteMatches(pair.image_id1, pair.image_id2, raw_matches);
      writer.WriteTwoViewGeometry(geometry);
    }
    begin = end;
  }
  writer.Commit();
}

void PosePriorGeneratorOptions::Check() const {
  auto require = [](bool ok, const std::string& name,
                    const std::string& problem) {
    if (!ok) throw InputError("--" + name, problem);
  };
  require(horizontal_std >= 0 && vertical_std >= 0, "prior_horizontal_std",
          "the standard deviations must be >= 0");
  require(outlier_fraction >= 0 && outlier_fraction <= 1,
          "prior_outlier_fraction", "must be in [0, 1]");
  require(
      outlier_min_distance >= 0 && outlier_max_distance >= outlier_min_distance,
      "prior_outlier_min_distance", "must be in [0, max distance]");
  require(gravity_std_deg >= 0 && gravity_std_deg < 30, "prior_gravity_std",
          "must be in [0, 30) deg");
  require(IsValidWgs84(origin), "prior_origin", "not a valid WGS84 position");
}

namespace {

// The priors' frame from the generator's world: y up becomes z up.
Eigen::Matrix3d EnuFromWorld() {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return R;
}

// The truth mapped by a rotation and translation x -> R x + t.
Reconstruction TransformTruth(const Reconstruction& model,
                              const Eigen::Matrix3d& R,
                              const Eigen::Vector3d& t) {
  Reconstruction truth = model;
  const Eigen::Quaterniond q(R);
  for (auto& [image_id, image] : truth.images) {
    const Eigen::Vector3d center = R * image.ProjectionCenter() + t;
    image.cam_from_world.rotation =
        (image.cam_from_world.rotation * q.inverse()).normalized();
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
  }
  for (auto& [point3D_id, point] : truth.points3D) {
    point.xyz = R * point.xyz + t;
  }
  return truth;
}

}  // namespace

Reconstruction TruthInPriorFrame(const GeneratedScene& scene,
                                 const GeneratedPosePriors& priors) {
  // World -> ENU at options.origin -> ENU at the priors' median origin.
  const EnuFrame from(priors.options.origin);
  const EnuFrame to(priors.enu_origin);
  const Eigen::Matrix3d R = to.EnuFromEcef() * from.EnuFromEcef().transpose();
  const Eigen::Vector3d t =
      to.EnuFromEcef() * (from.OriginEcef() - to.OriginEcef());
  return TransformTruth(scene.truth, R * EnuFromWorld(), t);
}

GeneratedPosePriors GeneratePosePriors(
    const GeneratedScene& scene, const PosePriorGeneratorOptions& options) {
  options.Check();
  GeneratedPosePriors priors;
  priors.options = options;
  std::mt19937_64 rng(Mix(options.seed ^ 0x706f73655f707269ULL));
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const EnuFrame frame(options.origin);
  // The truth in the east-north-up frame at options.origin.
  const Reconstruction truth =
      TransformTruth(scene.truth, EnuFromWorld(), Eigen::Vector3d::Zero());
  const double gravity_std = options.gravity_std_deg * M_PI / 180.0;
  for (const auto& [image_id, image] : truth.images) {
    Eigen::Vector3d enu =
        image.ProjectionCenter() +
        RandomVector<3>(normal, rng)
            .cwiseProduct(Eigen::Vector3d(options.horizontal_std,
                                          options.horizontal_std,
                                          options.vertical_std));
    if (unit(rng) < options.outlier_fraction) {
      const Eigen::Vector3d direction =
          RandomVector<3>(normal, rng).normalized();
      enu += direction * (options.outlier_min_distance +
                          unit(rng) * (options.outlier_max_distance -
                                       options.outlier_min_distance));
      priors.outliers.insert(image_id);
    }
    // Down in the camera frame, tilted by two small random angles.
    const Eigen::Vector3d down =
        image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
    const Eigen::Vector3d axis1 = down.unitOrthogonal();
    const Eigen::Vector3d axis2 = down.cross(axis1);
    const Eigen::Vector3d gravity = (down + gravity_std * normal(rng) * axis1 +
                                     gravity_std * normal(rng) * axis2)
                                        .normalized();
    StoredPosePrior stored;
    stored.image_name = image.name;
    const Wgs84 geodetic = frame.ToWgs84(enu);
    stored.position = Eigen::Vector3d(geodetic.latitude, geodetic.longitude,
                                      geodetic.altitude);
    stored.coordinate_system = PriorCoordinateSystem::kWgs84;
    stored.position_covariance =
        Eigen::Vector3d(options.horizontal_std * options.horizontal_std,
                        options.horizontal_std * options.horizontal_std,
                        options.vertical_std * options.vertical_std)
            .asDiagonal();
    stored.gravity = gravity;
    priors.wgs84[image_id] = stored;
  }
  // The frame and positions the mapper will derive from them.
  StoredPosePriors all;
  std::map<std::string, image_t> image_ids;
  for (const auto& [image_id, stored] : priors.wgs84) {
    all.priors.push_back(stored);
    image_ids[stored.image_name] = image_id;
  }
  const LocalPosePriors local = ConvertPosePriors(all, image_ids);
  priors.enu_origin = local.enu_origin;
  for (const auto& [image_id, prior] : local.priors) {
    priors.enu[image_id] = prior.position;
  }
  return priors;
}

void WritePosePriorText(const GeneratedScene& scene,
                        const GeneratedPosePriors& priors, bool wgs84,
                        const std::string& path) {
  std::ofstream file(path + ".tmp");
  file << std::setprecision(wgs84 ? 12 : 9);
  for (const auto& [image_id, enu] : priors.enu) {
    const Eigen::Vector3d position =
        wgs84 ? priors.wgs84.at(image_id).position : enu;
    file << scene.truth.images.at(image_id).name << ' ' << position.x() << ' '
         << position.y() << ' ' << position.z() << '\n';
  }
  file.close();
  if (!file) throw InputError(path, "cannot write");
  std::filesystem::rename(path + ".tmp", path);
}

}  // namespace colmap_irav4
