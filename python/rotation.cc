// colmap_irav4.rotation_averaging: absolute rotations from relative ones on
// NumPy arrays, every method of the rotation_averager command.

#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/rotation_averaging/rotation_averaging_summary.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/threading.h"
#include "colmap_irav4/util/timer.h"
#include "python/arrays.h"
#include "python/bindings.h"
#include "python/host.h"
#include "python/options.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

py::tuple RotationAveraging(int num_images, const py::object& pairs_argument,
                            const py::object& rotations_argument,
                            const py::object& weights_argument,
                            const std::string& method,
                            const py::object& options_argument) {
  // The command's options, names and checks (src/rotation_averager_command).
  RotationAveragerOptions options;
  options.log_progress = true;
  OptionManager manager("rotation_averager");
  manager.Add("log_progress", &options.log_progress,
              "progress lines during long runs");
  AddRotationAveragerOptions(&manager, &options);
  ParseOptions(options_argument, &manager);
  manager.Check([&] { options.Check(); });
  std::unique_ptr<RotationAverager> averager =
      CreateRotationAverager(method, options);

  if (num_images < 1) {
    throw InputError("num_images",
                     "must be at least 1, got " + std::to_string(num_images));
  }
  const Array<int64_t> pairs =
      CheckedArray<int64_t>(pairs_argument, "pairs", {-1, 2});
  const py::ssize_t num_pairs = pairs.shape(0);
  if (num_pairs == 0) throw InputError("pairs", "no pairs");
  // One rotation and weight per pair.
  const Array<double> rotations = CheckedArray<double>(
      rotations_argument, "relative_rotations", {num_pairs, 3, 3});
  std::vector<double> weights(static_cast<size_t>(num_pairs), 1.0);
  if (!weights_argument.is_none()) {
    const Array<double> values =
        CheckedArray<double>(weights_argument, "weights", {num_pairs});
    for (py::ssize_t k = 0; k < num_pairs; ++k) {
      if (!std::isfinite(values.at(k)) || !(values.at(k) > 0)) {
        throw InputError(
            "weights[" + std::to_string(k) + "]",
            "must be finite and positive, got " + std::to_string(values.at(k)));
      }
      weights[static_cast<size_t>(k)] = values.at(k);
    }
  }

  RotationGraph graph(num_images);
  std::set<std::pair<int64_t, int64_t>> seen;
  for (py::ssize_t k = 0; k < num_pairs; ++k) {
    const std::string row = "[" + std::to_string(k) + "]";
    const int64_t i = pairs.at(k, 0), j = pairs.at(k, 1);
    if (i < 0 || i >= num_images || j < 0 || j >= num_images) {
      throw InputError("pairs" + row, "(" + std::to_string(i) + ", " +
                                          std::to_string(j) +
                                          ") is not a pair of images 0.." +
                                          std::to_string(num_images - 1));
    }
    if (i == j) {
      throw InputError("pairs" + row,
                       "image " + std::to_string(i) + " paired with itself");
    }
    if (!seen.emplace(std::min(i, j), std::max(i, j)).second) {
      throw InputError("pairs" + row, "(" + std::to_string(i) + ", " +
                                          std::to_string(j) +
                                          ") given twice (either order)");
    }
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R(r, c) = rotations.at(k, r, c);
    }
    if (!R.allFinite()) {
      throw InputError("relative_rotations" + row, "is not finite");
    }
    if (!(((R * R.transpose()) - Eigen::Matrix3d::Identity()).norm() < 1e-6) ||
        !(R.determinant() > 0)) {
      throw InputError("relative_rotations" + row,
                       "is not a rotation matrix (R R^T = I within 1e-6, "
                       "det R = 1)");
    }
    graph.AddEdge(static_cast<int>(i), static_cast<int>(j), R,
                  weights[static_cast<size_t>(k)]);
  }

  // As the command: the largest connected component is estimated.
  std::vector<std::vector<int>> components;
  RotationAveragingResult result;
  RotationAveragingSummary summary;
  RunInPython([&] {
    LimitBlasThreads(options.irav4.engine.num_threads);
    components = graph.ConnectedComponents();
    const RotationGraph largest = graph.InducedSubgraph(components[0]);
    Timer timer;
    result = averager->Estimate(largest);
    summary = SummarizeRotationAveraging(method, largest, result,
                                         timer.ElapsedSeconds(), *averager);
  });

  Array<double> absolute({static_cast<py::ssize_t>(num_images),
                          static_cast<py::ssize_t>(3),
                          static_cast<py::ssize_t>(3)});
  std::fill(absolute.mutable_data(), absolute.mutable_data() + absolute.size(),
            std::numeric_limits<double>::quiet_NaN());
  for (size_t v = 0; v < components[0].size(); ++v) {
    if (!result.estimated[v]) continue;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        absolute.mutable_at(components[0][v], r, c) = result.rotations[v](r, c);
      }
    }
  }
  py::dict summary_dict =
      py::module_::import("json").attr("loads")(summary.ToJson());
  summary_dict["num_images"] = num_images;
  summary_dict["num_components"] = components.size();
  return py::make_tuple(absolute, summary_dict);
}

}  // namespace

void DefineRotationAveraging(py::module_& module) {
  // pybind11 keeps a pointer to the docstring: it must outlive the module.
  static const std::string doc =
      R"doc(Absolute rotations from relative ones (the rotation_averager
command on arrays).

num_images: images 0..num_images-1.
pairs: (N, 2) integers (i, j), each unordered pair at most once.
relative_rotations: (N, 3, 3) rotation matrices R_ij = cam_j_from_cam_i =
    R_j R_i^T, with R_i the absolute cam_from_world rotation (COLMAP's and
    the project's one convention, DESIGN.md).
weights: (N,) positive (e.g. inlier counts), default 1.
method: )doc" +
      RotationAveragerMethodList() + R"doc(.
options: {"RotationAveraging": {...}} with the command's names
    (`colmap_irav4 rotation_averager -h`).

Returns (rotations, summary): (num_images, 3, 3) cam_from_world rotations,
NaN for images not estimated (outside the largest connected component of
the pairs, or left out by the method); summary: method, num_cameras and
num_edges of that component, num_cameras_estimated, num_edges_used,
seconds, stage_seconds, reference_size and cluster_sizes (IRAv4),
num_images, num_components. The result is fixed up to one global rotation.
Bad input raises ValueError naming the argument or option.)doc";
  module.attr("rotation_averaging_methods") = RotationAveragerMethods();
  module.def("rotation_averaging", &RotationAveraging, py::arg("num_images"),
             py::arg("pairs"), py::arg("relative_rotations"),
             py::arg("weights") = py::none(), py::arg("method") = "irav4",
             py::arg("options") = py::none(), doc.c_str());
}

}  // namespace python
}  // namespace colmap_irav4
