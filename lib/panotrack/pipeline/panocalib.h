// panocalib's jobs over files: calibrate, evaluate, export, tilt, the
// batch projections and the lookup table, each
// one function the program calls with the options it parsed. They read the
// inputs, guard the outputs (core/output_check.h), run the library's
// algorithm and write every output atomically; printing is the caller's.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "panotrack/calibrate/batch_projection.h"
#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/evaluate.h"
#include "panotrack/calibrate/export_opencv.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/pipeline/sensor_tilt.h"
#include "panotrack/pipeline/target_input.h"

namespace pano {

// Output paths of `panocalib calibrate`; empty: not written.
struct CalibrationOutputs {
  std::string calibration;  // YAML (README, "Files and conventions")
  std::string lut;          // E(D,Z) table, referenced from the YAML
  std::string report;       // PNG
  std::string summary_json; // the summary as JSON (CalibrationSummaryJson); "-": standard output
  std::vector<std::string> command_line;  // recorded in the calibration and the summary JSON
};
// Writes every output atomically; all are prepared (LUT built, PNG encoded)
// before the first file is written, so a failure leaves no partial output.
void WriteCalibrationOutputs(const CalibrationResult& result, const CalibrationOutputs& out,
                             const cv::Mat& report_image);
// Text summary (parameters with standard deviations, RMS, per-image RMS,
// the model chosen, warnings).
std::string CalibrationSummary(const CalibrationResult& result);

// The files of a job under the names its messages give them (the program's
// options, e.g. {"--calib", path}), for the output guard: no output may be
// one of the files the job reads.
struct NamedFiles {
  NamedPaths inputs;
  NamedPaths outputs;
};

// panocalib calibrate: the board images (pipeline/target_input.h), the fit
// (calibrate/calibrate.h), the report drawn over the worst image, and the
// outputs.
struct CalibrateJob {
  std::string targets;      // target file, folder of images or video
  TargetInputBoard board;   // the board of a folder or a video
  CalibrateOptions options;
  CalibrationOutputs outputs;  // outputs.calibration is required
  NamedFiles names;            // outputs named for the guard (the inputs are found from `targets`)
};
// Throws pano::Error (nothing written) when the input cannot be read, an
// output is one of its files, or the calibration fails.
CalibrationResult RunCalibrate(const CalibrateJob& job);

// panocalib evaluate: a fixed calibration on board images, each board's pose
// fitted (calibrate/evaluate.h); the figures written as JSON when asked.
struct EvaluateJob {
  std::string calibration;  // calibration YAML
  std::string targets;      // as CalibrateJob::targets
  TargetInputBoard board;
  EvaluateOptions options;
  std::string summary_json;  // "-": standard output; empty: none
  std::vector<std::string> command_line;  // recorded in the JSON
  NamedFiles names;
};
EvaluationResult RunEvaluate(const EvaluateJob& job);

// panocalib export --opencv: the calibration in OpenCV's terms with the
// omnidir model fitted to the sensor.
struct ExportJob {
  std::string calibration;  // calibration YAML
  std::string output;       // cv::FileStorage file (.yml, .xml, .json)
  OmnidirApproximationOptions omnidir;
};
struct ExportResult {
  OmnidirApproximation omnidir;
  std::string units;  // the calibration's
};
ExportResult RunExport(const ExportJob& job);

// panocalib tilt: the sensor's tilt (and with fit_decentre the mirror's
// offset) measured from a video in a mapped room (pipeline/sensor_tilt.h),
// written into a copy of the calibration.
struct TiltJob {
  std::string calibration;  // calibration YAML
  std::string map;          // map YAML, in the calibration's units
  std::string input;        // video, image folder or pattern
  std::string output;       // the calibration with the tilt
  SensorTiltOptions tilt;
};
struct TiltResult {
  SensorTiltResult measured;
  Calibration calibration;  // as written
};
TiltResult RunTilt(const TiltJob& job);

// panocalib project --points and backproject --pixels: a file (or standard
// input) of points or pixels through a calibration file, one output line
// per input line (calibrate/batch_projection.h), written only after every
// line was read.
struct BatchProjectionJob {
  std::string calibration;  // calibration YAML
  std::string input;        // "-": standard input
  std::string output;       // "-" or empty: standard output
  bool overwrite = false;   // replace an existing output
};
BatchProjection RunProjectPoints(const BatchProjectionJob& job);
BatchProjection RunBackprojectPixels(const BatchProjectionJob& job);

// panocalib lut: the E(D,Z) table of a calibration, covering a map's room
// and landmarks when one is given (else the default ranges).
struct LutJob {
  std::string calibration, map, output;  // map: empty for the default ranges
  int size = 1024;                       // nodes along each axis of the forward table
  bool overwrite = false;
};
struct LutResult {
  LutRanges ranges;
  std::string units;  // the calibration's
};
LutResult RunLut(const LutJob& job);

}  // namespace pano
