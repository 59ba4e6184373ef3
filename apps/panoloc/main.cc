// panoloc: localise a robot through whole videos of a catadioptric camera
// against a map of landmarks, writing pose CSV files.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/error.h"
#include "pano/config.h"
#include "pipeline/panoloc.h"

namespace {

pano::Pose2 ParsePose(const std::string& text) {
  double v[3];
  char tail;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) != 3 ||
      !std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
    throw pano::Error("--init: expected x,y,theta (theta in radians), got '" + text + "'");
  return {v[0], v[1], v[2]};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "panoloc " PANO_VERSION
      ": localise a robot through videos of a catadioptric panoramic camera.\n"
      "Tracks map landmarks (corners of rectangles and boxes) frame by frame with the Panoramic\n"
      "Hough Transform (line junctions) and triangulates the pose (x, y, heading) from their\n"
      "azimuths. Writes one pose CSV per input (frame,time_s,x,y,theta_rad,status,n_landmarks,\n"
      "residual,std_x,std_y,std_theta), row by row."};
  pano::PanolocOptions o;
  std::string init, method = "junction";
  app.add_option("inputs", o.inputs,
                 "Video files (H.264 mp4...), image folders or printf patterns (frames/f_%04d.png)")
      ->required();
  app.add_option("--calib", o.calib_path, "Calibration YAML (panocalib's output)")->required();
  app.add_option("--map", o.map_path, "Map YAML of the room's landmarks")->required();
  app.add_option("--init", init,
                 "Initial pose x,y,theta (map units, radians); default: initial_pose of the "
                 "case.yaml beside the input");
  app.add_option("-o,--output", o.output, "Output pose CSV (one input)");
  app.add_option("--out-dir", o.out_dir, "Output folder: one <input>.csv per input");
  app.add_option("-j,--jobs", o.jobs, "Inputs processed in parallel (default: number of cores)");
  app.add_option("--fps", o.fps, "Frame rate for time_s (default: the video's, else 10)");
  app.add_option("--gt", o.gt,
                 "Ground-truth pose CSV: print the accuracy summary. 'auto': gt.csv beside each input");
  app.add_option("--debug-video", o.debug_video,
                 "Annotated video: predicted edges, found edge points, junctions, landmark ids");
  app.add_option("--plot", o.plot, "PNG of the map from above with the trajectory (and ground truth)");
  app.add_option("--method", method,
                 "Tracking method: junction (PH line junctions) or vertex (corner templates in the "
                 "quasi-cylindrical view)")
      ->check(CLI::IsMember({"junction", "vertex"}))
      ->capture_default_str();
  app.add_option("--search-px", o.localizer.search_px,
                 "Half-width of the linear samples: the largest expected image motion per frame (px)")
      ->capture_default_str();
  app.add_option("--min-step", o.localizer.junction.min_step,
                 "Smallest intensity step that counts as an edge (grey levels)")
      ->capture_default_str();
  app.add_flag("-q,--quiet", o.quiet, "No progress line, notes or summary");
  app.set_version_flag("--version", PANO_VERSION);
  try {
    app.parse(argc, argv);
    if (!init.empty()) o.init = ParsePose(init);
    o.localizer.method = method == "vertex" ? pano::TrackingMethod::kVertex : pano::TrackingMethod::kJunction;
    const std::vector<pano::VideoSummary> results = pano::RunPanoloc(o);
    int failed = 0;
    for (const pano::VideoSummary& s : results) {
      if (!s.ok) {
        ++failed;
        std::fprintf(stderr, "panoloc: %s\n", s.error.c_str());
        continue;
      }
      if (o.quiet) continue;
      std::printf("%s: %d frames, %d ok, %d lost, %.1f frames/s -> %s\n", s.input.c_str(), s.frames,
                  s.n_ok, s.n_lost, s.seconds > 0 ? s.frames / s.seconds : 0.0, s.output.c_str());
      if (s.has_accuracy)
        std::printf("  %s\n", pano::FormatAccuracy(s.accuracy, "units").c_str());
    }
    return failed ? 1 : 0;
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "panoloc: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "panoloc: unexpected error: %s\n", e.what());
    return 2;
  }
}
