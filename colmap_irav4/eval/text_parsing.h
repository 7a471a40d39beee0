#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace colmap_irav4 {

// Helpers for the whitespace-separated text formats the readers accept. All
// failures throw InputError("<path>", "line <n>: <problem>").

// A non-empty, non-comment ('#') line of a text file and its 1-based number.
struct TextLine {
  int number = 0;
  std::vector<std::string> fields;
};

// Reads every non-empty line that does not start with '#', split on
// whitespace. Throws InputError if the file cannot be opened.
std::vector<TextLine> ReadTextLines(const std::string& path);

// Throws unless the line has `count` fields (or a count in [min, max]).
void RequireFieldCount(const std::string& path, const TextLine& line,
                       int min_count, int max_count);
double ParseDouble(const std::string& path, const TextLine& line, int field);
// A non-negative integer index, < bound if bound > 0.
int ParseIndex(const std::string& path, const TextLine& line, int field,
               int bound = 0);
// Parses 9 numbers (row-major) from `first_field` and checks that they form a
// rotation up to `tolerance` (the files store few digits); returns the
// nearest exact rotation.
Eigen::Matrix3d ParseRotationMatrix(const std::string& path,
                                    const TextLine& line, int first_field,
                                    double tolerance = 1e-3);
// Parses a quaternion (qw qx qy qz) from `first_field`; its norm must be
// within `tolerance` of 1.
Eigen::Matrix3d ParseQuaternion(const std::string& path, const TextLine& line,
                                int first_field, double tolerance = 1e-3);

}  // namespace colmap_irav4
