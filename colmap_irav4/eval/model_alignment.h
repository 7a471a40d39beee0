#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/reconstruction.h"

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
  double max_relative_error = 0.05;
  // Random minimal samples; with at most 20 points every triple is tried.
  int num_trials = 2000;
  uint64_t seed = 0;
  void Check() const;
};

// RANSAC over minimal sets of 3 points, then least squares on the inliers.
// Deterministic for a given seed. Returns false when no model was found.
bool EstimateSimilarityRansac(const std::vector<Eigen::Vector3d>& src,
                              const std::vector<Eigen::Vector3d>& dst,
                              const SimilarityRansacOptions& options,
                              Sim3d* sim, std::vector<bool>* inliers = nullptr);

// Accuracy of estimated camera poses against reference poses of the same
// images (matched by name), after a robust similarity alignment over the
// camera centres.
struct PoseComparison {
  int num_estimated = 0;  // images in the estimate
  int num_reference = 0;  // images in the reference
  int num_common = 0;     // images in both (compared)
  int num_inliers = 0;    // common images within the RANSAC threshold
  Sim3d estimate_to_reference;
  double rotation_error_median_deg = 0;
  double rotation_error_max_deg = 0;
  double center_error_median = 0;  // in the reference's units
  double center_error_max = 0;
  std::vector<std::string> names;  // common images, sorted
  std::vector<double> rotation_errors_deg;
  std::vector<double> center_errors;
};

// Poses are cam_from_world, keyed by image name. Returns false (with the
// counts filled) when fewer than 3 common images or the alignment fails.
bool ComparePoses(const std::map<std::string, Rigid3d>& estimate,
                  const std::map<std::string, Rigid3d>& reference,
                  const SimilarityRansacOptions& options,
                  PoseComparison* comparison);

// cam_from_world poses of a reconstruction's images, by name.
std::map<std::string, Rigid3d> PosesByName(const Reconstruction& model);

}  // namespace colmap_irav4
