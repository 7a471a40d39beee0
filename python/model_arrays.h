#pragma once

// COLMAP models as Python data: a dict of three tables, each a dict of
// columns (NumPy arrays; per-row arrays of varying length as lists):
//   cameras:  camera_id (C,) int64, model [str], width (C,) int64,
//             height (C,) int64, params [(n,) float64]
//   images:   image_id (M,) int64, name [str], camera_id (M,) int64,
//             quaternion (M, 4) float64 (w, x, y, z), rotation (M, 3, 3)
//             float64 (both cam_from_world), translation (M, 3) float64,
//             points2D [(K, 2) float64], point3D_ids [(K,) int64, -1: none]
//   points3D: point3D_id (P,) int64, xyz (P, 3) float64, rgb (P, 3) uint8,
//             error (P,) float64, track [(L, 2) int64: image_id, point2D_idx]

#include <pybind11/pybind11.h>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {
namespace python {

pybind11::dict ModelToPython(const Reconstruction& model);

// The inverse; images take `quaternion` if given, else `rotation` (if both,
// they must agree). Throws InputError naming the table and column
// ("model['images']['rotation']: ...") for wrong types, shapes, lengths or
// values, then checks the model as the file readers do (CheckReconstruction).
Reconstruction ModelFromPython(const pybind11::handle& model);

}  // namespace python
}  // namespace colmap_irav4
