#include "colmap_irav4/eval/onedsfm.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/eval/text_parsing.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// Bundler axes -> OpenCV axes.
const Eigen::Matrix3d kFlipYZ = Eigen::Vector3d(1, -1, -1).asDiagonal();

}  // namespace

std::vector<OneDsfmEdge> ReadOneDsfmEdges(const std::string& path,
                                          int num_images,
                                          OneDsfmRotation rotation) {
  std::vector<OneDsfmEdge> edges;
  for (const TextLine& line : ReadTextLines(path)) {
    RequireFieldCount(path, line, 14, 14);
    OneDsfmEdge edge;
    edge.i = ParseIndex(path, line, 0, num_images);
    edge.j = ParseIndex(path, line, 1, num_images);
    if (edge.i == edge.j) {
      throw InputError(path, "line " + std::to_string(line.number) +
                                 ": edge from image " + std::to_string(edge.i) +
                                 " to itself");
    }
    const Eigen::Matrix3d stored = ParseRotationMatrix(path, line, 2);
    Eigen::Vector3d direction;  // camera j's centre in camera i's frame
    for (int k = 0; k < 3; ++k) direction(k) = ParseDouble(path, line, 11 + k);
    if (rotation == OneDsfmRotation::kStored) {
      edge.R_ij = stored;
    } else {
      // Stored: R_i R_j^T (Bundler axes). Ours: R_j R_i^T, OpenCV axes.
      edge.R_ij = kFlipYZ * stored.transpose() * kFlipYZ;
    }
    // x_j = R_ij x_i + t_ij vanishes at camera j's centre c (in frame i):
    // t_ij = -R_ij c, with c taken to OpenCV axes.
    const Eigen::Vector3d t = -edge.R_ij * (kFlipYZ * direction);
    if (t.norm() > 0) edge.t_ij = t.normalized();
    edges.push_back(edge);
  }
  if (edges.empty()) throw InputError(path, "no edges (empty file)");
  return edges;
}

std::vector<std::string> ReadOneDsfmList(const std::string& path) {
  std::ifstream check(path);
  if (!check) throw InputError(path, "cannot open file");
  // Every line counts (line k is image k), so read raw lines.
  std::vector<std::string> names;
  std::string text;
  int number = 0;
  while (std::getline(check, text)) {
    ++number;
    std::istringstream stream(text);
    std::string name;
    if (!(stream >> name)) {
      throw InputError(path, "line " + std::to_string(number) +
                                 ": empty line (line k names image k)");
    }
    names.push_back(name);
  }
  if (names.empty()) throw InputError(path, "no images");
  return names;
}

std::vector<int> ReadOneDsfmComponent(const std::string& path, int num_images) {
  std::vector<int> component;
  for (const TextLine& line : ReadTextLines(path)) {
    RequireFieldCount(path, line, 1, 1);
    component.push_back(ParseIndex(path, line, 0, num_images));
  }
  if (component.empty()) throw InputError(path, "no image indices");
  return component;
}

BundlerFile ReadBundlerFile(const std::string& path) {
  const std::vector<TextLine> lines = ReadTextLines(path);
  if (lines.empty()) throw InputError(path, "empty file");
  size_t next = 0;
  auto take = [&](int min_count, int max_count) -> const TextLine& {
    if (next >= lines.size()) throw InputError(path, "unexpected end of file");
    RequireFieldCount(path, lines[next], min_count, max_count);
    return lines[next++];
  };
  const TextLine& header = take(2, 2);
  const int num_cameras = ParseIndex(path, header, 0);
  const int num_points = ParseIndex(path, header, 1);
  BundlerFile bundler;
  for (int c = 0; c < num_cameras; ++c) {
    BundlerCamera camera;
    const TextLine& intrinsics = take(3, 3);
    camera.focal = ParseDouble(path, intrinsics, 0);
    camera.k1 = ParseDouble(path, intrinsics, 1);
    camera.k2 = ParseDouble(path, intrinsics, 2);
    TextLine rotation;  // the three rows joined, numbered by the first
    for (int row = 0; row < 3; ++row) {
      const TextLine& line = take(3, 3);
      if (row == 0) rotation.number = line.number;
      rotation.fields.insert(rotation.fields.end(), line.fields.begin(),
                             line.fields.end());
    }
    const TextLine& translation = take(3, 3);
    Eigen::Matrix3d R;
    for (int k = 0; k < 9; ++k)
      R(k / 3, k % 3) = ParseDouble(path, rotation, k);
    for (int k = 0; k < 3; ++k) {
      camera.t(k) = ParseDouble(path, translation, k);
    }
    // Bundler writes zeros for the cameras it did not reconstruct.
    camera.registered = !R.isZero(0.0);
    if (camera.registered) {
      R = ParseRotationMatrix(path, rotation, 0);
      // Bundler: x_cam = R X + t with the camera looking down -z.
      camera.R = kFlipYZ * R;
      camera.t = kFlipYZ * camera.t;
    }
    bundler.cameras.push_back(camera);
  }
  for (int p = 0; p < num_points; ++p) {
    BundlerPoint point;
    const TextLine& position = take(3, 3);
    for (int k = 0; k < 3; ++k) point.xyz(k) = ParseDouble(path, position, k);
    take(3, 3);  // colour
    if (next >= lines.size()) throw InputError(path, "unexpected end of file");
    const TextLine& views = lines[next];
    const int num_views = ParseIndex(path, views, 0);
    // Four fields a view; compared in 64 bits (1 + 4 * num_views can
    // overflow an int).
    if (static_cast<int64_t>(views.fields.size()) !=
        1 + 4 * static_cast<int64_t>(num_views)) {
      throw InputError(path, "line " + std::to_string(views.number) + ": " +
                                 std::to_string(num_views) + " views need " +
                                 std::to_string(1 + 4 * int64_t{num_views}) +
                                 " fields, found " +
                                 std::to_string(views.fields.size()));
    }
    for (int v = 0; v < num_views; ++v) {
      point.cameras.push_back(ParseIndex(path, views, 1 + 4 * v, num_cameras));
    }
    ++next;
    bundler.points.push_back(std::move(point));
  }
  if (next != lines.size()) {
    throw InputError(path, "line " + std::to_string(lines[next].number) +
                               ": unexpected data after the last point");
  }
  return bundler;
}

OneDsfmScene ReadOneDsfmScene(const std::string& directory) {
  namespace fs = std::filesystem;
  const fs::path dir(directory);
  if (!fs::is_directory(dir)) throw InputError(directory, "not a directory");
  const std::string edges_path = (dir / "EGs.txt").string();
  const std::string list_path = (dir / "list.txt").string();
  const std::string component_path = (dir / "cc.txt").string();
  const std::string bundle_path = (dir / "gt_bundle.out").string();
  if (!fs::exists(edges_path)) throw InputError(edges_path, "missing");

  std::vector<std::string> names;
  if (fs::exists(list_path)) names = ReadOneDsfmList(list_path);
  const int num_images = static_cast<int>(names.size());
  const std::vector<OneDsfmEdge> edges =
      ReadOneDsfmEdges(edges_path, num_images);
  int max_index = num_images - 1;
  for (const OneDsfmEdge& edge : edges) {
    max_index = std::max({max_index, edge.i, edge.j});
  }
  std::vector<int> images;
  if (fs::exists(component_path)) {
    images = ReadOneDsfmComponent(component_path, num_images);
    for (int image : images) max_index = std::max(max_index, image);
  } else {
    for (int k = 0; k <= max_index; ++k) images.push_back(k);
  }

  OneDsfmScene scene;
  std::vector<int> vertex_of(max_index + 1, -1);
  for (int image : images) {
    if (vertex_of[image] >= 0) continue;  // listed twice
    vertex_of[image] = scene.graph.AddVertex(
        image < num_images ? names[image] : std::to_string(image));
    scene.image_index.push_back(image);
  }
  int num_skipped = 0;
  for (const OneDsfmEdge& edge : edges) {
    const int vi = vertex_of[edge.i], vj = vertex_of[edge.j];
    if (vi < 0 || vj < 0) {
      ++num_skipped;
      continue;
    }
    scene.graph.AddEdge(vi, vj, edge.R_ij, 1.0);
  }
  LOG_IF(INFO, num_skipped > 0)
      << edges_path << ": " << num_skipped
      << " edges leave the component of cc.txt and are ignored";

  if (fs::exists(bundle_path)) {
    const BundlerFile bundler = ReadBundlerFile(bundle_path);
    if (num_images > 0 &&
        static_cast<int>(bundler.cameras.size()) != num_images) {
      throw InputError(bundle_path, std::to_string(bundler.cameras.size()) +
                                        " cameras but list.txt has " +
                                        std::to_string(num_images) + " images");
    }
    scene.ground_truth.assign(scene.graph.NumVertices(),
                              Eigen::Matrix3d::Identity());
    scene.has_ground_truth.assign(scene.graph.NumVertices(), false);
    for (int v = 0; v < scene.graph.NumVertices(); ++v) {
      const int image = scene.image_index[v];
      if (image < static_cast<int>(bundler.cameras.size()) &&
          bundler.cameras[image].registered) {
        scene.ground_truth[v] = bundler.cameras[image].R;
        scene.has_ground_truth[v] = true;
      }
    }
  }
  return scene;
}

}  // namespace colmap_irav4
