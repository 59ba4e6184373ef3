// panocalib unwarp: a cylindrical panorama or a perspective view of a raw
// image through a calibration (lib/panotrack/unwarp).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/pipeline/unwarp_files.h"

namespace pano::app {

namespace {

// "WxH" with both sides positive.
// A flag's value as typed in messages.
std::string Num(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

void ParseSize(const std::string& text, int* width, int* height) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 2 || h < 2)
    throw Error("--size: expected WxH (e.g. 1600x400, each side at least 2), got '" + text + "'");
  *width = w;
  *height = h;
}

}  // namespace

void AddUnwarpCommand(CLI::App& app) {
  struct Opts {
    std::string calib, image, out, size;
    bool panorama = false, perspective = false, clockwise = false, force = false, quiet = false;
    double distance = 0.0, yaw = 0.0, pitch = 0.0, fov = 60.0;
    std::vector<double> elevation;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "unwarp",
      "Unwarp a raw image into a cylindrical panorama (columns: azimuth 0..360 deg counter-clockwise from the "
      "sensor's +x, rows: elevation) or a perspective view. The mirror has no single viewpoint: the view is exact "
      "for points at --distance (on the cylinder of that radius, or the plane at that depth); default infinitely "
      "far.");
  cmd->add_option("--calib", o->calib, "Calibration YAML")->required();
  cmd->add_option("input", o->image,
                  "Raw image of the calibration's size; with a video output, a video, image folder or pattern")
      ->required();
  cmd->add_option("-o,--output", o->out,
                  "Output image (.png, .jpg, .tif...), or video (.mp4, .avi, .mkv, .mov: every frame, grey)")
      ->required();
  CLI::Option* pano = cmd->add_flag("--panorama", o->panorama, "Cylindrical panorama (the default)");
  CLI::Option* persp =
      cmd->add_flag("--perspective", o->perspective, "Perspective view (--yaw, --pitch, --fov)")->excludes(pano);
  cmd->add_option("--size", o->size,
                  "View size WxH (default: panorama 2 pi x the mirror's outer image radius wide, square pixels in "
                  "angle; perspective 640x480)");
  cmd->add_option("--distance", o->distance,
                  "Radius of the panorama's cylinder or depth of the perspective plane, calibration units (0: "
                  "infinitely far)")
      ->capture_default_str();
  cmd->add_option("--elevation", o->elevation,
                  "Panorama: MIN,MAX elevation of the bottom and top rows, degrees (default: what the mirror sees)")
      ->delimiter(',')
      ->allow_extra_args(false)  // one token: a positional after it stays positional
      ->expected(2)
      ->excludes(persp);
  cmd->add_flag("--clockwise", o->clockwise,
                "Panorama: columns clockwise (reads as seen from inside, not mirror-reversed)")
      ->excludes(persp);
  cmd->add_option("--yaw", o->yaw, "Perspective: bearing of the optical axis, degrees counter-clockwise from +x")
      ->capture_default_str()
      ->needs(persp);
  cmd->add_option("--pitch", o->pitch, "Perspective: elevation of the optical axis, degrees")
      ->capture_default_str()
      ->needs(persp);
  cmd->add_option("--fov", o->fov, "Perspective: horizontal field of view, degrees")->capture_default_str()->needs(persp);
  cmd->add_flag("--force", o->force, "Replace an existing output file (otherwise nothing is done)");
  cmd->add_flag("-q,--quiet", o->quiet, "Print nothing but errors");
  cmd->callback([o]() {
    UnwarpOptions opt;
    opt.kind = o->perspective ? UnwarpKind::kPerspective : UnwarpKind::kPanorama;
    if (!o->size.empty()) ParseSize(o->size, &opt.width, &opt.height);
    // The flags under their own names (UnwarpOptions::Check names its fields).
    if (!o->size.empty() && !(opt.width >= 2 && opt.width <= 65536 && opt.height >= 2 && opt.height <= 65536))
      throw Error("--size: expected WxH of 2..65536 pixels each, got " + o->size);
    if (!(o->distance >= 0))
      throw Error("--distance: expected a distance >= 0 (0: infinitely far), got " + Num(o->distance));
    if (!o->elevation.empty() && !(o->elevation[0] < o->elevation[1]))
      throw Error("--elevation: expected MIN,MAX with MIN below MAX (degrees), got " + Num(o->elevation[0]) + "," +
                  Num(o->elevation[1]));
    if (o->perspective && !(o->fov > 0 && o->fov <= 170))
      throw Error("--fov: expected 0 < fov <= 170 degrees, got " + Num(o->fov));
    opt.distance = o->distance;
    if (!o->elevation.empty()) {
      opt.min_elevation_deg = o->elevation[0];
      opt.max_elevation_deg = o->elevation[1];
    }
    opt.clockwise = o->clockwise;
    opt.yaw_deg = o->yaw;
    opt.pitch_deg = o->pitch;
    opt.fov_deg = o->fov;
    const UnwarpResult run = RunUnwarp({o->calib, o->image, o->out, opt, o->force});
    const UnwarpView& view = run.view;
    const int frames = run.frames;
    if (o->quiet) return;
    std::string written = o->out;
    if (frames >= 0) written += " (" + std::to_string(frames) + " frames)";
    char distance[64] = "infinitely far";
    if (opt.distance > 0.0) std::snprintf(distance, sizeof distance, "distance %g", opt.distance);
    if (view.kind() == UnwarpKind::kPanorama)
      std::printf("wrote %s: panorama %dx%d, elevation %.2f..%.2f deg, eye %.4g above the pinhole, %s\n",
                  written.c_str(), view.width(), view.height(), view.min_elevation() * 180 / M_PI,
                  view.max_elevation() * 180 / M_PI, view.eye_height(), distance);
    else
      std::printf("wrote %s: perspective %dx%d, yaw %.2f pitch %.2f fov %.2f deg (focal %.2f px), eye %.4g above "
                  "the pinhole, %s\n",
                  written.c_str(), view.width(), view.height(), opt.yaw_deg, opt.pitch_deg, opt.fov_deg,
                  view.focal_px(), view.eye_height(), distance);
  });
}

}  // namespace pano::app
