#include "colmap_irav4/eval/rotation_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {

Eigen::Matrix3d GeodesicL1Mean(const std::vector<Eigen::Matrix3d>& rotations,
                               int max_num_iterations) {
  const int n = static_cast<int>(rotations.size());
  if (n == 0) return Eigen::Matrix3d::Identity();
  // Medoid of a bounded, evenly strided subsample as the starting point: the
  // L1 cost has a single basin around the inlier majority, the chordal L2
  // mean does not when outliers are many.
  const int kMaxSamples = 200;
  const int stride = std::max(1, n / kMaxSamples);
  Eigen::Matrix3d R = rotations[0];
  double best_cost = std::numeric_limits<double>::infinity();
  for (int s = 0; s < n; s += stride) {
    double cost = 0.0;
    for (int t = 0; t < n; t += stride) {
      cost += AngularDistance(rotations[s], rotations[t]);
    }
    if (cost < best_cost) {
      best_cost = cost;
      R = rotations[s];
    }
  }
  // Weiszfeld in the tangent space at the current estimate, with the
  // Vardi-Zhang correction for samples that coincide with the estimate (the
  // plain iteration would skip them and walk away from a true minimiser that
  // sits on a cluster of identical samples).
  constexpr double kEps = 1e-12;
  for (int iter = 0; iter < max_num_iterations; ++iter) {
    Eigen::Vector3d numerator = Eigen::Vector3d::Zero();
    double denominator = 0.0;
    int num_coincident = 0;
    for (const Eigen::Matrix3d& R_i : rotations) {
      const Eigen::Vector3d v = RotationToAngleAxis(R.transpose() * R_i);
      const double d = v.norm();
      if (d < kEps) {
        ++num_coincident;
        continue;
      }
      numerator += v / d;
      denominator += 1.0 / d;
    }
    if (denominator == 0.0) break;
    Eigen::Vector3d step = numerator / denominator;
    if (num_coincident > 0) {
      // numerator is minus the gradient of the non-coincident part.
      const double pull = numerator.norm();
      if (pull <= num_coincident) break;  // the estimate is the minimiser
      step *= 1.0 - num_coincident / pull;
    }
    R = R * AngleAxisToRotation(step);
    if (step.norm() < 1e-12) break;
  }
  return R;
}

RotationErrors EvaluateRotations(
    const std::vector<Eigen::Matrix3d>& estimated,
    const std::vector<bool>& estimated_mask,
    const std::vector<Eigen::Matrix3d>& ground_truth,
    const std::vector<bool>& gt_mask) {
  CHECK_EQ(estimated.size(), ground_truth.size());
  CHECK(estimated_mask.empty() || estimated_mask.size() == estimated.size());
  CHECK(gt_mask.empty() || gt_mask.size() == ground_truth.size());
  std::vector<int> common;
  for (size_t i = 0; i < estimated.size(); ++i) {
    if ((estimated_mask.empty() || estimated_mask[i]) &&
        (gt_mask.empty() || gt_mask[i])) {
      common.push_back(static_cast<int>(i));
    }
  }
  RotationErrors errors;
  errors.num_compared = static_cast<int>(common.size());
  if (common.empty()) return errors;
  std::vector<Eigen::Matrix3d> offsets;
  offsets.reserve(common.size());
  for (int i : common) {
    offsets.push_back(estimated[i].transpose() * ground_truth[i]);
  }
  errors.alignment = GeodesicL1Mean(offsets);
  errors.errors_deg.reserve(common.size());
  for (int i : common) {
    errors.errors_deg.push_back(
        AngularDistanceDeg(ground_truth[i], estimated[i] * errors.alignment));
  }
  std::vector<double> sorted = errors.errors_deg;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  errors.median_deg =
      n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  errors.mean_deg = std::accumulate(sorted.begin(), sorted.end(), 0.0) / n;
  errors.max_deg = sorted.back();
  return errors;
}

RotationErrors EvaluateRotations(
    const RotationAveragingResult& result,
    const std::vector<Eigen::Matrix3d>& ground_truth,
    const std::vector<bool>& gt_mask) {
  return EvaluateRotations(result.rotations, result.estimated, ground_truth,
                           gt_mask);
}

RotationErrors EvaluateRotations(
    const std::map<std::string, Eigen::Matrix3d>& estimated,
    const std::map<std::string, Eigen::Matrix3d>& ground_truth) {
  std::vector<Eigen::Matrix3d> est;
  std::vector<Eigen::Matrix3d> gt;
  for (const auto& [name, R] : estimated) {
    const auto it = ground_truth.find(name);
    if (it == ground_truth.end()) continue;
    est.push_back(R);
    gt.push_back(it->second);
  }
  return EvaluateRotations(est, {}, gt, {});
}

}  // namespace colmap_irav4
