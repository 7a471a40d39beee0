#pragma once

// The module's functions, one file per group (python/*.cc); module.cc
// defines the module and calls these.

#include <pybind11/pybind11.h>

namespace colmap_irav4 {
namespace python {

void DefineMapping(pybind11::module_& module);            // mapping.cc
void DefineRotationAveraging(pybind11::module_& module);  // rotation.cc
void DefineModels(pybind11::module_& module);             // models.cc
void DefineViewGraph(pybind11::module_& module);          // view_graph.cc

}  // namespace python
}  // namespace colmap_irav4
