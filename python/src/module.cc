// The _panotrack extension: panotrack's sensor model, files, calibration and
// localisation for Python (re-exported by the panotrack package).
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "panotrack/core/error.h"

PYBIND11_MODULE(_panotrack, m) {
  namespace py = pybind11;
  m.doc() = "panotrack: localisation with catadioptric panoramic cameras (C++ extension)";
  // The package refuses numpy 2 with a pybind11 older than 2.12, which
  // returns corrupted arrays there instead of failing.
  m.attr("pybind11_version") = py::make_tuple(PYBIND11_VERSION_MAJOR, PYBIND11_VERSION_MINOR);
  // pano::Error keeps its one-line message; a subclass of RuntimeError so
  // that generic handlers catch it too.
  py::register_exception<pano::Error>(m, "Error", PyExc_RuntimeError);
  pano::python::BindSensor(m);
  pano::python::BindMap(m);
  pano::python::BindCalibrate(m);
  pano::python::BindLocalize(m);
}
