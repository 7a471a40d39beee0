#include "colmap_irav4/eval/relative_pose_eval.h"

#include <algorithm>
#include <cmath>

#include "colmap_irav4/geometry/rotation.h"

namespace colmap_irav4 {
namespace {

void Stats(std::vector<double> values, double* median, double* mean,
           double* max) {
  *median = *mean = *max = 0;
  if (values.empty()) return;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  *median =
      n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  double sum = 0;
  for (const double value : values) sum += value;
  *mean = sum / n;
  *max = values.back();
}

}  // namespace

RelativePoseErrors EvaluateRelativePoses(
    const ViewGraph& view_graph,
    const std::map<std::string, Rigid3d>& gt_cam_from_world) {
  RelativePoseErrors errors;
  std::vector<double> transposed;
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    const auto name1 = view_graph.image_names.find(pair.image_id1);
    const auto name2 = view_graph.image_names.find(pair.image_id2);
    if (name1 == view_graph.image_names.end() ||
        name2 == view_graph.image_names.end()) {
      continue;
    }
    const auto gt1 = gt_cam_from_world.find(name1->second);
    const auto gt2 = gt_cam_from_world.find(name2->second);
    if (gt1 == gt_cam_from_world.end() || gt2 == gt_cam_from_world.end()) {
      continue;
    }
    ++errors.num_pairs;
    const Eigen::Matrix3d R1 = gt1->second.rotation.toRotationMatrix();
    const Eigen::Matrix3d R2 = gt2->second.rotation.toRotationMatrix();
    const Eigen::Matrix3d R12 = R2 * R1.transpose();
    errors.rotation_errors_deg.push_back(AngularDistanceDeg(pair.R, R12));
    transposed.push_back(AngularDistanceDeg(pair.R, R12.transpose()));
    if (pair.t.norm() > 0) {
      // cam2_from_cam1 translation: t2 - R12 t1.
      const Eigen::Vector3d t12 =
          gt2->second.translation - R12 * gt1->second.translation;
      const double cosine =
          std::clamp(t12.normalized().dot(pair.t.normalized()), -1.0, 1.0);
      errors.translation_errors_deg.push_back(RadToDeg(std::acos(cosine)));
    }
  }
  Stats(errors.rotation_errors_deg, &errors.rotation_median_deg,
        &errors.rotation_mean_deg, &errors.rotation_max_deg);
  Stats(errors.translation_errors_deg, &errors.translation_median_deg,
        &errors.translation_mean_deg, &errors.translation_max_deg);
  double unused_mean, unused_max;
  Stats(transposed, &errors.rotation_median_transposed_deg, &unused_mean,
        &unused_max);
  for (const double e : errors.rotation_errors_deg) {
    errors.num_rotation_over_5deg += e > 5;
  }
  for (const double e : errors.translation_errors_deg) {
    errors.num_translation_over_5deg += e > 5;
  }
  return errors;
}

}  // namespace colmap_irav4
