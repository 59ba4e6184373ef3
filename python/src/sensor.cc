// Sensor model and calibration files: vectorised projection over numpy
// arrays (the loops in C++, without the GIL, in parallel for large arrays).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <string>

#include "bindings.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/sensor/sensor.h"

namespace pano::python {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

MirrorModel ModelFromName(const std::string& name) {
  if (name == "sphere") return MirrorModel::kSphere;
  if (name == "conic") return MirrorModel::kConic;
  if (name == "asphere") return MirrorModel::kAsphere;
  if (name == "unified") return MirrorModel::kUnified;
  throw Error("model: expected sphere, conic, asphere or unified, got '" + name + "'");
}

py::object Project(const Sensor& s, const DoubleArray& points, int num_threads) {
  const py::ssize_t n = RowsOf(points, 3, "points");
  DoubleArray pixels = NewRows(n, 2, points.ndim() == 1);
  const double* in = points.data();
  double* out = pixels.mutable_data();
  {
    py::gil_scoped_release release;
    ForEachRow(n, num_threads, [&](py::ssize_t i) {
      Eigen::Vector2d px;
      if (s.project(Eigen::Vector3d(in[3 * i], in[3 * i + 1], in[3 * i + 2]), &px)) {
        out[2 * i] = px.x();
        out[2 * i + 1] = px.y();
      } else {
        out[2 * i] = out[2 * i + 1] = kNaN;
      }
    });
  }
  return std::move(pixels);
}

py::tuple Backproject(const Sensor& s, const DoubleArray& pixels, int num_threads) {
  const py::ssize_t n = RowsOf(pixels, 2, "pixels");
  const bool single = pixels.ndim() == 1;
  DoubleArray origins = NewRows(n, 3, single), directions = NewRows(n, 3, single);
  const double* in = pixels.data();
  double* o = origins.mutable_data();
  double* d = directions.mutable_data();
  {
    py::gil_scoped_release release;
    ForEachRow(n, num_threads, [&](py::ssize_t i) {
      Eigen::Vector3d origin, direction;
      const bool ok = s.backproject(Eigen::Vector2d(in[2 * i], in[2 * i + 1]), &origin, &direction);
      for (int k = 0; k < 3; ++k) {
        o[3 * i + k] = ok ? origin[k] : kNaN;
        d[3 * i + k] = ok ? direction[k] : kNaN;
      }
    });
  }
  return py::make_tuple(origins, directions);
}

// fn(a, b, &result) over numpy's broadcast of a and b; NaN where fn is false.
// A float when both are scalars.
template <typename Fn>
py::object Broadcast(const py::object& a, const py::object& b, int num_threads, Fn&& fn) {
  const py::tuple both = py::module_::import("numpy").attr("broadcast_arrays")(a, b);
  const DoubleArray x = both[0].cast<DoubleArray>(), y = both[1].cast<DoubleArray>();
  std::vector<py::ssize_t> shape(x.shape(), x.shape() + x.ndim());
  DoubleArray out(shape);
  const py::ssize_t n = x.size();
  const double* px = x.data();
  const double* py_ = y.data();
  double* po = out.mutable_data();
  {
    py::gil_scoped_release release;
    ForEachRow(n, num_threads, [&](py::ssize_t i) {
      double r = kNaN;
      po[i] = fn(px[i], py_[i], &r) ? r : kNaN;
    });
  }
  if (out.ndim() == 0) return py::float_(*out.data());
  return std::move(out);
}

py::dict ParamsDict(const SensorParams<double>& p) {
  py::dict d;
  d["focal_px"] = p.focal_px;
  d["cx"] = p.cx;
  d["cy"] = p.cy;
  d["aspect"] = p.aspect;
  d["azimuth_offset"] = p.azimuth_offset;
  d["k1"] = p.k1;
  d["k2"] = p.k2;
  d["curvature_radius"] = p.curvature_radius;
  d["conic_constant"] = p.conic_constant;
  d["vertex_distance"] = p.vertex_distance;
  d["rim_radius"] = p.rim_radius;
  d["asphere_a4"] = p.asphere_a4;
  d["asphere_a6"] = p.asphere_a6;
  d["xi"] = p.xi;
  return d;
}

#define PANO_PARAM(name) \
  .def_property(#name, [](const Sensor& s) { return s.params.name; }, [](Sensor& s, double v) { s.params.name = v; })

void BindSensorClass(py::module_& m) {
  py::class_<Sensor>(m, "Sensor",
                     "Catadioptric sensor model: a pinhole camera below a mirror of revolution (sphere or "
                     "conic), with the image size. Units of length are the calibration's.")
      .def(py::init<>())
      .def_property(
          "model", [](const Sensor& s) { return std::string(MirrorModelName(s.model)); },
          [](Sensor& s, const std::string& name) {
            s.model = ModelFromName(name);
            s.params.unified = s.model == MirrorModel::kUnified;
          },
          "'sphere', 'conic', 'asphere' (a conic with even-asphere terms) or 'unified' (Mei's central model, xi)")
      .def_readwrite("image_width", &Sensor::image_width)
      .def_readwrite("image_height", &Sensor::image_height)
      // clang-format off
      PANO_PARAM(focal_px) PANO_PARAM(cx) PANO_PARAM(cy) PANO_PARAM(aspect) PANO_PARAM(azimuth_offset)
      PANO_PARAM(k1) PANO_PARAM(k2) PANO_PARAM(curvature_radius) PANO_PARAM(conic_constant)
      PANO_PARAM(vertex_distance) PANO_PARAM(rim_radius) PANO_PARAM(asphere_a4) PANO_PARAM(asphere_a6)
      PANO_PARAM(xi)
      // clang-format on
      .def_property_readonly("params", [](const Sensor& s) { return ParamsDict(s.params); },
                             "All model parameters as a dict (a copy)")
      .def_property_readonly("mirror_radius", &Sensor::mirror_radius, "Sphere radius (sphere model)")
      .def_property_readonly("mirror_distance", &Sensor::mirror_distance,
                             "Height of the sphere's centre above the pinhole (sphere model)")
      .def_property_readonly("limb_radius", &Sensor::limb_radius,
                             "Image radius (pixels) of the mirror's visible edge")
      .def(py::pickle(
          [](const Sensor& s) {
            return py::make_tuple(std::string(MirrorModelName(s.model)), s.image_width, s.image_height,
                                  ParamsDict(s.params));
          },
          [](const py::tuple& t) {
            if (t.size() != 4) throw py::value_error("Sensor: bad pickled state");
            Sensor s;
            s.model = ModelFromName(t[0].cast<std::string>());
            s.params.unified = s.model == MirrorModel::kUnified;
            s.image_width = t[1].cast<int>();
            s.image_height = t[2].cast<int>();
            const py::dict p = t[3].cast<py::dict>();
            auto get = [&p](const char* key) { return p[key].cast<double>(); };
            s.params.focal_px = get("focal_px");
            s.params.cx = get("cx");
            s.params.cy = get("cy");
            s.params.aspect = get("aspect");
            s.params.azimuth_offset = get("azimuth_offset");
            s.params.k1 = get("k1");
            s.params.k2 = get("k2");
            s.params.curvature_radius = get("curvature_radius");
            s.params.conic_constant = get("conic_constant");
            s.params.vertex_distance = get("vertex_distance");
            s.params.rim_radius = get("rim_radius");
            // States pickled before the even-asphere terms existed have none.
            if (p.contains("asphere_a4")) s.params.asphere_a4 = get("asphere_a4");
            if (p.contains("asphere_a6")) s.params.asphere_a6 = get("asphere_a6");
            if (p.contains("xi")) s.params.xi = get("xi");
            return s;
          }))
      .def("__copy__", [](const Sensor& s) { return s; })
      .def("__deepcopy__", [](const Sensor& s, const py::dict&) { return s; }, py::arg("memo"))
      .def("check", &Sensor::Check, py::arg("what") = "sensor",
           "Raises panotrack.Error naming `what` when the parameters are impossible")
      .def("project", &Project, py::arg("points"), py::arg("num_threads") = 0,
           "Sensor-frame points (N, 3) -> pixels (N, 2), NaN where the point is not visible. "
           "A single point (3,) gives (2,). num_threads 0: OpenMP's default.")
      .def("backproject", &Backproject, py::arg("pixels"), py::arg("num_threads") = 0,
           "Pixels (N, 2) -> (origins (N, 3), unit directions (N, 3)) of the rays leaving the mirror, "
           "NaN where the pixel does not see the mirror")
      .def(
          "image_radius",
          [](const Sensor& s, const py::object& d, const py::object& z, int num_threads) {
            return Broadcast(d, z, num_threads,
                             [&s](double a, double b, double* r) { return s.image_radius(a, b, r); });
          },
          py::arg("horizontal_distance"), py::arg("height"), py::arg("num_threads") = 0,
          "E(D, Z): image radius (pixels, aspect removed) of a point at horizontal distance D and height Z "
          "in the sensor frame; broadcasts like numpy; NaN where not visible")
      .def(
          "inverse_image_radius",
          [](const Sensor& s, const py::object& r, const py::object& z, int num_threads) {
            return Broadcast(r, z, num_threads,
                             [&s](double a, double b, double* d) { return s.inverse_image_radius(a, b, d); });
          },
          py::arg("radius"), py::arg("height"), py::arg("num_threads") = 0,
          "Horizontal distance D with E(D, Z) = radius; broadcasts; NaN where there is none")
      .def("__repr__", [](const Sensor& s) {
        return "<panotrack.Sensor " + std::string(MirrorModelName(s.model)) + " " +
               std::to_string(s.image_width) + "x" + std::to_string(s.image_height) +
               " focal_px=" + std::to_string(s.params.focal_px) + ">";
      });
}

void BindSensorFunctions(py::module_& m) {
  // For the speed comparison of the tests: the plain C++ loop over points
  // (one thread, no numpy), in seconds, and the number visible.
  m.def(
      "_time_project_loop",
      [](const Sensor& s, const DoubleArray& points) {
        const py::ssize_t n = RowsOf(points, 3, "points");
        std::vector<Eigen::Vector3d> in(static_cast<size_t>(n));
        for (py::ssize_t i = 0; i < n; ++i) in[i] = Eigen::Map<const Eigen::Vector3d>(points.data() + 3 * i);
        std::vector<Eigen::Vector2d> out(in.size());
        py::gil_scoped_release release;
        const auto t0 = std::chrono::steady_clock::now();
        long visible = 0;
        for (size_t i = 0; i < in.size(); ++i) visible += s.project(in[i], &out[i]);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return std::make_pair(seconds, visible);
      },
      py::arg("sensor"), py::arg("points"));

  m.def("sphere_sensor", &MakeSphereSensor, py::arg("width"), py::arg("height"), py::arg("focal_px"),
        py::arg("cx"), py::arg("cy"), py::arg("aspect"), py::arg("mirror_radius"), py::arg("mirror_distance"),
        py::arg("azimuth_offset") = 0.0,
        "The sphere model from its named parameters (mirror centre mirror_distance above the pinhole)");
}

void BindCalibration(py::module_& m) {
  py::class_<Calibration>(m, "Calibration", "A calibrated sensor as the tools exchange it (calibration YAML)")
      .def(py::init<>())
      .def(py::init([](const Sensor& s, const std::string& units) {
             Calibration c;
             c.sensor = s;
             c.units = units;
             return c;
           }),
           py::arg("sensor"), py::arg("units") = "cm")
      .def_readwrite("sensor", &Calibration::sensor)
      .def_readwrite("units", &Calibration::units)
      .def_readwrite("lut", &Calibration::lut, "E(D,Z) table path as written in the file ('' when none)")
      .def_readwrite("lut_resolved", &Calibration::lut_resolved, "The table path resolved against the file's folder")
      .def_readwrite("extras", &Calibration::extras, "Extra keys (standard deviations, RMS...)")
      .def_readwrite("comment", &Calibration::comment)
      .def_property_readonly(
          "images",
          [](const Calibration& c) {
            py::dict out;  // in the file's order (dicts keep insertion order)
            for (const CalibrationImage& im : c.images)
              out[py::str(im.file)] = py::dict(py::arg("method") = im.method, py::arg("corners") = im.corners,
                                               py::arg("rms_px") = im.rms_px,
                                               py::arg("rvec") = std::vector<double>(im.rvec.data(), im.rvec.data() + 3),
                                               py::arg("tvec") = std::vector<double>(im.tvec.data(), im.tvec.data() + 3));
            return out;
          },
          "Per-image results keyed by file name: method, corners, rms_px, rvec, tvec (the board pose)")
      .def_readwrite("images_not_found", &Calibration::images_not_found)
      .def_readwrite("images_total", &Calibration::images_total)
      .def_readwrite("software", &Calibration::software)
      .def_readwrite("command_line", &Calibration::command_line)
      .def("to_yaml", &CalibrationToYaml)
      .def(py::pickle(
          [](const Calibration& c) {
            py::list images;
            for (const CalibrationImage& im : c.images)
              images.append(py::make_tuple(im.file, im.method, im.corners, im.rms_px,
                                           std::vector<double>(im.rvec.data(), im.rvec.data() + 3),
                                           std::vector<double>(im.tvec.data(), im.tvec.data() + 3)));
            return py::make_tuple(py::cast(c.sensor), c.units, c.lut, c.lut_resolved, c.extras, c.comment, images,
                                  c.images_not_found, c.images_total, c.software, c.command_line);
          },
          [](const py::tuple& t) {
            if (t.size() != 11) throw py::value_error("Calibration: bad pickled state");
            Calibration c;
            c.sensor = t[0].cast<Sensor>();
            c.units = t[1].cast<std::string>();
            c.lut = t[2].cast<std::string>();
            c.lut_resolved = t[3].cast<std::string>();
            c.extras = t[4].cast<std::map<std::string, double>>();
            c.comment = t[5].cast<std::string>();
            for (const py::handle item : t[6].cast<py::list>()) {
              const py::tuple im_t = item.cast<py::tuple>();
              CalibrationImage im;
              im.file = im_t[0].cast<std::string>();
              im.method = im_t[1].cast<std::string>();
              im.corners = im_t[2].cast<int>();
              im.rms_px = im_t[3].cast<double>();
              const std::vector<double> rv = im_t[4].cast<std::vector<double>>(), tv = im_t[5].cast<std::vector<double>>();
              im.rvec = Eigen::Vector3d(rv.at(0), rv.at(1), rv.at(2));
              im.tvec = Eigen::Vector3d(tv.at(0), tv.at(1), tv.at(2));
              c.images.push_back(im);
            }
            c.images_not_found = t[7].cast<std::vector<std::string>>();
            c.images_total = t[8].cast<int>();
            c.software = t[9].cast<std::string>();
            c.command_line = t[10].cast<std::string>();
            return c;
          }))
      .def("__copy__", [](const Calibration& c) { return c; })
      .def("__deepcopy__", [](const Calibration& c, const py::dict&) { return c; }, py::arg("memo"))
      .def("__repr__", [](const Calibration& c) {
        return "<panotrack.Calibration " + std::string(MirrorModelName(c.sensor.model)) + " " +
               std::to_string(c.sensor.image_width) + "x" + std::to_string(c.sensor.image_height) + " " +
               c.units + ">";
      });

  m.def(
      "read_calibration", [](const std::filesystem::path& path) { return ReadCalibration(path.string()); }, py::arg("path"),
      "Reads and checks a calibration file; raises panotrack.Error naming the file and key");
  m.def(
      "write_calibration",
      [](const std::filesystem::path& path, const Calibration& calib) { WriteCalibration(path.string(), calib); }, py::arg("path"),
      py::arg("calibration"), "Writes a calibration file atomically");
}

}  // namespace

void BindSensor(py::module_& m) {
  BindSensorClass(m);
  BindSensorFunctions(m);
  BindCalibration(m);
}

}  // namespace pano::python
