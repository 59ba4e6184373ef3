// panocalib tilt: the sensor's tilt from the robot's vertical, measured from
// a video in a mapped room (pipeline/sensor_tilt.h).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/video/frame_source.h"

namespace pano::app {

namespace {

// A flag's value as typed in messages.
std::string Num(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

}  // namespace

void AddTiltCommand(CLI::App& app) {
  struct Opts {
    std::string calib, map, input, output;
    std::vector<double> init;
    SensorTiltOptions tilt;
    bool force = false, quiet = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "tilt",
      "Measure the sensor's tilt from the robot's vertical (sensor_tilt) from a video taken in a mapped "
      "room (the robot turning on the spot, or driving about), and write the calibration with it. A "
      "tilted mirror makes the bearings of a frame disagree; the tilt is the one under which the tracked "
      "frames fit best (their mean RMS bearing residual, minimised by Nelder-Mead, each trial tracking "
      "the frames). What the board calibration left of the mirror's misalignment is taken in too. Fails "
      "(exit 1) when too few frames are tracked with any tilt tried.");
  cmd->add_option("--calib", o->calib, "Calibration YAML (read; its sensor_tilt is the starting point)")->required();
  cmd->add_option("--map", o->map, "Map of the room (YAML)")->required();
  cmd->add_option("input", o->input, "Video (or image folder) taken in the room")->required();
  cmd->add_option("-o,--output", o->output, "Calibration YAML to write (with sensor_tilt)")->required();
  AddPoseOption(cmd, "--init", &o->init,
                "The pose x,y,theta at the first frame (map units, radians); default: initial_pose of the "
                "case.yaml beside the input, else the room-wide search");
  cmd->add_option("--frames", o->tilt.max_frames, "Frames used, from the start");
  cmd->add_flag("--decentre", o->tilt.fit_decentre,
                "Also refit the mirror's offset from the camera's axis (mirror_offset), which boards with "
                "unknown poses determine least well");
  cmd->add_option("--step", o->tilt.search_deg, "First step of the search (degrees)");
  cmd->add_option("--tolerance", o->tilt.tolerance_deg, "Stop when the search's steps are this small (degrees)");
  cmd->add_option("--max-trials", o->tilt.max_trials, "Tracking runs at most");
  cmd->add_flag("--force", o->force, "Replace an existing output file");
  cmd->add_flag("-q,--quiet", o->quiet, "No progress or result lines (errors still on stderr)");
  cmd->parse_complete_callback([o]() {
    NamedPaths reads = FrameSource::InputReads(o->input);
    reads.insert(reads.end(), {{"--calib", o->calib}, {"--map", o->map}});
    CheckPlannedOutputs(reads, {{"--output", o->output}}, o->force);
  });
  cmd->callback([o]() {
    SensorTiltOptions opt = o->tilt;
    if (o->init.size() == 3) opt.init = Pose2{o->init[0], o->init[1], o->init[2]};
    else opt.init = InitialPoseBeside(o->input);
    // The flags under their own names (SensorTiltOptions::Check names its fields).
    if (opt.max_frames < 5) throw Error("--frames: expected 5 or more, got " + std::to_string(opt.max_frames));
    if (!(opt.search_deg > 0)) throw Error("--step: expected a positive angle (degrees), got " + Num(opt.search_deg));
    if (!(opt.tolerance_deg > 0 && opt.tolerance_deg < opt.search_deg))
      throw Error("--tolerance: expected a positive angle below --step (" + Num(opt.search_deg) + " degrees), got " +
                  Num(opt.tolerance_deg));
    if (opt.max_trials < 3) throw Error("--max-trials: expected 3 or more, got " + std::to_string(opt.max_trials));
    const bool quiet = o->quiet;
    opt.on_trial = [quiet](int trials, const double* tilt, double residual) {
      if (!quiet)
        std::fprintf(stderr, "\rpanocalib: tilt: trial %d, best %.3f, %.3f deg (residual %.2e rad)   ", trials,
                     tilt[0] * 180 / M_PI, tilt[1] * 180 / M_PI, residual);
    };
    const TiltResult run = RunTilt({o->calib, o->map, o->input, o->output, opt});
    if (!quiet) std::fprintf(stderr, "\n");
    const SensorTiltResult& r = run.measured;
    const Calibration& calib = run.calibration;
    if (quiet) return;
    std::printf("sensor_tilt: %.4f, %.4f deg (about x, then y)\n", r.tilt[0] * 180 / M_PI, r.tilt[1] * 180 / M_PI);
    if (o->tilt.fit_decentre)
      std::printf("mirror_offset: %.4f, %.4f %s\n", r.mirror_offset[0], r.mirror_offset[1], calib.units.c_str());
    std::printf("frames: %d; tracked %d before, %d after\n", r.frames, r.tracked_before, r.tracked_after);
    std::printf("mean RMS bearing residual: %.3e rad before, %.3e rad after (%d tracking trials)\n",
                r.residual_before, r.residual_after, r.trials);
    std::printf("wrote %s\n", o->output.c_str());
  });
}

}  // namespace pano::app
