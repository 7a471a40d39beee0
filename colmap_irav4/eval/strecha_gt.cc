#include "colmap_irav4/eval/strecha_gt.h"

#include <filesystem>
#include <fstream>
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

}  // namespace colmap_irav4
