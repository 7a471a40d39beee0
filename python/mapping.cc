// colmap_irav4.global_mapping: the mapper command from Python.

#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/pybind11.h>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/threading.h"
#include "python/bindings.h"
#include "python/host.h"
#include "python/model_arrays.h"
#include "python/options.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

// The one call into the pipeline (as the mapper command makes it): the
// binding's only dependency on the pipeline's interface.
GlobalMapperSummary RunMapper(const GlobalMapperOptions& options,
                              const std::string& database_path,
                              const std::string& image_path,
                              const std::string& output_path,
                              const std::string& output_type) {
  LimitBlasThreads(options.num_threads);
  return RunGlobalMapperOnDatabase(options, database_path, image_path,
                                   output_path, output_type);
}

py::tuple GlobalMapping(const py::object& database_path_argument,
                        const py::object& output_path_argument,
                        const py::object& image_path_argument,
                        const py::object& options_argument) {
  const std::string database_path =
      PathArgument(database_path_argument, "database_path");
  const std::string output_path =
      PathArgument(output_path_argument, "output_path");
  const std::string image_path =
      image_path_argument.is_none()
          ? ""
          : PathArgument(image_path_argument, "image_path");
  // The command's options, names and checks (src/mapper_command.cc).
  GlobalMapperOptions options;
  std::string output_type = "BIN";
  OptionManager manager("mapper");
  manager.Add("output_type", &output_type, "BIN or TXT");
  AddGlobalMapperOptions(&manager, &options);
  ParseOptions(options_argument, &manager);
  manager.Check([&] { options.Check(); });

  GlobalMapperSummary summary;
  std::vector<Reconstruction> models;
  RunInPython([&] {
    summary =
        RunMapper(options, database_path, image_path, output_path, output_type);
    // The models as written (what a later read_model returns).
    for (const ComponentReport& component : summary.components) {
      models.push_back(ReadReconstruction(
          (std::filesystem::path(output_path) / std::to_string(component.index))
              .string()));
    }
  });
  py::list python_models;
  for (const Reconstruction& model : models) {
    python_models.append(ModelToPython(model));
  }
  const py::object summary_dict =
      py::module_::import("json").attr("loads")(summary.ToJson());
  return py::make_tuple(python_models, summary_dict);
}

}  // namespace

void DefineMapping(py::module_& module) {
  module.def("global_mapping", &GlobalMapping, py::arg("database_path"),
             py::arg("output_path"), py::arg("image_path") = py::none(),
             py::arg("options") = py::none(),
             R"doc(Runs the global mapper on a COLMAP database, as the command
`colmap_irav4 mapper` does: the database is only read; OUTPUT/0, OUTPUT/1,
... (largest first) and OUTPUT/summary.json are written atomically (complete
or not at all, also on Ctrl-C, which raises KeyboardInterrupt).

database_path, output_path, image_path: str or os.PathLike; image_path
(optional) is read for the point colours.
options: the command's options as a dict, nested by their dotted names,
e.g. {"Mapper": {"num_threads": 1, "seed": 0}, "output_type": "TXT"}
(`colmap_irav4 mapper -h` lists them). Unknown names and bad values raise
ValueError naming the option.

Returns (models, summary): the written models as read_model gives them, and
summary.json as a dict (summary["num_folded_models"] > 0: a model is still
flagged folded, where the command exits with code 3). Progress goes to the
logger 'colmap_irav4'.)doc");
}

}  // namespace python
}  // namespace colmap_irav4
