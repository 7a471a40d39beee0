#include "colmap_irav4/eval/text_parsing.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

[[noreturn]] void Fail(const std::string& path, const TextLine& line,
                       const std::string& problem) {
  throw InputError(path,
                   "line " + std::to_string(line.number) + ": " + problem);
}

}  // namespace

std::vector<TextLine> ReadTextLines(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw InputError(path, "cannot open file");
  std::vector<TextLine> lines;
  std::string text;
  int number = 0;
  while (std::getline(file, text)) {
    ++number;
    std::istringstream stream(text);
    TextLine line;
    line.number = number;
    std::string field;
    while (stream >> field) line.fields.push_back(field);
    if (line.fields.empty() || line.fields[0][0] == '#') continue;
    lines.push_back(std::move(line));
  }
  if (file.bad()) throw InputError(path, "read error");
  return lines;
}

void RequireFieldCount(const std::string& path, const TextLine& line,
                       int min_count, int max_count) {
  const int count = static_cast<int>(line.fields.size());
  if (count >= min_count && count <= max_count) return;
  const std::string expected =
      min_count == max_count
          ? std::to_string(min_count)
          : std::to_string(min_count) + " to " + std::to_string(max_count);
  Fail(path, line,
       "expected " + expected + " fields, found " + std::to_string(count));
}

double ParseDouble(const std::string& path, const TextLine& line, int field) {
  const std::string& text = line.fields.at(field);
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || errno == ERANGE ||
      !std::isfinite(value)) {
    Fail(path, line,
         "field " + std::to_string(field + 1) + " '" + text +
             "' is not a finite number");
  }
  return value;
}

int ParseIndex(const std::string& path, const TextLine& line, int field,
               int bound) {
  const std::string& text = line.fields.at(field);
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0' || errno == ERANGE) {
    Fail(path, line,
         "field " + std::to_string(field + 1) + " '" + text +
             "' is not an integer");
  }
  if (value < 0 || (bound > 0 && value >= bound) || value > 2000000000L) {
    Fail(path, line,
         "index " + text + " out of range" +
             (bound > 0 ? " [0, " + std::to_string(bound) + ")"
                        : std::string()));
  }
  return static_cast<int>(value);
}

Eigen::Matrix3d ParseRotationMatrix(const std::string& path,
                                    const TextLine& line, int first_field,
                                    double tolerance) {
  Eigen::Matrix3d M;
  for (int k = 0; k < 9; ++k) {
    M(k / 3, k % 3) = ParseDouble(path, line, first_field + k);
  }
  if (!IsRotation(M, tolerance)) {
    Fail(path, line, "the 3x3 matrix is not a rotation");
  }
  return ProjectToRotation(M);
}

Eigen::Matrix3d ParseQuaternion(const std::string& path, const TextLine& line,
                                int first_field, double tolerance) {
  Eigen::Vector4d q;
  for (int k = 0; k < 4; ++k) q(k) = ParseDouble(path, line, first_field + k);
  if (std::abs(q.norm() - 1.0) > tolerance) {
    std::ostringstream problem;
    problem << "quaternion norm " << q.norm() << " is not 1";
    Fail(path, line, problem.str());
  }
  return QuaternionToRotation(q);
}

}  // namespace colmap_irav4
