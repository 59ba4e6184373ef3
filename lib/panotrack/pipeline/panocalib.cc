#include "panotrack/pipeline/panocalib.h"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <sstream>

#include "panotrack/calibrate/model_selection.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/command_line.h"
#include "panotrack/core/error.h"
#include "panotrack/io/map.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/pipeline/calibration_json.h"
#include "panotrack/pipeline/calibration_report.h"

namespace pano {

std::string CalibrationSummary(const CalibrationResult& r) {
  std::ostringstream o;
  const Sensor& s = r.calib.sensor;
  o << "model " << MirrorModelName(s.model) << ", " << s.image_width << "x" << s.image_height << " px, "
    << r.views.size() << " boards used, board poses " << (r.poses_known ? "known" : "estimated") << "\n";
  char line[256];
  for (const ParameterEstimate& p : r.parameters) {
    if (p.fixed)
      std::snprintf(line, sizeof line, "  %-17s %14.6g   (fixed)\n", p.name.c_str(), p.value);
    else if (std::isfinite(p.stddev))
      std::snprintf(line, sizeof line, "  %-17s %14.6g +- %.3g\n", p.name.c_str(), p.value, p.stddev);
    else
      std::snprintf(line, sizeof line, "  %-17s %14.6g   (not determined)\n", p.name.c_str(), p.value);
    o << line;
  }
  if (s.params.rim_radius > 0)
    o << "  rim_radius        " << s.params.rim_radius << " (set to cover the image; not fitted)\n";
  if (std::isfinite(r.fit_rms_px))
    std::snprintf(line, sizeof line,
                  "RMS reprojection error %.4f px over %d boards (%s, each board's pose refitted: `panocalib "
                  "evaluate`%s on these images; the fit's own %.4f px)\n",
                  r.rms_px, r.boards_scored,
                  r.corners_refined ? "corners refined through the final model" : "the detector's corners",
                  r.corners_refined ? "" : " --no-refine", r.fit_rms_px);
  else
    std::snprintf(line, sizeof line,
                  "RMS reprojection error %.4f px over %zu boards (corners refined through the model)\n", r.rms_px,
                  r.views.size());
  o << line;
  if (std::isfinite(r.rms_raw_px)) {
    std::snprintf(line, sizeof line,
                  "RMS reprojection error %.4f px on the detector's corners over %d boards (poses refitted; "
                  "`panocalib evaluate --no-refine` on these images)\n",
                  r.rms_raw_px, r.raw_boards);
    o << line;
  }
  if (!r.limb.Empty()) {
    std::snprintf(line, sizeof line, "mirror limb: %zu points from %d images, RMS %.4f px (a point's sigma %.3f px)\n",
                  r.limb.points.size(), r.limb.images_used, r.limb_rms_px, r.limb.point_sigma_px);
    o << line;
  }
  for (size_t i = 0; i < r.views.size(); ++i) {
    std::snprintf(line, sizeof line, "  %-24s %8.4f px  (%s)\n", r.views[i].file.c_str(), r.image_rms[i],
                  r.views[i].method.c_str());
    o << line;
  }
  if (!r.not_found_files.empty()) {
    o << "no board found (skipped):";
    for (const std::string& f : r.not_found_files) o << " " << f;
    o << "\n";
  }
  if (!r.model_scores.empty()) {
    o << ModelSelectionTable(r.model_scores, r.model_chosen);
    if (!r.model_reason.empty()) o << "chosen: " << r.model_reason << "\n";
  }
  std::snprintf(line, sizeof line, "time: detection %.2f s, fit %.2f s\n", r.seconds_detect, r.seconds_fit);
  o << line;
  for (const std::string& w : r.warnings) o << "warning: " << w << "\n";
  return o.str();
}

void WriteCalibrationOutputs(const CalibrationResult& result, const CalibrationOutputs& out,
                             const cv::Mat& report_image) {
  namespace fs = std::filesystem;
  if (out.calibration.empty()) throw Error("-o: an output calibration file is required");
  Calibration calib = result.calib;
  calib.sensor.Check(out.calibration);
  // Prepare everything before writing anything.
  RadiusTable table;
  if (!out.lut.empty()) {
    table = RadiusTable::Build(calib.sensor, DefaultRanges(calib.sensor));
    const fs::path cal_dir = fs::absolute(fs::path(out.calibration)).parent_path();
    const fs::path lut_abs = fs::absolute(fs::path(out.lut));
    calib.lut = lut_abs.lexically_relative(cal_dir).string();
    if (calib.lut.empty()) calib.lut = lut_abs.string();
  }
  std::vector<uchar> png;
  if (!out.report.empty()) {
    if (report_image.empty()) throw Error(out.report + ": no report image to write");
    if (!cv::imencode(".png", report_image, png)) throw Error(out.report + ": cannot encode the report PNG");
  }
  const std::string yaml = CalibrationToYaml(calib);
  const std::string json = out.summary_json.empty() ? "" : CalibrationSummaryJson(result, out, out.command_line);
  // The summary's folder exists (a file there is replaced atomically).
  if (!out.summary_json.empty() && out.summary_json != "-") {
    const fs::path dir = fs::absolute(fs::path(out.summary_json)).parent_path();
    if (!fs::is_directory(dir)) throw Error(out.summary_json + ": no such folder " + dir.string());
  }
  if (!out.lut.empty()) table.Save(out.lut);
  if (!out.report.empty()) {
    AtomicFile f(out.report);
    f.Write(png.data(), png.size());
    f.Commit();
  }
  WriteFileAtomic(out.calibration, yaml);
  if (!out.summary_json.empty()) WriteFileOrStdout(out.summary_json, json, "--summary-json");
}

namespace {

std::string ReadInput(const std::string& path) {
  if (path != "-") return ReadFile(path);
  std::string text{std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>()};
  if (std::cin.bad()) throw Error("standard input: read failed");
  return text;
}

std::string SourceName(const std::string& path) { return path == "-" ? "<stdin>" : path; }

void WriteOutput(const std::string& path, const std::string& text) {
  WriteFileOrStdout(path.empty() ? "-" : path, text, "-o");
}

// The board input of a job, its files checked against the job's outputs.
TargetSet ReadGuardedTargets(const std::string& path, const TargetInputBoard& board, const NamedFiles& names) {
  const TargetSet targets = ReadTargetInput(path, board);
  // The board images are known once the target file is read.
  NamedPaths reads = TargetInputReads(path, targets);
  reads.insert(reads.end(), names.inputs.begin(), names.inputs.end());
  CheckOutputsDistinct(reads, names.outputs);
  return targets;
}

}  // namespace

CalibrationResult RunCalibrate(const CalibrateJob& job) {
  const TargetSet targets = ReadGuardedTargets(job.targets, job.board, job.names);
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  CalibrationResult r = Calibrate(targets, images, job.options);
  r.calib.command_line = ShellCommandLine(job.outputs.command_line);
  cv::Mat report;
  if (!job.outputs.report.empty()) {
    const int worst = WorstView(r);
    const cv::Mat& im = r.views.empty() ? cv::Mat() : images[r.views[worst].image_index];
    report = DrawReport(r, im, worst);
  }
  WriteCalibrationOutputs(r, job.outputs, report);
  return r;
}

EvaluationResult RunEvaluate(const EvaluateJob& job) {
  job.options.Check();
  const Calibration calib = ReadCalibration(job.calibration);
  const TargetSet targets = ReadGuardedTargets(job.targets, job.board, job.names);
  const std::vector<cv::Mat> images = LoadTargetImages(targets);
  const EvaluationResult r = EvaluateCalibration(targets, images, calib, job.options);
  if (!job.summary_json.empty())
    WriteFileOrStdout(job.summary_json, EvaluationSummaryJson(r, job.command_line), "--summary-json");
  return r;
}

ExportResult RunExport(const ExportJob& job) {
  const Calibration c = ReadCalibration(job.calibration);
  ExportResult r;
  r.omnidir = FitOmnidirApproximation(c.sensor, job.omnidir);
  r.units = c.units;
  WriteOpenCvCalibration(job.output, c, r.omnidir);
  return r;
}

TiltResult RunTilt(const TiltJob& job) {
  job.tilt.Check();
  TiltResult r;
  r.calibration = ReadCalibration(job.calibration);
  const Map map = ReadMap(job.map);
  if (r.calibration.units != map.units)
    throw Error(job.map + ": units '" + map.units + "' differ from the calibration's '" + r.calibration.units + "'");
  r.measured = EstimateSensorTilt(r.calibration, map, job.input, job.tilt);
  RigFaults<double>& faults = r.calibration.sensor.faults;
  faults.sensor_tilt[0] = r.measured.tilt[0];
  faults.sensor_tilt[1] = r.measured.tilt[1];
  faults.mirror_offset[0] = r.measured.mirror_offset[0];
  faults.mirror_offset[1] = r.measured.mirror_offset[1];
  WriteCalibration(job.output, r.calibration);
  return r;
}

namespace {

// The batch jobs' file form: `project` (ProjectPointsCsv or
// BackprojectPixelsCsv) on the input's text, the input named by its option.
BatchProjection RunBatchProjection(const BatchProjectionJob& job, const char* input_option,
                                   BatchProjection (*project)(const Sensor&, const std::string&, const std::string&)) {
  CheckPlannedOutputs({{"--calib", job.calibration}, {input_option, job.input}}, {{"-o", job.output}}, job.overwrite);
  const Calibration c = ReadCalibration(job.calibration);
  const BatchProjection b = project(c.sensor, ReadInput(job.input), SourceName(job.input));
  WriteOutput(job.output, b.text);
  return b;
}

}  // namespace

BatchProjection RunProjectPoints(const BatchProjectionJob& job) {
  return RunBatchProjection(job, "--points", ProjectPointsCsv);
}

BatchProjection RunBackprojectPixels(const BatchProjectionJob& job) {
  return RunBatchProjection(job, "--pixels", BackprojectPixelsCsv);
}

LutResult RunLut(const LutJob& job) {
  CheckPlannedOutputs({{"--calib", job.calibration}, {"--map", job.map}}, {{"-o", job.output}}, job.overwrite);
  const Calibration c = ReadCalibration(job.calibration);
  LutResult r;
  r.ranges = job.map.empty() ? DefaultRanges(c.sensor) : RangesForMap(ReadMap(job.map), c.sensor);
  r.units = c.units;
  LutSize size;
  size.n_distance = size.n_elevation = size.n_radius = job.size;
  RadiusTable::Build(c.sensor, r.ranges, size).Save(job.output);
  return r;
}

}  // namespace pano
