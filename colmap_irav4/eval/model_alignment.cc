#include "colmap_irav4/eval/model_alignment.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/statistics.h"

namespace colmap_irav4 {

bool ComparePoses(const std::map<std::string, Rigid3d>& estimate,
                  const std::map<std::string, Rigid3d>& reference,
                  const SimilarityRansacOptions& options,
                  PoseComparison* comparison, bool align) {
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
  std::vector<bool> inliers(src.size(), true);
  if (!align) {
    if (src.size() < 3) return false;
  } else if (!EstimateSimilarityRansac(src, dst, options,
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
  // Nearly collinear centres leave the similarity's rotation about their
  // line undetermined (any angle fits the centres): the rotation errors then
  // come from the rotation that best aligns the camera rotations themselves
  // (geodesic L1 mean of R_ref_i^T R_est_i), so that the headline does not
  // report an arbitrary angle up to 180 degrees.
  {
    Eigen::Matrix3Xd centers(3, dst.size());
    int num = 0;
    for (size_t k = 0; k < dst.size(); ++k) {
      if (inliers[k]) centers.col(num++) = dst[k];
    }
    centers.conservativeResize(3, num);
    const Eigen::Vector3d mean = centers.rowwise().mean();
    const Eigen::Matrix3Xd centered = centers.colwise() - mean;
    const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centered);
    const Eigen::Vector3d singular = svd.singularValues();
    comparison->centers_nearly_collinear =
        singular(1) < kCollinearRatio * singular(0);
  }
  if (comparison->centers_nearly_collinear && align) {
    std::vector<Eigen::Matrix3d> relative;
    for (const std::string& name : comparison->names) {
      relative.push_back(
          reference.at(name).rotation.toRotationMatrix().transpose() *
          estimate.at(name).rotation.toRotationMatrix());
    }
    const Eigen::Matrix3d R = GeodesicL1Mean(relative);
    for (size_t k = 0; k < comparison->names.size(); ++k) {
      const std::string& name = comparison->names[k];
      comparison->rotation_errors_deg[k] = AngularDistanceDeg(
          reference.at(name).rotation.toRotationMatrix(),
          estimate.at(name).rotation.toRotationMatrix() * R.transpose());
    }
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

ModelFigures ComputeModelFigures(Reconstruction* model) {
  ModelFigures figures;
  figures.mean_reprojection_error_per_observation =
      UpdateReprojectionErrors(model);
  figures.mean_reprojection_error_per_point =
      MeanPointReprojectionError(*model);
  figures.num_images = static_cast<int>(model->images.size());
  figures.num_points = static_cast<int>(model->points3D.size());
  figures.mean_track_length = MeanTrackLength(*model);
  return figures;
}

FocalErrors CompareFocalLengths(const Reconstruction& estimate,
                                const Reconstruction& reference) {
  std::map<std::string, double> reference_focals;
  for (const auto& [image_id, image] : reference.images) {
    reference_focals[image.name] =
        CameraMeanFocalLength(reference.cameras.at(image.camera_id));
  }
  FocalErrors errors;
  std::vector<double> values;
  for (const auto& [image_id, image] : estimate.images) {
    const auto it = reference_focals.find(image.name);
    if (it == reference_focals.end()) continue;
    const double focal =
        CameraMeanFocalLength(estimate.cameras.at(image.camera_id));
    const double error = std::abs(focal - it->second) / it->second;
    errors.relative_errors[image.name] = error;
    values.push_back(error);
  }
  errors.median = Median(values);
  errors.max =
      values.empty() ? 0 : *std::max_element(values.begin(), values.end());
  return errors;
}

RotationErrors CompareRotationsOnly(
    const std::map<std::string, Rigid3d>& estimate,
    const std::map<std::string, Rigid3d>& reference) {
  std::map<std::string, Eigen::Matrix3d> estimated_rotations,
      reference_rotations;
  for (const auto& [name, pose] : estimate) {
    estimated_rotations[name] = pose.rotation.toRotationMatrix();
  }
  for (const auto& [name, pose] : reference) {
    reference_rotations[name] = pose.rotation.toRotationMatrix();
  }
  return EvaluateRotations(estimated_rotations, reference_rotations);
}

}  // namespace colmap_irav4
