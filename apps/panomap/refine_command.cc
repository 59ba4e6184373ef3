#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "panotrack/core/parallel.h"
#include "panotrack/pipeline/panomap.h"

namespace pano::app {

namespace {

struct Opts {
  std::string map, calib, out, report;
  std::string pose_sigma = "auto";
  std::vector<std::string> poses, videos;
  double map_sigma = RefineOptions().map_sigma, reject_sigmas = 4.0, edge_gap = 10.0, radius_systematic = 0.04;
  bool free_height = false, fix_first_pose = false, free_floor = false, force = false, quiet = false, verbose = false;
  int passes = 2, threads = 0;
};

// The adjustment's options; returns --map-sigma (whether it was given).
CLI::Option* AddAdjustmentOptions(CLI::App* cmd, Opts* o) {
  CLI::Option* map_sigma_option =
      cmd->add_option("--map-sigma", o->map_sigma,
                      "Survey error: prior sigma of each coordinate (map units); default: the map's survey_sigma "
                      "where it states one, else 1")
          ->check(CLI::PositiveNumber)
          ->capture_default_str();
  cmd->add_option("--pose-sigma", o->pose_sigma,
                  "Prior sigma of each pose's position at its CSV value (map units), 0 for none, or auto: a "
                  "tenth of --map-sigma when the pose CSVs are a reference trajectory (ground truth, motion "
                  "capture: rows without panoloc's std columns), else none. A reference fixes the shift and "
                  "turn the images cannot see better than the survey; poses localised on the surveyed map "
                  "only repeat its gauge")
      ->check(CLI::Validator(
          [](std::string& v) {
            if (v == "auto") return std::string();
            try {
              size_t used = 0;
              const double sigma = std::stod(v, &used);
              if (used == v.size() && sigma >= 0.0 && std::isfinite(sigma)) return std::string();
            } catch (const std::exception&) {
            }
            return "expected auto or a number of 0 or more, got '" + v + "'";
          },
          "auto|SIGMA"))
      ->capture_default_str();
  cmd->add_option("--reject-sigmas", o->reject_sigmas,
                  "Drop measurements beyond this many noise sigmas (a tracker locked onto another edge)")
      ->check(CLI::Range(2.5, 100.0))
      ->capture_default_str();
  cmd->add_option("--edge-gap", o->edge_gap,
                  "Skip corners whose vertical edge passes within this many pixels of another landmark's (0: "
                  "measure all)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--radius-systematic", o->radius_systematic,
                  "Systematic image-radius error of a corner (px, repeated over its frames): its radius "
                  "measurements together weigh at most like one of this sigma, so that a small bias seen in "
                  "many frames does not move the corner along its line of sight (0: none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--free-height", o->free_height,
                "Also estimate the sensor height (no prior; it then joins the gauge as a scaling)");
  cmd->add_flag("--free-floor", o->free_floor,
                "Adjust z0 of rectangles surveyed standing on the floor too (held at 0 by default)");
  cmd->add_flag("--fix-first-pose", o->fix_first_pose, "Hold the first adjusted pose at its CSV value");
  cmd->add_option("--passes", o->passes, "Track-and-solve rounds (later ones re-track at the solution)")
      ->check(CLI::Range(1, 10))
      ->capture_default_str();
  return map_sigma_option;
}

// The adjustment's options from the command line; the sigmas the job
// settles from the inputs where they were not given.
MapRefineJob RefineJobOf(const Opts& o, bool map_sigma_given) {
  MapRefineJob job;
  job.map_path = o.map;
  job.calib_path = o.calib;
  job.videos = o.videos;
  job.poses = o.poses;
  job.output = o.out;
  job.report_csv = o.report;
  if (map_sigma_given) job.map_sigma = o.map_sigma;
  if (o.pose_sigma != "auto") job.pose_sigma = std::stod(o.pose_sigma);
  RefineOptions& opt = job.options;
  opt.reject_sigmas = o.reject_sigmas;
  opt.min_edge_gap_px = o.edge_gap;
  opt.radius_systematic_px = o.radius_systematic;
  opt.free_height = o.free_height;
  opt.fix_first_pose = o.fix_first_pose;
  opt.hold_floor_contacts = !o.free_floor;
  opt.passes = o.passes;
  opt.num_threads = o.threads;
  opt.tracking.num_threads = o.threads;
  job.overwrite = o.force;
  return job;
}

// Refines the map and prints the table.
void RefineAndPrint(const Opts& o, bool map_sigma_given) {
  CheckThreadCount(o.threads, "--threads");
  const MapRefineRun run = RunMapRefine(RefineJobOf(o, map_sigma_given));
  if (o.quiet) return;
  if (o.pose_sigma == "auto") {
    if (run.options.pose_sigma > 0.0)
      std::printf("poses: a reference trajectory (no standard deviations): positions held with sigma %g "
                  "(--pose-sigma auto)\n",
                  run.options.pose_sigma);
    else
      std::printf("poses: localised (with standard deviations): no pose prior, the survey fixes the gauge "
                  "(--pose-sigma auto)\n");
  }
  std::printf("%s", RefineReportTable(run.result, run.surveyed, run.options.map_sigma).c_str());
  std::printf("wrote %s\n", o.out.c_str());
}

}  // namespace

void AddRefineCommand(CLI::App& app) {
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "refine",
      "Refine a surveyed map from video: a bundle adjustment of the landmark rectangles (each vertical, "
      "its two floor end points and two heights shared by its four corners), the robot poses (started "
      "from the pose CSVs, ok rows only) and optionally the sensor height, against the azimuth and image "
      "radius of every junction tracked at its predicted place. Each surveyed coordinate has a Gaussian "
      "prior of sigma --map-sigma; the priors (and --pose-sigma's on the poses) fix the gauge, whose "
      "uncertainty is printed. Measurements beyond --reject-sigmas are dropped. Prints each landmark's "
      "correction and its standard deviation, flagged when beyond 3 sigma of the survey.");
  cmd->add_option("--map", o->map, "Surveyed map YAML (never overwritten)")->required();
  cmd->add_option("--calib", o->calib, "Calibration YAML")->required();
  cmd->add_option("--poses", o->poses,
                  "Pose CSV of each video (panoloc's output: one row per frame), repeated in the videos' order")
      ->required()
      ->allow_extra_args(false)
      ->take_all();
  cmd->add_option("videos", o->videos, "Videos (files, image folders or printf patterns)")->required();
  cmd->add_option("-o,--output", o->out, "Refined map YAML")->required()->group("Output");
  cmd->add_option("--report", o->report, "Per-landmark corrections as CSV")->group("Output");
  cmd->add_flag("--force", o->force, "Replace existing output files")->group("Output");
  CLI::Option* map_sigma_option = AddAdjustmentOptions(cmd, o.get());
  cmd->add_option("-j,--jobs,--threads", o->threads, "Threads (0: every core)")->group("Run");
  cmd->add_flag("-q,--quiet", o->quiet, "No table (errors still on stderr)")->group("Run");
  cmd->add_flag("-v,--verbose", o->verbose, "Also the libraries' logs")->group("Run");
  cmd->callback([o, map_sigma_option]() { RefineAndPrint(*o, map_sigma_option->count() > 0); });
}

}  // namespace pano::app
