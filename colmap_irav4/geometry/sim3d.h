#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace colmap_irav4 {

// Similarity transform x' = scale * R x + t.
struct Sim3d {
  double scale = 1.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return scale * (R * x) + t;
  }
};

// Least-squares similarity (Umeyama) mapping src onto dst; needs >= 3
// non-collinear points. Returns false when degenerate.
bool EstimateSimilarity(const std::vector<Eigen::Vector3d>& src,
                        const std::vector<Eigen::Vector3d>& dst, Sim3d* sim);

struct SimilarityRansacOptions {
  // Inlier threshold on the aligned distance, as a fraction of the median
  // distance of the dst points to their centroid (scale-free, so that a
  // normalised model can be compared with metric ground truth).
  double max_relative_error = 0.05;  // in (0, 1)
  // Random minimal samples; with at most 20 points every triple is tried.
  int num_trials = 2000;
  uint64_t seed = 0;
  bool Check() const;
};

// RANSAC over minimal sets of 3 points, then least squares on the inliers.
// Deterministic for a given seed. Returns false when no model was found.
bool EstimateSimilarityRansac(const std::vector<Eigen::Vector3d>& src,
                              const std::vector<Eigen::Vector3d>& dst,
                              const SimilarityRansacOptions& options,
                              Sim3d* sim, std::vector<bool>* inliers = nullptr);

}  // namespace colmap_irav4
