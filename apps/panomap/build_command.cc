// panomap build: grow a map from video (lib/panotrack/mapping/build.h).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/pipeline/panomap.h"

namespace pano::app {

void AddBuildCommand(CLI::App& app) {
  struct Opts {
    MapBuildJob job;
    std::vector<double> start;
    bool quiet = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "build",
      "Grow a map from video: with poses from --poses (or localised with the seed map from --start), the "
      "vertical edges the seed does not explain are triangulated over the run (rays on the floor from each "
      "pose, refined by least squares on their bearings), their heights read from their extent in the image, "
      "and pairs of edges with matching heights whose horizontal edges the images show become new rectangles "
      "(new ids, shade unknown; the seed is kept unchanged). Prints how many candidate edges were found, "
      "accepted and rejected and why, and each new rectangle's std. Polish the result with 'panomap refine'.");
  cmd->add_option("--map", o->job.map_path, "Seed map YAML (a few measured landmarks; never overwritten)")->required();
  cmd->add_option("--calib", o->job.calib_path, "Calibration YAML of the camera")->required();
  cmd->add_option("input", o->job.input, "Video, image folder or printf pattern")->required();
  AddPoseOption(cmd, "--start", &o->start, "The first frame's pose x,y,theta (map units, radians) for localising");
  cmd->add_option("--poses", o->job.poses_path,
                  "Pose CSV with one row per frame (panoloc's output or panosim's gt.csv); lost rows are skipped");
  cmd->add_option("-o,--output", o->job.output, "Grown map YAML")->required()->group("Output");
  cmd->add_option("--report", o->job.report_csv, "Per-candidate-edge figures as CSV")->group("Output");
  cmd->add_flag("--force", o->job.overwrite, "Replace existing output files")->group("Output");
  cmd->add_option("--min-views", o->job.options.min_views, "Frames that must see an accepted edge")
      ->capture_default_str();
  cmd->add_option("--min-parallax", o->job.options.min_parallax_deg,
                  "Smallest spread (degrees) of an edge's viewing directions")
      ->capture_default_str();
  cmd->add_option("--max-std", o->job.options.max_std_fraction,
                  "Largest position std of an accepted edge, as a fraction of the map's size")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--min-score", o->job.options.min_horizontal_score,
                  "Fraction of a new rectangle's horizontal edge samples that must show the step")
      ->capture_default_str();
  cmd->add_option("--id-prefix", o->job.options.id_prefix, "Ids of the new rectangles: PREFIX1, PREFIX2...")
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the counts");
  cmd->add_flag("-v,--verbose", "Print the libraries' logs");
  cmd->callback([o]() {
    if (!o->start.empty()) {
      o->job.start = Pose2{o->start[0], o->start[1], o->start[2]};
      o->job.has_start = true;
    }
    const MapBuildResult r = RunMapBuild(o->job);
    std::string text = FormatMapBuildReport(r);
    if (o->quiet) text = text.substr(0, text.find("\n\n") + 1);
    std::fputs(text.c_str(), stdout);
    std::printf("wrote %s\n", o->job.output.c_str());
  });
}

}  // namespace pano::app
