#pragma once

// The options dict of a module function, parsed by the command's own option
// registration (util/option_manager.h, pipeline/option_registration.h), so
// that names, values and errors are the command's:
//   {"Mapper": {"num_threads": 2}, "RotationAveraging.theta_deg": 3}
// is `--Mapper.num_threads 2 --RotationAveraging.theta_deg 3`.

#include <string>

#include <pybind11/pybind11.h>

#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {
namespace python {

// Parses `options` (None or a dict, nested dicts joined with ".") into the
// manager's registered members. Values: bool, int, float or str (NumPy
// scalars too). Throws InputError naming the option ("--Mapper.foo: ...").
void ParseOptions(const pybind11::handle& options, OptionManager* manager);

// A path argument (str or os.PathLike); throws InputError naming `argument`.
std::string PathArgument(const pybind11::handle& value,
                         const std::string& argument);

}  // namespace python
}  // namespace colmap_irav4
