// Maps: the landmarks (ids and corners) and the map's planes and boxes as
// numpy arrays.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <stdlib.h>  // mkdtemp

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bindings.h"
#include "panotrack/core/error.h"
#include "panotrack/io/map.h"
#include "panotrack/scene/map.h"
#include "panotrack/track/landmarks.h"

namespace pano::python {

namespace {

// (K, 2 or 3) array of the rows fn(k) fills.
template <typename Fn>
DoubleArray Table(size_t rows, py::ssize_t width, Fn&& fn) {
  DoubleArray a({static_cast<py::ssize_t>(rows), width});
  double* p = a.mutable_data();
  for (size_t k = 0; k < rows; ++k) fn(k, p + k * width);
  return a;
}

py::dict Rectangles(const std::vector<MapRectangle>& rects) {
  py::dict d;
  std::vector<std::string> ids;
  for (const MapRectangle& r : rects) ids.push_back(r.id);
  d["ids"] = ids;
  d["from"] = Table(rects.size(), 2, [&](size_t k, double* p) { p[0] = rects[k].from.x(), p[1] = rects[k].from.y(); });
  d["to"] = Table(rects.size(), 2, [&](size_t k, double* p) { p[0] = rects[k].to.x(), p[1] = rects[k].to.y(); });
  d["z"] = Table(rects.size(), 2, [&](size_t k, double* p) { p[0] = rects[k].z0, p[1] = rects[k].z1; });
  d["shade"] = Table(rects.size(), 1, [&](size_t k, double* p) { p[0] = rects[k].shade; }).attr("ravel")();
  return d;
}

Map MapFromYaml(const std::string& yaml) {
  std::string folder = (std::filesystem::temp_directory_path() / "panotrack_map_XXXXXX").string();
  if (!::mkdtemp(folder.data())) throw Error("cannot create a temporary folder to unpickle a map");
  const std::string path = folder + "/map.yaml";
  Map map;
  try {
    std::ofstream(path) << yaml;
    map = ReadMap(path);
  } catch (...) {
    std::filesystem::remove_all(folder);
    throw;
  }
  std::filesystem::remove_all(folder);
  return map;
}

}  // namespace

void BindMap(py::module_& m) {
  py::class_<Map>(m, "Map", "The a-priori model of the room and its landmarks (map YAML)")
      .def(py::init<>())
      .def_readwrite("units", &Map::units)
      .def_readwrite("sensor_height", &Map::sensor_height)
      .def_property_readonly(
          "landmark_ids",
          [](const Map& map) {
            std::vector<std::string> ids;
            for (const Landmark& l : LandmarksFromMap(map)) ids.push_back(l.id);
            return ids;
          },
          "Ids of the landmarks the localiser tracks (corners of rectangles and boxes)")
      .def_property_readonly(
          "landmark_corners",
          [](const Map& map) {
            const std::vector<Landmark> ls = LandmarksFromMap(map);
            return Table(ls.size(), 3, [&](size_t k, double* p) {
              for (int i = 0; i < 3; ++i) p[i] = ls[k].corner[i];
            });
          },
          "World coordinates (K, 3) of the landmarks, in the order of landmark_ids")
      .def_property_readonly("rectangles", [](const Map& map) { return Rectangles(map.rectangles); },
                             "dict: ids, from (K, 2), to (K, 2), z (K, 2: z0, z1), shade (K,)")
      .def_property_readonly("distractors", [](const Map& map) { return Rectangles(map.distractors); })
      .def_property_readonly(
          "boxes",
          [](const Map& map) {
            py::dict d;
            std::vector<std::string> ids;
            for (const MapBox& b : map.boxes) ids.push_back(b.id);
            d["ids"] = ids;
            d["min"] = Table(map.boxes.size(), 3, [&](size_t k, double* p) {
              for (int i = 0; i < 3; ++i) p[i] = map.boxes[k].min[i];
            });
            d["max"] = Table(map.boxes.size(), 3, [&](size_t k, double* p) {
              for (int i = 0; i < 3; ++i) p[i] = map.boxes[k].max[i];
            });
            return d;
          },
          "dict: ids, min (K, 3), max (K, 3)")
      .def_property_readonly(
          "room",
          [](const Map& map) -> py::object {
            if (!map.room.present) return py::none();
            py::dict d;
            d["min"] = py::make_tuple(map.room.min.x(), map.room.min.y());
            d["max"] = py::make_tuple(map.room.max.x(), map.room.max.y());
            d["height"] = map.room.height;
            return std::move(d);
          },
          "dict: min (x, y), max (x, y), height; None when the map has no room")
      .def("is_free", &Map::IsFree, py::arg("x"), py::arg("y"),
           "True when (x, y) is inside the room (or there is none) and not inside a box")
      // Pickled as its YAML (with the distractors), read back through a
      // scratch file by the library's reader, which checks it again.
      .def(py::pickle([](const Map& map) { return MapToYaml(map, /*with_distractors=*/true); },
                      [](const std::string& yaml) { return MapFromYaml(yaml); }))
      .def("__copy__", [](const Map& map) { return map; })
      .def("__deepcopy__", [](const Map& map, const py::dict&) { return map; }, py::arg("memo"))
      .def("units_per_metre", &Map::UnitsPerMetre)
      .def("to_yaml", &MapToYaml, py::arg("with_distractors") = false)
      .def("__repr__", [](const Map& map) {
        return "<panotrack.Map " + std::to_string(map.rectangles.size()) + " rectangles, " +
               std::to_string(map.boxes.size()) + " boxes, " + map.units + ">";
      });

  m.def(
      "read_map", [](const std::filesystem::path& path) { return ReadMap(path.string()); }, py::arg("path"),
      "Reads and checks a map file; raises panotrack.Error naming the file, key and problem");
  m.def(
      "write_map",
      [](const std::filesystem::path& path, const Map& map, bool with_distractors) {
        WriteMap(path.string(), map, with_distractors);
      },
      py::arg("path"), py::arg("map"), py::arg("with_distractors") = false, "Writes a map file atomically");
}

}  // namespace pano::python
