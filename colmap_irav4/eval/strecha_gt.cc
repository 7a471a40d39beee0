#include "colmap_irav4/eval/strecha_gt.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

StrechaCamera ReadStrechaCamera(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw InputError(path, "cannot open file");
  // Whitespace-separated numbers; '\r' of Windows line ends is whitespace.
  std::vector<double> values;
  std::string token;
  while (file >> token) {
    try {
      size_t end = 0;
      values.push_back(std::stod(token, &end));
      if (end != token.size()) throw std::invalid_argument(token);
    } catch (const std::exception&) {
      throw InputError(path, "not a number: '" + token + "'");
    }
  }
  constexpr size_t kNumValues = 9 + 3 + 9 + 3 + 2;
  if (values.size() != kNumValues) {
    throw InputError(path, "expected " + std::to_string(kNumValues) +
                               " numbers (K, distortion, R, C, W H), found " +
                               std::to_string(values.size()));
  }
  StrechaCamera camera;
  Eigen::Matrix3d world_from_cam;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      camera.K(r, c) = values[3 * r + c];
      world_from_cam(r, c) = values[12 + 3 * r + c];
    }
  }
  camera.distortion = Eigen::Vector3d(values[9], values[10], values[11]);
  camera.center = Eigen::Vector3d(values[21], values[22], values[23]);
  // Checked before the cast: a double outside int's range is undefined there.
  for (const double size : {values[24], values[25]}) {
    if (!(size >= 1 && size <= 1e6 && size == std::floor(size))) {
      throw InputError(path,
                       "W H (line 9) must be whole numbers from 1 to "
                       "1000000 pixels");
    }
  }
  camera.width = static_cast<int>(values[24]);
  camera.height = static_cast<int>(values[25]);
  // The files have 6 significant digits: accept that much non-orthogonality.
  if (!IsRotation(world_from_cam, 1e-4)) {
    throw InputError(path, "R (lines 5-7) is not a rotation matrix");
  }
  const Eigen::Matrix3d cam_from_world =
      ProjectToRotation(world_from_cam).transpose();
  camera.cam_from_world.rotation = Eigen::Quaterniond(cam_from_world);
  camera.cam_from_world.translation = -cam_from_world * camera.center;
  return camera;
}

std::map<std::string, StrechaCamera> ReadStrechaGroundTruth(
    const std::string& gt_dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(gt_dir, error)) {
    throw InputError(gt_dir, "not a directory");
  }
  std::map<std::string, StrechaCamera> cameras;
  for (const fs::directory_entry& entry : fs::directory_iterator(gt_dir)) {
    const fs::path& path = entry.path();
    if (path.extension() != ".camera") continue;
    cameras[path.stem().string()] = ReadStrechaCamera(path.string());
  }
  if (cameras.empty()) throw InputError(gt_dir, "no .camera files");
  return cameras;
}

StrechaStart MakeStrechaStart(const DatabaseContents& database,
                              const std::map<std::string, StrechaCamera>& gt,
                              const std::string& gt_path,
                              double rotation_noise_deg, uint64_t seed) {
  StrechaStart start;
  start.reconstruction.cameras = database.cameras;
  std::mt19937_64 rng(seed);
  for (const auto& [image_id, db_image] : database.images) {
    const auto camera = gt.find(db_image.name);
    if (camera == gt.end()) {
      throw InputError(gt_path, "no camera for " + db_image.name);
    }
    Image& image = start.reconstruction.images[image_id];
    image.image_id = image_id;
    image.name = db_image.name;
    image.camera_id = db_image.camera_id;
    image.cam_from_world.rotation = Eigen::Quaterniond(RandomRotationWithAngle(
                                        DegToRad(rotation_noise_deg), &rng)) *
                                    camera->second.cam_from_world.rotation;
    for (const Eigen::Vector2f& xy : database.keypoints.at(image_id)) {
      Point2D point2D;
      point2D.xy = xy.cast<double>();
      image.points2D.push_back(point2D);
    }
  }
  for (const TwoViewGeometry& geometry : database.two_view_geometries) {
    ImagePairMatches pair{geometry.image_id1, geometry.image_id2, {}};
    for (const FeatureMatch& match : geometry.inlier_matches) {
      pair.matches.emplace_back(match.point2D_idx1, match.point2D_idx2);
    }
    start.pairs.push_back(std::move(pair));
  }
  return start;
}

}  // namespace colmap_irav4
