// colmap_irav4.view_graph: a database's verified pairs as the rotation
// averaging problem of the rotation_averager command (--database_path).

#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/rotation_averaging/view_graph_rotations.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "python/bindings.h"
#include "python/host.h"
#include "python/options.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

py::dict ViewGraphOfDatabase(const py::object& database_path_argument,
                             const py::object& options_argument) {
  const std::string database_path =
      PathArgument(database_path_argument, "database_path");
  ViewGraphBuilderOptions options;
  OptionManager manager("view_graph");
  AddViewGraphOptions(&manager, &options);
  ParseOptions(options_argument, &manager);
  manager.Check([&] { options.Check(); });
  RotationGraph graph;
  std::vector<image_t> vertex_images;
  RunInPython([&] {
    const DatabaseContents database = ReadDatabase(database_path);
    ViewGraphSummary summary;
    graph = RotationGraphFromViewGraph(
        BuildViewGraph(database, options, &summary), &vertex_images);
  });
  const py::ssize_t n = graph.NumEdges();
  py::array_t<int64_t> pairs({n, static_cast<py::ssize_t>(2)});
  py::array_t<double> rotations(
      {n, static_cast<py::ssize_t>(3), static_cast<py::ssize_t>(3)});
  py::array_t<double> weights(n);
  for (py::ssize_t k = 0; k < n; ++k) {
    const RelativeRotation& edge = graph.Edge(static_cast<int>(k));
    pairs.mutable_at(k, 0) = edge.i;
    pairs.mutable_at(k, 1) = edge.j;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        rotations.mutable_at(k, r, c) = edge.R_ij(r, c);
    }
    weights.mutable_at(k) = edge.weight;
  }
  py::dict result;
  result["image_names"] = graph.Names();
  result["image_ids"] = vertex_images;
  result["pairs"] = pairs;
  result["relative_rotations"] = rotations;
  result["weights"] = weights;
  return result;
}

}  // namespace

void DefineViewGraph(py::module_& module) {
  module.def(
      "view_graph", &ViewGraphOfDatabase, py::arg("database_path"),
      py::arg("options") = py::none(),
      R"doc(The verified image pairs of a COLMAP database (read-only) after
the view graph's filters, as rotation_averaging takes them: a dict with
image_names and image_ids (the connected images, in image id order; index =
vertex), pairs (N, 2) vertex indices, relative_rotations (N, 3, 3)
cam_j_from_cam_i and weights (N,) inlier counts.
options: {"ViewGraph": {...}, "RelativePose": {...}} with the command's names
(`colmap_irav4 view_graph -h`).)doc");
}

}  // namespace python
}  // namespace colmap_irav4
