// colmap_irav4.read_model / write_model / compare_models / align_models.

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "python/bindings.h"
#include "python/host.h"
#include "python/model_arrays.h"
#include "python/options.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

py::dict ReadModel(const py::object& path_argument) {
  const std::string path = PathArgument(path_argument, "path");
  Reconstruction model;
  RunInPython([&] { model = ReadReconstruction(path); });
  return ModelToPython(model);
}

void WriteModel(const py::object& model_argument,
                const py::object& path_argument, const std::string& format) {
  const std::string path = PathArgument(path_argument, "path");
  if (format != "BIN" && format != "TXT" && format != "bin" &&
      format != "txt") {
    throw InputError("format", "must be BIN or TXT, got '" + format + "'");
  }
  const Reconstruction model = ModelFromPython(model_argument);
  RunInPython([&] { WriteReconstruction(model, path, format); });
}

// A model argument: a model dict or the path of a model directory.
Reconstruction ModelArgument(const py::object& value,
                             const std::string& argument) {
  if (py::isinstance<py::dict>(value)) return ModelFromPython(value);
  const std::string path = PathArgument(value, argument);
  Reconstruction model;
  RunInPython([&] { model = ReadReconstruction(path); });
  return model;
}

py::dict FiguresToPython(const ModelFigures& figures) {
  py::dict dict;
  dict["num_registered_images"] = figures.num_images;
  dict["num_points"] = figures.num_points;
  dict["mean_track_length"] = figures.mean_track_length;
  dict["mean_reprojection_error_per_observation"] =
      figures.mean_reprojection_error_per_observation;
  dict["mean_reprojection_error_per_point"] =
      figures.mean_reprojection_error_per_point;
  return dict;
}

// model_comparer's comparison: aligns `model` onto the reference (a model
// or Strecha ground truth) and returns what the command prints, plus the
// per-image errors and the similarity (`transformed`: the aligned model).
py::dict Compare(const py::object& model_argument,
                 const py::object& reference_argument,
                 const py::object& gt_path_argument,
                 const py::object& options_argument, bool transform) {
  SimilarityRansacOptions ransac;
  OptionManager manager("model_comparer");
  AddComparerOptions(&manager, &ransac);
  ParseOptions(options_argument, &manager);
  manager.Check([&] { ransac.Check(); });
  if (reference_argument.is_none() == gt_path_argument.is_none()) {
    throw InputError("reference/gt_path", "give exactly one of them");
  }
  Reconstruction model = ModelArgument(model_argument, "model");
  py::dict result;
  std::map<std::string, Rigid3d> reference;
  if (!gt_path_argument.is_none()) {
    const std::string gt_path = PathArgument(gt_path_argument, "gt_path");
    RunInPython([&] {
      for (const auto& [name, camera] : ReadStrechaGroundTruth(gt_path)) {
        reference[name] = camera.cam_from_world;
      }
    });
  } else {
    Reconstruction reference_model =
        ModelArgument(reference_argument, "reference");
    result["reference"] =
        FiguresToPython(ComputeModelFigures(&reference_model));
    reference = PosesByName(reference_model);
  }
  result["model"] = FiguresToPython(ComputeModelFigures(&model));

  PoseComparison comparison;
  RotationErrors rotation_only;
  bool aligned = false;
  RunInPython([&] {
    aligned = ComparePoses(PosesByName(model), reference, ransac, &comparison);
    if (aligned)
      rotation_only = CompareRotationsOnly(PosesByName(model), reference);
  });
  result["num_common"] = comparison.num_common;
  result["num_estimated"] = comparison.num_estimated;
  result["num_reference"] = comparison.num_reference;
  result["num_inliers"] = comparison.num_inliers;
  result["aligned"] = aligned;
  if (!aligned) return result;  // fewer than 3 common images or degenerate
  if (!std::isfinite(comparison.rotation_error_median_deg) ||
      !std::isfinite(comparison.rotation_error_max_deg) ||
      !std::isfinite(comparison.center_error_median) ||
      !std::isfinite(comparison.center_error_max)) {
    throw InputError("model",
                     "the errors are not finite (a pose of a model or of the "
                     "reference holds NaN or infinite values)");
  }
  const Sim3d& sim = comparison.estimate_to_reference;
  result["scale"] = sim.scale;
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> rotation = sim.R;
  result["rotation"] = py::array_t<double>({3, 3}, rotation.data());
  result["translation"] = py::array_t<double>(3, sim.t.data());
  result["centers_nearly_collinear"] = comparison.centers_nearly_collinear;
  result["rotation_error_median_deg"] = comparison.rotation_error_median_deg;
  result["rotation_error_max_deg"] = comparison.rotation_error_max_deg;
  result["center_error_median"] = comparison.center_error_median;
  result["center_error_max"] = comparison.center_error_max;
  result["rotation_only_error_median_deg"] = rotation_only.median_deg;
  result["rotation_only_error_max_deg"] = rotation_only.max_deg;
  result["names"] = comparison.names;
  result["rotation_errors_deg"] =
      py::array_t<double>(comparison.rotation_errors_deg.size(),
                          comparison.rotation_errors_deg.data());
  result["center_errors"] = py::array_t<double>(
      comparison.center_errors.size(), comparison.center_errors.data());
  if (transform) {
    TransformReconstruction(sim, &model);
    result["aligned_model"] = ModelToPython(model);
  }
  return result;
}

}  // namespace

void DefineModels(py::module_& module) {
  module.def(
      "read_model", &ReadModel, py::arg("path"),
      R"doc(Reads a COLMAP model directory (.bin, else .txt files), checked
as the commands check it (ValueError naming the file and the problem).

Returns {"cameras": {...}, "images": {...}, "points3D": {...}}, each a dict
of columns:
  cameras:  camera_id (C,) int64, model [str], width, height (C,) int64,
            params [(n,) float64]
  images:   image_id (M,) int64, name [str], camera_id (M,) int64,
            quaternion (M, 4) (w, x, y, z) and rotation (M, 3, 3), both
            cam_from_world, translation (M, 3), points2D [(K, 2) float64],
            point3D_ids [(K,) int64, -1: none]
  points3D: point3D_id (P,) int64, xyz (P, 3), rgb (P, 3) uint8,
            error (P,), track [(L, 2) int64: image_id, point2D_idx])doc");
  module.def(
      "write_model", &WriteModel, py::arg("model"), py::arg("path"),
      py::arg("format") = "BIN",
      R"doc(Writes a model (as read_model returns it) into directory `path`
in COLMAP 3.8's format, "BIN" or "TXT"; files appear complete or not at all.
Images take `quaternion` if present, else `rotation` (both: they must
agree). Every column is checked first (ValueError naming it, e.g.
"model['images']['rotation'][3]"), then the model as the readers check
files (cameras of images, tracks against observations).)doc");
  module.def(
      "compare_models",
      [](const py::object& model, const py::object& reference,
         const py::object& gt_path, const py::object& options) {
        return Compare(model, reference, gt_path, options, false);
      },
      py::arg("model"), py::arg("reference") = py::none(),
      py::arg("gt_path") = py::none(), py::arg("options") = py::none(),
      R"doc(What `colmap_irav4 model_comparer` prints: aligns `model` onto
`reference` (a model dict or directory) or onto Strecha ground truth
(`gt_path`, a directory of <image>.camera files) with a robust similarity
over the camera centres and returns a dict: model / reference figures
(registered images, points, mean track length, reprojection errors),
num_common, num_estimated, num_reference, num_inliers, aligned; if aligned:
scale, rotation, translation (reference = scale * rotation @ x +
translation), centers_nearly_collinear, rotation_error_median_deg / _max_deg,
center_error_median / _max (reference units), rotation_only_error_median_deg
/ _max_deg (one rotation fitted to the rotations), and per common image
(sorted names) rotation_errors_deg and center_errors.
options: {"Comparer": {"max_relative_error": 0.05}}.)doc");
  module.def(
      "align_models",
      [](const py::object& model, const py::object& reference,
         const py::object& options) {
        return Compare(model, reference, py::none(), options, true);
      },
      py::arg("model"), py::arg("reference"), py::arg("options") = py::none(),
      R"doc(compare_models(model, reference) plus "aligned_model": `model`
moved onto `reference` by the similarity (poses and points), as a model
dict. Without an alignment ("aligned" False) there is no aligned_model.)doc");
}

}  // namespace python
}  // namespace colmap_irav4
