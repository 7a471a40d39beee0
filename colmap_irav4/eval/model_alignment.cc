#include "colmap_irav4/eval/model_alignment.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double median = values[mid];
  if (values.size() % 2 == 0) {
    median = 0.5 * (median + *std::max_element(values.begin(),
                                               values.begin() + mid));
  }
  return median;
}

}  // namespace

bool ComparePoses(const std::map<std::string, Rigid3d>& estimate,
                  const std::map<std::string, Rigid3d>& reference,
                  const SimilarityRansacOptions& options,
                  PoseComparison* comparison) {
  *comparison = PoseComparison();
  comparison->num_estimated = static_cast<int>(estimate.size());
  comparison->num_reference = static_cast<int>(reference.size());
  std::vector<Eigen::Vector3d> src, dst;
  for (const auto& [name, pose] : estimate) {
    const auto it = reference.find(name);
    if (it == reference.end()) continue;
    comparison->names.push_back(name);
    src.push_back(pose.Inverse().translation);
    dst.push_back(it->second.Inverse().translation);
  }
  comparison->num_common = static_cast<int>(src.size());
  std::vector<bool> inliers;
  if (!EstimateSimilarityRansac(src, dst, options,
                                &comparison->estimate_to_reference,
                                &inliers)) {
    return false;
  }
  comparison->num_inliers =
      static_cast<int>(std::count(inliers.begin(), inliers.end(), true));
  const Sim3d& sim = comparison->estimate_to_reference;
  for (size_t k = 0; k < comparison->names.size(); ++k) {
    const std::string& name = comparison->names[k];
    // x_ref = s R x_est + t, so the aligned cam_from_world rotation is
    // R_est R^T.
    const Eigen::Matrix3d R_aligned =
        estimate.at(name).rotation.toRotationMatrix() * sim.R.transpose();
    comparison->rotation_errors_deg.push_back(AngularDistanceDeg(
        reference.at(name).rotation.toRotationMatrix(), R_aligned));
    comparison->center_errors.push_back((sim * src[k] - dst[k]).norm());
  }
  comparison->rotation_error_median_deg =
      Median(comparison->rotation_errors_deg);
  comparison->rotation_error_max_deg =
      *std::max_element(comparison->rotation_errors_deg.begin(),
                        comparison->rotation_errors_deg.end());
  comparison->center_error_median = Median(comparison->center_errors);
  comparison->center_error_max = *std::max_element(
      comparison->center_errors.begin(), comparison->center_errors.end());
  return true;
}

std::map<std::string, Rigid3d> PosesByName(const Reconstruction& model) {
  std::map<std::string, Rigid3d> poses;
  for (const auto& [image_id, image] : model.images) {
    poses[image.name] = image.cam_from_world;
  }
  return poses;
}

}  // namespace colmap_irav4
