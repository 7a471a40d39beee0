#pragma once

#include <algorithm>
#include <vector>

namespace colmap_irav4 {

// Median of `values` (the mean of the two middle values for an even count);
// 0 for an empty vector.
inline double Median(std::vector<double> values) {
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

}  // namespace colmap_irav4
