// panocalib calibrate: fit the sensor model to chessboard images.
#include <cstdio>
#include <memory>
#include <string>

#include "panotrack/core/output_check.h"
#include "commands.h"
#include "panotrack/core/command_line.h"
#include "panotrack/core/error.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/video/logging.h"

namespace pano::app {

namespace {

struct Opts {
  std::string targets, out, lut, report, model = "auto", distortion = "auto", free = "none";
  double huber = 1.0, max_rms = 5.0, full_weight = CalibrateOptions().full_weight_px;
  int max_iterations = 200, threads = 0, asphere_terms = 2;
  bool no_aspect = false, ignore_poses = false, no_unwarp = false, no_refine = false, limb = false, verbose = false;
};

// Input without a target file: the board on the command line.
struct BoardOpts {
  std::string board, dictionary = "DICT_4X4_50", units = TargetSet().units;
  double square = 0.0, marker = 0.0;
  int every = 0;
};

// The programs' shared conventions: existing outputs kept unless --force,
// -q, and the summary as JSON.
struct RunOpts {
  bool force = false, quiet = false;
  std::string summary_json;
};

// --- Folder or video input: the board (the target file's board fields).
void AddBoardOptions(CLI::App* cmd, BoardOpts* bo) {
  CLI::Option* board_opt = cmd->add_option(
      "--board", bo->board,
      "Board for a folder or video: COLSxROWS inner corners (board.cols along the board's x, board.rows "
      "along y; e.g. 7x11 for an 8 x 12 squares board), or charuco:COLSxROWS for a ChArUco board");
  cmd->add_option("--square", bo->square, "Square side in the map's units (with --board)")->needs(board_opt);
  cmd->add_option("--marker", bo->marker, "ChArUco marker side in the map's units (with --board charuco:...)")
      ->needs(board_opt);
  cmd->add_option("--dictionary", bo->dictionary, "ChArUco: OpenCV's ArUco dictionary")
      ->capture_default_str()
      ->needs(board_opt);
  cmd->add_option("--units", bo->units, "Map units of --square (with --board)")->capture_default_str()->needs(board_opt);
  cmd->add_option("--every", bo->every, "Video: take every N-th frame (0: about 30 frames)")
      ->capture_default_str()
      ->needs(board_opt);
}

// The mirror profile, lens distortion and rig faults; returns --free.
CLI::Option* AddModelOptions(CLI::App* cmd, Opts* o) {
  cmd->add_option("--model", o->model,
                  "Mirror profile: auto (the default: the mirror profile, the lens distortion and the rig faults "
                  "chosen by 5-fold cross-validation over the boards among sphere, sphere + decentre, sphere + "
                  "k1 k2, conic + k1 k2, asphere (a4) + k1 k2, asphere (a4, a6) + k1 k2, conic + k1 k2 + "
                  "decentre, camera tilt, unified + k1 k2 and unified + k1 k2 + p1 p2, skew: the simplest whose error "
                  "on boards left out of the fit is within 1 % of the best, refusing a model whose parameters the boards do not determine; --distortion or --free "
                  "given hold for every candidate; fewer than 4 boards: the sphere), sphere, conic "
                  "(quadric of revolution), asphere (the conic plus even-asphere terms a4, a6, for a mirror "
                  "whose maker does not publish its shape) or unified (Mei's central model, xi: for a "
                  "single-viewpoint camera such as a parabolic mirror behind a telecentric lens)")
      ->capture_default_str();
  cmd->add_option("--asphere-terms", o->asphere_terms, "Even-asphere terms fitted with --model asphere: 1 (a4) or 2 (a4, a6)")
      ->capture_default_str();
  cmd->add_option("--distortion", o->distortion,
                  "Lens radial distortion terms fitted: auto (chosen with --model auto; else none for sphere, k1 k2 for "
                  "conic, asphere and unified), 0, 1 or 2")
      ->capture_default_str();
  return cmd->add_option("--free", o->free,
                  "Rig faults fitted (general model; with --model auto and no --free they are chosen): none (the "
                  "aligned model), auto (decentre and camera-tilt "
                  "for conic; decentre for sphere, whose centre off the axis and a camera tilt are one and the "
                  "same; with estimated poses they trade against cx, cy; tangential and skew for unified, as "
                  "OpenCV's omnidir), or a comma list of decentre, camera-tilt, k1, k2 (as --distortion), "
                  "tangential (p1 p2), k3, skew (the pixel grid's shear), sensor-tilt (known board poses only)")
      ->capture_default_str();
}

void AddFitOptions(CLI::App* cmd, Opts* o) {
  cmd->add_option("--huber", o->huber, "Huber loss threshold in pixels (0: plain least squares)")
      ->capture_default_str();
  cmd->add_option("--full-weight", o->full_weight,
                  "Corners whose squares are squeezed below this many pixels (near the limb) count less, "
                  "most of all along an acute crossing, as they are located less precisely (0: uniform weights)")
      ->capture_default_str();
  cmd->add_option("--max-rms", o->max_rms, "Fail when the RMS reprojection error exceeds this (pixels)")
      ->capture_default_str();
  cmd->add_option("--max-iterations", o->max_iterations, "Ceres iterations at most")->capture_default_str();
  cmd->add_flag("--fix-aspect", o->no_aspect, "Hold the pixel aspect ratio at 1");
  cmd->add_flag("--ignore-poses", o->ignore_poses, "Estimate the board poses even when the target file gives them");
  cmd->add_flag("--no-unwarp", o->no_unwarp, "Do not retry images without a board in unwarped views");
  cmd->add_flag("--no-refine", o->no_refine,
                "Fit the detector's corners as found (default: located again through the fitted model and the "
                "model fitted again; `panocalib evaluate --no-refine` reproduces the figure)");
  cmd->add_flag("--limb", o->limb,
                "Sphere: measure the mirror's limb (its silhouette) in the images and fit it with the corners");
  cmd->add_option("-j,--jobs,--threads", o->threads, "Threads for the fit and the image searches (0: every core)")
      ->capture_default_str();
  cmd->add_flag("-v,--verbose", o->verbose,
                "Print step timings, the solver's progress and the libraries' warnings (quiet otherwise)");
}

void AddRunOptions(CLI::App* cmd, RunOpts* run) {
  cmd->add_flag("--force", run->force, "Replace existing output files (otherwise nothing is done)");
  cmd->add_option("--summary-json", run->summary_json,
                  "Also write the summary (RMS, per-image RMS, parameters with standard deviations, images "
                  "without a board, warnings, timings) as JSON; - writes it to standard output");
  cmd->add_flag("-q,--quiet", run->quiet, "No summary or warnings (errors still on stderr)");
}

// The calibration's options from the command line (free_given: --free was
// given). Throws pano::Error for a value the parser let through.
CalibrateOptions CalibrateOptionsOf(const Opts& o, bool free_given, bool quiet) {
  CalibrateOptions opt;
  if (o.model == "sphere") opt.model = MirrorModel::kSphere;
  else if (o.model == "conic") opt.model = MirrorModel::kConic;
  else if (o.model == "asphere") opt.model = MirrorModel::kAsphere;
  else if (o.model == "unified") opt.model = MirrorModel::kUnified;
  else if (o.model == "auto") opt.select_model = opt.selection_fallback = true;
  else throw Error("--model: expected sphere, conic, asphere, unified or auto, got '" + o.model + "'");
  opt.asphere_terms = o.asphere_terms;
  if (o.distortion == "auto") opt.distortion_terms = -1;
  else if (o.distortion == "0" || o.distortion == "1" || o.distortion == "2") opt.distortion_terms = std::stoi(o.distortion);
  else throw Error("--distortion: expected auto, 0, 1 or 2, got '" + o.distortion + "'");
  {
    int radial = -1;
    opt.free_faults = ParseFreeFaults(o.free, opt.model, &radial);
    opt.free_faults_auto = o.free == "auto";
    opt.selection_fixed_faults = free_given;
    if (radial >= 0) {
      if (o.distortion != "auto" && opt.distortion_terms != radial)
        throw Error("--free: names k1/k2 but --distortion says " + o.distortion);
      opt.distortion_terms = radial;
    }
  }
  opt.huber_px = o.huber;
  opt.max_rms_px = o.max_rms;
  opt.full_weight_px = o.full_weight;
  opt.max_iterations = o.max_iterations;
  opt.fit_aspect = !o.no_aspect;
  opt.ignore_known_poses = o.ignore_poses;
  opt.unwarp_fallback = !o.no_unwarp;
  if (o.no_refine) opt.refine_passes = 0;
  opt.use_limb = o.limb;
  opt.num_threads = o.threads;
  opt.verbose = o.verbose;
  if (o.verbose) opt.on_log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  if (opt.select_model && !quiet)
    opt.on_progress = [](const std::string& step) { std::fprintf(stderr, "panocalib: model selection: %s\n", step.c_str()); };
  opt.Check();
  return opt;
}

// Runs the calibration job and prints its summary.
void CalibrateAndPrint(const Opts& o, const BoardOpts& bo, const RunOpts& run, const CalibrateOptions& opt,
                       const NamedPaths& outputs) {
  CalibrateJob job;
  job.targets = o.targets;
  job.board = BoardInputOf(bo.board, bo.square, bo.marker, bo.dictionary, bo.units, bo.every, "map units");
  job.options = opt;
  job.outputs = {o.out, o.lut, o.report, run.summary_json, CommandLine()};
  job.names.outputs = outputs;
  const CalibrationResult r = RunCalibrate(job);
  if (run.quiet) return;
  // With the JSON on standard output, the text goes to stderr.
  std::FILE* text = run.summary_json == "-" ? stderr : stdout;
  std::fprintf(text, "%s", CalibrationSummary(r).c_str());
  std::fprintf(text, "wrote %s%s%s%s%s\n", o.out.c_str(), o.lut.empty() ? "" : ", ", o.lut.c_str(),
               o.report.empty() ? "" : ", ", o.report.c_str());
  for (const std::string& w : r.warnings) std::fprintf(stderr, "panocalib: warning: %s\n", w.c_str());
}

}  // namespace

TargetInputBoard BoardInputOf(const std::string& board, double square, double marker, const std::string& dictionary,
                              const std::string& units, int every, const std::string& square_units) {
  TargetInputBoard input;
  input.board_given = !board.empty();
  if (!input.board_given) return input;
  if (!(square > 0.0)) throw Error("--square: required with --board (the square side, " + square_units + ")");
  input.board = ParseBoardSpec(board, square, marker, dictionary);
  input.units = units;
  input.every = every;
  return input;
}

void AddCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<Opts>();
  auto bo = std::make_shared<BoardOpts>();
  auto run = std::make_shared<RunOpts>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Fit the sensor model to images of a chessboard or a ChArUco board (target file: see docs/calibration.md; "
      "or a folder of images or a video with --board). Writes the "
      "calibration YAML with standard deviations and RMS reprojection errors, "
      "optionally the E(D,Z) lookup table and a report PNG, and prints a summary. Boards with "
      "rvec/tvec given are 'known targets' (only the sensor is fitted); otherwise every board pose "
      "is estimated too. Nothing is written when the calibration fails.");
  cmd->add_option("targets", o->targets,
                  "Calibration target file (.yaml/.yml), or a folder of images (natural order: image_2 before "
                  "image_10), or a video (every --every-th frame, named VIDEO#FRAME); a folder or video "
                  "needs --board and --square")
      ->required();
  AddBoardOptions(cmd, bo.get());
  cmd->add_option("-o,--output", o->out, "Output calibration file (YAML)")->required();
  cmd->add_option("--lut", o->lut, "Also write the E(D,Z) lookup table here (referenced from the YAML)");
  cmd->add_option("--report", o->report, "Also write a report PNG (per-image RMS, residual vectors)");
  CLI::Option* free_opt = AddModelOptions(cmd, o.get());
  AddFitOptions(cmd, o.get());
  AddRunOptions(cmd, run.get());
  auto outputs = [o, run]() -> NamedPaths {
    return {{"-o", o->out}, {"--lut", o->lut}, {"--report", o->report}, {"--summary-json", run->summary_json}};
  };
  cmd->parse_complete_callback([o, run, outputs]() { CheckPlannedOutputs({{"", o->targets}}, outputs(), run->force); });
  cmd->callback([o, bo, run, outputs, free_opt]() {
    const CalibrateOptions opt = CalibrateOptionsOf(*o, free_opt->count() > 0, run->quiet);
    SetDecoderLogging(o->verbose);  // a board video's FFmpeg lines only with -v
    CalibrateAndPrint(*o, *bo, *run, opt, outputs());
  });
}

}  // namespace pano::app
