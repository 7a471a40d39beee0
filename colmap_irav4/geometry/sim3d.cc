#include "colmap_irav4/geometry/sim3d.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include <glog/logging.h>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"

namespace colmap_irav4 {

bool EstimateSimilarity(const std::vector<Eigen::Vector3d>& src,
                        const std::vector<Eigen::Vector3d>& dst, Sim3d* sim) {
  CHECK_EQ(src.size(), dst.size());
  if (src.size() < 3) return false;
  Eigen::Matrix3Xd src_matrix(3, src.size());
  Eigen::Matrix3Xd dst_matrix(3, dst.size());
  for (size_t k = 0; k < src.size(); ++k) {
    src_matrix.col(k) = src[k];
    dst_matrix.col(k) = dst[k];
  }
  // Degenerate when the source points are (nearly) collinear or coincident.
  const Eigen::Vector3d mean = src_matrix.rowwise().mean();
  const Eigen::Matrix3Xd centered = src_matrix.colwise() - mean;
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centered);
  const Eigen::Vector3d singular = svd.singularValues();
  if (!(singular(0) > 0) || singular(1) < 1e-9 * singular(0)) return false;

  const Eigen::Matrix4d T = Eigen::umeyama(src_matrix, dst_matrix, true);
  const Eigen::Matrix3d sR = T.topLeftCorner<3, 3>();
  sim->scale = std::cbrt(sR.determinant());
  if (!(sim->scale > 0) || !std::isfinite(sim->scale)) return false;
  sim->R = sR / sim->scale;
  sim->t = T.topRightCorner<3, 1>();
  return true;
}

void SimilarityRansacOptions::Check() const {
  if (!(max_relative_error > 0 && max_relative_error < 1)) {
    throw OptionError(&max_relative_error, "Comparer.max_relative_error",
                      "must be in (0, 1)");
  }
  if (num_trials < 1) {
    throw OptionError(&num_trials, "SimilarityRansacOptions::num_trials",
                      "must be >= 1");
  }
}

bool EstimateSimilarityRansac(const std::vector<Eigen::Vector3d>& src,
                              const std::vector<Eigen::Vector3d>& dst,
                              const SimilarityRansacOptions& options,
                              Sim3d* sim, std::vector<bool>* inliers) {
  options.Check();
  CHECK_EQ(src.size(), dst.size());
  const int n = static_cast<int>(src.size());
  if (n < 3) return false;

  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& x : dst) centroid += x;
  centroid /= n;
  std::vector<double> spreads;
  for (const Eigen::Vector3d& x : dst) spreads.push_back((x - centroid).norm());
  const double threshold = options.max_relative_error * Median(spreads);

  auto count_inliers = [&](const Sim3d& candidate, std::vector<bool>* mask) {
    int count = 0;
    mask->assign(n, false);
    for (int k = 0; k < n; ++k) {
      if ((candidate * src[k] - dst[k]).norm() <= threshold) {
        (*mask)[k] = true;
        ++count;
      }
    }
    return count;
  };

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int best_count = -1;
  std::vector<bool> best_mask;
  std::vector<bool> mask;
  Sim3d candidate;
  const bool exhaustive = n <= 20;
  std::vector<std::array<int, 3>> triples;
  if (exhaustive) {
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b)
        for (int c = b + 1; c < n; ++c) triples.push_back({a, b, c});
  }
  const int num_trials =
      exhaustive ? static_cast<int>(triples.size()) : options.num_trials;
  for (int trial = 0; trial < num_trials; ++trial) {
    std::array<int, 3> sample;
    if (exhaustive) {
      sample = triples[trial];
    } else {
      sample = {pick(rng), pick(rng), pick(rng)};
      if (sample[0] == sample[1] || sample[1] == sample[2] ||
          sample[0] == sample[2]) {
        continue;
      }
    }
    if (!EstimateSimilarity({src[sample[0]], src[sample[1]], src[sample[2]]},
                            {dst[sample[0]], dst[sample[1]], dst[sample[2]]},
                            &candidate)) {
      continue;
    }
    const int count = count_inliers(candidate, &mask);
    if (count > best_count) {
      best_count = count;
      best_mask = mask;
    }
  }
  if (best_count < 3) return false;

  // Least squares on the inliers, then once more on the refined inlier set.
  bool found = false;
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector3d> src_inliers, dst_inliers;
    for (int k = 0; k < n; ++k) {
      if (best_mask[k]) {
        src_inliers.push_back(src[k]);
        dst_inliers.push_back(dst[k]);
      }
    }
    if (!EstimateSimilarity(src_inliers, dst_inliers, &candidate)) break;
    *sim = candidate;
    found = true;
    if (count_inliers(candidate, &mask) < 3) break;
    best_mask = mask;
  }
  if (inliers != nullptr) *inliers = best_mask;
  return found;
}

}  // namespace colmap_irav4
