// Shared by the binding files of the _panotrack extension: numpy helpers and
// the per-area registration functions called from module.cc.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <string>
#include <vector>

#include "panotrack/core/parallel.h"

namespace pano::python {

namespace py = pybind11;

// A float64 array, C-contiguous (converted when it is not).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Rows of an (N, width) array, or N = 1 for a single (width,) vector; throws
// ValueError naming `what` otherwise.
inline py::ssize_t RowsOf(const DoubleArray& a, py::ssize_t width, const char* what) {
  if (a.ndim() == 1 && a.shape(0) == width) return 1;
  if (a.ndim() == 2 && a.shape(1) == width) return a.shape(0);
  throw py::value_error(std::string(what) + ": expected an array of shape (N, " + std::to_string(width) +
                        ") or (" + std::to_string(width) + ",), got " + std::to_string(a.ndim()) +
                        " dimension(s)" + (a.ndim() >= 1 ? " with " + std::to_string(a.shape(a.ndim() - 1)) + " last" : ""));
}

// A new float64 array of `rows` x `width`, or (width,) when the input was a
// single vector.
inline DoubleArray NewRows(py::ssize_t rows, py::ssize_t width, bool single) {
  if (single) return DoubleArray(std::vector<py::ssize_t>{width});
  return DoubleArray(std::vector<py::ssize_t>{rows, width});
}

// Loops below this many elements run on the calling thread only: starting
// the thread team costs more than they do.
constexpr py::ssize_t kParallelMinimum = 16384;

// body(i) for i in [0, n) in chunks, in parallel (ParallelFor) when n is
// large. Call with the GIL released; body must not touch Python objects.
template <typename Body>
void ForEachRow(py::ssize_t n, int num_threads, Body&& body) {
  constexpr py::ssize_t kChunk = 4096;
  const py::ssize_t chunks = (n + kChunk - 1) / kChunk;
  ParallelFor(
      static_cast<int>(chunks),
      [&](int c) {
        const py::ssize_t begin = c * kChunk, end = std::min(n, begin + kChunk);
        for (py::ssize_t i = begin; i < end; ++i) body(i);
      },
      n >= kParallelMinimum, num_threads);
}

void BindSensor(py::module_& m);
void BindMap(py::module_& m);
void BindCalibrate(py::module_& m);
void BindLocalize(py::module_& m);

}  // namespace pano::python
