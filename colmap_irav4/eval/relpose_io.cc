#include "colmap_irav4/eval/relpose_io.h"

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <set>
#include <unordered_map>

#include <glog/logging.h>
#include <unistd.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/eval/text_parsing.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

RotationGraph ReadRelativePoses(const std::string& path) {
  RotationGraph graph;
  std::unordered_map<std::string, int> vertex_of;
  auto vertex = [&](const std::string& name) {
    const auto it = vertex_of.find(name);
    if (it != vertex_of.end()) return it->second;
    const int v = graph.AddVertex(name);
    vertex_of.emplace(name, v);
    return v;
  };
  std::set<std::pair<int, int>> seen;
  int num_repeated = 0;
  int first_repeated_line = 0;
  for (const TextLine& line : ReadTextLines(path)) {
    RequireFieldCount(path, line, 9, 10);
    if (line.fields[0] == line.fields[1]) {
      throw InputError(path, "line " + std::to_string(line.number) +
                                 ": pair of image '" + line.fields[0] +
                                 "' with itself");
    }
    const Eigen::Matrix3d R = ParseQuaternion(path, line, 2);
    for (int k = 6; k < 9; ++k) ParseDouble(path, line, k);
    const double weight =
        line.fields.size() == 10 ? ParseIndex(path, line, 9) : 1.0;
    const int i = vertex(line.fields[0]);
    const int j = vertex(line.fields[1]);
    if (!seen.emplace(std::min(i, j), std::max(i, j)).second) {
      if (num_repeated++ == 0) first_repeated_line = line.number;
      continue;
    }
    graph.AddEdge(i, j, R, weight);
  }
  if (graph.NumEdges() == 0) throw InputError(path, "no image pairs");
  LOG_IF(WARNING, num_repeated > 0)
      << path << ": " << num_repeated
      << " repeated image pairs ignored (first at line "
      << first_repeated_line << ")";
  return graph;
}

std::vector<std::pair<std::string, Eigen::Matrix3d>> ReadAbsoluteRotations(
    const std::string& path) {
  std::vector<std::pair<std::string, Eigen::Matrix3d>> rotations;
  std::set<std::string> names;
  for (const TextLine& line : ReadTextLines(path)) {
    RequireFieldCount(path, line, 5, 5);
    const Eigen::Matrix3d R = ParseQuaternion(path, line, 1);
    if (!names.insert(line.fields[0]).second) {
      throw InputError(path, "line " + std::to_string(line.number) +
                                 ": image '" + line.fields[0] +
                                 "' listed twice");
    }
    rotations.emplace_back(line.fields[0], R);
  }
  if (rotations.empty()) throw InputError(path, "no rotations");
  return rotations;
}

void WriteAbsoluteRotations(const std::string& path,
                            const std::vector<std::string>& names,
                            const std::vector<Eigen::Matrix3d>& rotations,
                            const std::vector<bool>& estimated) {
  CHECK_EQ(names.size(), rotations.size());
  CHECK_EQ(names.size(), estimated.size());
  const std::string temp_path =
      path + ".tmp" + std::to_string(static_cast<long>(::getpid()));
  {
    std::ofstream file(temp_path);
    if (!file) throw InputError(path, "cannot write (temporary " + temp_path + ")");
    file << std::setprecision(17);
    for (size_t v = 0; v < names.size(); ++v) {
      if (!estimated[v]) continue;
      const Eigen::Vector4d q = RotationToQuaternion(rotations[v]);
      file << names[v] << ' ' << q(0) << ' ' << q(1) << ' ' << q(2) << ' '
           << q(3) << '\n';
    }
    file.close();
    if (!file) {
      std::remove(temp_path.c_str());
      throw InputError(path, "write failed");
    }
  }
  if (std::rename(temp_path.c_str(), path.c_str()) != 0) {
    std::remove(temp_path.c_str());
    throw InputError(path, "cannot rename the temporary file into place");
  }
}

}  // namespace colmap_irav4
