// panosim: catadioptric ray tracer for test sequences and calibration images
// with exact ground truth. Thin front end over lib/render.
#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/calibration.h"
#include "io/map.h"
#include "render/presets.h"
#include "render/render.h"
#include "render/targets_render.h"
#include "render/writers.h"

namespace {

std::vector<double> ParseNumbers(const std::string& text, size_t n, const std::string& option,
                                 const std::string& expected) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string f;
  while (std::getline(ss, f, ',')) {
    char* end = nullptr;
    const double v = std::strtod(f.c_str(), &end);
    if (end == f.c_str() || *end != '\0' || !std::isfinite(v))
      throw pano::Error(option + ": '" + f + "' is not a number (expected " + expected + ")");
    out.push_back(v);
  }
  if (out.size() != n) throw pano::Error(option + ": expected " + expected + ", got '" + text + "'");
  return out;
}

// Render options given on the command line; each overrides a preset's value
// only when given.
struct RenderFlags {
  int supersample = 3;
  double noise = 0.0;
  bool blur = false;
  double gradient = 0.0;
  double gradient_angle = 0.0;
  bool no_distractors = false;
  double camera_radius = 0.0;
  unsigned long long seed = 1;
  std::vector<CLI::Option*> opts;
  CLI::Option *o_ss, *o_noise, *o_blur, *o_grad, *o_grad_angle, *o_nodis, *o_cam, *o_seed;

  void Add(CLI::App* app, bool scene) {
    o_ss = app->add_option("--supersample", supersample, "Rays per pixel side: s x s subsamples per pixel (1..8)")
               ->default_val(3);
    o_noise = app->add_option("--noise", noise, "Gaussian noise sigma in grey levels (0..255 scale)")->default_val(0);
    o_seed = app->add_option("--seed", seed, "Seed of all randomness (noise; --auto board poses)")->default_val(1);
    if (!scene) return;
    o_blur = app->add_flag("--blur", blur, "3 x 3 box blur (before the noise)");
    o_grad = app->add_option("--gradient", gradient,
                             "Smooth illumination change: +-G relative across the scene (0 <= G < 1)")
                 ->default_val(0);
    o_grad_angle = app->add_option("--gradient-angle", gradient_angle,
                                   "Direction of the illumination gradient, radians from world +x")
                       ->default_val(0);
    o_nodis = app->add_flag("--no-distractors", no_distractors, "Do not render the map's distractor panels");
    o_cam = app->add_option("--camera-radius", camera_radius,
                            "Image radius (px) of a black disc at the centre: the camera's own reflection")
                ->default_val(0);
  }
  void Apply(pano::RenderOptions* o, bool scene) const {
    if (o_ss->count()) o->supersample = supersample;
    if (o_noise->count()) o->noise_sigma = noise;
    if (o_seed->count()) o->seed = seed;
    if (!scene) return;
    if (o_blur->count()) o->blur = blur;
    if (o_grad->count()) o->gradient = gradient;
    if (o_grad_angle->count()) o->gradient_angle = gradient_angle;
    if (o_nodis->count()) o->distractors = !no_distractors;
    if (o_cam->count()) o->camera_radius_px = camera_radius;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "panosim: ray tracer for a catadioptric panoramic sensor (pinhole camera looking up at a "
      "mirror of revolution). Renders stills, test sequences with ground truth, and chessboard "
      "calibration images. Lengths are in the map's units; angles in radians."};
  app.require_subcommand(1);

  // still
  CLI::App* still = app.add_subcommand("still", "Render one frame to a PNG (8-bit grey)");
  std::string map_path, calib_path, pose_text, out, preset;
  int frame_index = 0;
  RenderFlags still_flags;
  still->add_option("--map", map_path, "Map file (YAML, spec section 4)");
  still->add_option("--calib", calib_path, "Calibration file (YAML, spec section 3)");
  still->add_option("--pose", pose_text, "Robot pose x,y,theta: pinhole world position (map units), heading (radians)");
  still->add_option("--preset", preset, "Take map, sensor, options and pose from a preset instead");
  still->add_option("--frame", frame_index, "With --preset: the frame whose pose to render")->default_val(0);
  still->add_option("-o,--output", out, "Output PNG")->required();
  still_flags.Add(still, true);

  // sequence
  CLI::App* seq = app.add_subcommand(
      "sequence",
      "Render a sequence: DIR/video.mp4 (H.264), DIR/gt.csv (ground truth, spec section 5), "
      "DIR/map.yaml (no distractors), DIR/calib.yaml, DIR/case.yaml, and DIR/frames/ with --frames");
  std::string traj_path, seq_out, seq_preset, seq_map, seq_calib;
  double fps = 10.0;
  bool frames = false, no_video = false, quiet = false, force = false;
  RenderFlags seq_flags;
  seq->add_option("--preset", seq_preset, "Built-in case: paper-synthetic, paper-real, cluttered, kidnap");
  seq->add_option("--map", seq_map, "Map file (YAML, spec section 4)");
  seq->add_option("--calib", seq_calib, "Calibration file (YAML, spec section 3)");
  seq->add_option("--trajectory", traj_path,
                  "Poses, one per frame: CSV with header x,y,theta (radians), or a pose CSV (spec section 5)");
  CLI::Option* o_fps = seq->add_option("--fps", fps, "Frame rate of the video and of gt.csv times")->default_val(10);
  seq->add_option("-o,--output", seq_out, "Output folder (created; must not exist unless --force)")->required();
  seq->add_flag("--frames", frames, "Also write lossless DIR/frames/frame_%04d.png");
  seq->add_flag("--no-video", no_video, "Do not write video.mp4 (needs --frames)");
  seq->add_flag("-q,--quiet", quiet, "No progress on stderr");
  seq->add_flag("--force", force, "Replace an existing output folder");
  seq_flags.Add(seq, true);

  // targets
  CLI::App* tg = app.add_subcommand(
      "targets",
      "Render chessboard calibration images: DIR/cal_NNN.png, DIR/targets.yaml (known poses, spec "
      "section 6), DIR/targets_unknown.yaml (no poses), DIR/truth.yaml (the calibration used)");
  std::string tg_calib, board_text, poses_path, tg_out;
  int auto_n = 0;
  bool tg_quiet = false, tg_force = false;
  RenderFlags tg_flags;
  tg->add_option("--calib", tg_calib, "Calibration file of the sensor to render (YAML, spec section 3)")->required();
  tg->add_option("--board", board_text, "cols,rows,square: inner corners along x and y, square size (map units)")
      ->required();
  CLI::Option* o_poses = tg->add_option("--poses", poses_path,
                                        "Board poses CSV: header rx,ry,rz,tx,ty,tz, then one line per image; "
                                        "X_sensor = R(rvec) X_board + tvec (OpenCV)");
  CLI::Option* o_auto = tg->add_option(
      "--auto", auto_n,
      "Generate N fully visible board poses around the mirror: near it, from 20 degrees below to 60 above it, "
      "corners out to the limb (the placement that calibrates best with unknown poses)");
  o_poses->excludes(o_auto);
  tg->add_option("-o,--output", tg_out, "Output folder (created; must not exist unless --force)")->required();
  tg->add_flag("-q,--quiet", tg_quiet, "No progress on stderr");
  tg->add_flag("--force", tg_force, "Replace an existing output folder");
  tg_flags.Add(tg, false);

  CLI::App* list = app.add_subcommand("presets", "List the built-in presets");

  CLI11_PARSE(app, argc, argv);

  try {
    if (*still) {
      pano::Sensor sensor;
      pano::Map map;
      pano::Pose2 pose;
      pano::RenderOptions ro;
      if (!preset.empty()) {
        if (!map_path.empty() || !calib_path.empty() || !pose_text.empty())
          throw pano::Error("--preset: give either --preset or --map/--calib/--pose, not both");
        const pano::SequenceCase c = pano::MakePreset(preset);
        if (frame_index < 0 || frame_index >= static_cast<int>(c.poses.size()))
          throw pano::Error("--frame: " + std::to_string(frame_index) + " is outside 0.." +
                            std::to_string(c.poses.size() - 1) + " of preset '" + preset + "'");
        sensor = c.calib.sensor;
        map = c.map;
        pose = c.poses[static_cast<size_t>(frame_index)];
        ro = c.options;
      } else {
        if (map_path.empty()) throw pano::Error("--map: required (or give --preset)");
        if (calib_path.empty()) throw pano::Error("--calib: required (or give --preset)");
        if (pose_text.empty()) throw pano::Error("--pose: required: x,y,theta (map units, radians)");
        map = pano::ReadMap(map_path);
        sensor = pano::ReadCalibration(calib_path).sensor;
        const std::vector<double> p = ParseNumbers(pose_text, 3, "--pose", "x,y,theta (map units, radians)");
        pose = {p[0], p[1], p[2]};
        pano::CheckPose(map, pose, "--pose");
      }
      still_flags.Apply(&ro, true);
      ro.Check("options");
      const cv::Mat img = pano::RenderStill(sensor, map, pose, ro);
      pano::WritePng(out, img);
      return 0;
    }
    if (*seq) {
      pano::SequenceCase c;
      if (!seq_preset.empty()) {
        if (!seq_map.empty() || !seq_calib.empty() || !traj_path.empty())
          throw pano::Error("--preset: give either --preset or --map/--calib/--trajectory, not both");
        c = pano::MakePreset(seq_preset);
        if (o_fps->count()) c.fps = fps;
      } else {
        if (seq_map.empty()) throw pano::Error("--map: required (or give --preset)");
        if (seq_calib.empty()) throw pano::Error("--calib: required (or give --preset)");
        if (traj_path.empty()) throw pano::Error("--trajectory: required (or give --preset)");
        c = pano::MakeCase(seq_map, seq_calib, traj_path, fps);
      }
      seq_flags.Apply(&c.options, true);
      c.options.Check("options");
      pano::SequenceWriteOptions wo;
      wo.frames = frames;
      wo.video = !no_video;
      wo.quiet = quiet;
      wo.overwrite = force;
      const pano::SequenceWriteResult r = pano::WriteSequence(c, seq_out, wo);
      if (!quiet)
        std::cerr << "panosim: wrote " << r.frames << " frames to " << seq_out
                  << (r.codec.empty() ? "" : " (video codec " + r.codec + ")") << "\n";
      return 0;
    }
    if (*tg) {
      const pano::Calibration calib = pano::ReadCalibration(tg_calib);
      const std::vector<double> b = ParseNumbers(board_text, 3, "--board", "cols,rows,square");
      pano::TargetBoard board;
      board.cols = static_cast<int>(b[0]);
      board.rows = static_cast<int>(b[1]);
      board.square = b[2];
      if (board.cols != b[0] || board.rows != b[1] || board.cols < 2 || board.rows < 2 || !(board.square > 0.0))
        throw pano::Error("--board: expected integer cols,rows >= 2 and a positive square size, got '" +
                          board_text + "'");
      pano::RenderOptions ro;
      tg_flags.Apply(&ro, false);
      ro.Check("options");
      std::vector<pano::BoardPose> poses;
      if (o_poses->count()) {
        poses = pano::ReadBoardPoses(poses_path);
        for (size_t i = 0; i < poses.size(); ++i)
          if (!pano::BoardFullyVisible(calib.sensor, board, poses[i], 0.0, 1.0))
            std::cerr << "panosim: warning: " << poses_path << ": line " << i + 2
                      << ": not every inner corner of the board is in view\n";
      } else if (o_auto->count()) {
        poses = pano::AutoBoardPoses(calib.sensor, board, auto_n, ro.seed);
      } else {
        throw pano::Error("--poses or --auto: give the board poses file or the number of images to generate");
      }
      pano::TargetsWriteOptions wo;
      wo.overwrite = tg_force;
      wo.quiet = tg_quiet;
      pano::WriteTargetImages(tg_out, calib, board, poses, ro, wo);
      return 0;
    }
    if (*list) {
      for (const std::string& n : pano::PresetNames()) {
        const pano::SequenceCase c = pano::MakePreset(n);
        std::cout << n << ": " << c.poses.size() << " frames, " << c.calib.sensor.image_width << "x"
                  << c.calib.sensor.image_height << ", " << c.description << "\n";
      }
      return 0;
    }
  } catch (const pano::Error& e) {
    std::cerr << "panosim: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "panosim: internal error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
