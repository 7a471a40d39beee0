#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

constexpr double kCollinearRatio = 0.02;

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
  // The inliers' centres are nearly collinear (second singular value of the
  // centred centres < kCollinearRatio times the first): the similarity's
  // rotation about their line is then undetermined, and the rotation errors
  // are measured after aligning the rotations themselves instead.
  bool centers_nearly_collinear = false;
  std::vector<std::string> names;  // common images, sorted
  std::vector<double> rotation_errors_deg;
  std::vector<double> center_errors;
};

// Poses are cam_from_world, keyed by image name. Returns false (with the
// counts filled) when fewer than 3 common images or the alignment fails.
// Without `align` the poses are compared as they are (a model in the
// reference's frame, e.g. placed by pose priors): the similarity is the
// identity and every common image an inlier.
bool ComparePoses(const std::map<std::string, Rigid3d>& estimate,
                  const std::map<std::string, Rigid3d>& reference,
                  const SimilarityRansacOptions& options,
                  PoseComparison* comparison, bool align = true);

// cam_from_world poses of a reconstruction's images, by name.
std::map<std::string, Rigid3d> PosesByName(const Reconstruction& model);

// A model's figures as model_comparer prints them.
struct ModelFigures {
  int num_images = 0;
  int num_points = 0;
  double mean_track_length = 0;
  double mean_reprojection_error_per_observation = 0;  // px
  double mean_reprojection_error_per_point = 0;        // px
};
// Also updates the points' reprojection errors.
ModelFigures ComputeModelFigures(Reconstruction* model);

// Relative focal length errors |f - f_ref| / f_ref (each image's camera's
// mean focal, in pixels) of the images in both models, matched by name: the
// calibration a model recovered, against the true cameras.
struct FocalErrors {
  std::map<std::string, double> relative_errors;  // by image name
  double median = 0;
  double max = 0;
};
FocalErrors CompareFocalLengths(const Reconstruction& estimate,
                                const Reconstruction& reference);

// Rotation errors (deg) of the common images after one rotation fitted to
// the rotations (robust geodesic L1 mean, as for rotation averaging), not to
// the centres: model_comparer's second figure, firm where nearly collinear
// centres leave the similarity's rotation loose.
RotationErrors CompareRotationsOnly(
    const std::map<std::string, Rigid3d>& estimate,
    const std::map<std::string, Rigid3d>& reference);

}  // namespace colmap_irav4
