#include "python/model_arrays.h"

#include <cmath>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "python/arrays.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

// ---------------------------------------------------------------------------
// Model -> Python.

py::dict MakeTable(
    std::initializer_list<std::pair<const char*, py::object>> columns) {
  py::dict table;
  for (const auto& [name, column] : columns) table[name] = column;
  return table;
}

template <typename T>
Array<T> NewArray(std::vector<py::ssize_t> shape) {
  return Array<T>(shape);
}

py::dict CamerasToPython(const Reconstruction& model) {
  const py::ssize_t n = static_cast<py::ssize_t>(model.cameras.size());
  Array<int64_t> camera_id = NewArray<int64_t>({n});
  Array<int64_t> width = NewArray<int64_t>({n});
  Array<int64_t> height = NewArray<int64_t>({n});
  py::list model_names, params;
  py::ssize_t row = 0;
  for (const auto& [id, camera] : model.cameras) {
    camera_id.mutable_at(row) = id;
    width.mutable_at(row) = static_cast<int64_t>(camera.width);
    height.mutable_at(row) = static_cast<int64_t>(camera.height);
    model_names.append(CameraModelIdToName(camera.model_id));
    params.append(Array<double>(static_cast<py::ssize_t>(camera.params.size()),
                                camera.params.data()));
    ++row;
  }
  return MakeTable({{"camera_id", camera_id},
                    {"model", model_names},
                    {"width", width},
                    {"height", height},
                    {"params", params}});
}

py::dict ImagesToPython(const Reconstruction& model) {
  const py::ssize_t n = static_cast<py::ssize_t>(model.images.size());
  Array<int64_t> image_id = NewArray<int64_t>({n});
  Array<int64_t> camera_id = NewArray<int64_t>({n});
  Array<double> quaternion = NewArray<double>({n, 4});
  Array<double> rotation = NewArray<double>({n, 3, 3});
  Array<double> translation = NewArray<double>({n, 3});
  py::list names, points2D, point3D_ids;
  py::ssize_t row = 0;
  for (const auto& [id, image] : model.images) {
    image_id.mutable_at(row) = id;
    camera_id.mutable_at(row) = image.camera_id;
    names.append(image.name);
    const Eigen::Quaterniond& q = image.cam_from_world.rotation;
    const double q_values[4] = {q.w(), q.x(), q.y(), q.z()};
    for (int k = 0; k < 4; ++k) quaternion.mutable_at(row, k) = q_values[k];
    const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) rotation.mutable_at(row, r, c) = R(r, c);
      translation.mutable_at(row, r) = image.cam_from_world.translation(r);
    }
    const py::ssize_t k = static_cast<py::ssize_t>(image.points2D.size());
    Array<double> xy = NewArray<double>({k, 2});
    Array<int64_t> ids = NewArray<int64_t>({k});
    for (py::ssize_t i = 0; i < k; ++i) {
      const Point2D& point = image.points2D[static_cast<size_t>(i)];
      xy.mutable_at(i, 0) = point.xy.x();
      xy.mutable_at(i, 1) = point.xy.y();
      ids.mutable_at(i) = point.point3D_id == kInvalidPoint3DId
                              ? -1
                              : static_cast<int64_t>(point.point3D_id);
    }
    points2D.append(xy);
    point3D_ids.append(ids);
    ++row;
  }
  return MakeTable({{"image_id", image_id},
                    {"name", names},
                    {"camera_id", camera_id},
                    {"quaternion", quaternion},
                    {"rotation", rotation},
                    {"translation", translation},
                    {"points2D", points2D},
                    {"point3D_ids", point3D_ids}});
}

py::dict PointsToPython(const Reconstruction& model) {
  const py::ssize_t n = static_cast<py::ssize_t>(model.points3D.size());
  Array<int64_t> point3D_id = NewArray<int64_t>({n});
  Array<double> xyz = NewArray<double>({n, 3});
  Array<uint8_t> rgb = NewArray<uint8_t>({n, 3});
  Array<double> error = NewArray<double>({n});
  py::list tracks;
  py::ssize_t row = 0;
  for (const auto& [id, point] : model.points3D) {
    point3D_id.mutable_at(row) = static_cast<int64_t>(id);
    for (int k = 0; k < 3; ++k) {
      xyz.mutable_at(row, k) = point.xyz(k);
      rgb.mutable_at(row, k) = point.color(k);
    }
    error.mutable_at(row) = point.error;
    const py::ssize_t length = static_cast<py::ssize_t>(point.track.size());
    Array<int64_t> track = NewArray<int64_t>({length, 2});
    for (py::ssize_t i = 0; i < length; ++i) {
      track.mutable_at(i, 0) = point.track[static_cast<size_t>(i)].image_id;
      track.mutable_at(i, 1) = point.track[static_cast<size_t>(i)].point2D_idx;
    }
    tracks.append(track);
    ++row;
  }
  return MakeTable({{"point3D_id", point3D_id},
                    {"xyz", xyz},
                    {"rgb", rgb},
                    {"error", error},
                    {"track", tracks}});
}

// ---------------------------------------------------------------------------
// Python -> model, every value checked.

// An integer column's values within [low, high].
void CheckRange(const Array<int64_t>& values, const std::string& name,
                int64_t low, int64_t high) {
  for (py::ssize_t i = 0; i < values.size(); ++i) {
    const int64_t value = values.data()[i];
    if (value < low || value > high) {
      throw InputError(name + "[" + std::to_string(i) + "]",
                       std::to_string(value) + " is out of range [" +
                           std::to_string(low) + ", " + std::to_string(high) +
                           "]");
    }
  }
}

py::dict Table(const py::handle& model, const std::string& table) {
  if (!py::isinstance<py::dict>(model)) {
    throw InputError("model", "expected a dict with cameras, images, points3D");
  }
  const py::dict tables = py::reinterpret_borrow<py::dict>(model);
  if (!tables.contains(table) ||
      !py::isinstance<py::dict>(tables[table.c_str()])) {
    throw InputError("model['" + table + "']", "missing or not a dict");
  }
  return tables[table.c_str()];
}

py::object Column(const py::dict& table, const std::string& table_name,
                  const std::string& column) {
  if (!table.contains(column)) {
    throw InputError("model['" + table_name + "']['" + column + "']",
                     "missing");
  }
  return table[column.c_str()];
}

std::string ColumnName(const std::string& table, const std::string& column) {
  return "model['" + table + "']['" + column + "']";
}

// A list-like column of `rows` entries.
py::sequence ListColumn(const py::dict& table, const std::string& table_name,
                        const std::string& column, py::ssize_t rows) {
  const py::object value = Column(table, table_name, column);
  const std::string name = ColumnName(table_name, column);
  if (!py::isinstance<py::sequence>(value) || py::isinstance<py::str>(value)) {
    throw InputError(name, "expected a list");
  }
  const py::sequence sequence = py::reinterpret_borrow<py::sequence>(value);
  if (static_cast<py::ssize_t>(py::len(sequence)) != rows) {
    throw InputError(name, "has " + std::to_string(py::len(sequence)) +
                               " entries, expected " + std::to_string(rows));
  }
  return sequence;
}

std::string StringEntry(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::str>(value)) {
    throw InputError(name, "expected a str");
  }
  return value.cast<std::string>();
}

constexpr int64_t kMaxId32 = 4294967294;  // below the invalid id

void CamerasFromPython(const py::handle& model, Reconstruction* out) {
  const std::string t = "cameras";
  const py::dict table = Table(model, t);
  const Array<int64_t> ids = CheckedArray<int64_t>(
      Column(table, t, "camera_id"), ColumnName(t, "camera_id"), {-1});
  const py::ssize_t n = ids.shape(0);
  CheckRange(ids, ColumnName(t, "camera_id"), 0, kMaxId32);
  const Array<int64_t> width = CheckedArray<int64_t>(
      Column(table, t, "width"), ColumnName(t, "width"), {n});
  const Array<int64_t> height = CheckedArray<int64_t>(
      Column(table, t, "height"), ColumnName(t, "height"), {n});
  CheckRange(width, ColumnName(t, "width"), 0, INT64_MAX);
  CheckRange(height, ColumnName(t, "height"), 0, INT64_MAX);
  const py::sequence models = ListColumn(table, t, "model", n);
  const py::sequence params = ListColumn(table, t, "params", n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const std::string row = "[" + std::to_string(i) + "]";
    Camera camera;
    camera.camera_id = static_cast<camera_t>(ids.at(i));
    const std::string model_name = StringEntry(models[static_cast<size_t>(i)],
                                               ColumnName(t, "model") + row);
    camera.model_id = CameraModelNameToId(model_name);
    if (camera.model_id < 0) {
      throw InputError(ColumnName(t, "model") + row,
                       "unknown camera model '" + model_name +
                           "' (supported: COLMAP 3.8's eleven models)");
    }
    camera.width = static_cast<uint64_t>(width.at(i));
    camera.height = static_cast<uint64_t>(height.at(i));
    const Array<double> values = CheckedArray<double>(
        params[static_cast<size_t>(i)], ColumnName(t, "params") + row, {-1});
    camera.params.assign(values.data(), values.data() + values.size());
    if (!out->cameras.emplace(camera.camera_id, camera).second) {
      throw InputError(ColumnName(t, "camera_id") + row,
                       "duplicate camera id " + std::to_string(ids.at(i)));
    }
  }
}

void ImagesFromPython(const py::handle& model, Reconstruction* out) {
  const std::string t = "images";
  const py::dict table = Table(model, t);
  const Array<int64_t> ids = CheckedArray<int64_t>(
      Column(table, t, "image_id"), ColumnName(t, "image_id"), {-1});
  const py::ssize_t n = ids.shape(0);
  CheckRange(ids, ColumnName(t, "image_id"), 0, kMaxId32);
  const Array<int64_t> camera_ids = CheckedArray<int64_t>(
      Column(table, t, "camera_id"), ColumnName(t, "camera_id"), {n});
  CheckRange(camera_ids, ColumnName(t, "camera_id"), 0, kMaxId32);
  const bool has_quaternion =
      table.contains("quaternion") && !table["quaternion"].is_none();
  const bool has_rotation =
      table.contains("rotation") && !table["rotation"].is_none();
  if (!has_quaternion && !has_rotation) {
    throw InputError(ColumnName(t, "rotation"),
                     "missing (give rotation or quaternion)");
  }
  Array<double> quaternions, rotations;
  if (has_quaternion) {
    quaternions = CheckedArray<double>(table["quaternion"],
                                       ColumnName(t, "quaternion"), {n, 4});
  }
  if (has_rotation) {
    rotations = CheckedArray<double>(table["rotation"],
                                     ColumnName(t, "rotation"), {n, 3, 3});
  }
  const Array<double> translations = CheckedArray<double>(
      Column(table, t, "translation"), ColumnName(t, "translation"), {n, 3});
  const py::sequence names = ListColumn(table, t, "name", n);
  const py::sequence points2D = ListColumn(table, t, "points2D", n);
  const py::sequence point3D_ids = ListColumn(table, t, "point3D_ids", n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const std::string row = "[" + std::to_string(i) + "]";
    Image image;
    image.image_id = static_cast<image_t>(ids.at(i));
    image.camera_id = static_cast<camera_t>(camera_ids.at(i));
    image.name =
        StringEntry(names[static_cast<size_t>(i)], ColumnName(t, "name") + row);
    Eigen::Matrix3d R;
    if (has_rotation) {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) R(r, c) = rotations.at(i, r, c);
      }
      if (!R.allFinite() ||
          !(((R * R.transpose()) - Eigen::Matrix3d::Identity()).norm() <
            1e-6) ||
          !(R.determinant() > 0)) {
        throw InputError(ColumnName(t, "rotation") + row,
                         "not a rotation matrix (R R^T = I, det R = 1)");
      }
    }
    if (has_quaternion) {
      image.cam_from_world.rotation =
          Eigen::Quaterniond(quaternions.at(i, 0), quaternions.at(i, 1),
                             quaternions.at(i, 2), quaternions.at(i, 3));
      const Eigen::Quaterniond& q = image.cam_from_world.rotation;
      if (has_rotation && q.coeffs().allFinite() && q.norm() > 1e-8 &&
          !((q.normalized().toRotationMatrix() - R).norm() < 1e-6)) {
        throw InputError(ColumnName(t, "quaternion") + row,
                         "disagrees with model['images']['rotation']" + row +
                             " (give one of them, or both equal)");
      }
    } else {
      image.cam_from_world.rotation = Eigen::Quaterniond(R);
    }
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation(k) = translations.at(i, k);
    }
    const Array<double> xy =
        CheckedArray<double>(points2D[static_cast<size_t>(i)],
                             ColumnName(t, "points2D") + row, {-1, 2});
    const Array<int64_t> point_ids = CheckedArray<int64_t>(
        point3D_ids[static_cast<size_t>(i)], ColumnName(t, "point3D_ids") + row,
        {xy.shape(0)});
    CheckRange(point_ids, ColumnName(t, "point3D_ids") + row, -1, INT64_MAX);
    image.points2D.resize(static_cast<size_t>(xy.shape(0)));
    for (py::ssize_t k = 0; k < xy.shape(0); ++k) {
      Point2D& point = image.points2D[static_cast<size_t>(k)];
      point.xy = Eigen::Vector2d(xy.at(k, 0), xy.at(k, 1));
      point.point3D_id = point_ids.at(k) < 0
                             ? kInvalidPoint3DId
                             : static_cast<point3D_t>(point_ids.at(k));
    }
    if (!out->images.emplace(image.image_id, std::move(image)).second) {
      throw InputError(ColumnName(t, "image_id") + row,
                       "duplicate image id " + std::to_string(ids.at(i)));
    }
  }
}

void PointsFromPython(const py::handle& model, Reconstruction* out) {
  const std::string t = "points3D";
  const py::dict table = Table(model, t);
  const Array<int64_t> ids = CheckedArray<int64_t>(
      Column(table, t, "point3D_id"), ColumnName(t, "point3D_id"), {-1});
  const py::ssize_t n = ids.shape(0);
  CheckRange(ids, ColumnName(t, "point3D_id"), 0, INT64_MAX);
  const Array<double> xyz = CheckedArray<double>(Column(table, t, "xyz"),
                                                 ColumnName(t, "xyz"), {n, 3});
  const Array<int64_t> rgb = CheckedArray<int64_t>(
      Column(table, t, "rgb"), ColumnName(t, "rgb"), {n, 3});
  CheckRange(rgb, ColumnName(t, "rgb"), 0, 255);
  const Array<double> error = CheckedArray<double>(Column(table, t, "error"),
                                                   ColumnName(t, "error"), {n});
  const py::sequence tracks = ListColumn(table, t, "track", n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const std::string row = "[" + std::to_string(i) + "]";
    Point3D point;
    for (int k = 0; k < 3; ++k) {
      point.xyz(k) = xyz.at(i, k);
      point.color(k) = static_cast<uint8_t>(rgb.at(i, k));
    }
    point.error = error.at(i);
    const Array<int64_t> track = CheckedArray<int64_t>(
        tracks[static_cast<size_t>(i)], ColumnName(t, "track") + row, {-1, 2});
    CheckRange(track, ColumnName(t, "track") + row, 0, kMaxId32);
    for (py::ssize_t k = 0; k < track.shape(0); ++k) {
      TrackElement element;
      element.image_id = static_cast<image_t>(track.at(k, 0));
      element.point2D_idx = static_cast<point2D_t>(track.at(k, 1));
      point.track.push_back(element);
    }
    if (!out->points3D.emplace(static_cast<point3D_t>(ids.at(i)), point)
             .second) {
      throw InputError(ColumnName(t, "point3D_id") + row,
                       "duplicate point3D id " + std::to_string(ids.at(i)));
    }
  }
}

}  // namespace

py::dict ModelToPython(const Reconstruction& model) {
  py::dict tables;
  tables["cameras"] = CamerasToPython(model);
  tables["images"] = ImagesToPython(model);
  tables["points3D"] = PointsToPython(model);
  return tables;
}

Reconstruction ModelFromPython(const py::handle& model) {
  Reconstruction reconstruction;
  CamerasFromPython(model, &reconstruction);
  ImagesFromPython(model, &reconstruction);
  PointsFromPython(model, &reconstruction);
  CheckReconstruction("model", reconstruction);
  return reconstruction;
}

}  // namespace python
}  // namespace colmap_irav4
