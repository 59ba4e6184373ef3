// panosim: catadioptric ray tracer for test sequences and calibration images
// with exact ground truth. Thin front end over pipeline/panosim.h: one
// function adds each subcommand's options, one runs its job.
#include <CLI/CLI.hpp>

#include <opencv2/core/utils/logger.hpp>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_errors.h"
#include "cli_help.h"
#include "panotrack/config.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/pipeline/panosim.h"

namespace {

// The form of each comma-separated list option, for its parse errors.
std::map<std::string, std::string>& ListForms() {
  static std::map<std::string, std::string> forms;
  return forms;
}

// An option of exactly `n` comma-separated finite numbers ("x,y,theta").
CLI::Option* AddNumberList(CLI::App* app, const std::string& name, std::vector<double>* values, int n,
                           const std::string& form, const std::string& help) {
  ListForms()[name] = form;
  const CLI::Validator finite(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
          return "'" + text + "' is not a finite number";
        return std::string();
      },
      "");
  std::string upper = form.substr(0, form.find(' '));
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return app->add_option(name, *values, help)
      ->delimiter(',')
      ->allow_extra_args(false)  // one token: a positional after it stays positional
      ->expected(n)
      ->type_name(upper)
      ->check(finite)
      ->default_str("");  // no default to show
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
  double texture = 0.0;
  double exposure = 0.0;
  int blur_samples = 0;
  double auto_exposure = 0.0;
  int people = 0, covered_frames = 0, dropped_frames = 0;
  CLI::Option *o_texture = nullptr, *o_exposure = nullptr, *o_blur_samples = nullptr, *o_auto_exposure = nullptr,
              *o_people = nullptr, *o_covered = nullptr, *o_dropped = nullptr;
  std::vector<CLI::Option*> opts;
  CLI::Option *o_ss = nullptr, *o_noise = nullptr, *o_blur = nullptr, *o_grad = nullptr, *o_grad_angle = nullptr,
              *o_nodis = nullptr, *o_cam = nullptr, *o_seed = nullptr;

  // scene: options of rendering a room; sequence: the per-frame factors too.
  // Listed under their own heading in the help.
  void Add(CLI::App* app, bool scene, bool sequence = false) {
    AddOptions(app, scene, sequence);
    for (CLI::Option* o : {o_ss, o_noise, o_seed, o_blur, o_grad, o_grad_angle, o_nodis, o_cam, o_texture, o_exposure,
                           o_blur_samples, o_auto_exposure, o_people, o_covered, o_dropped})
      if (o) o->group("Rendering");
  }
  void AddOptions(CLI::App* app, bool scene, bool sequence) {
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
    o_texture = app->add_option("--texture", texture,
                                "World-fixed surface texture: every surface's shade times (1 + A t), t a smooth "
                                "pattern in [-1, 1] of the world point, wavelength about 6 % of the room (0..1)")
                    ->default_val(0);
    if (!sequence) return;
    o_exposure = app->add_option("--exposure", exposure,
                                 "Motion blur: shutter open for this fraction of the frame interval (0..1), "
                                 "centred on the frame's time, so gt.csv holds the mid-exposure pose; the frame "
                                 "is the mean of sub-frames (one ray per pixel each when 4 or more)")
                     ->default_val(0);
    o_blur_samples = app->add_option("--blur-samples", blur_samples,
                                     "Sub-frames averaged per blurred frame (1..64; 0: enough for about 1 px "
                                     "between sub-frames at the mirror's rim, 2..32)")
                         ->default_val(0);
    o_auto_exposure = app->add_option("--auto-exposure", auto_exposure,
                                      "Per-frame gain before clipping: slow drift and steps every 40..80 frames, "
                                      "within 1 +- A (0..0.9)")
                          ->default_val(0);
    o_people = app->add_option("--people", people,
                               "People walking back and forth (not in map.yaml): dark prisms 4 % of the room's "
                               "larger side wide, 60..90 % of its height, walking 1 % of that side per frame, "
                               "kept 8 % of it from the sensor (0..50)")
                   ->default_val(0);
    o_covered = app->add_option("--covered-frames", covered_frames,
                                "Frames (seeded, not the first 5) where a dark object in front of the lens "
                                "covers 60..100 % of the mirror; listed in case.yaml")
                    ->default_val(0);
    o_dropped = app->add_option("--dropped-frames", dropped_frames,
                                "Frames (seeded, not the first 5) left out of video.mp4 and gt.csv; the video "
                                "stays constant-rate, gt.csv's frame column is the video's frame index and "
                                "its time column the true time; listed in case.yaml")
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
    if (o_texture->count()) o->texture = texture;
    if (!o_exposure) return;
    if (o_exposure->count()) o->exposure = exposure;
    if (o_blur_samples->count()) o->blur_samples = blur_samples;
    if (o_auto_exposure->count()) o->auto_exposure = auto_exposure;
    if (o_people->count()) o->people = people;
    if (o_covered->count()) o->covered_frames = covered_frames;
    if (o_dropped->count()) o->dropped_frames = dropped_frames;
  }
};

std::string Joined(const std::vector<double>& values) {
  std::ostringstream s;
  for (size_t i = 0; i < values.size(); ++i) s << (i ? "," : "") << values[i];
  return s.str();
}

// Faults of a real rig (sensor/general_model.h) set on the sensor being
// rendered; each replaces that fault of the preset or calibration file.
struct RigFlags {
  std::vector<double> decentre, camera_tilt, distortion, sensor_tilt, asphere;

  void Add(CLI::App* app) {
    for (CLI::Option* o :
         {AddNumberList(app, "--decentre", &decentre, 2, "dx,dy (map units)",
                        "Rig fault: the mirror's axis (a sphere's centre) off the pinhole by dx,dy in the mirror's "
                        "frame (map units; paper-real: cm)"),
          AddNumberList(app, "--camera-tilt", &camera_tilt, 2, "ax,ay (degrees)",
                        "Rig fault: the camera turned relative to the mirror, about x then y (degrees)"),
          app->add_option("--distortion", distortion,
                          "Lens distortion k1,k2[,p1,p2[,k3]] (Brown, on normalised image coordinates)")
              ->delimiter(',')
              ->allow_extra_args(false)  // one token: a positional after it stays positional
              ->expected(2, 5)
              ->type_name("K1,K2[,P1,P2[,K3]]")
              ->default_str(""),
          AddNumberList(app, "--sensor-tilt", &sensor_tilt, 2, "ax,ay (degrees)",
                        "Rig fault: the mirror's axis tilted from the robot's vertical, about x then y (degrees)")})
      o->group("Rig faults");
    app->add_option("--asphere", asphere,
                    "Mirror profile: even-asphere terms a4[,a6] added to the sphere's or conic's sag, "
                    "R (a4 (s/R)^4 + a6 (s/R)^6) (model asphere: a mirror that is not a conic)")
        ->delimiter(',')
        ->allow_extra_args(false)  // one token: a positional after it stays positional
        ->expected(1, 2)
        ->type_name("A4[,A6]")
        ->group("Mirror profile");
  }
  void Apply(pano::Sensor* s) const {
    const double deg = M_PI / 180.0;
    pano::RigFaults<double>& f = s->faults;
    if (!decentre.empty()) {
      f.mirror_offset[0] = decentre[0];
      f.mirror_offset[1] = decentre[1];
    }
    // The sensor model's bound on a tilt (0.5 rad), checked under the flags' names.
    constexpr double kMaxTiltDeg = 0.5 * 180.0 / M_PI;
    for (const auto& [flag, angles] : {std::pair{"--camera-tilt", &camera_tilt}, {"--sensor-tilt", &sensor_tilt}})
      for (double v : *angles)
        if (!(std::abs(v) <= kMaxTiltDeg))
          throw pano::Error(std::string(flag) + ": expected angles within +-28.6 degrees (0.5 rad), got " +
                            Joined(*angles));
    if (!camera_tilt.empty()) {
      f.camera_tilt[0] = camera_tilt[0] * deg;
      f.camera_tilt[1] = camera_tilt[1] * deg;
    }
    if (!distortion.empty()) {
      if (distortion.size() == 3)
        throw pano::Error("--distortion: expected k1,k2 or k1,k2,p1,p2 or k1,k2,p1,p2,k3");
      // A real lens's Brown coefficients (normalised coordinates) are well within this.
      constexpr double kMaxCoefficient = 10.0;
      for (double v : distortion)
        if (!(std::abs(v) <= kMaxCoefficient))
          throw pano::Error("--distortion: expected coefficients within +-10, got " + Joined(distortion));
      s->params.k1 = distortion[0];
      s->params.k2 = distortion[1];
      f.p1 = distortion.size() >= 4 ? distortion[2] : 0.0;
      f.p2 = distortion.size() >= 4 ? distortion[3] : 0.0;
      f.k3 = distortion.size() == 5 ? distortion[4] : 0.0;
    }
    if (!sensor_tilt.empty()) {
      f.sensor_tilt[0] = sensor_tilt[0] * deg;
      f.sensor_tilt[1] = sensor_tilt[1] * deg;
    }
    if (!asphere.empty()) {
      for (double v : asphere)
        if (!std::isfinite(v)) throw pano::Error("--asphere: expected finite numbers");
      s->params.asphere_a4 = asphere[0];
      s->params.asphere_a6 = asphere.size() == 2 ? asphere[1] : 0.0;
      const bool terms = s->params.asphere_a4 != 0.0 || s->params.asphere_a6 != 0.0;
      if (terms) s->model = pano::MirrorModel::kAsphere;
      else if (s->model == pano::MirrorModel::kAsphere) s->model = pano::MirrorModel::kConic;
      s->Check("--asphere");
    }
    s->Check("rig faults");
  }
};

// Options not yet under a heading (but help) go under "Input".
void GroupInputs(CLI::App* app) {
  for (CLI::Option* o : app->get_options({}))
    if (o->get_group() == "Options" && o != app->get_help_ptr()) o->group("Input");
}

// The options every rendering subcommand shares with panoloc and panocalib.
struct CommonFlags {
  bool quiet = false, verbose = false, force = false;
  int jobs = 0;

  void Add(CLI::App* app, const std::string& force_help) {
    app->add_flag("--force", force, force_help)->group("Output");
    app->add_option("-j,--jobs", jobs, "Rendering threads (0: every core)")->group("Run");
    app->add_flag("-q,--quiet", quiet, "No progress or notes on stderr (errors still)")->group("Run");
    app->add_flag("-v,--verbose", verbose, "Also the rendering time")->group("Run");
  }
};

struct StillArgs {
  std::string map_path, calib_path, out, preset;
  std::vector<double> pose;
  int frame_index = 0;
  RenderFlags flags;
  RigFlags rig;
  CommonFlags common;
};

CLI::App* AddStill(CLI::App* app, StillArgs* a) {
  CLI::App* still = app->add_subcommand("still", "Render one frame to a PNG (8-bit grey)");
  still->add_option("--map", a->map_path, "Map file (YAML, docs/maps.md)");
  still->add_option("--calib", a->calib_path, "Calibration file (YAML)");
  AddNumberList(still, "--pose", &a->pose, 3, "x,y,theta (map units, radians)",
                "Robot pose x,y,theta: pinhole world position (map units), heading (radians)");
  still->add_option("--preset", a->preset, "Take map, sensor, options and pose from a preset instead");
  still->add_option("--frame", a->frame_index, "With --preset: the frame whose pose to render")
      ->default_val(0);
  still->add_option("-o,--output", a->out, "Output PNG")->required()->group("Output");
  GroupInputs(still);
  a->common.Add(still, "Replace an existing output file");
  a->flags.Add(still, true);
  a->rig.Add(still);
  return still;
}

// The flags over the scene: rig faults, rendering options (scene: a room,
// not boards), threads.
pano::RenderAdjustments AdjustmentsOf(const RenderFlags& flags, const RigFlags& rig, const CommonFlags& common,
                                      bool scene) {
  pano::RenderAdjustments adjust;
  adjust.sensor = [&rig](pano::Sensor* s) { rig.Apply(s); };
  adjust.options = [&flags, scene](pano::RenderOptions* o) { flags.Apply(o, scene); };
  adjust.num_threads = common.jobs;
  return adjust;
}

void RunStill(const StillArgs& a) {
  pano::StillJob job;
  job.preset = a.preset;
  job.frame = a.frame_index;
  job.map_path = a.map_path;
  job.calib_path = a.calib_path;
  if (!a.pose.empty()) job.pose = pano::Pose2{a.pose[0], a.pose[1], a.pose[2]};
  job.output = a.out;
  job.overwrite = a.common.force;
  job.adjust = AdjustmentsOf(a.flags, a.rig, a.common, true);
  pano::RunStill(job);
}

struct SequenceArgs {
  std::string traj_path, out, preset, map_path, calib_path;
  double fps = 10.0;
  bool frames = false, no_video = false;
  CLI::Option* o_fps = nullptr;
  pano::SurveyError survey;
  CLI::Option *o_map_sigma = nullptr, *o_map_seed = nullptr;
  RenderFlags flags;
  RigFlags rig;
  CommonFlags common;
};

// The survey error of map.yaml (render/sequence.h SurveyMap).
void AddSurveyOptions(CLI::App* seq, SequenceArgs* a) {
  const char* group = "Survey error";
  a->o_map_sigma = seq->add_option("--map-sigma", a->survey.sigma,
                                   "Survey error of map.yaml: every rectangle's end points (x, y) and heights, "
                                   "and every box coordinate, moved by Gaussian errors of this sigma (map "
                                   "units); map.yaml then states survey_sigma and the true map is written as "
                                   "map_true.yaml. Default: the preset's (0 for most)")
                       ->check(CLI::NonNegativeNumber)
                       ->group(group);
  seq->add_option("--map-offset-sigma", a->survey.offset_sigma,
                  "Each rectangle and box of map.yaml moved as a whole by Gaussian errors of this sigma in x and "
                  "y (map units): placed from one reference measurement that was off")
      ->check(CLI::NonNegativeNumber)
      ->group(group);
  seq->add_option("--map-gross", a->survey.gross,
                  "Gross errors: this many rectangles (picked by --map-seed) get a fault in turn: moved by "
                  "--map-gross-offset along its bottom edge, in the map but not rendered, rendered but left out of the map; listed "
                  "in DIR/map_faults.yaml")
      ->check(CLI::NonNegativeNumber)
      ->group(group);
  seq->add_option("--map-gross-offset", a->survey.gross_offset,
                  "How far --map-gross moves a rectangle (map units). Default: 8 cm in the map's units")
      ->check(CLI::PositiveNumber)
      ->default_str("8 cm")
      ->group(group);
  a->o_map_seed =
      seq->add_option("--map-seed", a->survey.seed, "Seed of the survey errors")->default_val(1)->group(group);
}

CLI::App* AddSequence(CLI::App* app, SequenceArgs* a) {
  CLI::App* seq = app->add_subcommand(
      "sequence",
      "Render a test sequence with its ground truth into a folder. Writes DIR/video.mp4 (H.264), "
      "DIR/gt.csv (ground truth, a pose CSV), DIR/gt.tum (the same for evo: metres, the video's "
      "clock), DIR/map.yaml (no distractors), DIR/calib.yaml, DIR/case.yaml, and DIR/frames/ with "
      "--frames; with survey error (--map-*) also DIR/map_true.yaml (the room rendered) and, with --map-gross, "
      "DIR/map_faults.yaml.");
  seq->add_option("--preset", a->preset,
                  "Built-in case (panosim presets lists them): paper-synthetic, paper-real, cluttered, kidnap, "
                  "fast-turns, motion-blur, real-conditions, long-run, long-run-blur, paper-real-map-error, "
                  "paper-synthetic-map-error; the options below apply on top");
  seq->add_option("--map", a->map_path, "Map file (YAML, docs/maps.md)");
  seq->add_option("--calib", a->calib_path, "Calibration file (YAML)");
  seq->add_option(
      "--trajectory", a->traj_path,
      "Poses, one per frame: CSV with header x,y,theta (radians), or a pose CSV (docs/panoloc.md)");
  a->o_fps = seq->add_option("--fps", a->fps, "Frame rate of the video and of gt.csv times")->default_val(10);
  seq->add_option("-o,--output", a->out, "Output folder (created; must not exist unless --force)")
      ->required()
      ->group("Output");
  seq->add_flag("--frames", a->frames, "Also write lossless DIR/frames/frame_%04d.png")->group("Output");
  seq->add_flag("--no-video", a->no_video, "Do not write video.mp4 (needs --frames)")->group("Output");
  AddSurveyOptions(seq, a);
  GroupInputs(seq);
  a->common.Add(seq, "Replace an existing output folder");
  a->flags.Add(seq, true, true);
  a->rig.Add(seq);
  return seq;
}

void RunSequence(const SequenceArgs& a) {
  pano::SequenceJob job;
  job.preset = a.preset;
  job.map_path = a.map_path;
  job.calib_path = a.calib_path;
  job.trajectory_path = a.traj_path;
  if (a.o_fps->count()) job.fps = a.fps;
  job.survey = a.survey;
  if (a.o_map_sigma->count()) job.survey_sigma = a.survey.sigma;
  if (a.o_map_seed->count()) job.survey_seed = a.survey.seed;
  job.output = a.out;
  job.write.frames = a.frames;
  job.write.video = !a.no_video;
  job.write.overwrite = a.common.force;
  if (!a.common.quiet) {
    job.write.on_progress = [](int done, int total) { std::cerr << "panosim: frame " << done << "/" << total << "\n"; };
    job.write.on_note = [](const std::string& note) { std::cerr << "panosim: " << note << "\n"; };
  }
  job.adjust = AdjustmentsOf(a.flags, a.rig, a.common, true);
  const pano::SequenceWriteResult r = pano::RunSequence(job);
  if (!a.common.quiet)
    std::cerr << "panosim: wrote " << r.frames << " frames to " << a.out
              << (r.codec.empty() ? "" : " (video codec " + r.codec + ")") << "\n";
}

struct TargetsArgs {
  std::string calib_path, preset, poses_path, out;
  std::vector<double> board;
  int auto_n = 0;
  double charuco_marker = 0.0, min_visible = 1.0;  // ChArUco: marker side (0: chessboard)
  std::string dictionary = "DICT_4X4_50";
  CLI::Option *o_poses = nullptr, *o_auto = nullptr;
  RenderFlags flags;
  RigFlags rig;
  CommonFlags common;
};

CLI::App* AddTargets(CLI::App* app, TargetsArgs* a) {
  CLI::App* tg = app->add_subcommand(
      "targets",
      "Render chessboard calibration images into a folder. Writes DIR/cal_NNN.png, DIR/targets.yaml "
      "(known poses), DIR/targets_unknown.yaml (no poses), DIR/truth.yaml (the "
      "calibration used).");
  CLI::Option* o_calib =
      tg->add_option("--calib", a->calib_path, "Calibration file of the sensor to render (YAML)");
  tg->add_option("--preset", a->preset, "Render the sensor of this preset (e.g. faulty-rig) instead of --calib")
      ->excludes(o_calib);
  AddNumberList(tg, "--board", &a->board, 3, "cols,rows,square",
                "cols,rows,square: inner corners along x and y, square size (map units)")
      ->required();
  a->o_poses = tg->add_option("--poses", a->poses_path,
                              "Board poses CSV: header rx,ry,rz,tx,ty,tz, then one line per image; "
                              "X_sensor = R(rvec) X_board + tvec (OpenCV)");
  a->o_auto = tg->add_option("--auto", a->auto_n,
                             "Generate N fully visible board poses around the mirror: near it, from 20 degrees "
                             "below to 60 above it, corners out to the limb (the placement that calibrates "
                             "best with unknown poses)");
  a->o_poses->excludes(a->o_auto);
  tg->add_option("--charuco", a->charuco_marker,
                 "Render a ChArUco board with markers of this side (map units) instead of a chessboard")
      ->group("Rendering");
  tg->add_option("--dictionary", a->dictionary, "ChArUco: OpenCV's ArUco dictionary")
      ->capture_default_str()
      ->group("Rendering");
  tg->add_option("--min-visible", a->min_visible,
                 "--auto: fraction of the inner corners that must be in view (below 1: boards run past the limb)")
      ->capture_default_str()
      ->group("Input");
  tg->add_option("-o,--output", a->out, "Output folder (created; must not exist unless --force)")
      ->required()
      ->group("Output");
  GroupInputs(tg);
  a->common.Add(tg, "Replace an existing output folder");
  a->flags.Add(tg, false);
  a->rig.Add(tg);
  return tg;
}


pano::TargetBoard BoardOf(const std::vector<double>& b) {
  pano::TargetBoard board;
  board.cols = static_cast<int>(b[0]);
  board.rows = static_cast<int>(b[1]);
  board.square = b[2];
  if (board.cols != b[0] || board.rows != b[1] || board.cols < 2 || board.rows < 2 || !(board.square > 0.0))
    throw pano::Error("--board: expected integer cols,rows >= 2 and a positive square size, got " +
                      Joined(b));
  pano::CheckTargetBoard(board, "--board");  // at most kMaxBoardCorners a side
  return board;
}

void RunTargets(const TargetsArgs& a) {
  pano::TargetsJob job;
  job.preset = a.preset;
  job.calib_path = a.calib_path;
  job.board = BoardOf(a.board);
  if (a.charuco_marker != 0.0) {
    job.board.type = "charuco";
    job.board.marker = a.charuco_marker;
    job.board.dictionary = a.dictionary;
    pano::CheckTargetBoard(job.board, pano::ArucoDictionaryId(job.board.dictionary) < 0 ? "--dictionary" : "--charuco");
  }
  if (a.o_poses->count()) job.board_poses_path = a.poses_path;
  if (a.o_auto->count()) job.auto_count = a.auto_n;
  job.min_visible = a.min_visible;
  job.output = a.out;
  job.write.overwrite = a.common.force;
  if (!a.common.quiet) {
    job.write.on_progress = [](int done, int total) { std::cerr << "panosim: image " << done << "/" << total << "\n"; };
    job.on_warning = [](const std::string& w) { std::cerr << "panosim: warning: " << w << "\n"; };
  }
  job.adjust = AdjustmentsOf(a.flags, a.rig, a.common, false);
  pano::RunTargets(job);
}

void ListPresets() {
  for (const std::string& n : pano::PresetNames()) {
    const pano::SequenceCase c = pano::MakePreset(n);
    std::cout << n << ": " << c.poses.size() << " frames, " << c.calib.sensor.image_width << "x"
              << c.calib.sensor.image_height << ", " << c.description << "\n";
  }
}


// Command-line errors in the program's one-line form; help and version as CLI11 prints them.
int ParseCommandLine(CLI::App* app, int argc, char** argv) {
  try {
    app->parse(argc, argv);
    pano::app::RefuseNonFiniteNumbers(*app);
    return -1;
  } catch (const CLI::CallForHelp& e) {
    return app->exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app->exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app->exit(e);
  } catch (const CLI::ParseError& e) {
    std::string message = pano::app::ParseErrorMessage(*app, e, "panosim");
    // The form of a list option where the message does not already say what is expected.
    for (const auto& [name, form] : ListForms())
      if (message.rfind(name + ":", 0) == 0 && message.find("expected") == std::string::npos)
        message += " (expected " + form + ")";
    std::cerr << "panosim: " << message << "\n";
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "panosim: render what a catadioptric panoramic sensor sees, with exact ground truth.\n"
      "A ray tracer for a pinhole camera looking up at a mirror of revolution: stills, test\n"
      "sequences with ground truth, and chessboard calibration images. Lengths are in the map's\n"
      "units; angles in radians. Existing outputs are kept unless --force is given.",
      "panosim"};
  const std::string exit_codes =
      "Exit status: 0 success; 1 bad options or files, an existing output without --force, or\n"
      "the rendering failed; 2 unexpected internal error.";
  app.footer(exit_codes);
  app.require_subcommand(1);
  app.set_version_flag("--version", "panosim " PANO_VERSION, "Print the version and exit");
  app.set_help_flag("-h,--help", "Print this help and exit");
  app.option_defaults()->always_capture_default();
  StillArgs still_args;
  SequenceArgs seq_args;
  TargetsArgs tg_args;
  const CLI::App* still = AddStill(&app, &still_args);
  const CLI::App* seq = AddSequence(&app, &seq_args);
  const CLI::App* tg = AddTargets(&app, &tg_args);
  const CLI::App* list = app.add_subcommand("presets", "List the built-in presets");
  pano::app::SplitDescriptions(app, exit_codes);
  const int parsed = ParseCommandLine(&app, argc, argv);
  if (parsed >= 0) return parsed;
  try {
    const CommonFlags* common = *still ? &still_args.common
                                : *seq ? &seq_args.common
                                : *tg  ? &tg_args.common
                                       : nullptr;
    if (common) pano::CheckThreadCount(common->jobs, "-j/--jobs");
    // OpenCV's warnings (an image it cannot write) only with --verbose: the error says it in one line.
    cv::utils::logging::setLogLevel(common && common->verbose ? cv::utils::logging::LOG_LEVEL_WARNING
                                                              : cv::utils::logging::LOG_LEVEL_ERROR);
    const auto t0 = std::chrono::steady_clock::now();
    if (*still) RunStill(still_args);
    if (*seq) RunSequence(seq_args);
    if (*tg) RunTargets(tg_args);
    if (*list) ListPresets();
    if (common && common->verbose && !common->quiet)
      std::cerr << "panosim: rendered in "
                << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n";
  } catch (const pano::Error& e) {
    std::cerr << "panosim: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "panosim: unexpected error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
