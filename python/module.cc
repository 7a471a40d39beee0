// The Python module colmap_irav4: the global mapper, rotation averaging
// (IRAv4 and the other methods) on NumPy arrays, COLMAP models as arrays
// and model comparison. Bad input raises ValueError naming the argument or
// option (the library's InputError); Ctrl-C raises KeyboardInterrupt after
// the work has stopped (python/host.h).

#include <pybind11/pybind11.h>

#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/interrupt.h"
#include "python/bindings.h"
#include "python/host.h"

namespace py = pybind11;

PYBIND11_MODULE(colmap_irav4, module) {
  using namespace colmap_irav4;
  module.doc() =
      "colmap_irav4: global Structure-from-Motion for COLMAP databases with "
      "IRAv4 rotation averaging. Log messages go to the logger "
      "'colmap_irav4' (logging.basicConfig(level=logging.INFO) shows the "
      "stages).";
  python::InitLogging();
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const InputError& input_error) {
      PyErr_SetString(PyExc_ValueError, input_error.what());
    } catch (const Interrupted&) {
      PyErr_SetNone(PyExc_KeyboardInterrupt);
    }
  });
  python::DefineMapping(module);
  python::DefineRotationAveraging(module);
  python::DefineModels(module);
  python::DefineViewGraph(module);
}
