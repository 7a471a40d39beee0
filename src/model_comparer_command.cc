// colmap_irav4 model_comparer: accuracy of one model against another (or
// against Strecha-style ground truth cameras):
//   colmap_irav4 model_comparer --input_path1 A --input_path2 B
//   colmap_irav4 model_comparer --input_path1 A --gt_path GT_CAMERAS_DIR
// Model 1 is aligned onto the reference with a robust similarity (RANSAC
// over the camera centres, then least squares on the inliers); then the
// registered-image counts, rotation and centre errors (median, max; centre
// errors in the reference's units), the relative focal length errors
// (against a reference model: e.g. the true cameras of a generated scene)
// and each model's points and mean reprojection error are printed.

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <numeric>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

void PrintModel(const std::string& label, const std::string& path,
                Reconstruction* model) {
  const ModelFigures figures = ComputeModelFigures(model);
  std::cout << std::left << std::setw(12) << label << std::right << path << ": "
            << figures.num_images << " registered images, "
            << figures.num_points << " points, mean track length " << std::fixed
            << std::setprecision(2) << figures.mean_track_length
            << ", mean reprojection error per observation "
            << std::setprecision(3)
            << figures.mean_reprojection_error_per_observation
            << " px, per point " << figures.mean_reprojection_error_per_point
            << " px\n";
}

// One line per common image, worst rotation first (rotation-only alignment:
// free of the centre alignment's small common rotation; ties: larger centre
// error first), so that the cameras to doubt stand at the top.
// `rotation_only_deg`: per common image, in comparison.names' order;
// `focal_errors`: by name (none against Strecha cameras).
void PrintPerImage(const PoseComparison& comparison,
                   const std::vector<double>& rotation_only_deg,
                   const std::map<std::string, double>& focal_errors) {
  CHECK_EQ(rotation_only_deg.size(), comparison.names.size());
  std::vector<size_t> order(comparison.names.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (rotation_only_deg[a] != rotation_only_deg[b]) {
      return rotation_only_deg[a] > rotation_only_deg[b];
    }
    return comparison.center_errors[a] > comparison.center_errors[b];
  });
  std::cout << "per image, worst first: name, rotation error [deg] "
               "(rotation-only alignment, similarity alignment), centre "
               "error"
            << (focal_errors.empty() ? "" : ", relative focal error") << "\n";
  for (const size_t k : order) {
    std::cout << "  " << comparison.names[k] << std::setprecision(4) << " "
              << rotation_only_deg[k] << " "
              << comparison.rotation_errors_deg[k] << std::setprecision(6)
              << " " << comparison.center_errors[k];
    const auto focal = focal_errors.find(comparison.names[k]);
    if (focal != focal_errors.end()) std::cout << " " << focal->second;
    std::cout << "\n";
  }
}

int RunModelComparer(int argc, char** argv) {
  std::string input_path1;
  std::string input_path2;
  std::string gt_path;
  SimilarityRansacOptions ransac;
  bool per_image = false;
  OptionManager manager(
      "model_comparer",
      "Aligns model 1 onto model 2 (or onto Strecha gt_cameras) with a robust\n"
      "similarity and prints rotation and camera centre errors.");
  manager.AddRequired("input_path1", &input_path1, "model to evaluate");
  manager.Add("input_path2", &input_path2, "reference model");
  manager.Add("gt_path", &gt_path,
              "reference: directory of Strecha <image>.camera files");
  AddComparerOptions(&manager, &ransac);
  manager.Add("per_image", &per_image,
              "also print each common image's rotation and centre error, "
              "worst rotation first");
  std::string alignment = "similarity";
  manager.Add("Comparer.alignment", &alignment,
              "similarity (robust, RANSAC) or none: model 1 is compared in "
              "its own frame (e.g. placed by pose priors in the reference's)");
  if (!manager.Parse(argc, argv)) return 0;
  if (alignment != "similarity" && alignment != "none") {
    throw InputError("--Comparer.alignment", "must be similarity or none");
  }
  if (input_path2.empty() == gt_path.empty()) {
    throw InputError("--input_path2/--gt_path", "give exactly one of them");
  }
  manager.Check([&] { ransac.Check(); });

  Reconstruction model1 = ReadReconstruction(input_path1);
  std::map<std::string, Rigid3d> reference;
  FocalErrors focal;
  PrintModel("model 1", input_path1, &model1);
  if (!gt_path.empty()) {
    for (const auto& [name, camera] : ReadStrechaGroundTruth(gt_path)) {
      reference[name] = camera.cam_from_world;
    }
    std::cout << std::left << std::setw(12) << "reference" << std::right
              << gt_path << ": " << reference.size()
              << " ground truth cameras\n";
  } else {
    Reconstruction model2 = ReadReconstruction(input_path2);
    PrintModel("model 2", input_path2, &model2);
    reference = PosesByName(model2);
    focal = CompareFocalLengths(model1, model2);
  }

  PoseComparison comparison;
  const bool aligned = ComparePoses(PosesByName(model1), reference, ransac,
                                    &comparison, alignment == "similarity");
  std::cout << "common images: " << comparison.num_common
            << " (model 1: " << comparison.num_estimated
            << ", reference: " << comparison.num_reference
            << "), alignment inliers: " << comparison.num_inliers << "\n";
  if (!aligned) {
    std::cout << "ERROR: no similarity alignment (fewer than 3 common images "
                 "or degenerate centres)\n";
    return 1;
  }
  if (!std::isfinite(comparison.rotation_error_median_deg) ||
      !std::isfinite(comparison.rotation_error_max_deg) ||
      !std::isfinite(comparison.center_error_median) ||
      !std::isfinite(comparison.center_error_max)) {
    throw InputError(input_path1,
                     "the errors are not finite (a pose of a model or of the "
                     "reference holds NaN or infinite values)");
  }
  std::cout << std::setprecision(4)
            << "alignment scale: " << comparison.estimate_to_reference.scale
            << "\n"
            << (comparison.centers_nearly_collinear
                    ? "camera centres nearly collinear: the similarity's "
                      "rotation about their line is undetermined; rotation "
                      "errors below are after aligning the rotations\n"
                    : "")
            << "rotation error [deg]: median "
            << comparison.rotation_error_median_deg << ", max "
            << comparison.rotation_error_max_deg << "\n"
            << std::setprecision(6) << "centre error: median "
            << comparison.center_error_median << ", max "
            << comparison.center_error_max << " (reference units"
            << (gt_path.empty() ? "" : ": metres") << ")\n";
  // The similarity's rotation comes from the centres alone; nearly collinear
  // cameras leave it loose. With one rotation fitted to the rotations instead:
  const RotationErrors rotation_only =
      CompareRotationsOnly(PosesByName(model1), reference);
  std::cout << std::setprecision(4)
            << "rotation error, rotation-only alignment [deg]: median "
            << rotation_only.median_deg << ", max " << rotation_only.max_deg
            << "\n";
  if (!focal.relative_errors.empty()) {
    std::cout << "focal length relative error: median " << focal.median
              << ", max " << focal.max << " (" << focal.relative_errors.size()
              << " images)\n";
  }
  if (per_image) {
    PrintPerImage(comparison, rotation_only.errors_deg, focal.relative_errors);
  }
  return 0;
}

static CommandRegistrar registrar(
    "model_comparer",
    "Rotation and centre errors of a model after similarity alignment",
    RunModelComparer);

}  // namespace
}  // namespace colmap_irav4
