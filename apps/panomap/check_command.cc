// panomap check: the map against video of the room (lib/panotrack/mapping).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/pipeline/panomap.h"

namespace pano::app {

void AddCheckCommand(CLI::App& app) {
  struct Opts {
    MapCheckJob job;
    std::vector<double> pose;
    bool quiet = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "check",
      "Check a map against video (or an image) of the room. Each frame's landmarks are predicted from its pose "
      "(--pose, --poses, or else localised with the map) and looked for near their predicted edges. Prints, per "
      "vertical edge of the map, how often it was in view and found, whether its step has the polarity the map's "
      "shades imply, and its bearing residual (measured minus predicted, degrees); then the findings: never "
      "found (not in the room, or moved), wrong polarity (shade inverted), biased (corner mis-measured), not in "
      "the map (a rectangle the images show that the map lacks, found as panomap build finds new ones; near a "
      "mapped rectangle with a finding it says where that one stands instead). Without "
      "poses, each object's residuals are measured from the pose solved from the other objects' bearings, so a "
      "mis-measured corner cannot pull the pose. Findings are results: the exit status is 0 once the map was "
      "checked.");
  cmd->add_option("--map", o->job.map_path, "Map YAML to check")->required();
  cmd->add_option("--calib", o->job.calib_path, "Calibration YAML of the camera")->required();
  cmd->add_option("input", o->job.input, "Video, image folder, printf pattern or one image")->required();
  AddPoseOption(cmd, "--pose", &o->pose, "The camera's pose x,y,theta (map units, radians) for every frame");
  cmd->add_option("--poses", o->job.poses_path,
                  "Pose CSV with one row per frame (panoloc's output or panosim's gt.csv); lost rows are skipped");
  cmd->add_option("-o,--output", o->job.overlay,
                  "Predicted edges drawn on the frames, coloured by status: .png/.jpg (the frame with the most "
                  "edges in view) or a video such as .mp4 (every frame)");
  cmd->add_option("--report", o->job.report_csv, "Per-edge figures as CSV");
  cmd->add_option("--search", o->job.options.search_px, "Half-width (px) searched across each predicted edge")
      ->check(CLI::Range(0.5, 2000.0))
      ->capture_default_str();
  cmd->add_option("--min-found", o->job.options.min_found_fraction,
                  "Edges found in fewer than this fraction of the frames that show them are 'never found'")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--bias-floor", o->job.options.bias_floor_deg,
                  "Smallest mean bearing residual (degrees) reported as biased")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--bias-survey-sigmas", o->job.options.bias_survey_sigmas,
                  "When the map states a survey_sigma: a corner is reported biased only when off by more than "
                  "this many survey sigmas across the line of sight")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--no-unmapped", [o](int64_t) { o->job.options.find_unmapped = false; },
                "Do not look for rectangles that the map lacks (most of the check's time on a long video)");
  cmd->add_flag("--force", o->job.overwrite, "Replace existing output files");
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the findings");
  cmd->add_flag("-v,--verbose", "Print the libraries' logs");
  cmd->callback([o]() {
    if (!o->pose.empty()) o->job.pose = Pose2{o->pose[0], o->pose[1], o->pose[2]};
    const MapCheckReport report = RunMapCheck(o->job);
    if (o->quiet) {
      for (const ObjectFinding& f : report.findings) std::printf("%s\n", f.message.c_str());
    } else {
      std::fputs(FormatMapCheckTable(report).c_str(), stdout);
    }
  });
}

}  // namespace pano::app
