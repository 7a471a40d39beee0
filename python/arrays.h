#pragma once

// NumPy arrays in and out of the module: every array argument is checked
// (dtype kind, shape) with an InputError naming it, never silently rounded.

#include <string>
#include <type_traits>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace python {

template <typename T>
using Array =
    pybind11::array_t<T, pybind11::array::c_style | pybind11::array::forcecast>;

inline std::string ShapeText(const pybind11::array& array) {
  std::string text = "(";
  for (pybind11::ssize_t d = 0; d < array.ndim(); ++d) {
    text += (d ? ", " : "") + std::to_string(array.shape(d));
  }
  return text + (array.ndim() == 1 ? ",)" : ")");
}

// `value` as an array of T with `shape` (-1: any size), named `name` in
// errors. Integers must come from an integer (or bool) array, never rounded
// from floats.
template <typename T>
Array<T> CheckedArray(const pybind11::handle& value, const std::string& name,
                      const std::vector<pybind11::ssize_t>& shape) {
  const pybind11::module_ numpy = pybind11::module_::import("numpy");
  pybind11::array array;
  try {
    array = numpy.attr("asarray")(value);
  } catch (const pybind11::error_already_set& error) {
    throw InputError(name, std::string("not an array: ") + error.what());
  }
  const std::string kind =
      pybind11::str(array.dtype().attr("kind")).cast<std::string>();
  if (std::is_integral<T>::value
          ? (kind != "i" && kind != "u" && kind != "b")
          : (kind != "i" && kind != "u" && kind != "f" && kind != "b")) {
    throw InputError(name,
                     std::string("expected ") +
                         (std::is_integral<T>::value ? "integers" : "numbers") +
                         ", got dtype " +
                         pybind11::str(array.dtype()).cast<std::string>());
  }
  bool ok = array.ndim() == static_cast<pybind11::ssize_t>(shape.size());
  for (size_t d = 0; ok && d < shape.size(); ++d) {
    ok = shape[d] < 0 ||
         array.shape(static_cast<pybind11::ssize_t>(d)) == shape[d];
  }
  if (!ok) {
    std::string expected = "(";
    for (size_t d = 0; d < shape.size(); ++d) {
      expected += (d ? ", " : "") +
                  (shape[d] < 0 ? std::string("n") : std::to_string(shape[d]));
    }
    expected += shape.size() == 1 ? ",)" : ")";
    throw InputError(
        name, "expected shape " + expected + ", got " + ShapeText(array));
  }
  return Array<T>::ensure(array);
}

}  // namespace python
}  // namespace colmap_irav4
