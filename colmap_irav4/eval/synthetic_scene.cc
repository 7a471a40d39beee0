#include "colmap_irav4/eval/synthetic_scene.h"

#include <algorithm>
#include <random>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/random.h"

namespace colmap_irav4 {
namespace {

Camera MakeCamera(const SyntheticSceneOptions& options, camera_t camera_id) {
  Camera camera;
  camera.camera_id = camera_id;
  camera.model_id = options.camera_model_id;
  camera.width = options.width;
  camera.height = options.height;
  const int num_params = CameraModelNumParams(options.camera_model_id);
  CHECK_GT(num_params, 0) << "unknown camera model " << options.camera_model_id;
  camera.params.assign(num_params, options.extra_param);
  for (int idx : CameraModelFocalLengthIdxs(camera.model_id)) {
    camera.params[idx] = options.focal_length;
  }
  const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
  CHECK_EQ(pp.size(), 2u);
  camera.params[pp[0]] = 0.5 * options.width;
  camera.params[pp[1]] = 0.5 * options.height;
  return camera;
}

// cam_from_world rotation of a camera at `center` looking at `target`, image
// y axis pointing roughly along world -Y.
Eigen::Matrix3d LookAt(const Eigen::Vector3d& center,
                       const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - center).normalized();
  const Eigen::Vector3d x = z.cross(-Eigen::Vector3d::UnitY()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.row(0) = x.transpose();
  R.row(1) = y.transpose();
  R.row(2) = z.transpose();
  return R;
}

}  // namespace

SyntheticScene GenerateSyntheticScene(const SyntheticSceneOptions& options) {
  CHECK_GE(options.num_images, 2);
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  SyntheticScene scene;
  Reconstruction& truth = scene.truth;
  for (int i = 0; i < options.num_images; ++i) {
    const camera_t camera_id = options.shared_camera ? 1 : i + 1;
    if (!truth.cameras.count(camera_id)) {
      truth.cameras[camera_id] = MakeCamera(options, camera_id);
    }
    const double angle =
        DegToRad(options.arc_angle_deg) *
        (options.num_images == 1 ? 0.0
                                 : (i / (options.num_images - 1.0) - 0.5));
    const Eigen::Vector3d center(
        options.arc_radius * std::sin(angle),
        options.height_jitter * options.arc_radius * uniform(rng),
        -options.arc_radius * std::cos(angle));
    const Eigen::Vector3d target =
        0.05 * options.arc_radius * RandomVector<3>(uniform, rng);
    Image image;
    image.image_id = i + 1;
    image.name = "image" + std::to_string(i + 1) + ".jpg";
    image.camera_id = camera_id;
    image.cam_from_world.rotation = Eigen::Quaterniond(LookAt(center, target));
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
    truth.images[image.image_id] = image;
  }

  for (int k = 0; k < options.num_points; ++k) {
    const Eigen::Vector3d xyz =
        options.point_half_extent * RandomVector<3>(uniform, rng);
    Point3D point;
    point.xyz = xyz;
    std::vector<std::pair<image_t, Eigen::Vector2d>> observations;
    for (auto& [image_id, image] : truth.images) {
      const Camera& camera = truth.cameras.at(image.camera_id);
      const Eigen::Vector3d in_cam = image.cam_from_world * xyz;
      if (in_cam.z() < 1e-3) continue;
      Eigen::Vector2d xy = CameraCameraToImage(camera, in_cam.hnormalized());
      if (xy.x() < 0 || xy.y() < 0 || xy.x() > camera.width ||
          xy.y() > camera.height) {
        continue;
      }
      if (unit(rng) >= options.visibility) continue;
      xy += options.noise_px * RandomVector<2>(normal, rng);
      observations.emplace_back(image_id, xy);
    }
    if (observations.size() < 2) continue;
    const point3D_t point3D_id = truth.points3D.size() + 1;
    for (const auto& [image_id, xy] : observations) {
      Image& image = truth.images.at(image_id);
      Point2D point2D;
      point2D.xy = xy;
      point2D.point3D_id = point3D_id;
      point.track.push_back(
          {image_id, static_cast<point2D_t>(image.points2D.size())});
      image.points2D.push_back(point2D);
    }
    truth.points3D[point3D_id] = point;
  }

  // Matches of every pair from the common points.
  std::map<std::pair<image_t, image_t>, ImagePairMatches> pairs;
  for (const auto& [point3D_id, point] : truth.points3D) {
    for (size_t a = 0; a < point.track.size(); ++a) {
      for (size_t b = a + 1; b < point.track.size(); ++b) {
        const TrackElement& e1 = point.track[a];
        const TrackElement& e2 = point.track[b];
        ImagePairMatches& pair = pairs[{e1.image_id, e2.image_id}];
        pair.image_id1 = e1.image_id;
        pair.image_id2 = e2.image_id;
        pair.matches.emplace_back(e1.point2D_idx, e2.point2D_idx);
      }
    }
  }
  for (auto& [key, pair] : pairs) {
    const Image& image1 = truth.images.at(pair.image_id1);
    const Image& image2 = truth.images.at(pair.image_id2);
    const int num_outliers = static_cast<int>(
        std::round(options.outlier_match_ratio * pair.matches.size()));
    std::uniform_int_distribution<size_t> idx1(0, image1.points2D.size() - 1);
    std::uniform_int_distribution<size_t> idx2(0, image2.points2D.size() - 1);
    for (int n = 0; n < num_outliers; ++n) {
      const point2D_t p1 = idx1(rng);
      const point2D_t p2 = idx2(rng);
      if (image1.points2D[p1].point3D_id == image2.points2D[p2].point3D_id)
        continue;
      pair.matches.emplace_back(p1, p2);
    }
    scene.matches.push_back(std::move(pair));
  }
  return scene;
}

Reconstruction StripPoints(const Reconstruction& truth) {
  Reconstruction reconstruction = truth;
  reconstruction.points3D.clear();
  for (auto& [image_id, image] : reconstruction.images) {
    for (Point2D& point2D : image.points2D)
      point2D.point3D_id = kInvalidPoint3DId;
  }
  return reconstruction;
}

}  // namespace colmap_irav4
