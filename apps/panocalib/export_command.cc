// panocalib export: a calibration in another tool's format.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/pipeline/panocalib.h"

namespace pano::app {

void AddExportCommand(CLI::App& app) {
  struct Opts {
    std::string calib, out;
    bool opencv = false, force = false, quiet = false;
    OmnidirApproximationOptions omnidir;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write a calibration in OpenCV's terms (--opencv). A cv::FileStorage file (.yml, .xml or .json) "
      "with the camera matrix and distortion of the pinhole that views the mirror, the mirror, and "
      "OpenCV's omnidirectional model (cv::omnidir: K, xi, D) fitted to the sensor, with the RMS of "
      "that approximation (the mirror has no single viewpoint, so it is exact only at one distance).");
  cmd->add_option("--calib", o->calib, "Calibration YAML (panocalib calibrate's output)")->required();
  cmd->add_flag("--opencv", o->opencv, "OpenCV FileStorage output (the only format so far)")->required();
  cmd->add_option("-o,--output", o->out, "Output file: .yml, .yaml, .xml or .json")->required();
  cmd->add_option("--distance", o->omnidir.distance,
                  "Horizontal distance (calibration units) at which the omnidir model is fitted; "
                  "0: the far field (1000 mirror distances)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace an existing output file (otherwise nothing is done)");
  cmd->add_flag("-q,--quiet", o->quiet, "Print nothing but errors");
  cmd->callback([o]() {
    CheckPlannedOutputs({{"--calib", o->calib}}, {{"-o", o->out}}, o->force);
    const ExportResult r = RunExport({o->calib, o->out, o->omnidir});
    const OmnidirApproximation& om = r.omnidir;
    if (!o->quiet)
      std::printf("wrote %s: omnidir approximation xi %.4f, RMS %.3f px (max %.3f px) at distance %g %s\n",
                  o->out.c_str(), om.xi, om.rms_px, om.max_px, om.distance, r.units.c_str());
  });
}

}  // namespace pano::app
