#include "colmap_irav4/eval/relpose_io.h"

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>

#include <glog/logging.h>
#include <unistd.h>

#include "colmap_irav4/eval/text_parsing.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/atomic_output.h"
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
  // First line of each pair and its rotation in (min, max) vertex order.
  std::map<std::pair<int, int>, std::pair<int, Eigen::Matrix3d>> seen;
  int num_repeated = 0;
  int first_repeated_line = 0;
  int num_self = 0;
  for (const TextLine& line : ReadTextLines(path)) {
    RequireFieldCount(path, line, 9, 10);
    const std::string at = "line " + std::to_string(line.number) + ": ";
    const Eigen::Matrix3d R = ParseQuaternion(path, line, 2);
    for (int k = 6; k < 9; ++k) ParseDouble(path, line, k);
    if (line.fields.size() == 10 && !line.fields[9].empty() &&
        line.fields[9][0] == '-') {
      throw InputError(path,
                       at + "inlier count " + line.fields[9] + " is negative");
    }
    const double weight =
        line.fields.size() == 10 ? ParseIndex(path, line, 9) : 1.0;
    if (line.fields[0] == line.fields[1]) {
      // Carries no information; a graph edge needs two images.
      if (num_self++ == 0) {
        LOG(WARNING) << path << ": " << at << "image '" << line.fields[0]
                     << "' paired with itself, skipped";
      }
      continue;
    }
    const int i = vertex(line.fields[0]);
    const int j = vertex(line.fields[1]);
    const std::pair<int, int> key(std::min(i, j), std::max(i, j));
    const Eigen::Matrix3d R_ordered =
        i < j ? R : Eigen::Matrix3d(R.transpose());
    const auto it = seen.find(key);
    if (it != seen.end()) {
      // A repetition is harmless; a different rotation for the same pair
      // means the file is not what it claims to be.
      const double angle = AngularDistanceDeg(it->second.second, R_ordered);
      if (angle > 1.0) {
        throw InputError(
            path, at + "pair '" + line.fields[0] + "' '" + line.fields[1] +
                      "' repeated with a rotation " + std::to_string(angle) +
                      " deg away from line " +
                      std::to_string(it->second.first) + "'s");
      }
      if (num_repeated++ == 0) first_repeated_line = line.number;
      continue;
    }
    seen.emplace(key, std::make_pair(line.number, R_ordered));
    graph.AddEdge(i, j, R, weight);
  }
  if (graph.NumEdges() == 0) throw InputError(path, "no image pairs");
  LOG_IF(WARNING, num_repeated > 0)
      << path << ": " << num_repeated
      << " repeated image pairs ignored (first at line " << first_repeated_line
      << ")";
  LOG_IF(WARNING, num_self > 1) << path << ": " << num_self
                                << " lines pair an image with itself, skipped";
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
  std::ostringstream file;
  file << std::setprecision(17);
  for (size_t v = 0; v < names.size(); ++v) {
    if (!estimated[v]) continue;
    const Eigen::Vector4d q = RotationToQuaternion(rotations[v]);
    file << names[v] << ' ' << q(0) << ' ' << q(1) << ' ' << q(2) << ' ' << q(3)
         << '\n';
  }
  WriteFileAtomically(path, file.str());
}

}  // namespace colmap_irav4
