#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// Robust geodesic L1 mean of rotations (Weiszfeld's algorithm on SO(3)):
// argmin_R sum_i d(R_i, R). Started from the sample with the smallest sum of
// distances to the others (over a bounded subsample), so that up to about
// half of the inputs may be outliers. Empty input -> identity.
Eigen::Matrix3d GeodesicL1Mean(const std::vector<Eigen::Matrix3d>& rotations,
                               int max_num_iterations = 100);

// Absolute rotation errors of an estimate against ground truth, after aligning
// the estimate with one rotation A (R_est_i A ~ R_gt_i) taken as the geodesic
// L1 mean of R_est_i^T R_gt_i over the common cameras.
struct RotationErrors {
  int num_compared = 0;
  double median_deg = 0.0;
  double mean_deg = 0.0;
  double max_deg = 0.0;
  Eigen::Matrix3d alignment = Eigen::Matrix3d::Identity();  // A
  std::vector<double> errors_deg;  // per compared camera, in input order
};

// Cameras compared: those with estimated_mask[i] && gt_mask[i] (empty mask =
// all). Sizes must agree (CHECKed). No common camera -> num_compared = 0.
RotationErrors EvaluateRotations(
    const std::vector<Eigen::Matrix3d>& estimated,
    const std::vector<bool>& estimated_mask,
    const std::vector<Eigen::Matrix3d>& ground_truth,
    const std::vector<bool>& gt_mask = {});
RotationErrors EvaluateRotations(
    const RotationAveragingResult& result,
    const std::vector<Eigen::Matrix3d>& ground_truth,
    const std::vector<bool>& gt_mask = {});
// By name: cameras present in both maps are compared (in name order).
RotationErrors EvaluateRotations(
    const std::map<std::string, Eigen::Matrix3d>& estimated,
    const std::map<std::string, Eigen::Matrix3d>& ground_truth);

}  // namespace colmap_irav4
