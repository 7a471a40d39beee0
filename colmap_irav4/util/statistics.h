#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace colmap_irav4 {

// Median of `values` (the mean of the two middle values for an even count);
// 0 for an empty vector.
// (T = double for a braced list.)
template <typename T = double>
double Median(std::vector<T> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double median = values[mid];
  if (values.size() % 2 == 0) {
    median = 0.5 *
             (median + *std::max_element(values.begin(), values.begin() + mid));
  }
  return median;
}

// Mean of `values`; 0 for an empty vector.
inline double Mean(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  double sum = 0.0;
  for (const double value : values) sum += value;
  return sum / values.size();
}

// Sample standard deviation of `values` (divided by n - 1); 0 for fewer than
// two values.
inline double StandardDeviation(const std::vector<double>& values) {
  if (values.size() < 2) return 0.0;
  const double mean = Mean(values);
  double sum = 0.0;
  for (const double value : values) sum += (value - mean) * (value - mean);
  return std::sqrt(sum / (values.size() - 1));
}

}  // namespace colmap_irav4
