#include "python/options.h"

#include <vector>

#include "colmap_irav4/util/error.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

// The option's value as the command line would give it.
std::string OptionText(const std::string& name, const py::handle& value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "1" : "0";
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  // Python's and NumPy's integers and floats.
  const py::object builtins = py::module_::import("builtins");
  const py::module_ numbers = py::module_::import("numbers");
  if (py::type::of(value).attr("__name__").cast<std::string>() == "bool_") {
    return value.cast<bool>() ? "1" : "0";  // numpy.bool_
  }
  if (py::isinstance(value, numbers.attr("Integral"))) {
    return py::str(builtins.attr("int")(value)).cast<std::string>();
  }
  if (py::isinstance(value, numbers.attr("Real"))) {
    // repr: the shortest text that reads back as the same double.
    return py::repr(builtins.attr("float")(value)).cast<std::string>();
  }
  throw InputError(
      "--" + name,
      "expected a bool, int, float or str, got " +
          py::str(py::type::of(value).attr("__name__")).cast<std::string>());
}

void Flatten(const std::string& prefix, const py::handle& options,
             std::vector<std::string>* arguments) {
  if (!py::isinstance<py::dict>(options)) {
    throw InputError(prefix.empty() ? "options" : "--" + prefix,
                     "expected a dict of options");
  }
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(options)) {
    if (!py::isinstance<py::str>(key)) {
      throw InputError(prefix.empty() ? "options" : "--" + prefix,
                       "option names must be strings, got " +
                           py::repr(key).cast<std::string>());
    }
    const std::string name =
        (prefix.empty() ? "" : prefix + ".") + key.cast<std::string>();
    if (py::isinstance<py::dict>(value)) {
      Flatten(name, value, arguments);
      continue;
    }
    // "--name=value" is one argument to the parser; a name holding "=" or
    // its help flags is no option.
    if (name.find('=') != std::string::npos || name == "h" || name == "help") {
      throw InputError("--" + name, "unknown option");
    }
    arguments->push_back("--" + name + "=" + OptionText(name, value));
  }
}

}  // namespace

void ParseOptions(const py::handle& options, OptionManager* manager) {
  std::vector<std::string> arguments = {"options"};
  if (!options.is_none()) Flatten("", options, &arguments);
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  manager->Parse(static_cast<int>(argv.size()), argv.data());
}

std::string PathArgument(const py::handle& value, const std::string& argument) {
  try {
    return py::module_::import("os").attr("fspath")(value).cast<std::string>();
  } catch (const py::error_already_set&) {
    throw InputError(argument, "expected a path (str or os.PathLike), got " +
                                   py::repr(value).cast<std::string>());
  } catch (const py::cast_error&) {
    throw InputError(argument, "expected a str path, got " +
                                   py::repr(value).cast<std::string>());
  }
}

}  // namespace python
}  // namespace colmap_irav4
