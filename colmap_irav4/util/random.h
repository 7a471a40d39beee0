#pragma once

#include <Eigen/Core>

namespace colmap_irav4 {

// A vector of N independent draws, the last coordinate drawn first. C++
// leaves the order of a call's arguments unspecified: gcc evaluates
// Vector3d(d(rng), d(rng), d(rng)) right to left and clang left to right, so
// that form gave clang builds (the sanitizer runs) other scenes and other
// initial values than gcc builds. This is gcc's order, so the scenes and
// figures measured so far stay as they were.
template <int N, typename Distribution, typename Rng>
Eigen::Matrix<double, N, 1> RandomVector(Distribution& distribution, Rng& rng) {
  Eigen::Matrix<double, N, 1> vector;
  for (int i = N - 1; i >= 0; --i) vector[i] = distribution(rng);
  return vector;
}

}  // namespace colmap_irav4
