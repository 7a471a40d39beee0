#pragma once

#include <cstdint>

#include "colmap_irav4/rotation_averaging/synthetic.h"

namespace colmap_irav4 {
namespace test {

// Relative rotations on a random connected graph of n vertices and m edges:
// noise of sigma_deg, a fraction outlier_ratio of them outliers.
inline SyntheticProblem MakeRandomProblem(int n, int m, double sigma_deg,
                                          double outlier_ratio, uint64_t seed) {
  SyntheticOptions options;
  options.noise_sigma_deg = sigma_deg;
  options.outlier_ratio = outlier_ratio;
  options.seed = seed;
  return MakeSyntheticProblem(n, RandomConnectedGraph(n, m, seed), options);
}

}  // namespace test
}  // namespace colmap_irav4
