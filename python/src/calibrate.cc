// Calibration from chessboard images: the library's Calibrate and its result.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bindings.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/core/error.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/pipeline/calibration_report.h"

namespace pano::python {

namespace {

// "auto" (panocalib's default): the profile, lens and rig faults chosen by
// error on boards left out (SelectModel), the sphere when too few.
void SetModel(const std::string& name, CalibrateOptions* o) {
  if (name == "sphere") o->model = MirrorModel::kSphere;
  else if (name == "conic") o->model = MirrorModel::kConic;
  else if (name == "asphere") o->model = MirrorModel::kAsphere;
  else if (name == "unified") o->model = MirrorModel::kUnified;
  else if (name == "auto") o->select_model = o->selection_fallback = true;
  else throw Error("model: expected sphere, conic, asphere, unified or auto, got '" + name + "'");
}

CalibrationResult RunCalibrate(const std::filesystem::path& targets_path, const std::string& model,
                               int distortion_terms, bool fit_aspect, bool fit_azimuth_offset,
                               bool ignore_known_poses, double huber_px, bool unwarp_fallback, int refine_passes,
                               double full_weight_px, int max_iterations, double max_rms_px, int num_threads,
                               bool verbose) {
  CalibrateOptions o;
  SetModel(model, &o);
  o.distortion_terms = distortion_terms;
  o.fit_aspect = fit_aspect;
  o.fit_azimuth_offset = fit_azimuth_offset;
  o.ignore_known_poses = ignore_known_poses;
  o.huber_px = huber_px;
  o.unwarp_fallback = unwarp_fallback;
  o.refine_passes = refine_passes;
  o.full_weight_px = full_weight_px;
  o.max_iterations = max_iterations;
  o.max_rms_px = max_rms_px;
  o.num_threads = num_threads;
  o.verbose = verbose;
  if (verbose) o.on_log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  o.Check();
  py::gil_scoped_release release;
  const TargetSet targets = ReadTargets(targets_path.string());
  return Calibrate(targets, LoadTargetImages(targets), o);
}

}  // namespace

void BindCalibrate(py::module_& m) {
  py::class_<ParameterEstimate>(m, "ParameterEstimate", "A fitted parameter: value and standard deviation")
      .def_readonly("name", &ParameterEstimate::name)
      .def_readonly("value", &ParameterEstimate::value)
      .def_readonly("stddev", &ParameterEstimate::stddev, "NaN: not determined by the data; 0 when fixed")
      .def_readonly("fixed", &ParameterEstimate::fixed)
      .def("__repr__", [](const ParameterEstimate& p) {
        return "<ParameterEstimate " + p.name + " = " + std::to_string(p.value) +
               (p.fixed ? " (fixed)" : " +- " + std::to_string(p.stddev)) + ">";
      });

  py::class_<CalibrationResult>(m, "CalibrationResult", "What calibrate() found")
      .def_readonly("calibration", &CalibrationResult::calib, "The fitted Calibration (with extras: std devs, RMS)")
      .def_readonly("rms_px", &CalibrationResult::rms_px,
                    "Euclidean RMS reprojection error over all corners (px), as panocalib evaluate gives it on "
                    "these images")
      .def_readonly("fit_rms_px", &CalibrationResult::fit_rms_px, "The final fit's own RMS (px)")
      .def_readonly("rms_raw_px", &CalibrationResult::rms_raw_px,
                    "The final model on the detector's corners, as evaluate --no-refine gives it (px)")
      .def_property_readonly(
          "image_rms",
          [](const CalibrationResult& r) {
            py::dict d;
            for (size_t i = 0; i < r.views.size() && i < r.image_rms.size(); ++i)
              d[py::str(r.views[i].file)] = r.image_rms[i];
            return d;
          },
          "RMS reprojection error (px) per image used, keyed by the image's file name")
      .def_property_readonly(
          "parameters",
          [](const CalibrationResult& r) {
            py::dict d;
            for (const ParameterEstimate& p : r.parameters) d[py::str(p.name)] = p;
            return d;
          },
          "dict name -> ParameterEstimate (value, stddev, fixed)")
      .def_readonly("poses_known", &CalibrationResult::poses_known)
      .def_readonly("fit_cost", &CalibrationResult::fit_cost)
      .def_readonly("not_found_files", &CalibrationResult::not_found_files, "Images where no board was found")
      .def_readonly("warnings", &CalibrationResult::warnings)
      .def_readonly("init_summary", &CalibrationResult::init_summary)
      .def_readonly("iterations", &CalibrationResult::iterations)
      .def_readonly("seconds_detect", &CalibrationResult::seconds_detect)
      .def_readonly("seconds_fit", &CalibrationResult::seconds_fit)
      .def("summary", &CalibrationSummary, "The text summary panocalib prints")
      .def(
          "write",
          [](const CalibrationResult& r, const std::filesystem::path& calibration, const std::filesystem::path& lut,
             const std::filesystem::path& report) {
            CalibrationOutputs out;
            out.calibration = calibration.string();
            out.lut = lut.string();
            out.report = report.string();
            cv::Mat report_image;
            if (!out.report.empty()) {
              report_image = DrawReport(r, cv::Mat(), WorstView(r));
            }
            py::gil_scoped_release release;
            WriteCalibrationOutputs(r, out, report_image);
          },
          py::arg("calibration"), py::arg("lut") = "", py::arg("report") = "",
          "Writes the calibration YAML and, when given, the E(D,Z) table and a report PNG, as panocalib "
          "calibrate does (the report on a grey canvas: the images are not kept)");

  const CalibrateOptions d;
  m.def("calibrate", &RunCalibrate, py::arg("targets_path"), py::kw_only(), py::arg("model") = "auto",
        py::arg("distortion_terms") = d.distortion_terms, py::arg("fit_aspect") = d.fit_aspect,
        py::arg("fit_azimuth_offset") = d.fit_azimuth_offset, py::arg("ignore_known_poses") = d.ignore_known_poses,
        py::arg("huber_px") = d.huber_px, py::arg("unwarp_fallback") = d.unwarp_fallback,
        py::arg("refine_passes") = d.refine_passes, py::arg("full_weight_px") = d.full_weight_px,
        py::arg("max_iterations") = d.max_iterations, py::arg("max_rms_px") = d.max_rms_px,
        py::arg("num_threads") = d.num_threads, py::arg("verbose") = d.verbose,
        "Calibrates the sensor from the chessboard images of a target file (panocalib calibrate); "
        "raises panotrack.Error when the calibration fails. Options as CalibrateOptions.");
}

}  // namespace pano::python
